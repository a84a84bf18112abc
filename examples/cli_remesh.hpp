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
    double envelope = 0; // relative eps; used only when --envelope is given
    double feature_angle = -1;
    bool keep_boundary = true;
    bool as_json = false, ascii = false;
    bool deterministic = false; // lock::deterministic_rounds
    bool drop_attributes = false;
    bool allow_self_intersections = false; // no_self_intersection off
    std::string backend = "indexed";
    // The default output limit: about 15 GB while remeshing (connectivity, queues,
    // attributes and the written copy take some 150 bytes per face).
    std::uint64_t max_faces = 100'000'000;
    CLI::Option* envelope_option = nullptr;
    CLI::Option* feature_angle_option = nullptr;
};

/// Every option that needs no input is checked before any reading.
void check_remesh_options(const remesh_arguments& a) {
    check_threads(a.threads);
    if (!(a.edge_length > 0) || !std::isfinite(a.edge_length))
        throw idas::input_error("--edge-length must be a positive number");
    if (a.envelope_option && a.envelope_option->count() > 0 &&
        !(a.envelope > 0 && std::isfinite(a.envelope)))
        throw idas::input_error("--envelope must be a positive number");
    if (a.feature_angle_option && a.feature_angle_option->count() > 0 &&
        !(a.feature_angle >= 0 && a.feature_angle <= 180))
        throw idas::input_error("--feature-angle must be between 0 and 180 degrees");
}

/// Faces of an isotropic mesh of edge length L on the surface: area / (sqrt(3)/4 L^2).
double estimated_faces(const idas::io::surface& s, double target_length) {
    double area = 0;
    for (const auto& f : s.faces)
        area += 0.5 * idas::norm(idas::cross(s.vertices[f[1]] - s.vertices[f[0]],
                                             s.vertices[f[2]] - s.vertices[f[0]]));
    return area / (std::sqrt(3.0) / 4 * target_length * target_length);
}

template <class Lock, class Mesh, class... Extra>
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
    return idas::algorithms::isotropic_remeshing<Mesh, Lock, idas::queue::dary_heap<4>,
                                                 idas::partition::morton,
                                                 Extra...>::run_observed(m, o, exec, observer,
                                                                         extra...);
}

template <class Mesh>
int run_remesh(const remesh_arguments& a) {
    phase_times phases;
    idas::io::format_of(a.out); // an unknown output extension fails before any work
    check_remesh_options(a);
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, a.threads);
    const idas::io::surface s = load(a.in, !a.drop_attributes);
    phases.lap("read");
    const mesh_stats in_stats = compute_stats(s);
    phases.lap("input_statistics");
    std::optional<Mesh> built;
    try {
        built.emplace(s.vertices, s.faces);
    } catch (const idas::input_error& e) {
        throw idas::input_error(a.in + ": " + e.what());
    }
    auto& m = *built;
    phases.lap("build");
    idas::algorithms::remeshing_options o;
    o.target_length = a.absolute ? a.edge_length : a.edge_length * in_stats.diagonal;
    if (!(o.target_length > 0) || !std::isfinite(o.target_length))
        throw idas::input_error(fmt::format("--edge-length {} gives a target length of {} on {}",
                                            a.edge_length, o.target_length, a.in));
    // A tiny length would grow the mesh until memory runs out: refuse it up front.
    if (const double n = estimated_faces(s, o.target_length); !(n <= double(a.max_faces)))
        throw idas::input_error(fmt::format(
            "--edge-length {} (target length {:.6g}) would make about {:.3g} faces on {}, more "
            "than --max-faces {}",
            a.edge_length, o.target_length, n, a.in, a.max_faces));
    o.iterations = a.iterations;
    o.preserve_boundary = a.keep_boundary;
    o.feature_angle_deg = a.feature_angle;
    // The file's attributes ride along; boundary and features are the remesher's own.
    carried_attributes carried;
    o.transfer = carried.attach(m, s, {});
    phases.lap("attributes");

    idas::algorithms::remeshing_report r;
    // Faces that meet other faces are refused unless asked otherwise; the index of faces
    // lives through every phase, with cells of a few target lengths.
    std::optional<idas::self_intersection_index> index;
    if (!a.allow_self_intersections) index.emplace(m, 4 * o.target_length);
    const idas::no_self_intersection guard =
        index ? idas::no_self_intersection(*index) : idas::no_self_intersection();
    phases.lap("self_intersection_index");
    if (a.envelope_option && a.envelope_option->count() > 0) {
#if IDAS_CLI_HAVE_CGAL
        if (!std::isfinite(a.envelope * in_stats.diagonal))
            throw idas::input_error(
                fmt::format("--envelope {} is too large for {}", a.envelope, a.in));
        const idas::envelope env(s.vertices, s.faces, a.envelope * in_stats.diagonal);
        r = a.deterministic
                ? remesh_with<idas::lock::deterministic_rounds>(m, o, a.threads, env, guard)
                : remesh_with<idas::lock::vertex_try_lock>(m, o, a.threads, env, guard);
#else
        throw idas::input_error("--envelope needs a build with CGAL");
#endif
    } else {
        r = a.deterministic ? remesh_with<idas::lock::deterministic_rounds>(m, o, a.threads, guard)
                            : remesh_with<idas::lock::vertex_try_lock>(m, o, a.threads, guard);
    }
    phases.lap("remeshing", r.setup_seconds, r.tail_seconds);
    idas::io::surface result;
    std::tie(result.vertices, result.faces) = m.to_arrays();
    carried.export_to(m, result, s);
    phases.lap("export");
    const mesh_stats out_stats = compute_stats(result);
    phases.lap("output_statistics");
    const stopwatch check_clock;
    check_result("remesh", summary_of(in_stats.topo), summary_of(out_stats.topo));
    const double t_check = check_clock.seconds();
    phases.lap("check");
    save(a.out, result, a.ascii);
    phases.lap("write");
    if (a.as_json) {
        json j;
        j["input"] = a.in;
        j["output"] = a.out;
        j["target_edge_length"] = o.target_length;
        j["input_faces"] = s.faces.size();
        j["output_faces"] = result.faces.size();
        j["threads"] = a.threads;
        j["deterministic"] = a.deterministic;
        j["self_intersections_refused"] = !a.allow_self_intersections;
        j["backend"] = a.backend;
        j["iterations"] = r.iterations;
        j["envelope"] =
            a.envelope_option->count() > 0 ? json(a.envelope * in_stats.diagonal) : json(nullptr);
        j["splits"] = r.splits;
        j["collapses"] = r.collapses;
        j["swaps"] = r.swaps;
        j["smooths"] = r.smooths;
        j["attributes"] = attributes_json(result);
        j["seconds_algorithm"] = r.seconds;
        j["seconds_check"] = t_check;
        j["seconds_total"] = phases.total();
        j["phases"] = phases.to_json();
        static constexpr const char* kinds[] = {"split", "collapse", "swap", "smooth"};
        for (std::size_t k = 0; k < 4; ++k)
            j["remeshing_phases"][kinds[k]] = {{"seconds", r.phases[k].seconds},
                                               {"setup", r.phases[k].setup_seconds},
                                               {"serial_tail", r.phases[k].tail_seconds},
                                               {"succeeded", r.phases[k].succeeded},
                                               {"lock_failures", r.phases[k].lock_failures}};
        j["output_stats"] = stats_json(out_stats);
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} -> {} faces, target edge length {:.6g}, {} iterations on {} thread{} in "
                   "{:.3f} s (result check {:.3f} s, {:.3f} s total)\n",
                   a.in, s.faces.size(), result.faces.size(), o.target_length, r.iterations,
                   a.threads, a.threads == 1 ? "" : "s", r.seconds, t_check, phases.total());
        fmt::print("  seconds: {}\n", phases.to_text());
        fmt::print("  splits {}, collapses {}, swaps {}, smooths {}\n", r.splits, r.collapses,
                   r.swaps, r.smooths);
        fmt::print("{}\n", a.out);
        print_stats(out_stats);
    }
    return 0;
}
