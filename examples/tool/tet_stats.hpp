// The statistics of a tet mesh that `idas info` reports for .msh files, and their JSON
// object: shared by the tool and the Python module's idas.info.
#pragma once

#include "surface_stats.hpp"

#include <idas/io/volume.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/mesh/tet_quality.hpp>
#include <idas/mesh/topology_report.hpp>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace idas::tool {

/// Everything `info` reports about tets. Computed from the tet list itself, so available
/// for inverted, overlapping or non-manifold input too.
struct tet_stats {
    std::size_t vertices = 0, referenced_vertices = 0, tets = 0, skipped_elements = 0;
    std::size_t faces = 0, boundary_faces = 0, interior_faces = 0, edges = 0;
    std::size_t nonmanifold_faces = 0;       // shared by more than two tets
    std::size_t overlapping_faces = 0;       // shared by two tets on the same side of it
    long euler_characteristic = 0;           // V - E + F - T of the referenced complex
    idas::topology_report boundary;          // of the outward boundary faces
    std::optional<long> boundary_genus;      // orientable manifold boundaries only
    std::optional<std::string> not_editable; // why tet_mesh refuses the input, if it does
    vec3 bbox_min, bbox_max;
    double diagonal = 0;
    min_mean_max edge_length;
    idas::tet_quality_summary quality;
    std::vector<idas::tri_indices> boundary_face_list; // outward, for convert
};

inline tet_stats compute_tet_stats(const idas::io::volume& v) {
    tet_stats st;
    st.vertices = v.vertices.size();
    st.tets = v.tets.size();
    st.skipped_elements = v.skipped_elements;
    st.quality = idas::summarize_tet_quality(v.vertices, v.tets);

    // Faces as sorted triples with the parity of the stored corner order: two tets on
    // opposite sides of a shared face list it in opposite directions.
    struct face_rec {
        idas::tri_indices key;
        bool odd;
        idas::tri_indices outward; // corners as seen from outside the tet (geometrically)
    };
    std::vector<face_rec> faces;
    faces.reserve(4 * v.tets.size());
    for (const auto& t : v.tets) {
        // An inverted tet's stored faces point inwards; flip them so the boundary of a
        // mesh written with the opposite convention is still seen outward.
        const bool inverted = idas::orient3d(v.vertices[t[0]], v.vertices[t[1]], v.vertices[t[2]],
                                             v.vertices[t[3]]) < 0;
        for (const auto& f : idas::tet_local::face_vertices) {
            face_rec r{{t[f[0]], t[f[1]], t[f[2]]}, false, {t[f[0]], t[f[1]], t[f[2]]}};
            if (inverted) std::swap(r.outward[1], r.outward[2]);
            auto& k = r.key;
            if (k[0] > k[1]) std::swap(k[0], k[1]), r.odd = !r.odd;
            if (k[1] > k[2]) std::swap(k[1], k[2]), r.odd = !r.odd;
            if (k[0] > k[1]) std::swap(k[0], k[1]), r.odd = !r.odd;
            faces.push_back(r);
        }
    }
    std::sort(faces.begin(), faces.end(),
              [](const face_rec& x, const face_rec& y) { return x.key < y.key; });
    for (std::size_t i = 0; i < faces.size();) {
        std::size_t j = i + 1;
        while (j < faces.size() && faces[j].key == faces[i].key) ++j;
        ++st.faces;
        if (j - i == 1) {
            ++st.boundary_faces;
            st.boundary_face_list.push_back(faces[i].outward);
        } else if (j - i == 2) {
            ++st.interior_faces;
            st.overlapping_faces += faces[i].odd == faces[i + 1].odd ? 1 : 0;
        } else {
            ++st.nonmanifold_faces;
        }
        i = j;
    }

    // Edges, each once, and the referenced vertices.
    std::vector<std::uint64_t> keys;
    keys.reserve(6 * v.tets.size());
    std::vector<char> used(v.vertices.size(), 0);
    for (const auto& t : v.tets) {
        for (index_t x : t) used[x] = 1;
        for (const auto& e : idas::tet_edge_corners) {
            const index_t a = std::min(t[e[0]], t[e[1]]), b = std::max(t[e[0]], t[e[1]]);
            keys.push_back(std::uint64_t{a} << 32 | b);
        }
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    st.edges = keys.size();
    constexpr double inf = std::numeric_limits<double>::infinity();
    st.edge_length = {inf, 0, 0};
    double sum_len = 0;
    for (const std::uint64_t k : keys) {
        const double len = idas::norm(v.vertices[k >> 32] - v.vertices[k & 0xffffffffu]);
        st.edge_length.min = std::min(st.edge_length.min, len);
        st.edge_length.max = std::max(st.edge_length.max, len);
        sum_len += len;
    }
    st.edge_length.mean = sum_len / static_cast<double>(std::max<std::size_t>(1, keys.size()));

    vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
    for (std::size_t i = 0; i < v.vertices.size(); ++i) {
        if (!used[i]) continue;
        ++st.referenced_vertices;
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], v.vertices[i][k]);
            hi[k] = std::max(hi[k], v.vertices[i][k]);
        }
    }
    st.bbox_min = lo, st.bbox_max = hi, st.diagonal = idas::norm(hi - lo);
    st.euler_characteristic =
        long(st.referenced_vertices) - long(st.edges) + long(st.faces) - long(st.tets);

    st.boundary = idas::diagnose_topology(v.vertices.size(), st.boundary_face_list);
    const auto& b = st.boundary;
    if (b.editable()) {
        const long twice_g = 2 * static_cast<long>(b.components) - b.euler_characteristic -
                             static_cast<long>(b.boundary_loops);
        if (twice_g >= 0 && twice_g % 2 == 0) st.boundary_genus = twice_g / 2;
    }

    // Editable means exactly what tet_mesh accepts; ask it rather than restate its rules.
    try {
        const idas::tet_mesh<> m(v.vertices, v.tets);
    } catch (const idas::input_error& e) {
        st.not_editable = e.what();
    }
    return st;
}

/// A closed 2-manifold boundary: every boundary edge in exactly two boundary faces, in
/// opposite directions, and every boundary vertex a single fan.
inline bool closed_2_manifold(const idas::topology_report& b) {
    return b.editable() && b.closed() && b.faces > 0;
}

inline json tet_stats_json(const tet_stats& st) {
    const auto& q = st.quality;
    const auto& b = st.boundary;
    json j;
    j["kind"] = "tetrahedral";
    j["vertices"] = st.vertices;
    j["referenced_vertices"] = st.referenced_vertices;
    j["tets"] = st.tets;
    j["skipped_elements"] = st.skipped_elements;
    j["faces"] = st.faces;
    j["boundary_faces"] = st.boundary_faces;
    j["interior_faces"] = st.interior_faces;
    j["nonmanifold_faces"] = st.nonmanifold_faces;
    j["overlapping_faces"] = st.overlapping_faces;
    j["edges"] = st.edges;
    j["euler_characteristic"] = st.euler_characteristic;
    j["inverted_tets"] = q.inverted;
    j["flat_tets"] = q.flat;
    j["editable"] = !st.not_editable;
    j["problem"] = st.not_editable ? json(*st.not_editable) : json(nullptr);
    j["boundary"] = {{"closed_2_manifold", closed_2_manifold(b)},
                     {"faces", b.faces},
                     {"vertices", b.referenced_vertices},
                     {"edges", b.edges},
                     {"manifold", b.manifold()},
                     {"oriented", b.oriented()},
                     {"closed", b.closed()},
                     {"open_edges", b.boundary_edges},
                     {"nonmanifold_edges", b.nonmanifold_edges},
                     {"nonmanifold_vertices", b.nonmanifold_vertices},
                     {"components", b.components},
                     {"euler_characteristic", b.euler_characteristic},
                     {"genus", st.boundary_genus ? json(*st.boundary_genus) : json(nullptr)},
                     {"problems", b.problems}};
    j["bounding_box"] = {
        {"min", vec_json(st.bbox_min)}, {"max", vec_json(st.bbox_max)}, {"diagonal", st.diagonal}};
    j["edge_length"] = {
        {"min", st.edge_length.min}, {"mean", st.edge_length.mean}, {"max", st.edge_length.max}};
    j["volume"] = {{"total", q.total_volume},
                   {"min", q.volume.min},
                   {"mean", q.volume.mean},
                   {"max", q.volume.max}};
    j["dihedral_angle_deg"] = {
        {"min", q.dihedral_deg.min}, {"mean", q.dihedral_deg.mean}, {"max", q.dihedral_deg.max}};
    const auto maybe = [&](double x) { return q.amips_finite > 0 ? json(x) : json(nullptr); };
    j["amips"] = {{"min", maybe(q.amips.min)},
                  {"mean", maybe(q.amips.mean)},
                  {"max", maybe(q.amips.max)},
                  {"finite_tets", q.amips_finite},
                  {"histogram",
                   {{"bounds", idas::amips_histogram_bounds},
                    {"counts", q.amips_histogram},
                    {"note", "counts[i]: energies from bounds[i] up to bounds[i + 1] (the last: "
                             "from bounds[i] up); flat and inverted tets in none"}}},
                  {"definition", "conformal AMIPS tr(J^T J)/det(J)^(2/3), J the map from the "
                                 "regular tet: 3 is optimal, flat/inverted tets are infinite "
                                 "and excluded"}};
    j["quality"] = {{"min", q.quality.min}, {"mean", q.quality.mean}, {"max", q.quality.max}};
    return j;
}

} // namespace idas::tool
