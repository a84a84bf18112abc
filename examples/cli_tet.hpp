// `idas info` and `idas convert` for tetrahedral meshes. Included by idas_cli.cpp inside
// its anonymous namespace, after load/save/compute_stats and friends (so it includes
// nothing itself: idas_cli.cpp includes the library headers it needs; is_tet_path and
// load_tets are in tool/common.hpp, the statistics in tool/tet_stats.hpp).
//
// Surface or tets is decided by the file extension, never by content: .msh is read as a
// tet mesh (only its 4-node tetrahedra; Gmsh files also list points, lines and
// triangles, which are skipped) and .msh/.vtu outputs need a tet mesh. VTU is output
// only. Converting a tet mesh to a surface format (.obj, .off, .ply, .stl) writes its
// boundary surface.
#pragma once

// ---- statistics of a tet list (tool/tet_stats.hpp) --------------------------------------

void print_tet_stats(const tet_stats& st) {
    const auto& q = st.quality;
    const auto& b = st.boundary;
    fmt::print("  tetrahedra            {}", st.tets);
    if (st.skipped_elements > 0) fmt::print(" ({} other elements skipped)", st.skipped_elements);
    fmt::print("\n");
    fmt::print("  vertices              {} ({} referenced)\n", st.vertices, st.referenced_vertices);
    fmt::print("  faces                 {} ({} boundary, {} interior", st.faces, st.boundary_faces,
               st.interior_faces);
    if (st.nonmanifold_faces > 0) fmt::print(", {} in more than two tets", st.nonmanifold_faces);
    fmt::print(")\n");
    fmt::print("  edges                 {}\n", st.edges);
    fmt::print("  Euler characteristic  {}\n", st.euler_characteristic);
    fmt::print("  inverted tets         {}", q.inverted);
    if (q.flat > 0) fmt::print(" ({} flat)", q.flat);
    fmt::print("\n");
    if (st.overlapping_faces > 0)
        fmt::print("  overlapping faces     {} (both tets on the same side)\n",
                   st.overlapping_faces);
    fmt::print("  editable              {}\n", st.not_editable ? "no: " + *st.not_editable : "yes");
    if (closed_2_manifold(b)) {
        fmt::print("  boundary              closed 2-manifold: {} faces, {} components", b.faces,
                   b.components);
        if (st.boundary_genus) fmt::print(", genus {}", *st.boundary_genus);
        fmt::print("\n");
    } else {
        fmt::print("  boundary              NOT a closed 2-manifold: {} faces, {} open edges, {} "
                   "non-manifold edges, {} non-manifold vertices, {} misoriented edges\n",
                   b.faces, b.boundary_edges, b.nonmanifold_edges, b.nonmanifold_vertices,
                   b.misoriented_edges);
        for (const auto& p : b.problems) fmt::print("    - {}\n", p);
    }
    fmt::print("  bounding box          [{:.6g}, {:.6g}, {:.6g}] .. [{:.6g}, {:.6g}, {:.6g}]\n",
               st.bbox_min.x, st.bbox_min.y, st.bbox_min.z, st.bbox_max.x, st.bbox_max.y,
               st.bbox_max.z);
    fmt::print("  edge length           min {:.6g}, mean {:.6g}, max {:.6g}\n", st.edge_length.min,
               st.edge_length.mean, st.edge_length.max);
    fmt::print("  volume                total {:.6g}; per tet min {:.6g}, max {:.6g}\n",
               q.total_volume, q.volume.min, q.volume.max);
    fmt::print("  dihedral angles       min {:.3f} deg, max {:.3f} deg\n", q.dihedral_deg.min,
               q.dihedral_deg.max);
    if (q.amips_finite > 0)
        fmt::print("  AMIPS energy          min {:.4f}, mean {:.4f}, max {:.4g} (3 = regular)",
                   q.amips.min, q.amips.mean, q.amips.max);
    else
        fmt::print("  AMIPS energy          infinite for every tet");
    if (q.amips_finite < q.tets)
        fmt::print("; {} flat or inverted tets excluded", q.tets - q.amips_finite);
    fmt::print("\n");
    fmt::print("  shape quality         min {:.4f}, mean {:.4f}, max {:.4f} (1 = regular)\n",
               q.quality.min, q.quality.mean, q.quality.max);
}

int run_tet_info(const std::string& in, bool as_json, const info_reference& ref) {
    const stopwatch clock;
    const idas::io::volume v = load_tets(in);
    const tet_stats st = compute_tet_stats(v);
    const auto distance = measure_reference(v.vertices, st.boundary_face_list, ref);
    if (as_json) {
        json j;
        j["file"] = in;
        j.update(tet_stats_json(st));
        if (distance) j["reference"] = reference_distance_json(*distance);
        j["seconds"] = clock.seconds();
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}\n", in);
        print_tet_stats(st);
        if (distance) print_reference_distance(*distance, "boundary");
    }
    return 0;
}

// ---- convert ---------------------------------------------------------------------------------

struct tet_convert_arguments {
    std::string msh_version = "4.1";
    CLI::Option* msh_version_option = nullptr;
};

void add_tet_convert_options(CLI::App* convert, tet_convert_arguments& a) {
    a.msh_version_option =
        convert
            ->add_option("--msh-version", a.msh_version, "MSH version of .msh output: 2.2 or 4.1")
            ->check(CLI::IsMember({"2.2", "4.1"}))
            ->capture_default_str();
}

/// The boundary of a tet mesh as a surface on its own vertices (outward faces).
idas::io::surface boundary_surface(const idas::io::volume& v) {
    const tet_stats st = compute_tet_stats(v);
    idas::io::surface s;
    std::vector<index_t> new_id(v.vertices.size(), idas::invalid_index);
    for (auto f : st.boundary_face_list) {
        for (index_t& x : f) {
            if (new_id[x] == idas::invalid_index) {
                new_id[x] = static_cast<index_t>(s.vertices.size());
                s.vertices.push_back(v.vertices[x]);
            }
            x = new_id[x];
        }
        s.faces.push_back(f);
    }
    return s;
}

/// Whether `convert IN OUT` is a tet-mesh conversion (rather than surface to surface).
bool is_tet_convert(const std::string& in, const std::string& out) {
    return is_tet_path(in) || is_tet_path(out);
}

int run_tet_convert(const std::string& in, const std::string& out, bool ascii,
                    const tet_convert_arguments& a) {
    // Everything that can be refused without reading fails before any reading.
    const bool to_tets = is_tet_path(out);
    if (!to_tets) {
        try {
            idas::io::format_of(out);
        } catch (const idas::input_error&) {
            throw idas::input_error(out +
                                    ": unknown output extension for a tet mesh (expected "
                                    ".msh, .vtu, or .obj, .off, .ply, .stl for its boundary)");
        }
    }
    if (a.msh_version_option && a.msh_version_option->count() > 0 && (!to_tets || is_vtu_path(out)))
        throw idas::input_error("--msh-version applies to .msh output only, not " + out);
    if (!is_tet_path(in))
        throw idas::input_error(in + ": a triangle surface cannot be converted to a tet mesh (" +
                                out + "); idas does not tetrahedralize");
    const idas::io::volume v = load_tets(in);
    const auto enc = ascii ? idas::io::encoding::ascii : idas::io::encoding::binary;
    if (is_vtu_path(out)) {
        write_vtu_file(out, v, enc);
    } else if (to_tets) {
        idas::io::write_msh(out, v,
                            a.msh_version == "2.2" ? idas::io::msh_version::v2_2
                                                   : idas::io::msh_version::v4_1,
                            enc);
    } else {
        // A surface format gets the boundary, on its own vertices only.
        const idas::io::surface s = boundary_surface(v);
        save(out, s, ascii);
        fmt::print("{}: boundary of {} tets, {} vertices and {} faces, written to {}\n", in,
                   v.tets.size(), s.vertices.size(), s.faces.size(), out);
        return 0;
    }
    fmt::print("{}: {} vertices, {} tets written to {}\n", in, v.vertices.size(), v.tets.size(),
               out);
    return 0;
}
