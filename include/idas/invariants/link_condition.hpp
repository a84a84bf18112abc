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
inline constexpr index_t omega = invalid_index - 1; // the virtual boundary vertex

template <class Mesh>
void vertex_link(const Mesh& m, index_t a, boost::container::small_vector<index_t, 64>& verts,
                 boost::container::small_vector<std::pair<index_t, index_t>, 32>& edges) {
    for (index_t f : m.vertex_faces(a)) {
        const auto& fv = m.face_vertices(f);
        const std::uint8_t i = fv[0] == a ? 0 : (fv[1] == a ? 1 : 2);
        const index_t x = fv[(i + 1) % 3], y = fv[(i + 2) % 3];
        verts.push_back(x), verts.push_back(y);
        edges.push_back(std::minmax(x, y));
        // The face's edges at a are (a,x), opposite corner i+2, and (a,y), opposite corner i+1.
        if (m.connectivity().opposite_face(f, static_cast<std::uint8_t>((i + 2) % 3)) == invalid_index)
            verts.push_back(omega), edges.push_back(std::minmax(x, omega));
        if (m.connectivity().opposite_face(f, static_cast<std::uint8_t>((i + 1) % 3)) == invalid_index)
            verts.push_back(omega), edges.push_back(std::minmax(y, omega));
    }
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
}

template <class Range>
std::size_t count_common(const Range& a, const Range& b) {
    std::size_t n = 0;
    for (auto i = a.begin(), j = b.begin(); i != a.end() && j != b.end();) {
        if (*i < *j) ++i;
        else if (*j < *i) ++j;
        else ++n, ++i, ++j;
    }
    return n;
}
} // namespace detail

/// True iff collapsing the tuple's edge leaves a 2-manifold with the same topology.
template <class Mesh>
bool link_condition_holds(const Mesh& m, const typename Mesh::tuple& t) {
    const auto [a, b] = m.edge_vertices(t);
    boost::container::small_vector<index_t, 64> la, lb;
    boost::container::small_vector<std::pair<index_t, index_t>, 32> ea, eb;
    detail::vertex_link(m, a, la, ea);
    detail::vertex_link(m, b, lb, eb);
    // lk(ab) always has two vertices: the two opposite vertices, or one and ω.
    if (detail::count_common(la, lb) != 2) return false;
    // lk(ab) has no edges, so the links may share none.
    return detail::count_common(ea, eb) == 0;
}

/// Invariant form, for specs that list it explicitly. collapse_edge always enforces it.
struct link_condition {
    struct state {};
    template <class Op, class Mesh>
    bool before(Op, const Mesh& m, const typename Mesh::tuple& t, state&) const {
        if constexpr (std::is_same_v<Op, op::collapse_edge>) return link_condition_holds(m, t);
        else return true;
    }
};

} // namespace idas
