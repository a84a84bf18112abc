// `idas tetmesh`: tetrahedral meshing of a triangle soup, part 1 (exact insertion with
// inside and outside; the quality optimization is the next stage). Included by
// idas_cli.cpp inside its anonymous namespace, after the helpers it uses.
//
//   idas tetmesh IN OUT.msh [--epsilon E] [--edge-length L] [--absolute]
//                [--stage insertion] [--threads T] [--json] [--ascii]
//
// OUT is MSH 2.2 with every tet of the mesh: physical tag 1 inside (winding number above
// 1/2 at its centroid), 2 outside.
#pragma once

struct tetmesh_arguments {
    std::string in, out, stage = "insertion";
    double epsilon = 1e-3, edge_length = 1.0 / 20.0;
    bool absolute = false, as_json = false, ascii = false;
    unsigned threads = 1;
};

CLI::App* add_tetmesh_command(CLI::App& app, tetmesh_arguments& a,
                              const CLI::Validator& unsigned_check) {
    auto* c = app.add_subcommand(
        "tetmesh", "Tetrahedral mesh of a triangle soup (TetWild-style): every input triangle "
                   "inserted exactly into a background mesh, tets tagged inside/outside");
    c->add_option("IN", a.in, "input triangle soup (.obj, .off, .ply, .stl)")->required();
    c->add_option("OUT", a.out, "output tet mesh (.msh, MSH 2.2: tag 1 inside, 2 outside)")
        ->required();
    c->add_option("--epsilon", a.epsilon,
                  "envelope half-width, relative to the bounding-box diagonal (used by the "
                  "optimization stage; insertion is exact)")
        ->capture_default_str();
    c->add_option("--edge-length", a.edge_length,
                  "target edge length, relative to the diagonal (spacing of the background "
                  "box points)")
        ->capture_default_str();
    c->add_flag("--absolute", a.absolute, "--epsilon and --edge-length are absolute lengths");
    c->add_option("--stage", a.stage, "last stage to run (insertion: part 1)")
        ->check(CLI::IsMember({"insertion"}))
        ->capture_default_str();
    c->add_option("--threads", a.threads, "worker threads")
        ->check(unsigned_check)
        ->capture_default_str();
    c->add_flag("--json", a.as_json, "print one JSON object instead of text");
    c->add_flag("--ascii", a.ascii, "write MSH as text instead of binary");
    return c;
}

int run_tetmesh(const tetmesh_arguments& a) {
#if IDAS_CLI_HAVE_CGAL
    const stopwatch total;
    if (lowercase_extension(a.out) != ".msh")
        throw idas::input_error(a.out + ": unknown output extension (expected .msh)");
    check_threads(a.threads);
    if (!(a.epsilon > 0) || !std::isfinite(a.epsilon) || (!a.absolute && a.epsilon > 1))
        throw idas::input_error("--epsilon must be positive and finite (at most 1 when relative)");
    if (!(a.edge_length > 0) || !std::isfinite(a.edge_length) ||
        (!a.absolute && a.edge_length > 10))
        throw idas::input_error(
            "--edge-length must be positive and finite (at most 10 when relative)");
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, a.threads);

    const idas::io::surface s = load(a.in);
    idas::tetmesh::options o;
    o.epsilon = a.epsilon, o.edge_length = a.edge_length, o.absolute = a.absolute;
    idas::tetmesh::result res = idas::tetmesh::mesh_insertion(s.vertices, s.faces, o, a.in);
    const auto& r = res.stats;
    // The guarantee, checked: a failure is a bug in idas, not in the input (exit 1).
    if (r.covered_triangles != r.triangles || r.inverted_tets != 0)
        throw std::runtime_error(
            "internal error: tetmesh covered " + std::to_string(r.covered_triangles) + " of " +
            std::to_string(r.triangles) + " triangles exactly and left " +
            std::to_string(r.inverted_tets) + " inverted tets; nothing was written");
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
    idas::io::write_msh(a.out, v, idas::io::msh_version::v2_2,
                        a.ascii ? idas::io::encoding::ascii : idas::io::encoding::binary);

    if (a.as_json) {
        json j;
        j["input"] = {{"file", a.in},
                      {"vertices", r.input_vertices},
                      {"faces", r.input_faces},
                      {"welded_vertices", r.welded_vertices},
                      {"degenerate_faces_dropped", r.degenerate_faces + s.dropped_faces},
                      {"repeated_faces_dropped", r.repeated_faces}};
        j["triangles"] = r.triangles;
        j["inserted_triangles"] = r.covered_triangles;
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
        j["diagonal"] = r.diagonal;
        j["epsilon"] = r.epsilon;
        j["edge_length"] = r.edge_length;
        j["kept"] = "all tets; MSH physical tag 1 = inside, 2 = outside";
        j["threads"] = a.threads;
        j["seconds"] = {{"cleaning", r.seconds_cleaning},
                        {"delaunay", r.seconds_delaunay},
                        {"insertion", r.seconds_insertion},
                        {"rounding", r.seconds_rounding},
                        {"winding_number", r.seconds_winding},
                        {"checks", r.seconds_check},
                        {"total", total.seconds()}};
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
                    r.seconds_check, total.seconds());
        std::printf("wrote %s\n", a.out.c_str());
    }
    return 0;
#else
    (void)a;
    return error(2,
                 "tetmesh needs CGAL (Delaunay background mesh); this idas was built without it");
#endif
}
