// Consistency checks of a tri_mesh: what the tests run after every operation.
#pragma once

#include <idas/mesh/topology_report.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include <boost/container/small_vector.hpp>

#include <optional>
#include <string>

namespace idas {

namespace detail {

inline std::string at(const char* what, index_t i) {
    return std::string(what) + " " + std::to_string(i) + ": ";
}

/// A live face: live distinct vertices that list it, tuple identities on its three
/// edges, and neighbours that traverse each shared edge in the opposite direction.
template <class Backend>
std::optional<std::string> check_face(const tri_mesh<Backend>& m, index_t f) {
    const auto& c = m.connectivity();
    const auto& fv = c.face_vertices(f);
    for (int i = 0; i < 3; ++i) {
        if (fv[i] >= m.vertex_slots() || !c.vertex_alive(fv[i]))
            return at("face", f) + "references dead or missing vertex " + std::to_string(fv[i]);
        if (fv[i] == fv[(i + 1) % 3]) return at("face", f) + "is degenerate";
        bool listed = false;
        for (index_t g : c.vertex_faces(fv[i])) listed |= g == f;
        if (!listed)
            return at("face", f) + "missing from incidence list of vertex " + std::to_string(fv[i]);
    }
    if constexpr (requires {
                      { c.check_face(f) } -> std::same_as<std::optional<std::string>>;
                  })
        if (auto e = c.check_face(f)) return at("face", f) + *e; // the backend's own invariants
    for (std::uint8_t le = 0; le < 3; ++le) {
        const auto t = m.tuple_from_edge(f, le);
        if (!m.is_valid(t)) return at("face", f) + "fresh tuple is not valid";
        if (m.switch_vertex(m.switch_vertex(t)) != t)
            return at("face", f) + "switch_vertex is not an involution";
        if (m.switch_edge(m.switch_edge(t)) != t)
            return at("face", f) + "switch_edge is not an involution";
        if (auto g = m.switch_face(t)) {
            auto back = m.switch_face(*g);
            if (!back || *back != t) return at("face", f) + "switch_face is not an involution";
            const auto& gv = c.face_vertices(g->fid);
            const index_t x = fv[(le + 1) % 3], y = fv[(le + 2) % 3];
            const std::uint8_t gl = g->local_edge;
            if (!(gv[(gl + 1) % 3] == y && gv[(gl + 2) % 3] == x))
                return at("face", f) + "neighbour " + std::to_string(g->fid) +
                       " is oriented inconsistently";
        } else {
            // A boundary edge must really have no other face (a backend that stores
            // neighbour links could have missed one).
            const index_t x = fv[(le + 1) % 3], y = fv[(le + 2) % 3];
            for (index_t g : c.vertex_faces(x)) {
                const auto& gv = c.face_vertices(g);
                if (g != f && (gv[0] == y || gv[1] == y || gv[2] == y))
                    return at("face", f) + "edge " + std::to_string(x) + "-" + std::to_string(y) +
                           " is marked boundary but face " + std::to_string(g) + " shares it";
            }
        }
    }
    return std::nullopt;
}

/// A vertex: its incidence list holds live faces containing it, and its faces form a
/// single fan (open or closed), i.e. the vertex is manifold.
template <class Backend>
std::optional<std::string> check_vertex(const tri_mesh<Backend>& m, index_t v) {
    const auto& c = m.connectivity();
    std::size_t n = 0;
    for (index_t f : c.vertex_faces(v)) {
        ++n;
        if (!c.vertex_alive(v)) return at("vertex", v) + "is dead but has faces";
        if (f >= m.face_slots() || !c.face_alive(f)) return at("vertex", v) + "lists a dead face";
        const auto& fv = c.face_vertices(f);
        if (fv[0] != v && fv[1] != v && fv[2] != v)
            return at("vertex", v) + "lists a face without it";
    }
    if constexpr (requires {
                      { c.check_vertex(v) } -> std::same_as<std::optional<std::string>>;
                  })
        if (auto e = c.check_vertex(v)) return at("vertex", v) + *e; // the backend's own invariants
    if (n == 0) return std::nullopt;
    // Walk the fan from one face; it must reach every face of the star.
    auto t = m.tuple_from_vertex(v);
    // Rewind to the boundary if there is one, so the walk covers an open fan.
    for (std::size_t k = 0; k <= n; ++k) {
        auto g = m.switch_face(t);
        if (!g) break;
        t = m.switch_edge(*g);
    }
    std::size_t seen = 1;
    for (auto u = m.switch_edge(t); seen <= n; ++seen) {
        auto g = m.switch_face(u);
        if (!g || g->fid == t.fid) break;
        u = m.switch_edge(*g);
    }
    if (seen != n)
        return at("vertex", v) + "its " + std::to_string(n) +
               " faces do not form one fan (walked " + std::to_string(seen) + ")";
    return std::nullopt;
}

} // namespace detail

/// Checks every face and vertex, then the global topology. Returns a description of the
/// first problem, or nothing.
template <class Backend>
std::optional<std::string> find_inconsistency(const tri_mesh<Backend>& m) {
    for (index_t f = 0; f < m.face_slots(); ++f)
        if (m.connectivity().face_alive(f))
            if (auto e = detail::check_face(m, f)) return e;
    for (index_t v = 0; v < m.vertex_slots(); ++v)
        if (auto e = detail::check_vertex(m, v)) return e;
    const auto [V, F] = m.to_arrays();
    const topology_report r = diagnose_topology(V.size(), F);
    if (!r.editable()) return "topology: " + describe_problems(r);
    return std::nullopt;
}

/// The same local checks, restricted to the given faces, their vertices and the stars
/// of those vertices: cheap enough to run after every operation of a long sequence.
template <class Backend, class Cells>
std::optional<std::string> find_inconsistency_near(const tri_mesh<Backend>& m, const Cells& cells) {
    boost::container::small_vector<index_t, 64> verts;
    for (const auto& t : cells) {
        if (!m.is_valid(t))
            return detail::at("face", t.fid) + "returned by the operation is not valid";
        for (index_t v : m.face_vertices(t.fid))
            if (std::find(verts.begin(), verts.end(), v) == verts.end()) verts.push_back(v);
    }
    for (index_t v : verts) {
        if (auto e = detail::check_vertex(m, v)) return e;
        for (index_t f : m.vertex_faces(v))
            if (auto e = detail::check_face(m, f)) return e;
    }
    return std::nullopt;
}

} // namespace idas
