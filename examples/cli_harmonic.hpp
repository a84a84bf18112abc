// `idas harmonic`: harmonic triangulation (Alexa 2019) of a point set: CGAL's Delaunay
// tetrahedralization, then harmonic flips (and smoothing in complete mode). Included by
// idas_cli.cpp inside its anonymous namespace (so it includes nothing itself; idas_cli.cpp
// includes the library headers, the CGAL ones when IDAS_CLI_HAVE_CGAL).
//
//   idas harmonic OUT (--points IN | --gaussian N [--seed S]) [--mode reduced|complete]
//                 [--threads T] [--rounds R] [--backend indexed|adjacency] [--json] [--ascii]
//
// OUT is .msh (MSH 4.1) or .vtu. IN is .xyz or .ply (its vertex element; other elements,
// such as a dummy face, are ignored).
#pragma once

struct harmonic_arguments {
    std::string out, points;
    std::size_t gaussian = 0;
    std::uint64_t seed = 1;
    std::string mode = "complete";
    std::string backend = "indexed";
    unsigned threads = 1, rounds = idas::algorithms::harmonic_options{}.rounds;
    bool as_json = false, ascii = false;
    CLI::Option* points_option = nullptr;
    CLI::Option* gaussian_option = nullptr;
};

CLI::App* add_harmonic_command(CLI::App& app, harmonic_arguments& a,
                               const CLI::Validator& unsigned_check) {
    auto* c = app.add_subcommand("harmonic",
                                 "Harmonic triangulation (Alexa 2019) of a point set: Delaunay, "
                                 "then energy-lowering flips");
    c->add_option("OUT", a.out, "output tet mesh (.msh or .vtu)")->required();
    a.points_option = c->add_option("--points", a.points, "input points (.xyz or .ply)");
    a.gaussian_option = c->add_option("--gaussian", a.gaussian, "use N standard-normal points")
                            ->check(unsigned_check);
    a.points_option->excludes(a.gaussian_option);
    c->add_option("--seed", a.seed, "seed of --gaussian")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_option("--mode", a.mode,
                  "reduced (3-2 swaps only) or complete (2-3, 3-2, 4-4 swaps and smoothing)")
        ->check(CLI::IsMember({"reduced", "complete"}))
        ->capture_default_str();
    c->add_option("--threads", a.threads, "worker threads")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_option("--rounds", a.rounds, "complete mode: rounds of smoothing and flips")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_option("--backend", a.backend,
                  "tet connectivity: indexed (vertex-to-tet lists) or adjacency (tet-to-tet "
                  "links, one tet per vertex)")
        ->check(CLI::IsMember({"indexed", "adjacency"}))
        ->capture_default_str();
    c->add_flag("--json", a.as_json, "print one JSON object instead of text");
    c->add_flag("--ascii", a.ascii, "write MSH and VTU as text instead of binary");
    c->callback([&a] {
        if (a.points_option->count() + a.gaussian_option->count() != 1)
            throw CLI::ValidationError("harmonic",
                                       "give exactly one of --points IN or --gaussian N");
    });
    return c;
}

/// The lower-case extension of a path (".msh").
std::string harmonic_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    return ext;
}

int run_harmonic(const harmonic_arguments& a) {
#if IDAS_CLI_HAVE_CGAL
    const stopwatch total;
    // Everything that can be refused without work is refused first.
    const std::string ext = harmonic_extension(a.out);
    if (ext != ".msh" && ext != ".vtu")
        throw idas::input_error(a.out + ": unknown output extension (expected .msh or .vtu)");
    if (a.threads == 0) throw idas::input_error("--threads must be at least 1");
    if (a.gaussian_option->count() > 0 && a.gaussian < 4)
        throw idas::input_error("--gaussian needs at least 4 points");

    const std::vector<idas::vec3> points = a.points.empty()
                                               ? idas::io::gaussian_points(a.gaussian, a.seed)
                                               : idas::io::read_points(a.points);
    const std::string source =
        a.points.empty() ? "--gaussian " + std::to_string(a.gaussian) : a.points;

    const stopwatch delaunay_clock;
    idas::cgal::delaunay_result dt;
    try {
        dt = idas::cgal::delaunay_tetrahedralization(points);
    } catch (const idas::input_error& e) {
        throw idas::input_error(source + ": " + e.what());
    }
    const double delaunay_seconds = delaunay_clock.seconds();
    idas::algorithms::harmonic_options o;
    o.mode = a.mode == "reduced" ? idas::algorithms::harmonic_mode::reduced
                                 : idas::algorithms::harmonic_mode::complete;
    o.rounds = a.rounds;
    o.exec.threads = a.threads;
    idas::algorithms::harmonic_stats before, after;
    idas::algorithms::harmonic_report r;
    idas::io::volume v;
    // The same run on either tet backend (--backend).
    const auto flip = [&]<class Mesh>(Mesh m) {
        before = idas::algorithms::harmonic_statistics(m);
        terminal_progress bar("harmonic");
        const unsigned phases = o.mode == idas::algorithms::harmonic_mode::reduced ? 1 : 1 + 2 * o.rounds;
        unsigned ran = 0;
        auto observer = [&](std::size_t phase, unsigned round, const idas::run_report& pr) {
            static constexpr const char* names[] = {"3-2 flips", "smoothing", "seeded flips"};
            bar.draw(double(++ran) / phases, std::string(names[phase]) + ", round " +
                                                 std::to_string(round + 1) + ": " +
                                                 std::to_string(pr.succeeded) + " done");
        };
        r = idas::algorithms::harmonic_triangulation<Mesh>::run_observed(m, o, observer);
        after = idas::algorithms::harmonic_statistics(m);
        std::tie(v.vertices, v.tets) = m.to_arrays();
    };
    if (a.backend == "adjacency")
        flip(idas::tet_mesh<idas::backend::adjacency_tet>(dt.vertices, dt.tets));
    else
        flip(idas::tet_mesh<idas::backend::indexed_tet>(dt.vertices, dt.tets));
    const auto enc = a.ascii ? idas::io::encoding::ascii : idas::io::encoding::binary;
    if (ext == ".vtu") {
        idas::io::vtu_options options;
        options.enc = enc;
        idas::io::write_vtu(a.out, v, options);
    } else {
        idas::io::write_msh(a.out, v, idas::io::msh_version::v4_1, enc);
    }

    if (a.as_json) {
        json j;
        j["input"] = source;
        j["output"] = a.out;
        j["points"] = points.size();
        j["duplicate_points"] = dt.duplicates;
        j["mode"] = a.mode;
        j["threads"] = a.threads;
        j["backend"] = a.backend;
        j["tets_before"] = before.tets;
        j["tets_after"] = after.tets;
        j["mean_harmonic_index_before"] = before.mean_index;
        j["mean_harmonic_index_after"] = after.mean_index;
        j["max_energy_before"] = before.max_energy;
        j["max_energy_after"] = after.max_energy;
        j["flips"] = r.flips;
        j["smoothed"] = r.smoothed;
        j["seconds_delaunay"] = delaunay_seconds;
        j["seconds_flipping"] = r.seconds;
        j["seconds_total"] = total.seconds();
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} points, Delaunay {} tets in {:.3f} s\n", source, points.size(),
                   before.tets, delaunay_seconds);
        fmt::print("  {} mode on {} thread{}: {} flips, {} vertices smoothed in {:.3f} s\n", a.mode,
                   a.threads, a.threads == 1 ? "" : "s", r.flips, r.smoothed, r.seconds);
        fmt::print("  tets {} -> {}, mean harmonic index {:.4f} -> {:.4f}\n", before.tets,
                   after.tets, before.mean_index, after.mean_index);
        fmt::print("{} ({:.3f} s total)\n", a.out, total.seconds());
    }
    return 0;
#else
    (void)a;
    throw idas::input_error("idas harmonic needs a build with CGAL (for the Delaunay input)");
#endif
}
