// Pieces shared by the one-run-per-process benchmark drivers (bench_decimation,
// bench_remeshing): a stopwatch, 1-to-4 subdivision of the input, a subdivided cube,
// surface measures, peak memory, conversion to and from CGAL Surface_mesh, and CGAL's
// sampled Hausdorff distance.
// Needs CGAL (header-only) and TBB (CGAL's parallel sampling).
#pragma once

#include <idas/core/types.hpp>
#include <idas/io/surface.hpp>

#include "../tests/shapes.hpp"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <unordered_map>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

namespace idas_bench {

using idas::index_t;
using idas::tri_indices;
using idas::vec3;
using surface = idas::io::surface;

class stopwatch {
public:
    double seconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    }

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

/// Times `fn()` on a steady clock.
template <class Fn>
double timed(Fn&& fn) {
    const stopwatch clock;
    fn();
    return clock.seconds();
}

// ---- input -----------------------------------------------------------------------------

/// One level of 1-to-4 midpoint subdivision: each edge gets its exact midpoint (shared by
/// the edge's two faces through a hash map) and each triangle becomes four, same
/// orientation. Geometry is unchanged: the new faces lie in the old ones.
inline surface subdivide(const surface& s) {
    surface out;
    out.vertices = s.vertices;
    out.vertices.reserve(s.vertices.size() + 3 * s.faces.size() / 2 + 16);
    out.faces.reserve(4 * s.faces.size());
    std::unordered_map<std::uint64_t, index_t> midpoint;
    midpoint.reserve(3 * s.faces.size() / 2 + 16);
    auto mid = [&](index_t a, index_t b) {
        const std::uint64_t key = std::uint64_t{std::min(a, b)} << 32 | std::max(a, b);
        const auto [it, fresh] =
            midpoint.try_emplace(key, static_cast<index_t>(out.vertices.size()));
        if (fresh) out.vertices.push_back((s.vertices[a] + s.vertices[b]) * 0.5);
        return it->second;
    };
    for (const tri_indices& f : s.faces) {
        const index_t a = f[0], b = f[1], c = f[2];
        const index_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
        out.faces.push_back({a, ab, ca});
        out.faces.push_back({ab, b, bc});
        out.faces.push_back({ca, bc, c});
        out.faces.push_back({ab, bc, ca});
    }
    return out;
}

/// The surface without vertices that no face uses. Scanned inputs have them (bunny.obj:
/// 1,113 of 35,947); they are not part of the surface, yet a Hausdorff distance that
/// samples every input vertex would measure them.
inline surface drop_unreferenced(const surface& s) {
    std::vector<index_t> id(s.vertices.size(), idas::invalid_index);
    surface out;
    out.faces = s.faces;
    for (tri_indices& f : out.faces)
        for (index_t& v : f) {
            if (id[v] == idas::invalid_index) {
                id[v] = static_cast<index_t>(out.vertices.size());
                out.vertices.push_back(s.vertices[v]);
            }
            v = id[v];
        }
    return out;
}

/// A unit cube, each side an n x n grid of right triangles, vertices shared, outward: a
/// CAD-like input with flat sides and sharp edges (n = 32: 12,288 faces): the test suite's
/// cube (tests/shapes.hpp).
inline surface subdivided_cube(int n) {
    surface s;
    std::tie(s.vertices, s.faces) = idas::test::subdivided_cube_arrays(n);
    return s;
}

inline double surface_area(const surface& s) {
    double area = 0;
    for (const tri_indices& f : s.faces) {
        const vec3 &p = s.vertices[f[0]], &q = s.vertices[f[1]], &r = s.vertices[f[2]];
        area += 0.5 * idas::norm(idas::cross(q - p, r - p));
    }
    return area;
}

inline double bbox_diagonal(const surface& s) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
    for (const vec3& p : s.vertices)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    return idas::norm(hi - lo);
}

// ---- memory ------------------------------------------------------------------------------

inline double current_rss_mb() {
    long pages = 0, resident = 0;
    if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
        if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
        std::fclose(f);
    }
    return double(resident) * double(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

inline double peak_rss_mb() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_maxrss) / 1024.0; // kilobytes on Linux
}

/// Resets the kernel's peak-RSS mark to the current RSS (Linux >= 4.0); true if it did.
inline bool reset_peak_rss() {
    {
        std::ofstream clear("/proc/self/clear_refs");
        if (!clear) return false;
        clear << "5";
        if (!clear.flush()) return false;
    }
    return peak_rss_mb() <= current_rss_mb() + 1.0;
}

// ---- CGAL --------------------------------------------------------------------------------

using kernel = CGAL::Simple_cartesian<double>;
using cgal_mesh = CGAL::Surface_mesh<kernel::Point_3>;

template <class Mesh = cgal_mesh>
Mesh to_cgal(const surface& s) {
    using point = typename Mesh::Point;
    Mesh m;
    m.reserve(static_cast<typename Mesh::size_type>(s.vertices.size()),
              static_cast<typename Mesh::size_type>(3 * s.faces.size() / 2),
              static_cast<typename Mesh::size_type>(s.faces.size()));
    std::vector<typename Mesh::Vertex_index> v;
    v.reserve(s.vertices.size());
    for (const vec3& p : s.vertices) v.push_back(m.add_vertex(point(p.x, p.y, p.z)));
    for (const tri_indices& f : s.faces)
        if (m.add_face(v[f[0]], v[f[1]], v[f[2]]) == Mesh::null_face())
            throw std::runtime_error("CGAL refused a face of the input");
    return m;
}

template <class Mesh>
surface from_cgal(const Mesh& m) {
    surface s;
    std::vector<index_t> id(m.num_vertices() + m.number_of_removed_vertices(), 0);
    for (auto v : m.vertices()) {
        id[v.idx()] = static_cast<index_t>(s.vertices.size());
        const auto& p = m.point(v);
        s.vertices.push_back(
            {CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z())});
    }
    for (auto f : m.faces()) {
        tri_indices t{};
        int k = 0;
        for (auto v : CGAL::vertices_around_face(m.halfedge(f), m)) t[k++] = id[v.idx()];
        s.faces.push_back(t);
    }
    return s;
}

/// One-sided approximate Hausdorff distance from `a` to `b` (samples on `a`).
inline double hausdorff(const cgal_mesh& a, const cgal_mesh& b, double per_area) {
    namespace P = CGAL::parameters;
    // CGAL picks the sampled faces with the seeded generator but the point inside each face
    // with its default one: seed that too, so every run samples the same points.
    CGAL::get_default_random() = CGAL::Random(20240601);
    return CGAL::Polygon_mesh_processing::approximate_Hausdorff_distance<
        CGAL::Parallel_if_available_tag>(a, b,
                                         P::number_of_points_per_area_unit(per_area)
                                             .do_sample_vertices(true)
                                             .do_sample_edges(false)
                                             .random_seed(20240601));
}

/// One-sided mean distance from `a` to `b`: the same samples on `a` as `hausdorff` takes
/// (same density, seed and vertices), each measured to its closest point of `b`. The
/// Hausdorff distance is the worst sample's, so one vertex decides it; the mean weighs the
/// whole surface, and is the steadier figure when two decimations differ only in order.
inline double mean_distance(const cgal_mesh& a, const cgal_mesh& b, double per_area) {
    namespace P = CGAL::parameters;
    CGAL::get_default_random() = CGAL::Random(20240601);
    std::vector<kernel::Point_3> samples;
    CGAL::Polygon_mesh_processing::sample_triangle_mesh(a, std::back_inserter(samples),
                                                        P::number_of_points_per_area_unit(per_area)
                                                            .do_sample_vertices(true)
                                                            .do_sample_edges(false)
                                                            .random_seed(20240601));
    using primitive = CGAL::AABB_face_graph_triangle_primitive<cgal_mesh>;
    CGAL::AABB_tree<CGAL::AABB_traits<kernel, primitive>> tree(faces(b).first, faces(b).second, b);
    tree.accelerate_distance_queries();
    double sum = 0;
    for (const auto& p : samples) sum += std::sqrt(tree.squared_distance(p));
    return samples.empty() ? 0.0 : sum / double(samples.size());
}

} // namespace idas_bench
