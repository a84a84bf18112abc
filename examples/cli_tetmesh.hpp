// `idas tetmesh`: tetrahedral meshing of a triangle soup: exact insertion with inside and
// outside (part 1), then the quality optimization (part 2; the options, their checks and
// the full run are tool/tetmesh.hpp, shared with the Python module). Included by
// idas_cli.cpp inside its anonymous namespace, after the helpers it uses.
//
//   idas tetmesh IN OUT.msh|OUT.vtu [--epsilon E] [--edge-length L] [--absolute]
//                [--sizing VALUE|FILE.msh] [--stop-energy 10] [--max-iterations 80]
//                [--stall-rounds 12]
//                [--keep-outside] [--no-simplify] [--boundary SURFACE]
//                [--stage insertion|optimize] [--msh-version 2.2|4.1] [--threads T]
//                [--deterministic] [--json] [--ascii]
//
// OUT is MSH (2.2 by default, or 4.1) with physical tag 1 inside (winding number above
// 1/2 at its centroid) and 2 outside, or VTU with the cell fields "region" (the same 1
// and 2) and "amips". The full run writes the inside only (with --keep-outside, every
// tet); the insertion stage writes every tet. --boundary writes the inside's boundary
// surface (.obj, .off, .ply, .stl).
#pragma once

struct tetmesh_arguments {
    std::string in, out, boundary, msh_version = "2.2";
    tetmesh_options options;
    bool as_json = false, ascii = false;
};

CLI::App* add_tetmesh_command(CLI::App& app, tetmesh_arguments& a,
                              const CLI::Validator& unsigned_check) {
    auto* c = app.add_subcommand(
        "tetmesh", "Tetrahedral mesh of a triangle soup (TetWild-style): every input triangle "
                   "inserted exactly into a background mesh, the tets optimized to AMIPS at "
                   "most --stop-energy, the inside kept");
    c->add_option("IN", a.in, "input triangle soup (.obj, .off, .ply, .stl)")->required();
    c->add_option("OUT", a.out,
                  "output tet mesh: .msh (physical tag 1 inside, 2 outside) or .vtu (cell "
                  "fields region, the same tags, and amips)")
        ->required();
    c->add_option("--epsilon", a.options.epsilon,
                  "envelope half-width, relative to the bounding-box diagonal (used by the "
                  "optimization stage; insertion is exact)")
        ->capture_default_str();
    c->add_option("--edge-length", a.options.edge_length,
                  "target edge length, relative to the diagonal (spacing of the background "
                  "box points)")
        ->capture_default_str();
    c->add_flag("--absolute", a.options.absolute,
                "--epsilon, --edge-length and a constant --sizing are absolute lengths");
    c->add_option("--sizing", a.options.sizing,
                  "target edge length field of the optimization: a constant (relative to the "
                  "diagonal unless --absolute), or a .msh tet mesh whose first scalar "
                  "$NodeData gives an absolute length per node, interpolated linearly (points "
                  "outside it take the nearest tet's value)");
    c->add_option("--boundary", a.boundary,
                  "also write the boundary surface of the inside (.obj, .off, .ply, .stl)");
    c->add_option("--msh-version", a.msh_version, "MSH version of .msh output")
        ->check(CLI::IsMember({"2.2", "4.1"}))
        ->capture_default_str();
    c->add_option("--stop-energy", a.options.stop_energy,
                  "stop optimizing when the largest AMIPS energy is at most this (>= 3)")
        ->capture_default_str();
    c->add_option("--max-iterations", a.options.max_iterations,
                  "at most this many rounds of split, collapse, swap and smooth")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_option("--stall-rounds", a.options.stall_rounds,
                  "stop once this many rounds in a row lowered neither the largest AMIPS nor the "
                  "number of tets above the stop energy (0: never)")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_flag("--keep-outside", a.options.keep_outside,
                "write every tet (tag 1 inside, 2 outside), not only the inside");
    c->add_flag("--no-simplify", a.options.no_simplify,
                "insert every input triangle as it is (by default the full run first collapses "
                "the input's short edges inside an envelope of 0.8 epsilon, as fTetWild)");
    c->add_option("--stage", a.options.stage,
                  "last stage to run (insertion: part 1, every tet written unoptimized)")
        ->check(CLI::IsMember({"insertion", "optimize"}))
        ->capture_default_str();
    c->add_option("--threads", a.options.threads, "worker threads")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_flag("--deterministic", a.options.deterministic,
                "the same mesh at any thread count (deterministic rounds: slower)");
    c->add_flag("--json", a.as_json, "print one JSON object instead of text");
    c->add_flag("--ascii", a.ascii, "write MSH, VTU and the boundary as text instead of binary");
    return c;
}

#if IDAS_CLI_HAVE_CGAL
/// Writes OUT (MSH or VTU, every tet of v with its region tag) and, when asked, the
/// boundary surface of the inside tets.
void write_tetmesh_output(const tetmesh_arguments& a, const idas::io::volume& v) {
    const auto enc = a.ascii ? idas::io::encoding::ascii : idas::io::encoding::binary;
    if (is_vtu_path(a.out)) {
        idas::io::vtu_options options;
        options.enc = enc;
        idas::io::vtu_field region{"region", 1, {}}, amips{"amips", 1, {}};
        for (std::size_t t = 0; t < v.tets.size(); ++t) {
            const auto& tv = v.tets[t];
            region.values.push_back(v.tags.empty() ? 1.0 : double(v.tags[t]));
            amips.values.push_back(idas::tet_amips(v.vertices[tv[0]], v.vertices[tv[1]],
                                                   v.vertices[tv[2]], v.vertices[tv[3]]));
        }
        options.cell_data = {std::move(region), std::move(amips)};
        idas::io::write_vtu(a.out, v, options);
    } else {
        idas::io::write_msh(a.out, v,
                            a.msh_version == "4.1" ? idas::io::msh_version::v4_1
                                                   : idas::io::msh_version::v2_2,
                            enc);
    }
    if (a.boundary.empty()) return;
    idas::io::volume inside;
    inside.vertices = v.vertices;
    for (std::size_t t = 0; t < v.tets.size(); ++t)
        if (v.tags.empty() || v.tags[t] == 1) inside.tets.push_back(v.tets[t]);
    save(a.boundary, boundary_surface(inside), a.ascii);
}

/// What both stages report: the input, the insertion, the lengths and part 1's seconds.
json insertion_json(const tetmesh_arguments& a, const idas::io::surface& s,
                    const idas::tetmesh::report& r) {
    json j;
    j["input"] = {{"file", a.in},
                  {"vertices", r.input_vertices},
                  {"faces", r.input_faces},
                  {"welded_vertices", r.welded_vertices},
                  {"degenerate_faces_dropped", r.degenerate_faces + s.dropped_faces},
                  {"repeated_faces_dropped", r.repeated_faces}};
    j["triangles"] = r.triangles;
    j["simplified_triangles"] = r.simplified_triangles;
    j["inserted_triangles"] = r.covered_triangles;
    j["diagonal"] = r.diagonal;
    j["epsilon"] = r.epsilon;
    j["edge_length"] = r.edge_length;
    j["threads"] = a.options.threads;
    j["deterministic"] = a.options.deterministic;
    j["seconds"] = {{"cleaning", r.seconds_cleaning}, {"simplification", r.seconds_simplification},
                    {"delaunay", r.seconds_delaunay}, {"insertion", r.seconds_insertion},
                    {"rounding", r.seconds_rounding}, {"checks", r.seconds_check}};
    return j;
}

/// The command's clock, and the time its reading and writing took.
struct tetmesh_clock {
    stopwatch total;
    double read = 0, write = 0;
};

/// The full run: parts 1 and 2.
int run_tetmesh_optimized(const tetmesh_arguments& a, const idas::io::surface& s,
                          const tetmesh_setup& setup, tetmesh_clock& clock) {
    const unsigned max_iterations = a.options.max_iterations;
    std::optional<terminal_progress> bar;
    if (!a.as_json) bar.emplace("tetmesh");
    const auto draw = [&](unsigned round, double max_energy) {
        if (bar)
            bar->draw(double(round + 1) / std::max(1u, max_iterations),
                      "round " + std::to_string(round + 1) + ", max AMIPS " +
                          std::to_string(max_energy));
    };
    const round_observer observer(draw);
    const tetmeshed res = tetmesh_volume(s, a.in, a.options, setup, &observer);
    if (bar) bar->end_line();
    const auto& r = res.insertion;
    const auto& qr = res.quality;
    const auto& opt = qr.optimization;
    const idas::io::volume& v = res.mesh;
    const stopwatch writing;
    write_tetmesh_output(a, v);
    clock.write = writing.seconds();
    using idas::algorithms::tet_optimization_stop;
    const char* stop = opt.stopped == tet_optimization_stop::iteration_limit ? "iteration_limit"
                       : opt.stopped == tet_optimization_stop::stalled       ? "stalled"
                                                                             : "energy_reached";
    // A run that missed what it promises says so on stderr, whatever the output's format:
    // the file is written (usable, and what the report describes), but not silently.
    if (qr.quality.amips.max > a.options.stop_energy)
        std::fprintf(
            stderr,
            "idas: warning: %s: the largest AMIPS energy %.4g is above the stop energy %.4g "
            "(stopped: %s)\n",
            a.out.c_str(), qr.quality.amips.max, a.options.stop_energy, stop);
    if (qr.flat_or_inverted > 0)
        std::fprintf(stderr,
                     "idas: warning: %s: %zu tets are flat or inverted as written (%zu vertices "
                     "could not be rounded to doubles)\n",
                     a.out.c_str(), std::size_t(qr.flat_or_inverted),
                     std::size_t(opt.rational_left));
    if (a.as_json) {
        json j = insertion_json(a, s, r);
        j["tets"] = v.tets.size();
        j["vertices"] = v.vertices.size();
        j["inside_tets"] = qr.inside_tets;
        j["added_for_manifold_boundary"] = qr.added_for_manifold;
        j["boundary"] = {
            {"faces", qr.boundary_faces},
            {"non_manifold_edges", qr.non_manifold_edges},
            {"non_manifold_vertices", qr.non_manifold_vertices},
            {"closed_2_manifold", qr.non_manifold_edges == 0 && qr.non_manifold_vertices == 0}};
        j["amips"] = {{"min", qr.quality.amips.min},
                      {"mean", qr.quality.amips.mean},
                      {"max", qr.quality.amips.max}};
        j["min_dihedral_deg"] = qr.quality.dihedral_deg.min;
        j["flat_or_inverted_tets"] = qr.flat_or_inverted;
        j["optimization"] = {{"iterations", opt.iterations},
                             {"stopped", stop},
                             {"stop_energy", a.options.stop_energy},
                             {"max_energy_before", opt.max_energy_before},
                             {"max_energy", opt.max_energy},
                             {"splits", opt.splits},
                             {"collapses", opt.collapses},
                             {"swaps", opt.swaps},
                             {"smooths", opt.smooths},
                             {"sizing_refinements", opt.sizing_refinements},
                             {"touch_ups", opt.touch_ups},
                             {"last_passes", opt.last_passes},
                             {"rational_vertices_left", opt.rational_left}};
        // Where the optimization's time went: each operation's passes (their serial set-up
        // and tail included) and, the rest, the work between rounds (energies, rounding,
        // sizing).
        static constexpr const char* kinds[] = {"split", "collapse", "swap", "smooth"};
        double in_phases = 0;
        for (std::size_t k = 0; k < 4; ++k) {
            const auto& p = opt.phases[k];
            j["optimization"]["phases"][kinds[k]] = {{"seconds", p.seconds},
                                                     {"setup", p.setup_seconds},
                                                     {"serial_tail", p.tail_seconds},
                                                     {"attempted", p.attempted},
                                                     {"succeeded", p.succeeded},
                                                     {"lock_failures", p.lock_failures},
                                                     {"stolen", p.stolen},
                                                     {"retaken", p.retaken},
                                                     {"deferred_to_serial", p.deferred_to_serial}};
            in_phases += p.seconds;
        }
        j["optimization"]["seconds_between_rounds"] = opt.seconds - in_phases;
        j["optimization"]["max_energy_per_round"] = opt.max_energy_history;
        j["optimization"]["tets_above_stop_per_round"] = opt.above_stop_history;
        j["kept"] = a.options.keep_outside ? "all tets; MSH physical tag 1 = inside, 2 = outside"
                                           : "inside tets (MSH physical tag 1)";
        j["seconds"]["optimization"] = qr.seconds_optimization;
        j["seconds"]["winding_number_and_output"] = qr.seconds_output;
        j["seconds"]["winding_number"] = qr.seconds_winding;
        j["seconds"]["read"] = clock.read;
        j["seconds"]["write"] = clock.write;
        j["seconds"]["total"] = clock.total.seconds();
        std::printf("%s\n", j.dump(2).c_str());
    } else {
        std::printf("%s: %zu triangles, simplified to %zu, all inserted exactly\n", a.in.c_str(),
                    r.triangles, r.covered_triangles);
        std::printf("optimization: %u rounds (%s), max AMIPS %.3g -> %.3g; %llu splits, %llu "
                    "collapses, %llu swaps, %llu smooths\n",
                    opt.iterations, stop, opt.max_energy_before, opt.max_energy,
                    (unsigned long long)opt.splits, (unsigned long long)opt.collapses,
                    (unsigned long long)opt.swaps, (unsigned long long)opt.smooths);
        std::printf("output: %zu tets, %zu vertices; AMIPS min %.3f mean %.3f max %.3f; min "
                    "dihedral %.2f deg; boundary %s\n",
                    v.tets.size(), v.vertices.size(), qr.quality.amips.min, qr.quality.amips.mean,
                    qr.quality.amips.max, qr.quality.dihedral_deg.min,
                    qr.non_manifold_edges == 0 && qr.non_manifold_vertices == 0
                        ? "closed 2-manifold"
                        : "NOT a closed 2-manifold");
        std::printf("seconds: simplification %.3f, delaunay %.3f, insertion %.3f, optimization "
                    "%.3f, output %.3f, total %.3f\n",
                    r.seconds_simplification, r.seconds_delaunay, r.seconds_insertion,
                    qr.seconds_optimization, qr.seconds_output, clock.total.seconds());
        std::printf("wrote %s\n", a.out.c_str());
    }
    return 0;
}
#endif

int run_tetmesh(const tetmesh_arguments& a) {
#if IDAS_CLI_HAVE_CGAL
    tetmesh_clock clock;
    if (!is_tet_path(a.out))
        throw idas::input_error(a.out + ": unknown output extension (expected .msh or .vtu)");
    if (!a.boundary.empty()) {
        try {
            idas::io::format_of(a.boundary);
        } catch (const idas::input_error&) {
            throw idas::input_error(a.boundary + ": unknown extension for --boundary (expected "
                                                 ".obj, .off, .ply or .stl)");
        }
    }
    const std::optional<double> constant_sizing = check_tetmesh_options(a.options);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, a.options.threads);

    const stopwatch reading;
    const idas::io::surface s = load(a.in);
    clock.read = reading.seconds();
    const tetmesh_setup setup = prepare_tetmesh(a.options, s, constant_sizing);
    if (a.options.stage == "optimize") return run_tetmesh_optimized(a, s, setup, clock);
    idas::tetmesh::result res =
        idas::tetmesh::mesh_insertion(s.vertices, s.faces, setup.options, a.in);
    const auto& r = res.stats;
    check_insertion_guarantee(r);
    if (r.inside_tets == 0)
        throw idas::input_error(a.in + ": the input encloses no volume (the winding number is "
                                       "at most 1/2 at every tet: a flat or open sheet?); nothing "
                                       "was written");

    idas::io::volume v;
    v.vertices = res.mesh.vertices;
    v.tets = res.mesh.tets;
    v.tags.resize(v.tets.size());
    std::size_t flat_in_file = 0; // vertices still rational are written rounded
    for (std::size_t t = 0; t < v.tets.size(); ++t) {
        v.tags[t] = res.inside[t] ? 1 : 2;
        const auto& tv = v.tets[t];
        if (!res.mesh.exact.empty() && idas::orient3d(v.vertices[tv[0]], v.vertices[tv[1]],
                                                      v.vertices[tv[2]], v.vertices[tv[3]]) <= 0)
            ++flat_in_file;
    }
    const stopwatch writing;
    write_tetmesh_output(a, v);
    clock.write = writing.seconds();

    if (a.as_json) {
        json j = insertion_json(a, s, r);
        j["background_tets"] = r.background_tets;
        j["cut_tets"] = r.cut_tets;
        j["tets"] = r.tets;
        j["inside_tets"] = r.inside_tets;
        j["vertices"] = r.vertices;
        j["tracked_faces"] = r.tracked_faces;
        j["rational_vertices_created"] = r.rational_vertices_created;
        j["rational_vertices_left"] = r.rational_vertices_left;
        j["inverted_tets"] = r.inverted_tets;
        j["flat_or_inverted_as_written"] = flat_in_file;
        j["kept"] = "all tets; MSH physical tag 1 = inside, 2 = outside";
        j["seconds"]["winding_number"] = r.seconds_winding;
        j["seconds"]["read"] = clock.read;
        j["seconds"]["write"] = clock.write;
        j["seconds"]["total"] = clock.total.seconds();
        std::printf("%s\n", j.dump(2).c_str());
    } else {
        std::printf("%s: %zu triangles (%zu dropped as degenerate, %zu repeated, %zu vertices "
                    "welded)\n",
                    a.in.c_str(), r.triangles, r.degenerate_faces + s.dropped_faces,
                    r.repeated_faces, r.welded_vertices);
        std::printf("inserted exactly: %zu of %zu triangles; %zu tets (%zu inside), %zu "
                    "vertices, %zu tracked faces\n",
                    r.covered_triangles, r.triangles, r.tets, r.inside_tets, r.vertices,
                    r.tracked_faces);
        std::printf("rational vertices: %zu created, %zu left; inverted tets (exact): %zu\n",
                    r.rational_vertices_created, r.rational_vertices_left, r.inverted_tets);
        std::printf("seconds: delaunay %.3f, insertion %.3f, rounding %.3f, winding number "
                    "%.3f, checks %.3f, total %.3f\n",
                    r.seconds_delaunay, r.seconds_insertion, r.seconds_rounding, r.seconds_winding,
                    r.seconds_check, clock.total.seconds());
        std::printf("wrote %s\n", a.out.c_str());
    }
    return 0;
#else
    (void)a;
    return error(2,
                 "tetmesh needs CGAL (Delaunay background mesh); this idas was built without it");
#endif
}
