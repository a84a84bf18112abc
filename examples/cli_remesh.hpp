// `idas remesh`: isotropic remeshing from the command line (the run itself is
// tool/remesh.hpp, shared with the Python module). Included by idas_cli.cpp inside its
// anonymous namespace, after print_stats and friends (which is why it includes nothing
// itself: idas_cli.cpp includes the headers it needs).
#pragma once

struct remesh_arguments {
    std::string in, out;
    remesh_options options;
    double envelope = 0;       // copied into options when --envelope is given
    double feature_angle = -1; // copied into options when --feature-angle is given
    bool as_json = false, ascii = false;
    bool drop_attributes = false;
    CLI::Option* envelope_option = nullptr;
    CLI::Option* feature_angle_option = nullptr;
};

int run_remesh(const remesh_arguments& a) {
    phase_times phases;
    idas::io::format_of(a.out); // an unknown output extension fails before any work
    check_remesh_options(a.options);
    const unsigned threads = a.options.threads;
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
    const idas::io::surface s = load(a.in, !a.drop_attributes);
    phases.lap("read");
    terminal_progress bar("remesh");
    const auto draw = [&bar](double done, const std::string& note) { bar.draw(done, note); };
    const phase_progress progress(draw);
    const remeshed res =
        remesh_surface(s, a.in, a.options, phases, bar.enabled() ? &progress : nullptr);
    bar.end_line();
    const auto& r = res.report;
    const idas::io::surface& result = res.mesh;
    save(a.out, result, a.ascii);
    phases.lap("write");
    if (a.as_json) {
        json j;
        j["input"] = a.in;
        j["output"] = a.out;
        j["target_edge_length"] = res.target_length;
        j["input_faces"] = s.faces.size();
        j["output_faces"] = result.faces.size();
        j["threads"] = threads;
        j["deterministic"] = a.options.deterministic;
        j["self_intersections_refused"] = !a.options.allow_self_intersections;
        j["backend"] = a.options.backend;
        j["iterations"] = r.iterations;
        j["envelope"] = res.envelope ? json(*res.envelope) : json(nullptr);
        j["splits"] = r.splits;
        j["collapses"] = r.collapses;
        j["swaps"] = r.swaps;
        j["smooths"] = r.smooths;
        j["attributes"] = attributes_json(result);
        j["seconds_algorithm"] = r.seconds;
        j["seconds_check"] = res.check_seconds;
        j["seconds_total"] = phases.total();
        j["phases"] = phases.to_json();
        static constexpr const char* kinds[] = {"split", "collapse", "swap", "smooth"};
        for (std::size_t k = 0; k < 4; ++k)
            j["remeshing_phases"][kinds[k]] = {{"seconds", r.phases[k].seconds},
                                               {"setup", r.phases[k].setup_seconds},
                                               {"serial_tail", r.phases[k].tail_seconds},
                                               {"succeeded", r.phases[k].succeeded},
                                               {"lock_failures", r.phases[k].lock_failures}};
        j["output_stats"] = stats_json(res.output_stats);
        if (a.options.trace) {
            j["trace"] = json::array();
            for (const auto& q : res.trace)
                j["trace"].push_back(
                    {{"iteration", q.iteration + 1},
                     {"phase", idas::tool::remeshing_phase_names[q.phase]},
                     {"faces", q.faces},
                     {"min_angle_deg", q.min_angle_deg},
                     {"min_angle_at", {q.min_angle_at[0], q.min_angle_at[1], q.min_angle_at[2]}},
                     {"valence", {q.min_valence, q.max_valence}}});
        }
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} -> {} faces, target edge length {:.6g}, {} iterations on {} thread{} in "
                   "{:.3f} s (result check {:.3f} s, {:.3f} s total)\n",
                   a.in, s.faces.size(), result.faces.size(), res.target_length, r.iterations,
                   threads, threads == 1 ? "" : "s", r.seconds, res.check_seconds, phases.total());
        fmt::print("  seconds: {}\n", phases.to_text());
        fmt::print("  splits {}, collapses {}, swaps {}, smooths {}\n", r.splits, r.collapses,
                   r.swaps, r.smooths);
        fmt::print("{}\n", a.out);
        print_stats(res.output_stats);
        for (const auto& q : res.trace)
            fmt::print("  iteration {} {:8}: {} faces, smallest angle {:.2f} deg at ({:.6g}, "
                       "{:.6g}, {:.6g}), valences {}-{}\n",
                       q.iteration + 1, idas::tool::remeshing_phase_names[q.phase], q.faces,
                       q.min_angle_deg, q.min_angle_at[0], q.min_angle_at[1], q.min_angle_at[2],
                       q.min_valence, q.max_valence);
    }
    return 0;
}
