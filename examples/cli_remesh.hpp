// `idas remesh`: isotropic remeshing from the command line. Included by idas_cli.cpp
// inside its anonymous namespace, after load/save/compute_stats and friends (which is
// why it includes nothing itself: idas_cli.cpp includes the library headers it needs).
#pragma once

struct remesh_arguments {
    std::string in, out;
    double edge_length = 0.01;
    bool absolute = false;
    unsigned iterations = 5;
    unsigned threads = 1;
    double envelope = -1; // relative eps; <0: off
    double feature_angle = -1;
    bool keep_boundary = true;
    bool as_json = false, ascii = false;
    std::string backend = "indexed";
};

template <class Mesh, class... Extra>
idas::algorithms::remeshing_report remesh_with(Mesh& m,
                                               const idas::algorithms::remeshing_options& o,
                                               unsigned threads, Extra... extra) {
    idas::exec_options exec;
    exec.threads = threads;
    terminal_progress bar("remesh");
    static constexpr const char* phases[] = {"split", "collapse", "swap", "smooth"};
    auto observer = [&](std::size_t phase, unsigned iteration, const idas::run_report&) {
        const double done = double(iteration * 4 + phase + 1) / double(4 * o.iterations);
        bar.draw(done, "iteration " + std::to_string(iteration + 1) + "/" +
                           std::to_string(o.iterations) + ", " + phases[phase % 4]);
    };
    return idas::algorithms::isotropic_remeshing<Mesh, idas::lock::vertex_try_lock,
                                                 idas::queue::dary_heap<4>, idas::partition::morton,
                                                 Extra...>::run_observed(m, o, exec, observer,
                                                                         extra...);
}

template <class Mesh>
int run_remesh(const remesh_arguments& a) {
    const stopwatch total;
    idas::io::format_of(a.out); // an unknown output extension fails before any work
    if (a.threads == 0) throw idas::input_error("--threads must be at least 1");
    if (!(a.edge_length > 0) || !std::isfinite(a.edge_length))
        throw idas::input_error("--edge-length must be positive");
    const idas::io::surface s = load(a.in);
    const mesh_stats in_stats = compute_stats(s);
    std::optional<Mesh> built;
    try {
        built.emplace(s.vertices, s.faces);
    } catch (const idas::input_error& e) {
        throw idas::input_error(a.in + ": " + e.what());
    }
    auto& m = *built;
    idas::algorithms::remeshing_options o;
    o.target_length = a.absolute ? a.edge_length : a.edge_length * in_stats.diagonal;
    o.iterations = a.iterations;
    o.preserve_boundary = a.keep_boundary;
    o.feature_angle_deg = a.feature_angle;

    idas::algorithms::remeshing_report r;
    if (a.envelope > 0) {
#if IDAS_CLI_HAVE_CGAL
        const idas::envelope env(s.vertices, s.faces, a.envelope * in_stats.diagonal);
        r = remesh_with(m, o, a.threads, env);
#else
        throw idas::input_error("--envelope needs a build with CGAL");
#endif
    } else {
        r = remesh_with(m, o, a.threads);
    }

    idas::io::surface result;
    std::tie(result.vertices, result.faces) = m.to_arrays();
    save(a.out, result, a.ascii);
    const mesh_stats out_stats = compute_stats(result);
    if (a.as_json) {
        json j;
        j["input"] = a.in;
        j["output"] = a.out;
        j["target_edge_length"] = o.target_length;
        j["input_faces"] = s.faces.size();
        j["output_faces"] = result.faces.size();
        j["threads"] = a.threads;
        j["backend"] = a.backend;
        j["iterations"] = r.iterations;
        j["envelope"] = a.envelope > 0 ? json(a.envelope * in_stats.diagonal) : json(nullptr);
        j["splits"] = r.splits;
        j["collapses"] = r.collapses;
        j["swaps"] = r.swaps;
        j["smooths"] = r.smooths;
        j["seconds_algorithm"] = r.seconds;
        j["seconds_total"] = total.seconds();
        j["output_stats"] = stats_json(out_stats);
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} -> {} faces, target edge length {:.6g}, {} iterations on {} thread{} in "
                   "{:.3f} s "
                   "({:.3f} s total)\n",
                   a.in, s.faces.size(), result.faces.size(), o.target_length, r.iterations,
                   a.threads, a.threads == 1 ? "" : "s", r.seconds, total.seconds());
        fmt::print("  splits {}, collapses {}, swaps {}, smooths {}\n", r.splits, r.collapses,
                   r.swaps, r.smooths);
        fmt::print("{}\n", a.out);
        print_stats(out_stats);
    }
    return 0;
}
