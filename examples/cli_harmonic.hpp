// `idas harmonic`: harmonic triangulation (Alexa 2019) of a point set: CGAL's Delaunay
// tetrahedralization, then harmonic flips (and smoothing in complete mode; the run itself
// is tool/harmonic.hpp, shared with the Python module). Included by idas_cli.cpp inside its
// anonymous namespace (so it includes nothing itself; idas_cli.cpp includes the library
// headers, the CGAL ones when IDAS_CLI_HAVE_CGAL).
//
//   idas harmonic OUT (--points IN | --gaussian N [--seed S]) [--mode reduced|complete]
//                 [--threads T] [--rounds R] [--backend indexed|adjacency] [--deterministic]
//                 [--json] [--ascii]
//
// OUT is .msh (MSH 4.1) or .vtu. IN is .xyz or .ply (its vertex element; other elements,
// such as a dummy face, are ignored).
#pragma once

struct harmonic_arguments {
    std::string out, points;
    std::size_t gaussian = 0;
    std::uint64_t seed = 1;
    harmonic_options options;
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
    c->add_option("--mode", a.options.mode,
                  "reduced (3-2 swaps only) or complete (2-3, 3-2, 4-4 swaps and smoothing)")
        ->check(CLI::IsMember({"reduced", "complete"}))
        ->capture_default_str();
    c->add_option("--threads", a.options.threads, "worker threads")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_option("--rounds", a.options.rounds, "complete mode: rounds of smoothing and flips")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_option("--backend", a.options.backend,
                  "tet connectivity: indexed (vertex-to-tet lists) or adjacency (tet-to-tet "
                  "links, one tet per vertex)")
        ->check(CLI::IsMember({"indexed", "adjacency"}))
        ->capture_default_str();
    c->add_flag("--deterministic", a.options.deterministic,
                "the same output at every thread count (deterministic rounds)");
    c->add_flag("--json", a.as_json, "print one JSON object instead of text");
    c->add_flag("--ascii", a.ascii, "write MSH and VTU as text instead of binary");
    c->callback([&a] {
        if (a.points_option->count() + a.gaussian_option->count() != 1)
            throw CLI::ValidationError("harmonic",
                                       "give exactly one of --points IN or --gaussian N");
    });
    return c;
}

/// `--gaussian` above this is refused before allocating: the Delaunay tetrahedralization
/// of N points has about 6.5 N tets, and 100 million points already need some 100 GB.
constexpr std::size_t max_gaussian_points = 100'000'000;

int run_harmonic(const harmonic_arguments& a) {
#if IDAS_CLI_HAVE_CGAL
    phase_times phases;
    // Everything that can be refused without work is refused first.
    const std::string ext = lowercase_extension(a.out);
    if (ext != ".msh" && ext != ".vtu")
        throw idas::input_error(a.out + ": unknown output extension (expected .msh or .vtu)");
    check_harmonic_options(a.options);
    const unsigned threads = a.options.threads;
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
    if (a.gaussian_option->count() > 0 && a.gaussian < 4)
        throw idas::input_error("--gaussian needs at least 4 points");
    if (a.gaussian > max_gaussian_points)
        throw idas::input_error("--gaussian must be at most " +
                                std::to_string(max_gaussian_points) + " points");

    const std::vector<idas::vec3> points = a.points.empty()
                                               ? idas::io::gaussian_points(a.gaussian, a.seed)
                                               : idas::io::read_points(a.points);
    const std::string source =
        a.points.empty() ? "--gaussian " + std::to_string(a.gaussian) : a.points;
    phases.lap(a.points.empty() ? "generate" : "read");
    terminal_progress bar("harmonic");
    const auto draw = [&bar](double done, const std::string& note) { bar.draw(done, note); };
    const phase_progress progress(draw);
    const harmonic_result res =
        harmonic_volume(points, source, a.options, phases, bar.enabled() ? &progress : nullptr);
    bar.end_line();
    const idas::io::volume& v = res.mesh;
    const auto& before = res.before;
    const auto& after = res.after;
    const auto& r = res.report;
    const auto enc = a.ascii ? idas::io::encoding::ascii : idas::io::encoding::binary;
    if (ext == ".vtu") {
        idas::io::vtu_options options;
        options.enc = enc;
        idas::io::write_vtu(a.out, v, options);
    } else {
        idas::io::write_msh(a.out, v, idas::io::msh_version::v4_1, enc);
    }
    phases.lap("write");

    if (a.as_json) {
        json j;
        j["input"] = source;
        j["output"] = a.out;
        j["points"] = points.size();
        j["duplicate_points"] = res.duplicate_points;
        j["mode"] = a.options.mode;
        j["threads"] = threads;
        j["deterministic"] = a.options.deterministic;
        j["backend"] = a.options.backend;
        j["tets_before"] = before.tets;
        j["tets_after"] = after.tets;
        j["mean_harmonic_index_before"] = before.mean_index;
        j["mean_harmonic_index_after"] = after.mean_index;
        j["max_energy_before"] = before.max_energy;
        j["max_energy_after"] = after.max_energy;
        j["flips"] = r.flips;
        j["smoothed"] = r.smoothed;
        j["seconds_delaunay"] = res.delaunay_seconds;
        j["seconds_flipping"] = r.seconds;
        j["seconds_check"] = res.check_seconds;
        j["seconds_total"] = phases.total();
        j["phases"] = phases.to_json();
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} points, Delaunay {} tets in {:.3f} s\n", source, points.size(),
                   before.tets, res.delaunay_seconds);
        fmt::print("  {} mode on {} thread{}: {} flips, {} vertices smoothed in {:.3f} s\n",
                   a.options.mode, threads, threads == 1 ? "" : "s", r.flips, r.smoothed,
                   r.seconds);
        fmt::print("  tets {} -> {}, mean harmonic index {:.4f} -> {:.4f}\n", before.tets,
                   after.tets, before.mean_index, after.mean_index);
        fmt::print("{} (result check {:.3f} s, {:.3f} s total)\n", a.out, res.check_seconds,
                   phases.total());
        fmt::print("  seconds: {}\n", phases.to_text());
    }
    return 0;
#else
    (void)a;
    throw idas::input_error("idas harmonic needs a build with CGAL (for the Delaunay input)");
#endif
}
