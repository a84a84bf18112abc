// `idas harmonic`: harmonic triangulation (Alexa 2019) of a point set: CGAL's Delaunay
// tetrahedralization, then harmonic flips (and smoothing in complete mode). Included by
// idas_cli.cpp inside its anonymous namespace (so it includes nothing itself; idas_cli.cpp
// includes the library headers, the CGAL ones when IDAS_CLI_HAVE_CGAL).
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
    std::string mode = "complete";
    std::string backend = "indexed";
    unsigned threads = 1, rounds = idas::algorithms::harmonic_options{}.rounds;
    bool as_json = false, ascii = false;
    bool deterministic = false; // lock::deterministic_rounds
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
    c->add_flag("--deterministic", a.deterministic,
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

/// The result check of harmonic: every tet positively oriented (exact orient3d), every
/// face shared by at most two tets, and the boundary a closed oriented 2-manifold with
/// `boundary_chi` (the input hull's). One parallel sort of the faces.
std::optional<std::string> check_harmonic_result(const idas::io::volume& v, long boundary_chi) {
    const auto& V = v.vertices;
    const auto& T = v.tets;
    using range = tbb::blocked_range<std::size_t>;
    // Each tet on its own, in parallel; the lowest bad tet is reported.
    const auto tet_problem = [&](std::size_t t) -> std::optional<std::string> {
        const auto& tv = T[t];
        for (index_t x : tv)
            if (x >= V.size()) return "tet " + std::to_string(t) + " references a missing vertex";
        if (idas::orient3d(V[tv[0]], V[tv[1]], V[tv[2]], V[tv[3]]) <= 0)
            return "tet " + std::to_string(t) + " is flat or inverted";
        return std::nullopt;
    };
    const std::size_t first_bad = tbb::parallel_reduce(
        range(0, T.size(), 4096), T.size(),
        [&](const range& r, std::size_t bad) {
            for (std::size_t t = r.begin(); t != r.end() && t < bad; ++t)
                if (tet_problem(t)) return t;
            return bad;
        },
        [](std::size_t a, std::size_t b) { return std::min(a, b); });
    if (first_bad < T.size()) return tet_problem(first_bad);
    // Every face (sorted key, as its tet sees it from outside), sorted so that copies of a
    // face are adjacent: a face seen once is on the boundary, more than twice is an error.
    struct face_use {
        std::array<index_t, 3> key;
        idas::tri_indices outward;
    };
    std::vector<face_use> faces(4 * T.size());
    tbb::parallel_for(range(0, T.size(), 4096), [&](const range& r) {
        for (std::size_t t = r.begin(); t != r.end(); ++t)
            for (std::size_t k = 0; k < 4; ++k) {
                const auto& lf = idas::tet_local::face_vertices[k];
                const idas::tri_indices f = {T[t][lf[0]], T[t][lf[1]], T[t][lf[2]]};
                std::array<index_t, 3> key = f;
                std::sort(key.begin(), key.end());
                faces[4 * t + k] = {key, f};
            }
    });
    tbb::parallel_sort(faces.begin(), faces.end(), [](const face_use& a, const face_use& b) {
        return std::tie(a.key[0], a.key[1], a.key[2], a.outward[0], a.outward[1], a.outward[2]) <
               std::tie(b.key[0], b.key[1], b.key[2], b.outward[0], b.outward[1], b.outward[2]);
    });
    std::vector<idas::tri_indices> boundary;
    for (std::size_t i = 0; i < faces.size();) {
        std::size_t j = i + 1;
        while (j < faces.size() && faces[j].key == faces[i].key) ++j;
        if (j - i > 2) {
            const auto& k = faces[i].key;
            return "face (" + std::to_string(k[0]) + ", " + std::to_string(k[1]) + ", " +
                   std::to_string(k[2]) + ") is shared by more than two tets";
        }
        if (j - i == 1) boundary.push_back(faces[i].outward);
        i = j;
    }
    const auto b = idas::summarize_surface(V.size(), boundary);
    if (b.problem) return "the boundary is not an oriented 2-manifold: " + *b.problem;
    if (b.boundary_edges > 0) return "the boundary surface is not closed";
    if (b.euler_characteristic != boundary_chi)
        return "the boundary has Euler characteristic " + std::to_string(b.euler_characteristic) +
               ", the input's has " + std::to_string(boundary_chi);
    return std::nullopt;
}

int run_harmonic(const harmonic_arguments& a) {
#if IDAS_CLI_HAVE_CGAL
    phase_times phases;
    // Everything that can be refused without work is refused first.
    const std::string ext = lowercase_extension(a.out);
    if (ext != ".msh" && ext != ".vtu")
        throw idas::input_error(a.out + ": unknown output extension (expected .msh or .vtu)");
    check_threads(a.threads);
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, a.threads);
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
    check_range(source, points);
    phases.lap(a.points.empty() ? "generate" : "read");

    const stopwatch delaunay_clock;
    idas::cgal::delaunay_result dt;
    try {
        dt = idas::cgal::delaunay_tetrahedralization(points, a.threads);
    } catch (const idas::input_error& e) {
        throw idas::input_error(source + ": " + e.what());
    }
    const double delaunay_seconds = delaunay_clock.seconds();
    phases.lap("delaunay");
    idas::algorithms::harmonic_options o;
    o.mode = a.mode == "reduced" ? idas::algorithms::harmonic_mode::reduced
                                 : idas::algorithms::harmonic_mode::complete;
    o.rounds = a.rounds;
    o.exec.threads = a.threads;
    idas::algorithms::harmonic_stats before, after;
    idas::algorithms::harmonic_report r;
    idas::io::volume v;
    // The same run on either tet backend (--backend).
    // The flips keep the convex hull: its boundary is a sphere before and after.
    double check_seconds = 0;
    const auto flip = [&]<class Mesh>(Mesh m) {
        phases.lap("build");
        before = idas::algorithms::harmonic_statistics(m);
        phases.lap("statistics_before");
        terminal_progress bar("harmonic");
        const unsigned phase_count =
            o.mode == idas::algorithms::harmonic_mode::reduced ? 1 : 1 + 2 * o.rounds;
        unsigned ran = 0;
        auto observer = [&](std::size_t phase, unsigned round, const idas::run_report& pr) {
            static constexpr const char* names[] = {"3-2 flips", "smoothing", "seeded flips"};
            bar.draw(double(++ran) / phase_count, std::string(names[phase]) + ", round " +
                                                      std::to_string(round + 1) + ": " +
                                                      std::to_string(pr.succeeded) + " done");
        };
        if (a.deterministic)
            r = idas::algorithms::harmonic_triangulation<
                Mesh, idas::lock::deterministic_rounds>::run_observed(m, o, observer);
        else
            r = idas::algorithms::harmonic_triangulation<Mesh>::run_observed(m, o, observer);
        phases.lap("flipping", r.setup_seconds, r.tail_seconds);
        after = idas::algorithms::harmonic_statistics(m);
        phases.lap("statistics_after");
        std::tie(v.vertices, v.tets) = m.to_arrays();
        phases.lap("export");
        const stopwatch check_clock;
        if (const auto failed = check_harmonic_result(v, 2))
            throw std::runtime_error("internal error: harmonic produced an invalid mesh (result "
                                     "check: " +
                                     *failed + "); nothing was written");
        check_seconds = check_clock.seconds();
        phases.lap("check");
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
    phases.lap("write");

    if (a.as_json) {
        json j;
        j["input"] = source;
        j["output"] = a.out;
        j["points"] = points.size();
        j["duplicate_points"] = dt.duplicates;
        j["mode"] = a.mode;
        j["threads"] = a.threads;
        j["deterministic"] = a.deterministic;
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
        j["seconds_check"] = check_seconds;
        j["seconds_total"] = phases.total();
        j["phases"] = phases.to_json();
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} points, Delaunay {} tets in {:.3f} s\n", source, points.size(),
                   before.tets, delaunay_seconds);
        fmt::print("  {} mode on {} thread{}: {} flips, {} vertices smoothed in {:.3f} s\n", a.mode,
                   a.threads, a.threads == 1 ? "" : "s", r.flips, r.smoothed, r.seconds);
        fmt::print("  tets {} -> {}, mean harmonic index {:.4f} -> {:.4f}\n", before.tets,
                   after.tets, before.mean_index, after.mean_index);
        fmt::print("{} (result check {:.3f} s, {:.3f} s total)\n", a.out, check_seconds,
                   phases.total());
        fmt::print("  seconds: {}\n", phases.to_text());
    }
    return 0;
#else
    (void)a;
    throw idas::input_error("idas harmonic needs a build with CGAL (for the Delaunay input)");
#endif
}
