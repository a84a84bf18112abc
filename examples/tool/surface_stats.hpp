// The statistics of a triangle soup that `idas info` reports (and the editing commands
// print for their input and output), and the JSON object `idas info --json` prints: shared
// by the tool and the Python module's idas.info, so both say the same.
#pragma once

#include "common.hpp"

#include <idas/invariants/no_self_intersection.hpp>
#include <idas/mesh/topology_report.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>

namespace idas::tool {

struct min_mean_max {
    double min = 0, mean = 0, max = 0;
};

/// Everything `info` reports. Geometry is computed from the face list itself, so it is
/// available for non-manifold input too.
struct mesh_stats {
    idas::topology_report topo;
    std::optional<long> genus; // orientable manifolds only
    vec3 bbox_min, bbox_max;
    double diagonal = 0;
    min_mean_max edge_length;
    double min_valence = 0, mean_valence = 0, max_valence = 0;
    std::size_t interior_vertices = 0;
    double valence6_fraction = 0; // of interior vertices
    double min_angle_deg = 0, mean_min_angle_deg = 0;
    std::size_t zero_area_faces = 0;
};

inline mesh_stats compute_stats(const idas::io::surface& s) {
    mesh_stats st;
    st.topo = idas::diagnose_topology(s.vertices.size(), s.faces);
    const auto& t = st.topo;
    if (t.editable()) {
        // chi = 2C - 2g - b for an orientable surface with b boundary loops.
        const long twice_g = 2 * static_cast<long>(t.components) - t.euler_characteristic -
                             static_cast<long>(t.boundary_loops);
        if (twice_g >= 0 && twice_g % 2 == 0) st.genus = twice_g / 2;
    }

    const std::size_t nv = s.vertices.size();
    auto usable = [&](const idas::tri_indices& f) {
        return f[0] < nv && f[1] < nv && f[2] < nv && f[0] != f[1] && f[1] != f[2] && f[0] != f[2];
    };

    // Bounding box of the referenced vertices (of all of them if no face is usable).
    std::vector<char> used(nv, 0);
    for (const auto& f : s.faces)
        if (usable(f)) used[f[0]] = used[f[1]] = used[f[2]] = 1;
    const bool any_used = std::find(used.begin(), used.end(), 1) != used.end();
    constexpr double inf = std::numeric_limits<double>::infinity();
    vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
    for (std::size_t v = 0; v < nv; ++v) {
        if (any_used && !used[v]) continue;
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], s.vertices[v][k]);
            hi[k] = std::max(hi[k], s.vertices[v][k]);
        }
    }
    if (nv > 0) st.bbox_min = lo, st.bbox_max = hi, st.diagonal = idas::norm(hi - lo);

    // Undirected edges, each once, with the number of faces using it.
    std::vector<std::uint64_t> keys;
    keys.reserve(3 * s.faces.size());
    for (const auto& f : s.faces) {
        if (!usable(f)) continue;
        for (int i = 0; i < 3; ++i) {
            const index_t a = std::min(f[i], f[(i + 1) % 3]), b = std::max(f[i], f[(i + 1) % 3]);
            keys.push_back(std::uint64_t{a} << 32 | b);
        }
    }
    tbb::parallel_sort(keys.begin(), keys.end());
    std::vector<std::uint32_t> valence(nv, 0);
    std::vector<char> on_boundary(nv, 0);
    double sum_len = 0;
    std::size_t n_edges = 0;
    st.edge_length.min = inf;
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i;
        while (j < keys.size() && keys[j] == keys[i]) ++j;
        const auto a = static_cast<index_t>(keys[i] >> 32);
        const auto b = static_cast<index_t>(keys[i] & 0xffffffffu);
        const double len = idas::norm(s.vertices[a] - s.vertices[b]);
        st.edge_length.min = std::min(st.edge_length.min, len);
        st.edge_length.max = std::max(st.edge_length.max, len);
        sum_len += len, ++n_edges;
        ++valence[a], ++valence[b];
        if (j - i == 1) on_boundary[a] = on_boundary[b] = 1;
        i = j;
    }
    if (n_edges > 0)
        st.edge_length.mean = sum_len / static_cast<double>(n_edges);
    else
        st.edge_length.min = 0;

    std::size_t n_ref = 0, n_val6 = 0;
    double sum_val = 0;
    st.min_valence = inf;
    for (std::size_t v = 0; v < nv; ++v) {
        if (valence[v] == 0) continue;
        ++n_ref;
        sum_val += valence[v];
        st.min_valence = std::min(st.min_valence, double(valence[v]));
        st.max_valence = std::max(st.max_valence, double(valence[v]));
        if (!on_boundary[v]) {
            ++st.interior_vertices;
            n_val6 += valence[v] == 6 ? 1 : 0;
        }
    }
    if (n_ref > 0)
        st.mean_valence = sum_val / static_cast<double>(n_ref);
    else
        st.min_valence = 0;
    if (st.interior_vertices > 0)
        st.valence6_fraction = double(n_val6) / static_cast<double>(st.interior_vertices);

    // Angles: atan2(|u x v|, u . v) is accurate for tiny and near-straight angles and
    // gives 0 (not NaN) for zero-length edges.
    constexpr double to_deg = 180.0 / std::numbers::pi;
    struct angles {
        double sum_min = 0, min = inf;
        std::size_t faces = 0, zero_area = 0;
    };
    // Blocks of faces in parallel, summed in a fixed tree: the same sum on any thread count.
    using range = tbb::blocked_range<std::size_t>;
    const angles a = tbb::parallel_deterministic_reduce(
        range(0, s.faces.size(), 8192), angles{},
        [&](const range& r, angles acc) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                const auto& f = s.faces[i];
                if (!usable(f)) continue;
                double face_min = inf;
                for (int k = 0; k < 3; ++k) {
                    const vec3& p = s.vertices[f[k]];
                    const vec3 u = s.vertices[f[(k + 1) % 3]] - p,
                               w = s.vertices[f[(k + 2) % 3]] - p;
                    face_min = std::min(face_min,
                                        std::atan2(idas::norm(idas::cross(u, w)), idas::dot(u, w)));
                }
                const vec3 n = idas::cross(s.vertices[f[1]] - s.vertices[f[0]],
                                           s.vertices[f[2]] - s.vertices[f[0]]);
                if (idas::squared_norm(n) == 0) ++acc.zero_area;
                acc.min = std::min(acc.min, face_min * to_deg);
                acc.sum_min += face_min * to_deg, ++acc.faces;
            }
            return acc;
        },
        [](angles x, const angles& y) {
            x.sum_min += y.sum_min, x.min = std::min(x.min, y.min);
            x.faces += y.faces, x.zero_area += y.zero_area;
            return x;
        });
    st.zero_area_faces = a.zero_area;
    st.min_angle_deg = a.min;
    const double sum_min_angle = a.sum_min;
    const std::size_t n_faces = a.faces;
    if (n_faces > 0)
        st.mean_min_angle_deg = sum_min_angle / static_cast<double>(n_faces);
    else
        st.min_angle_deg = 0;
    return st;
}

inline json vec_json(const vec3& v) {
    return json::array({v.x, v.y, v.z});
}

inline json stats_json(const mesh_stats& st) {
    const auto& t = st.topo;
    json j;
    j["vertices"] = t.vertices;
    j["faces"] = t.faces;
    j["referenced_vertices"] = t.referenced_vertices;
    j["edges"] = t.edges;
    j["manifold"] = t.manifold();
    j["nonmanifold_edges"] = t.nonmanifold_edges;
    j["nonmanifold_vertices"] = t.nonmanifold_vertices;
    j["degenerate_faces"] = t.degenerate_faces;
    j["out_of_range_faces"] = t.out_of_range_faces;
    j["oriented"] = t.oriented();
    j["misoriented_edges"] = t.misoriented_edges;
    j["editable"] = t.editable();
    j["closed"] = t.closed();
    j["boundary_edges"] = t.boundary_edges;
    j["boundary_loops"] = t.boundary_loops;
    j["components"] = t.components;
    j["euler_characteristic"] = t.euler_characteristic;
    j["genus"] = st.genus ? json(*st.genus) : json(nullptr);
    j["problems"] = t.problems;
    j["bounding_box"] = {
        {"min", vec_json(st.bbox_min)}, {"max", vec_json(st.bbox_max)}, {"diagonal", st.diagonal}};
    j["edge_length"] = {
        {"min", st.edge_length.min}, {"mean", st.edge_length.mean}, {"max", st.edge_length.max}};
    j["valence"] = {{"min", st.min_valence},
                    {"mean", st.mean_valence},
                    {"max", st.max_valence},
                    {"interior_vertices", st.interior_vertices},
                    {"interior_valence6_fraction", st.valence6_fraction}};
    j["angles"] = {{"min_deg", st.min_angle_deg}, {"mean_min_deg", st.mean_min_angle_deg}};
    j["zero_area_faces"] = st.zero_area_faces;
    return j;
}

/// A surface file's faces as idas::count_self_intersections reads a mesh: any soup.
struct soup_view {
    const idas::io::surface& s;
    idas::index_t face_slots() const noexcept { return idas::index_t(s.faces.size()); }
    static constexpr bool face_alive(idas::index_t) noexcept { return true; }
    const idas::tri_indices& face_vertices(idas::index_t f) const noexcept { return s.faces[f]; }
    const vec3& position(idas::index_t v) const noexcept { return s.vertices[v]; }
};

/// What `idas info` finds in a surface: its statistics and, when asked, how many face pairs
/// meet (exact).
struct surface_info {
    mesh_stats stats;
    std::optional<std::size_t> self_intersections;
};

inline surface_info inspect_surface(const idas::io::surface& s, bool self_intersections,
                                    phase_times& phases) {
    surface_info info;
    info.stats = compute_stats(s);
    phases.lap("statistics");
    if (self_intersections) info.self_intersections = idas::count_self_intersections(soup_view{s});
    phases.lap("self_intersections");
    return info;
}

/// `idas info --json` without its times.
inline json surface_info_json(const std::string& file, const idas::io::surface& s,
                              const surface_info& info) {
    json j;
    j["file"] = file;
    j.update(stats_json(info.stats));
    if (info.self_intersections) j["self_intersections"] = *info.self_intersections;
    j["attributes"] = attributes_json(s);
    return j;
}

} // namespace idas::tool
