// Tet meshes built in code for the tet-core tests, and a geometry-aware spec that
// writes attributes and can be told to fail at random (to exercise rollback).
#pragma once

#include <idas/invariants/positive_orientation.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/mesh/tet_validate.hpp>
#include <idas/ops/tet_ops.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

// The tet conformance suite: tet-mesh tests are TEST_CASE_TEMPLATEs over both backends.
TYPE_TO_STRING_AS("indexed", idas::tet_mesh<idas::backend::indexed_tet>);
TYPE_TO_STRING_AS("adjacency", idas::tet_mesh<idas::backend::adjacency_tet>);
#define IDAS_TET_MESHES                                                                            \
    idas::tet_mesh<idas::backend::indexed_tet>, idas::tet_mesh<idas::backend::adjacency_tet>

namespace idas::test {

/// Whether the mesh type stores face links (adjacency_tet), which refuses pinched vertices.
template <class Mesh>
inline constexpr bool refuses_pinched = Mesh::face_links;

/// Swaps two corners of a negatively oriented tet so it is positive.
inline void orient_positively(const std::vector<vec3>& V, tet_indices& t) {
    if (orient3d(V[t[0]], V[t[1]], V[t[2]], V[t[3]]) < 0) std::swap(t[2], t[3]);
}

/// The unit cube cut into n^3 cells, each split into 6 tets (around its main diagonal)
/// or 5 (a central tet and four corners, mirrored in alternate cells so faces match).
/// Interior vertices are moved at random by up to `jitter` times the cell size.
inline std::pair<std::vector<vec3>, std::vector<tet_indices>>
cube_arrays(int n, bool five = false, double jitter = 0, unsigned seed = 1) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> shake(-jitter, jitter);
    const double h = 1.0 / n;
    auto id = [&](int i, int j, int k) { return index_t((k * (n + 1) + j) * (n + 1) + i); };
    std::vector<vec3> V;
    for (int k = 0; k <= n; ++k)
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) {
                vec3 p{i * h, j * h, k * h};
                if (i > 0 && j > 0 && k > 0 && i < n && j < n && k < n)
                    p += vec3{shake(rng), shake(rng), shake(rng)} * h;
                V.push_back(p);
            }
    std::vector<tet_indices> T;
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                // Corner c has offsets (c & 1, c >> 1 & 1, c >> 2 & 1).
                auto c = [&](int bits) {
                    return id(i + (bits & 1), j + (bits >> 1 & 1), k + (bits >> 2 & 1));
                };
                std::vector<tet_indices> cell;
                if (!five) {
                    const int axes[6][2] = {{1, 2}, {1, 4}, {2, 1}, {2, 4}, {4, 1}, {4, 2}};
                    for (const auto& ax : axes)
                        cell.push_back({c(0), c(ax[0]), c(ax[0] | ax[1]), c(7)});
                } else if ((i + j + k) % 2 == 0) {
                    cell = {{c(0), c(3), c(5), c(6)},
                            {c(1), c(0), c(3), c(5)},
                            {c(2), c(0), c(3), c(6)},
                            {c(4), c(0), c(5), c(6)},
                            {c(7), c(3), c(5), c(6)}};
                } else {
                    cell = {{c(1), c(2), c(4), c(7)},
                            {c(0), c(1), c(2), c(4)},
                            {c(3), c(1), c(2), c(7)},
                            {c(5), c(1), c(4), c(7)},
                            {c(6), c(2), c(4), c(7)}};
                }
                for (auto& t : cell) {
                    orient_positively(V, t);
                    T.push_back(t);
                }
            }
    return {V, T};
}

template <class Mesh = tet_mesh<>>
Mesh cube(int n, bool five = false, double jitter = 0, unsigned seed = 1) {
    auto [V, T] = cube_arrays(n, five, jitter, seed);
    return {V, T};
}

/// n tets around the edge from a = (0, 0, 1) (vertex 0) to b = (0, 0, -1) (vertex 1);
/// the ring vertices 2..n+1 lie on the unit circle, radii scaled by `radius(i)`.
template <class Mesh = tet_mesh<>>
Mesh edge_ring_mesh(int n, double wobble = 0) {
    std::vector<vec3> V = {{0, 0, 1}, {0, 0, -1}};
    for (int i = 0; i < n; ++i) {
        const double phi = 2 * std::numbers::pi * i / n;
        const double r = 1 + wobble * ((i % 3) - 1);
        V.push_back({r * std::cos(phi), r * std::sin(phi), 0.05 * wobble * (i % 2)});
    }
    std::vector<tet_indices> T;
    for (int i = 0; i < n; ++i) {
        tet_indices t = {0, 1, index_t(2 + i), index_t(2 + (i + 1) % n)};
        orient_positively(V, t);
        T.push_back(t);
    }
    return {V, T};
}

/// Every link and every star of a mesh with face links against indexed_tet built from its
/// live tets (whose adjacency is searched, not stored). Returns the number of mismatches.
template <class Mesh>
std::size_t mismatches_against_search(const Mesh& m) {
    const auto& c = m.connectivity();
    std::vector<index_t> slot_of; // indexed tet -> slot in m
    std::vector<tet_indices> T;
    for (index_t t = 0; t < m.tet_slots(); ++t)
        if (c.tet_alive(t)) slot_of.push_back(t), T.push_back(c.tet_vertices(t));
    backend::indexed_tet ix;
    ix.build(m.vertex_slots(), T);
    std::size_t bad = 0;
    for (index_t i = 0; i < T.size(); ++i)
        for (std::uint8_t lf = 0; lf < 4; ++lf) {
            const index_t want = ix.opposite_tet(i, lf);
            const index_t got = c.opposite_tet(slot_of[i], lf);
            bad += (want == invalid_index ? got != invalid_index : got != slot_of[want]) ? 1 : 0;
        }
    for (index_t v = 0; v < m.vertex_slots(); ++v) {
        std::vector<index_t> want;
        for (index_t i : ix.vertex_tets(v)) want.push_back(slot_of[i]);
        const auto star = c.vertex_tets(v);
        std::vector<index_t> got(star.begin(), star.end());
        std::sort(want.begin(), want.end());
        std::sort(got.begin(), got.end());
        bad += want != got ? 1 : 0;
    }
    return bad;
}

/// Geometry-aware spec: midpoint splits and collapses, Laplacian smoothing, attributes
/// written by after() on every kind, optional random failures, positive orientation.
template <bool AllowBoundary = false>
struct tet_spec {
    static constexpr bool allow_boundary_change = AllowBoundary;
    edge_attribute<float> edge_length;
    face_attribute<int> face_mark;
    tet_attribute<int> generation;
    double fail_probability = 0;
    std::mt19937* rng = nullptr;

    template <class Mesh>
    void attach(Mesh& m) {
        edge_length = m.template add_edge_attribute<float>("edge_length", -1.f);
        face_mark = m.template add_face_attribute<int>("face_mark", 0);
        generation = m.template add_tet_attribute<int>("generation", 0);
    }
    bool fail_now() {
        return rng && std::uniform_real_distribution<double>(0, 1)(*rng) < fail_probability;
    }

    template <class Mesh>
    void write_cells(Mesh& m, const op_result<tet_tuple>& r) {
        if (!edge_length.valid()) return; // not attached to a mesh
        auto len = m.attribute(edge_length, r);
        auto mark = m.attribute(face_mark, r);
        auto gen = m.attribute(generation, r);
        auto p = m.positions();
        for (std::size_t i = 0; i < r.cells.size(); ++i) {
            const auto& t = r.cells[i];
            gen.set(t.tid, gen[r.origins[i]] + 1);
            for (std::uint8_t le = 0; le < 6; ++le) {
                const auto e = m.tuple_from_edge(t.tid, le);
                const auto [a, b] = m.edge_vertices(e);
                len.set(m.eid(e), static_cast<float>(norm(p[a] - p[b])));
            }
            for (std::uint8_t lf = 0; lf < 4; ++lf)
                mark.set(m.fid(m.tuple_from_face(t.tid, lf)), int(i));
        }
    }

    template <class Mesh>
    std::optional<vec3> before(op::split_edge, const Mesh& m, const tet_tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Mesh>
    std::optional<vec3> before(op::collapse_edge, const Mesh& m, const tet_tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        // A boundary vertex stays where it is, so the boundary keeps its shape if it can.
        const bool ba = m.is_boundary_vertex(a), bb = m.is_boundary_vertex(b);
        if (ba && bb) return (m.position(a) + m.position(b)) * 0.5;
        if (ba) return m.position(a);
        if (bb) return m.position(b);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Op, class Mesh>
    requires(std::is_same_v<Op, op::split_edge> ||
             std::is_same_v<Op, op::collapse_edge>) bool after(Op, Mesh& m,
                                                               const op_result<tet_tuple>& r,
                                                               vec3& new_position) {
        m.positions(r).set(r.anchor.vid, new_position);
        write_cells(m, r);
        return !fail_now();
    }
    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<tet_tuple>& r) {
        boost::container::small_vector<index_t, 32> ring;
        m.one_ring_vertices(r.anchor.vid, ring);
        vec3 c{};
        for (index_t w : ring) c += m.position(w);
        m.positions(r).set(r.anchor.vid, c / double(ring.size()));
        write_cells(m, r);
        return !fail_now();
    }
    template <class Op, class Mesh>
    requires(std::is_same_v<Op, op::face_swap_23> || std::is_same_v<Op, op::edge_swap_32> ||
             std::is_same_v<Op, op::edge_swap_44> ||
             std::is_same_v<Op, op::edge_removal>) bool after(Op, Mesh& m,
                                                              const op_result<tet_tuple>& r) {
        write_cells(m, r);
        return !fail_now();
    }
    auto invariants() const { return invariant_set<positive_orientation>{}; }
};

} // namespace idas::test
