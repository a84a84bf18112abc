// Consistency checks of a tet_mesh: what the tests run after every operation.
#pragma once

#include <idas/mesh/tet_mesh.hpp>
#include <idas/mesh/topology_report.hpp>
#include <idas/predicates/orient.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <optional>
#include <string>

namespace idas {

namespace detail {

inline std::string at_tet(const char* what, index_t i) {
    return std::string(what) + " " + std::to_string(i) + ": ";
}

/// True iff y is x reversed, up to rotation.
inline bool reversed_cycle(const tri_indices& x, const tri_indices& y) noexcept {
    for (int r = 0; r < 3; ++r)
        if (x[0] == y[r] && x[1] == y[(r + 2) % 3] && x[2] == y[(r + 1) % 3]) return true;
    return false;
}

/// A live tet: live distinct vertices that list it, exact positive orientation, faces
/// shared by at most two tets, the switch identities on all 24 of its tuples, and
/// neighbours that see each shared face in the opposite direction.
template <class Backend>
std::optional<std::string> check_tet(const tet_mesh<Backend>& m, index_t t) {
    const auto& c = m.connectivity();
    const auto& tv = c.tet_vertices(t);
    for (int i = 0; i < 4; ++i) {
        if (tv[i] >= m.vertex_slots() || !c.vertex_alive(tv[i]))
            return at_tet("tet", t) + "references dead or missing vertex " + std::to_string(tv[i]);
        for (int j = i + 1; j < 4; ++j)
            if (tv[i] == tv[j]) return at_tet("tet", t) + "repeats vertex " + std::to_string(tv[i]);
        const auto list = c.vertex_tets(tv[i]);
        if (std::count(list.begin(), list.end(), t) != 1)
            return at_tet("tet", t) + "is not listed exactly once by vertex " +
                   std::to_string(tv[i]);
    }
    if constexpr (requires {
                      { c.check_tet(t) } -> std::same_as<std::optional<std::string>>;
                  }) {
        if (auto e = c.check_tet(t)) return at_tet("tet", t) + *e; // the backend's own invariants
    }
    const auto p = m.positions();
    if (orient3d(p[tv[0]], p[tv[1]], p[tv[2]], p[tv[3]]) <= 0)
        return at_tet("tet", t) + "is flat or inverted";
    for (std::uint8_t lf = 0; lf < 4; ++lf) {
        const auto f = tet_local::face_vertices[lf];
        int sharing = 0;
        for (index_t g : c.vertex_tets(tv[f[0]])) {
            const auto& gv = c.tet_vertices(g);
            sharing += tet_local::contains(gv, tv[f[1]]) && tet_local::contains(gv, tv[f[2]]);
        }
        if (sharing > 2)
            return at_tet("tet", t) + "face " + std::to_string(lf) + " is shared by " +
                   std::to_string(sharing) + " tets";
    }
    for (std::uint8_t le = 0; le < 6; ++le) {
        for (int end = 0; end < 2; ++end) {
            auto base = m.tuple_from_edge(t, le);
            if (end) base = m.switch_vertex(base);
            for (int side = 0; side < 2; ++side) {
                const auto u = side ? m.switch_face(base) : base;
                if (!m.is_valid(u)) return at_tet("tet", t) + "fresh tuple is not valid";
                if (m.switch_vertex(u).vid == u.vid)
                    return at_tet("tet", t) + "switch_vertex keeps the vertex";
                if (m.switch_vertex(m.switch_vertex(u)) != u)
                    return at_tet("tet", t) + "switch_vertex is not an involution";
                if (m.switch_edge(m.switch_edge(u)) != u || m.switch_edge(u) == u)
                    return at_tet("tet", t) + "switch_edge is not an involution";
                if (m.switch_face(m.switch_face(u)) != u || m.switch_face(u) == u)
                    return at_tet("tet", t) + "switch_face is not an involution";
                if (!m.is_valid(m.switch_edge(u)) || !m.is_valid(m.switch_face(u)))
                    return at_tet("tet", t) + "switched tuple is not valid";
                const auto g = m.switch_tetrahedron(u);
                if (!g) {
                    if (!m.is_boundary_face(u))
                        return at_tet("tet", t) + "boundary face is not reported as such";
                    continue;
                }
                const auto back = m.switch_tetrahedron(*g);
                if (!back || *back != u)
                    return at_tet("tet", t) + "switch_tetrahedron is not an involution";
                if (g->tid == t || g->vid != u.vid || !m.is_valid(*g))
                    return at_tet("tet", t) + "switch_tetrahedron gives a bad tuple";
                if (m.eid(*g) != m.eid(u) || m.fid(*g) != m.fid(u))
                    return at_tet("tet", t) + "ids differ across switch_tetrahedron";
                if (!reversed_cycle(m.face_vertices_outward(u), m.face_vertices_outward(*g)))
                    return at_tet("tet", t) + "neighbour " + std::to_string(g->tid) +
                           " is oriented inconsistently";
            }
        }
    }
    return std::nullopt;
}

/// A vertex: dead ones have no tets; live ones list live tets that contain them, once.
template <class Backend>
std::optional<std::string> check_tet_vertex(const tet_mesh<Backend>& m, index_t v) {
    const auto& c = m.connectivity();
    const auto list = c.vertex_tets(v);
    if (!c.vertex_alive(v) && !std::ranges::empty(list))
        return at_tet("vertex", v) + "is dead but has tets";
    if constexpr (requires {
                      { c.check_vertex(v) } -> std::same_as<std::optional<std::string>>;
                  }) {
        if (auto e = c.check_vertex(v)) return at_tet("vertex", v) + *e;
    }
    for (auto it = list.begin(); it != list.end(); ++it) {
        const index_t g = *it;
        if (g >= m.tet_slots() || !c.tet_alive(g)) return at_tet("vertex", v) + "lists a dead tet";
        if (!tet_local::contains(c.tet_vertices(g), v))
            return at_tet("vertex", v) + "lists a tet without it";
        if (std::find(list.begin(), it, g) != it)
            return at_tet("vertex", v) + "lists tet " + std::to_string(g) + " twice";
    }
    return std::nullopt;
}

} // namespace detail

/// V - E + F - T of the live complex.
template <class Backend>
long euler_characteristic(const tet_mesh<Backend>& m) {
    return long(m.n_vertices()) - long(m.n_edges()) + long(m.n_faces()) - long(m.n_tets());
}

/// Topology of the boundary surface (its faces outward-oriented, on the mesh's ids).
template <class Backend>
topology_report boundary_topology(const tet_mesh<Backend>& m) {
    return diagnose_topology(m.vertex_slots(), m.boundary_faces());
}

/// Checks every tet and vertex, and that the boundary surface is closed and consistently
/// oriented (true of any valid tet mesh, manifold or not). With `manifold_boundary` the
/// boundary must also be a 2-manifold (true when the input's was and operations keep
/// topology). Returns a description of the first problem, or nothing.
template <class Backend>
std::optional<std::string> find_inconsistency(const tet_mesh<Backend>& m,
                                              bool manifold_boundary = false) {
    for (index_t t = 0; t < m.tet_slots(); ++t)
        if (m.connectivity().tet_alive(t))
            if (auto e = detail::check_tet(m, t)) return e;
    for (index_t v = 0; v < m.vertex_slots(); ++v)
        if (auto e = detail::check_tet_vertex(m, v)) return e;
    const topology_report r = boundary_topology(m);
    if (r.boundary_edges != 0)
        return "boundary surface has " + std::to_string(r.boundary_edges) + " open edges";
    if (r.misoriented_edges != 0)
        return "boundary surface has " + std::to_string(r.misoriented_edges) +
               " inconsistently oriented edges";
    if (manifold_boundary && !r.editable()) return "boundary: " + describe_problems(r);
    return std::nullopt;
}

/// The same local checks, restricted to the given tets and the vertices of those tets:
/// cheap enough to run after every operation of a long sequence.
template <class Backend, class Cells>
std::optional<std::string> find_inconsistency_near(const tet_mesh<Backend>& m, const Cells& cells) {
    boost::container::small_vector<index_t, 64> verts;
    for (const auto& t : cells) {
        if (!m.is_valid(t))
            return detail::at_tet("tet", t.tid) + "returned by the operation is not valid";
        if (auto e = detail::check_tet(m, t.tid)) return e;
        for (index_t v : m.tet_vertices(t.tid))
            if (std::find(verts.begin(), verts.end(), v) == verts.end()) verts.push_back(v);
    }
    for (index_t v : verts)
        if (auto e = detail::check_tet_vertex(m, v)) return e;
    return std::nullopt;
}

} // namespace idas
