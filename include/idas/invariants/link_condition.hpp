// The link condition (Dey et al. 1999; Edelsbrunner): collapsing edge ab keeps a
// 2-manifold iff lk(a) ∩ lk(b) = lk(ab). Boundaries are handled by coning them to a
// virtual vertex ω, so a collapse that would pinch a boundary is refused too.
#pragma once

#include <idas/core/tuple.hpp>
#include <idas/ops/operation.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <type_traits>
#include <utility>

namespace idas {

namespace detail {

/// One-ring of v (unsorted, each vertex once); tells whether v is on the boundary
/// (an open fan has one more neighbour than faces).
template <class Mesh, class Ring>
bool ring_of(const Mesh& m, index_t v, Ring& ring) {
    std::size_t faces = 0;
    for (index_t f : m.vertex_faces(v)) {
        ++faces;
        for (index_t w : m.face_vertices(f))
            if (w != v && std::find(ring.begin(), ring.end(), w) == ring.end()) ring.push_back(w);
    }
    return ring.size() != faces;
}

/// Is there a face (v, x, y)?
template <class Mesh>
bool has_face(const Mesh& m, index_t v, index_t x, index_t y) {
    for (index_t f : m.vertex_faces(v)) {
        const auto& fv = m.face_vertices(f);
        const bool hx = fv[0] == x || fv[1] == x || fv[2] == x;
        const bool hy = fv[0] == y || fv[1] == y || fv[2] == y;
        if (hx && hy) return true;
    }
    return false;
}

} // namespace detail

/// True iff collapsing the tuple's edge leaves a 2-manifold with the same topology.
///
/// With the boundary coned to ω, lk(ab) is always two vertices: the two opposite vertices
/// c, d of an interior edge, or c and ω for a boundary edge. The vertex condition is
/// |lk(a) ∩ lk(b)| = 2; the edge condition (links share no edge) can only fail on the
/// pair lk(ab) itself: faces acd and bcd both exist (a tetrahedron), or, on the boundary,
/// ac and bc are both boundary edges (an isolated ear). The smallest closed surfaces are
/// refused too: a double triangle (abc and bac) has lk(a) ∩ lk(b) = {c}, one vertex.
template <class Mesh>
bool link_condition_holds(const Mesh& m, const typename Mesh::tuple& t) {
    const auto [a, b] = m.edge_vertices(t);
    boost::container::small_vector<index_t, 32> ra, rb;
    const bool boundary_a = detail::ring_of(m, a, ra);
    const bool boundary_b = detail::ring_of(m, b, rb);
    std::size_t common = (boundary_a && boundary_b) ? 1 : 0; // ω
    for (index_t x : ra) common += std::find(rb.begin(), rb.end(), x) != rb.end() ? 1 : 0;
    if (common != 2) return false;
    const index_t c = m.opposite_vertex(t);
    if (const auto g = m.switch_face(t)) {
        const index_t d = m.opposite_vertex(*g);
        return !(detail::has_face(m, a, c, d) && detail::has_face(m, b, c, d));
    }
    // Boundary edge ab in face abc: refuse if ac and bc are boundary edges too.
    const auto ac = m.switch_edge(t);                  // at a, edge (a, c)
    const auto bc = m.switch_edge(m.switch_vertex(t)); // at b, edge (b, c)
    return !(m.is_boundary_edge(ac) && m.is_boundary_edge(bc));
}

/// Invariant form, for specs that list it explicitly. collapse_edge always enforces it.
struct link_condition {
    struct state {};
    template <class Op, class Mesh>
    bool before(Op, const Mesh& m, const typename Mesh::tuple& t, state&) const {
        if constexpr (std::is_same_v<Op, op::collapse_edge>)
            return link_condition_holds(m, t);
        else
            return true;
    }
};

} // namespace idas
