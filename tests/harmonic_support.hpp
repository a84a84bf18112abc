// Checks shared by the serial and parallel harmonic-triangulation tests.
#pragma once

#include <idas/algorithms/harmonic_triangulation.hpp>
#include <idas/cgal/delaunay.hpp>
#include <idas/mesh/tet_validate.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <vector>

namespace idas::test {

template <class Mesh = tet_mesh<>>
Mesh delaunay_mesh(const std::vector<vec3>& points) {
    const auto dt = cgal::delaunay_tetrahedralization(points);
    return Mesh(dt.vertices, dt.tets);
}

/// n^3 separate flat bipyramids: triangle abc with apexes 0.2 above and below, two tets
/// whose 2-3 swap lowers the energy by half. A Delaunay mesh wants no 2-3 swap at all (its
/// flips are 3-2 and 4-4), so this is the mesh that makes a flip spec grow.
template <class Mesh = tet_mesh<>>
Mesh flat_bipyramids(int n) {
    std::vector<vec3> points;
    std::vector<tet_indices> tets;
    for (int i = 0; i < n * n * n; ++i) {
        const vec3 o{3.0 * (i % n), 3.0 * (i / n % n), 3.0 * (i / n / n)};
        const auto v = index_t(points.size());
        for (const vec3 p : {vec3{1, 0, 0}, vec3{-0.5, 0.866, 0}, vec3{-0.5, -0.866, 0},
                             vec3{0, 0, 0.2}, vec3{0, 0, -0.2}})
            points.push_back(o + p);
        tets.push_back({v, v + 1, v + 2, v + 3});
        tets.push_back({v, v + 2, v + 1, v + 4});
    }
    return Mesh(points, tets);
}

/// Complete-mode flips with a tiny pool for new tets (two a worker on four threads), so
/// 2-3 swaps run out of slots and go to the serial pass.
struct small_pool : algorithms::harmonic_flip_spec<algorithms::harmonic_mode::complete> {
    template <class Mesh>
    std::pair<index_t, index_t> parallel_growth(const Mesh&) const {
        return {0, 8};
    }
};

/// The boundary surface as a sorted list of triangles of positions, each rotated to start
/// at its smallest corner (orientation kept): equal iff the hull is the same surface.
inline std::vector<std::array<vec3, 3>> hull_of(const tet_mesh<>& m) {
    const auto less = [](const vec3& a, const vec3& b) {
        return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
    };
    std::vector<std::array<vec3, 3>> out;
    for (const auto& f : m.boundary_faces()) {
        std::array<vec3, 3> t = {m.position(f[0]), m.position(f[1]), m.position(f[2])};
        while (less(t[1], t[0]) || less(t[2], t[0])) std::rotate(t.begin(), t.begin() + 1, t.end());
        out.push_back(t);
    }
    std::sort(out.begin(), out.end(), [&](const auto& a, const auto& b) {
        for (int k = 0; k < 3; ++k) {
            if (less(a[k], b[k])) return true;
            if (less(b[k], a[k])) return false;
        }
        return false;
    });
    return out;
}

/// The positions of the live vertices (those with tets), sorted.
inline std::vector<vec3> vertex_set(const tet_mesh<>& m) {
    std::vector<vec3> out = m.to_arrays().first;
    std::sort(out.begin(), out.end(), [](const vec3& a, const vec3& b) {
        return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
    });
    return out;
}

/// Every live tet positively oriented by the exact predicate.
template <class Mesh>
std::size_t inverted_or_flat_tets(const Mesh& m) {
    std::size_t n = 0;
    const auto p = m.positions();
    for (index_t t = 0; t < m.tet_slots(); ++t) {
        if (!m.tet_alive(t)) continue;
        const auto& v = m.tet_vertices(t);
        n += orient3d(p[v[0]], p[v[1]], p[v[2]], p[v[3]]) <= 0 ? 1 : 0;
    }
    return n;
}

/// Runs the algorithm and checks what must hold of any run: a valid mesh, no inverted
/// tet, total and maximum energy not higher, the hull the same; in reduced mode not a
/// single vertex moved, else the vertex count is the same. `full` runs the complete
/// consistency check (every tet's tuples and adjacency; slow on 100k points) instead of
/// rebuilding the mesh from its arrays (which checks face pairing and orientation).
template <class Algorithm = algorithms::harmonic_triangulation<>>
algorithms::harmonic_report check_run(tet_mesh<>& m, const algorithms::harmonic_options& o,
                                      bool full = true) {
    const auto before = algorithms::harmonic_statistics(m);
    const auto hull = hull_of(m);
    const auto verts = vertex_set(m);
    const auto rep = Algorithm::run(m, o);
    const auto after = algorithms::harmonic_statistics(m);
    if (full) {
        CHECK(find_inconsistency(m, true) == std::nullopt);
    } else {
        const auto [V, T] = m.to_arrays();
        CHECK_NOTHROW(tet_mesh<>(V, T));
    }
    CHECK(inverted_or_flat_tets(m) == 0);
    CHECK(after.total_energy < before.total_energy);
    CHECK(after.max_energy <= before.max_energy);
    // (Not the mean index: 3-2 swaps remove tets, and a few flat hull tets, which no flip
    // can reach, dominate the mean on small point sets.)
    CHECK(rep.flips > 0);
    CHECK(hull_of(m) == hull);
    if (o.mode == algorithms::harmonic_mode::reduced)
        CHECK(vertex_set(m) == verts);
    else
        CHECK(m.n_vertices() == verts.size());
    return rep;
}

} // namespace idas::test
