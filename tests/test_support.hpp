// Shared helpers for the doctest suite.
#pragma once

#include <idas/idas.hpp>
#include <idas/io/io.hpp>

#include <doctest/doctest.h>

#include "shapes.hpp"

#include <array>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

// The conformance suite: every triangle-mesh test is a TEST_CASE_TEMPLATE over these
// meshes, one per connectivity backend, so each runs on both (named "...<indexed>" and
// "...<corner_table>").
#define IDAS_TRI_MESHES                                                                            \
    idas::tri_mesh<idas::backend::indexed_tri>, idas::tri_mesh<idas::backend::corner_table_tri>
TYPE_TO_STRING_AS("indexed", idas::tri_mesh<idas::backend::indexed_tri>);
TYPE_TO_STRING_AS("corner_table", idas::tri_mesh<idas::backend::corner_table_tri>);

namespace idas::test {

inline std::string data(const std::string& name) {
    return std::string(IDAS_DATA_DIR) + "/" + name;
}
inline std::string tmp(const std::string& name) {
    return std::string(IDAS_TEST_TMP) + "/" + name;
}

/// What a valid edit keeps: Euler characteristic, boundary loops, components.
struct topology {
    long chi;
    std::size_t loops, components;
    bool operator==(const topology&) const = default;
};
template <class Mesh>
topology topology_of(const Mesh& m) {
    const auto [V, F] = m.to_arrays();
    const auto r = diagnose_topology(V.size(), F);
    return {r.euler_characteristic, r.boundary_loops, r.components};
}

/// A unit cube, each side an n x n grid of right triangles, vertices shared, outward.
template <class Mesh>
Mesh subdivided_cube(int n) {
    const auto [V, F] = subdivided_cube_arrays(n);
    return Mesh(V, F);
}

/// A closed thin plate (1 x 1 x `thickness`), each side an n x n grid like
/// subdivided_cube's, whose top and bottom inner vertices are moved up or down by up to
/// `noise` / 2 of the thickness (a fixed hash, no generator): two nearly touching bumpy
/// sheets, where unguarded decimation folds faces of one through the other.
template <class Mesh>
Mesh noisy_thin_plate(int n, double thickness, double noise) {
    const Mesh cube = subdivided_cube<Mesh>(n);
    auto [V, F] = cube.to_arrays();
    for (std::size_t i = 0; i < V.size(); ++i) {
        vec3& p = V[i];
        const bool cap = p.z == 0 || p.z == 1;
        const bool inner = p.x > 0 && p.x < 1 && p.y > 0 && p.y < 1;
        const auto c = [&](double x) { return unsigned(std::lround(x * n)); };
        unsigned h = (c(p.x) * 73856093u) ^ (c(p.y) * 19349663u) ^ (c(p.z) * 83492791u);
        h *= 2654435761u;
        const double bump = cap && inner ? noise * (double((h >> 8) % 1000) / 1000.0 - 0.5) : 0;
        p.z = thickness * (p.z + bump);
    }
    return Mesh(V, F);
}

template <class Mesh = tri_mesh<>>
Mesh load(const std::string& name) {
    const auto s = io::read_surface(data(name));
    return Mesh(s.vertices, s.faces);
}

/// Geometry-aware spec used by the randomized tests: midpoint splits and collapses,
/// Laplacian smoothing, plus edge and face attributes written by after(), and a
/// switch to make after() fail at random (to exercise rollback).
struct midpoint_spec {
    edge_attribute<float> edge_length;
    face_attribute<int> generation;
    double fail_probability = 0;
    bool collapse_to_survivor = false; // keep the surviving vertex where it is
    std::mt19937* rng = nullptr;

    template <class Mesh>
    void attach(Mesh& m) {
        edge_length = m.template add_edge_attribute<float>("edge_length", -1.f);
        generation = m.template add_face_attribute<int>("generation", 0);
    }

    bool fail_now() {
        return rng && std::uniform_real_distribution<double>(0, 1)(*rng) < fail_probability;
    }

    template <class Mesh>
    void write_cells(Mesh& m, const op_result<tri_tuple>& r) {
        auto len = m.attribute(edge_length, r);
        auto gen = m.attribute(generation, r);
        auto p = m.positions();
        for (const auto& t : r.cells) {
            gen.set(t.fid, gen[r.origins[&t - r.cells.data()]] + 1);
            auto e = t;
            for (int k = 0; k < 3; ++k, e = m.switch_edge(m.switch_vertex(e))) {
                const auto [a, b] = m.edge_vertices(e);
                len.set(m.eid(e), static_cast<float>(norm(p[a] - p[b])));
            }
        }
    }

    template <class Mesh>
    std::optional<vec3> before(op::split_edge, const Mesh& m, const tri_tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Mesh>
    std::optional<vec3> before(op::collapse_edge, const Mesh& m, const tri_tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        if (collapse_to_survivor) return m.position(a);
        // Keep boundaries where they are: a boundary endpoint stays put.
        const bool ba = m.is_boundary_vertex(a), bb = m.is_boundary_vertex(b);
        if (ba && bb && !m.is_boundary_edge(t)) return std::nullopt;
        if (ba) return m.position(a);
        if (bb) return m.position(b);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Mesh, class Op>
    requires(std::is_same_v<Op, op::split_edge> ||
             std::is_same_v<Op, op::collapse_edge>) bool after(Op, Mesh& m,
                                                               const op_result<tri_tuple>& r,
                                                               vec3& new_position) {
        m.positions(r).set(r.anchor.vid, new_position);
        write_cells(m, r);
        return !fail_now();
    }
    template <class Mesh>
    bool after(op::swap_edge, Mesh& m, const op_result<tri_tuple>& r) {
        write_cells(m, r);
        return !fail_now();
    }
    template <class Mesh>
    bool before(op::smooth_vertex, const Mesh& m, const tri_tuple& t) {
        return !m.is_boundary_vertex(t.vid);
    }
    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<tri_tuple>& r) {
        boost::container::small_vector<index_t, 16> ring;
        m.one_ring_vertices(r.anchor.vid, ring);
        vec3 c{};
        for (index_t w : ring) c += m.position(w);
        m.positions(r).set(r.anchor.vid, c / double(ring.size()));
        write_cells(m, r);
        return !fail_now();
    }
    auto invariants() const { return invariant_set<no_normal_flip>{}; }
};

} // namespace idas::test
