// tet_mesh: a tetrahedral mesh seen only through cell tuples. Connectivity lives in a
// swappable backend, data in the same journaled attribute columns as tri_mesh.
//
// Local numbering inside a tet (v0, v1, v2, v3), which is stored positively oriented
// (orient3d(v0, v1, v2, v3) > 0):
//   local edges  0:(0,1) 1:(0,2) 2:(0,3) 3:(1,2) 4:(1,3) 5:(2,3)
//   local faces  i is the face opposite local vertex i; tet_local::face_vertices lists its
//                corners in outward (counter-clockwise seen from outside) order.
#pragma once

#include <idas/core/attribute.hpp>
#include <idas/core/concepts.hpp>
#include <idas/core/tuple.hpp>
#include <idas/mesh/backend/adjacency_tet.hpp>
#include <idas/mesh/backend/indexed_tet.hpp>
#include <idas/predicates/orient.hpp>

#include <boost/container/small_vector.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace idas {

namespace tet_local {
inline constexpr std::uint8_t none = 255;
inline constexpr std::array<std::array<std::uint8_t, 2>, 6> edge_vertices = {
    {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};
inline constexpr std::array<std::array<std::uint8_t, 4>, 4> edge_of = {
    {{none, 0, 1, 2}, {0, none, 3, 4}, {1, 3, none, 5}, {2, 4, 5, none}}};
inline constexpr std::array<std::array<std::uint8_t, 3>, 4> face_vertices = {
    {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};

/// Local position of global vertex v in `t`, or `none`.
inline std::uint8_t index_of(const tet_indices& t, index_t v) noexcept {
    for (std::uint8_t i = 0; i < 4; ++i)
        if (t[i] == v) return i;
    return none;
}
inline bool contains(const tet_indices& t, index_t v) noexcept {
    return t[0] == v || t[1] == v || t[2] == v || t[3] == v;
}
/// The two local vertices not on local edge `le`, in increasing order.
inline std::array<std::uint8_t, 2> edge_complement(std::uint8_t le) noexcept {
    const auto e = edge_vertices[le];
    std::array<std::uint8_t, 2> r{};
    std::uint8_t k = 0;
    for (std::uint8_t i = 0; i < 4; ++i)
        if (i != e[0] && i != e[1]) r[k++] = i;
    return r;
}
} // namespace tet_local

template <tet_connectivity Backend = backend::indexed_tet>
class tet_mesh {
public:
    using backend_type = Backend;
    using tuple = tet_tuple;
    using undo_log = typename Backend::undo_log;

    tet_mesh() { position_ = attrs_.add<vec3, simplex_kind::vertex>("position", 0); }

    /// Whether the backend stores face links (adjacency_tet): then crossing a face is one
    /// load and the queries about an edge walk around it instead of searching a star.
    static constexpr bool face_links = requires(const Backend& b, index_t t, std::uint8_t lf) {
        { b.opposite_face(t, lf) } -> std::same_as<std::pair<index_t, std::uint8_t>>;
    };

    /// Builds an editable mesh. Throws input_error naming the offending element unless
    /// every coordinate is finite, every tet has four distinct in-range vertices and is
    /// positively oriented (exact orient3d > 0), and every face is shared by at most two
    /// tets lying on opposite sides of it.
    tet_mesh(const std::vector<vec3>& vertices, const std::vector<tet_indices>& tets)
        : tet_mesh(vertices, tets, true) {}

    /// The same checks but the orientation one, for tets positive in exact coordinates
    /// that `vertices` only approximates (rational vertices of tetrahedral meshing, which
    /// its own exact invariant checks): the caller vouches for their orientation.
    struct orientation_checked_by_caller {};
    tet_mesh(const std::vector<vec3>& vertices, const std::vector<tet_indices>& tets,
             orientation_checked_by_caller)
        : tet_mesh(vertices, tets, false) {}

private:
    tet_mesh(const std::vector<vec3>& vertices, const std::vector<tet_indices>& tets,
             bool check_orientation)
        : tet_mesh() {
        check_input(vertices, tets, check_orientation);
        conn_.build(static_cast<index_t>(vertices.size()), tets);
        grow_attributes();
        auto p = positions();
        for (index_t v = 0; v < vertices.size(); ++v) p.raw(v) = vertices[v];
    }

public:
    // ---- sizes ----
    index_t vertex_slots() const noexcept { return conn_.vertex_slots(); }
    index_t tet_slots() const noexcept { return conn_.tet_slots(); }
    /// Edge ids are (tet, local edge) slots, 6 per tet; edge attributes need this many.
    std::size_t edge_slots() const noexcept { return 6 * std::size_t(conn_.tet_slots()); }
    /// Face ids are (tet, local face) slots, 4 per tet.
    std::size_t face_slots() const noexcept { return 4 * std::size_t(conn_.tet_slots()); }
    std::size_t n_vertices() const {
        std::size_t n = 0;
        for_each_vertex([&](const tuple&) { ++n; });
        return n;
    }
    std::size_t n_tets() const {
        std::size_t n = 0;
        for (index_t t = 0; t < tet_slots(); ++t) n += conn_.tet_alive(t) ? 1 : 0;
        return n;
    }
    std::size_t n_faces() const {
        std::size_t n = 0;
        for_each_face([&](const tuple&) { ++n; });
        return n;
    }
    std::size_t n_edges() const {
        std::size_t n = 0;
        for_each_edge([&](const tuple&) { ++n; });
        return n;
    }
    bool vertex_alive(index_t v) const noexcept { return conn_.vertex_alive(v); }
    bool tet_alive(index_t t) const noexcept { return conn_.tet_alive(t); }

    // ---- tuples ----
    /// Tuple on local edge `le` of tet t, at the edge's first corner, in the first face
    /// holding the edge.
    tuple tuple_from_edge(index_t t, std::uint8_t le) const noexcept {
        const auto& tv = conn_.tet_vertices(t);
        return {tv[tet_local::edge_vertices[le][0]], t, le, tet_local::edge_complement(le)[0],
                conn_.tet_version(t)};
    }
    /// Tuple on local face `lf` of tet t, at the face's first corner and its first edge.
    tuple tuple_from_face(index_t t, std::uint8_t lf) const noexcept {
        const auto fv = tet_local::face_vertices[lf];
        return {conn_.tet_vertices(t)[fv[0]], t, tet_local::edge_of[fv[0]][fv[1]], lf,
                conn_.tet_version(t)};
    }
    tuple tuple_from_tet(index_t t) const noexcept { return tuple_from_edge(t, 0); }
    /// Tuple at vertex v in tet t (v must be a vertex of t).
    tuple tuple_in_tet(index_t v, index_t t) const noexcept {
        const std::uint8_t i = tet_local::index_of(conn_.tet_vertices(t), v);
        const std::uint8_t j = static_cast<std::uint8_t>((i + 1) % 4);
        const std::uint8_t le = tet_local::edge_of[i][j];
        return {v, t, le, tet_local::edge_complement(le)[0], conn_.tet_version(t)};
    }
    /// Tuple at vertex v on edge vw of tet t (both must be vertices of t).
    tuple tuple_at(index_t t, index_t v, index_t w) const noexcept {
        const auto& tv = conn_.tet_vertices(t);
        const std::uint8_t le =
            tet_local::edge_of[tet_local::index_of(tv, v)][tet_local::index_of(tv, w)];
        return {v, t, le, tet_local::edge_complement(le)[0], conn_.tet_version(t)};
    }
    /// Tuple at vertex v in one of its tets; v must have a tet.
    tuple tuple_from_vertex(index_t v) const noexcept {
        if constexpr (requires { conn_.vertex_anchor(v); }) {
            const index_t t = conn_.vertex_anchor(v);
            if (t != invalid_index) return tuple_in_tet(v, t);
            return {v, invalid_index, 0, 0, 0};
        }
        for (index_t t : conn_.vertex_tets(v)) return tuple_in_tet(v, t);
        return {v, invalid_index, 0, 0, 0};
    }
    /// Tuple at a on edge ab, if the edge exists.
    std::optional<tuple> find_edge(index_t a, index_t b) const noexcept {
        if (a >= vertex_slots() || b >= vertex_slots() || a == b) return std::nullopt;
        for (index_t t : conn_.vertex_tets(a)) {
            const auto& tv = conn_.tet_vertices(t);
            const std::uint8_t j = tet_local::index_of(tv, b);
            if (j == tet_local::none) continue;
            const std::uint8_t i = tet_local::index_of(tv, a);
            const std::uint8_t le = tet_local::edge_of[i][j];
            return tuple{a, t, le, tet_local::edge_complement(le)[0], conn_.tet_version(t)};
        }
        return std::nullopt;
    }
    /// Tuple at a on edge ab of face abc, if the face exists.
    std::optional<tuple> find_face(index_t a, index_t b, index_t c) const noexcept {
        if (a >= vertex_slots() || b >= vertex_slots() || c >= vertex_slots()) return std::nullopt;
        for (index_t t : conn_.vertex_tets(a)) {
            const auto& tv = conn_.tet_vertices(t);
            const std::uint8_t j = tet_local::index_of(tv, b), k = tet_local::index_of(tv, c);
            if (j == tet_local::none || k == tet_local::none || a == b || b == c || a == c)
                continue;
            const std::uint8_t i = tet_local::index_of(tv, a);
            const auto lf = static_cast<std::uint8_t>(6 - i - j - k);
            return tuple{a, t, tet_local::edge_of[i][j], lf, conn_.tet_version(t)};
        }
        return std::nullopt;
    }

    /// False once the tuple's tet was removed or changed by a later operation.
    bool is_valid(const tuple& t) const noexcept {
        if (t.tid >= tet_slots() || t.local_edge > 5 || t.local_face > 3 ||
            !conn_.tet_alive(t.tid) || conn_.tet_version(t.tid) != t.version)
            return false;
        const auto& tv = conn_.tet_vertices(t.tid);
        const auto e = tet_local::edge_vertices[t.local_edge];
        return (tv[e[0]] == t.vid || tv[e[1]] == t.vid) && e[0] != t.local_face &&
               e[1] != t.local_face;
    }

    index_t vid(const tuple& t) const noexcept { return t.vid; }
    index_t tid(const tuple& t) const noexcept { return t.tid; }
    /// Edge identity: the smallest (tet * 6 + local edge) slot among the edge's tets.
    index_t eid(const tuple& t) const noexcept {
        const auto [a, b] = edge_vertices(t);
        index_t best = 6 * t.tid + t.local_edge;
        if constexpr (face_links) {
            walk_edge(t.tid, a, b, [&](index_t g) {
                const auto& gv = conn_.tet_vertices(g);
                best = std::min<index_t>(
                    best,
                    6 * g +
                        tet_local::edge_of[tet_local::index_of(gv, a)][tet_local::index_of(gv, b)]);
            });
            return best;
        }
        for (index_t g : conn_.vertex_tets(a)) {
            if (6 * g >= best) continue;
            const auto& gv = conn_.tet_vertices(g);
            const std::uint8_t j = tet_local::index_of(gv, b);
            if (j != tet_local::none)
                best = 6 * g + tet_local::edge_of[tet_local::index_of(gv, a)][j];
        }
        return best;
    }
    /// Face identity: the smaller (tet * 4 + local face) slot of the face's (up to) two tets.
    index_t fid(const tuple& t) const noexcept {
        const index_t h = 4 * t.tid + t.local_face;
        if constexpr (face_links) {
            const auto [g, lf] = conn_.opposite_face(t.tid, t.local_face);
            return g == invalid_index || g > t.tid ? h : 4 * g + lf;
        }
        const index_t g = conn_.opposite_tet(t.tid, t.local_face);
        if (g == invalid_index || g > t.tid) return h;
        return 4 * g + local_face_in(g, t.tid, t.local_face);
    }

    /// Same edge, face and tet; the edge's other vertex.
    tuple switch_vertex(const tuple& t) const noexcept {
        tuple r = t;
        r.vid = other_endpoint(t);
        return r;
    }
    /// Same vertex, face and tet; the face's other edge at the vertex.
    tuple switch_edge(const tuple& t) const noexcept {
        const auto& tv = conn_.tet_vertices(t.tid);
        const std::uint8_t i = tet_local::index_of(tv, t.vid);
        const auto e = tet_local::edge_vertices[t.local_edge];
        const std::uint8_t j = e[0] == i ? e[1] : e[0];
        // The face's third corner is the one neither on the edge nor opposite the face.
        const auto k = static_cast<std::uint8_t>(6 - i - j - t.local_face);
        tuple r = t;
        r.local_edge = tet_local::edge_of[i][k];
        return r;
    }
    /// Same vertex, edge and tet; the tet's other face at the edge.
    tuple switch_face(const tuple& t) const noexcept {
        const auto c = tet_local::edge_complement(t.local_edge);
        tuple r = t;
        r.local_face = t.local_face == c[0] ? c[1] : c[0];
        return r;
    }
    /// Same vertex, edge and face; the tet on the face's other side, or nothing on the
    /// boundary.
    std::optional<tuple> switch_tetrahedron(const tuple& t) const noexcept {
        std::uint8_t lf = 0;
        index_t g;
        if constexpr (face_links)
            std::tie(g, lf) = conn_.opposite_face(t.tid, t.local_face);
        else
            g = conn_.opposite_tet(t.tid, t.local_face);
        if (g == invalid_index) return std::nullopt;
        if constexpr (!face_links) lf = local_face_in(g, t.tid, t.local_face);
        const auto& gv = conn_.tet_vertices(g);
        const std::uint8_t i = tet_local::index_of(gv, t.vid);
        const std::uint8_t j = tet_local::index_of(gv, other_endpoint(t));
        return tuple{t.vid, g, tet_local::edge_of[i][j], lf, conn_.tet_version(g)};
    }

    bool is_boundary_face(const tuple& t) const noexcept {
        return conn_.opposite_tet(t.tid, t.local_face) == invalid_index;
    }
    /// An edge is interior iff its tets close into a ring: every vertex of the ring is
    /// shared by exactly two of them.
    bool is_boundary_edge(const tuple& t) const noexcept {
        const auto [a, b] = edge_vertices(t);
        if constexpr (face_links) return !walk_edge(t.tid, a, b, [](index_t) {});
        boost::container::small_vector<index_t, 64> ring;
        for (index_t g : conn_.vertex_tets(a)) {
            const auto& gv = conn_.tet_vertices(g);
            if (!tet_local::contains(gv, b)) continue;
            for (index_t x : gv)
                if (x != a && x != b) ring.push_back(x);
        }
        std::sort(ring.begin(), ring.end());
        for (std::size_t i = 0; i < ring.size(); i += 2)
            if (i + 1 >= ring.size() || ring[i] != ring[i + 1] ||
                (i + 2 < ring.size() && ring[i + 2] == ring[i]))
                return true;
        return false;
    }
    /// A vertex is interior iff its link is closed: every link edge lies in two link
    /// triangles.
    bool is_boundary_vertex(index_t v) const noexcept {
        if constexpr (face_links) { // a face of the star at v without a twin
            for (index_t g : conn_.vertex_tets(v)) {
                const auto& gv = conn_.tet_vertices(g);
                for (std::uint8_t k = 0; k < 4; ++k)
                    if (gv[k] != v && conn_.opposite_tet(g, k) == invalid_index) return true;
            }
            return false;
        }
        boost::container::small_vector<std::pair<index_t, index_t>, 192> edges;
        for (index_t g : conn_.vertex_tets(v)) {
            const auto& gv = conn_.tet_vertices(g);
            const std::uint8_t i = tet_local::index_of(gv, v);
            const index_t x = gv[(i + 1) % 4], y = gv[(i + 2) % 4], z = gv[(i + 3) % 4];
            edges.push_back(std::minmax(x, y));
            edges.push_back(std::minmax(y, z));
            edges.push_back(std::minmax(x, z));
        }
        if (edges.empty()) return false;
        std::sort(edges.begin(), edges.end());
        for (std::size_t i = 0; i < edges.size(); i += 2)
            if (i + 1 >= edges.size() || edges[i] != edges[i + 1] ||
                (i + 2 < edges.size() && edges[i + 2] == edges[i]))
                return true;
        return false;
    }

    /// Appends the vertices adjacent to v (each once) to `out`.
    template <class Out>
    void one_ring_vertices(index_t v, Out& out) const {
        const auto start = out.size();
        for (index_t g : conn_.vertex_tets(v))
            for (index_t w : conn_.tet_vertices(g))
                if (w != v && std::find(out.begin() + start, out.end(), w) == out.end())
                    out.push_back(w);
    }
    /// Appends the tets containing the tuple's edge to `out`.
    template <class Out>
    void edge_tets(const tuple& t, Out& out) const {
        const auto [a, b] = edge_vertices(t);
        if constexpr (face_links) {
            walk_edge(t.tid, a, b, [&](index_t g) { out.push_back(g); });
            return;
        }
        for (index_t g : conn_.vertex_tets(a))
            if (tet_local::contains(conn_.tet_vertices(g), b)) out.push_back(g);
    }
    decltype(auto) vertex_tets(index_t v) const noexcept { return conn_.vertex_tets(v); }
    /// With face links: visits the tets around edge ab, starting at tet t (which holds
    /// it), each once; true iff they close into a ring (ab is interior).
    template <class F>
    bool walk_edge(index_t t, index_t a, index_t b, F&& f) const requires face_links {
        f(t);
        const auto& tv = conn_.tet_vertices(t);
        const auto rest = tet_local::edge_complement(
            tet_local::edge_of[tet_local::index_of(tv, a)][tet_local::index_of(tv, b)]);
        // Leaving a tet across the face opposite one of its two other vertices, the next
        // tet is left across the face opposite the vertex the two share besides a and b.
        for (std::uint8_t side = 0; side < 2; ++side) {
            index_t g = t;
            std::uint8_t cross = rest[side];
            for (;;) {
                const auto [h, lf] = conn_.opposite_face(g, cross);
                if (h == invalid_index) break;
                if (h == t) return true;
                f(h);
                const auto& hv = conn_.tet_vertices(h);
                cross = static_cast<std::uint8_t>(6 - tet_local::index_of(hv, a) -
                                                  tet_local::index_of(hv, b) - lf);
                g = h;
            }
        }
        return false;
    }
    const tet_indices& tet_vertices(index_t t) const noexcept { return conn_.tet_vertices(t); }
    /// The two vertices of the tuple's edge, tuple's vertex first.
    std::pair<index_t, index_t> edge_vertices(const tuple& t) const noexcept {
        return {t.vid, other_endpoint(t)};
    }
    /// The tuple's face: its vertex, the edge's other vertex, then the third corner.
    tri_indices face_vertices(const tuple& t) const noexcept {
        const auto& tv = conn_.tet_vertices(t.tid);
        const index_t b = other_endpoint(t);
        index_t c = invalid_index;
        for (std::uint8_t k = 0; k < 4; ++k)
            if (k != t.local_face && tv[k] != t.vid && tv[k] != b) c = tv[k];
        return {t.vid, b, c};
    }
    /// The tuple's face with its corners in outward order (seen from outside the tuple's tet).
    tri_indices face_vertices_outward(const tuple& t) const noexcept {
        const auto& tv = conn_.tet_vertices(t.tid);
        const auto f = tet_local::face_vertices[t.local_face];
        return {tv[f[0]], tv[f[1]], tv[f[2]]};
    }
    /// The vertex of the tuple's tet not on the tuple's face.
    index_t opposite_vertex(const tuple& t) const noexcept {
        return conn_.tet_vertices(t.tid)[t.local_face];
    }

    // ---- iteration (one tuple per simplex) ----
    template <class F>
    void for_each_vertex(F&& f) const {
        for (index_t v = 0; v < vertex_slots(); ++v)
            if (conn_.vertex_alive(v) && !std::ranges::empty(conn_.vertex_tets(v)))
                f(tuple_from_vertex(v));
    }
    template <class F>
    void for_each_tet(F&& f) const {
        for (index_t i = 0; i < tet_slots(); ++i)
            if (conn_.tet_alive(i)) f(tuple_from_tet(i));
    }
    /// Each face once, through the tuple whose slot is its id.
    template <class F>
    void for_each_face(F&& f) const {
        for (index_t i = 0; i < tet_slots(); ++i) {
            if (!conn_.tet_alive(i)) continue;
            for (std::uint8_t lf = 0; lf < 4; ++lf) {
                const tuple t = tuple_from_face(i, lf);
                if (fid(t) == 4 * i + lf) f(t);
            }
        }
    }
    /// Each edge once, through the tuple whose slot is its id.
    template <class F>
    void for_each_edge(F&& f) const {
        for (index_t i = 0; i < tet_slots(); ++i) {
            if (!conn_.tet_alive(i)) continue;
            for (std::uint8_t le = 0; le < 6; ++le) {
                const tuple t = tuple_from_edge(i, le);
                if (eid(t) == 6 * i + le) f(t);
            }
        }
    }
    /// Each boundary face once; the tuple's tet is the face's only tet.
    template <class F>
    void for_each_boundary_face(F&& f) const {
        for (index_t i = 0; i < tet_slots(); ++i) {
            if (!conn_.tet_alive(i)) continue;
            for (std::uint8_t lf = 0; lf < 4; ++lf)
                if (conn_.opposite_tet(i, lf) == invalid_index) f(tuple_from_face(i, lf));
        }
    }
    std::vector<tuple> get_vertices() const {
        return collect([&](auto&& g) { for_each_vertex(g); });
    }
    std::vector<tuple> get_edges() const {
        return collect([&](auto&& g) { for_each_edge(g); });
    }
    std::vector<tuple> get_faces() const {
        return collect([&](auto&& g) { for_each_face(g); });
    }
    std::vector<tuple> get_tets() const {
        return collect([&](auto&& g) { for_each_tet(g); });
    }
    /// The boundary surface: outward-oriented triangles on the mesh's vertex ids.
    std::vector<tri_indices> boundary_faces() const {
        std::vector<tri_indices> out;
        for_each_boundary_face([&](const tuple& t) { out.push_back(face_vertices_outward(t)); });
        return out;
    }
    /// The ids of the vertices on the boundary, ascending.
    std::vector<index_t> boundary_vertices() const {
        std::vector<index_t> out;
        for (const auto& f : boundary_faces()) out.insert(out.end(), f.begin(), f.end());
        std::sort(out.begin(), out.end());
        out.erase(std::unique(out.begin(), out.end()), out.end());
        return out;
    }
    /// One tuple per boundary edge.
    std::vector<tuple> boundary_edges() const {
        std::vector<tuple> out;
        for_each_edge([&](const tuple& t) {
            if (is_boundary_edge(t)) out.push_back(t);
        });
        return out;
    }

    // ---- attributes ----
    template <attribute_value T>
    vertex_attribute<T> add_vertex_attribute(std::string name, T dflt = T{}) {
        return attrs_.add<T, simplex_kind::vertex>(std::move(name), vertex_slots(), dflt);
    }
    template <attribute_value T>
    edge_attribute<T> add_edge_attribute(std::string name, T dflt = T{}) {
        return attrs_.add<T, simplex_kind::edge>(std::move(name), edge_slots(), dflt);
    }
    template <attribute_value T>
    face_attribute<T> add_face_attribute(std::string name, T dflt = T{}) {
        return attrs_.add<T, simplex_kind::face>(std::move(name), face_slots(), dflt);
    }
    template <attribute_value T>
    tet_attribute<T> add_tet_attribute(std::string name, T dflt = T{}) {
        return attrs_.add<T, simplex_kind::tet>(std::move(name), tet_slots(), dflt);
    }
    /// A column for set-up outside operations (reads, and `raw` writes); through a const
    /// mesh, a read-only view.
    template <attribute_value T, simplex_kind K>
    attribute_setup<T> attribute(attribute_handle<T, K> h) {
        return attrs_.setup(h);
    }
    template <attribute_value T, simplex_kind K>
    attribute_view<T> attribute(attribute_handle<T, K> h) const {
        return attrs_.view(h);
    }
    /// A column as the operation that `edit` names writes it (`after`: `m.attribute(h,
    /// r)`): every `set` is journaled there, so a refusal restores the old value.
    template <attribute_value T, simplex_kind K, names_journal Edit>
    attribute_accessor<T> attribute(attribute_handle<T, K> h, const Edit& edit) {
        assert(edit.journal && "idas: an op_result made outside an operation names no journal");
        return attrs_.access(h, *edit.journal);
    }
    /// Removes a column added by the user or an algorithm (not the positions).
    template <attribute_value T, simplex_kind K>
    void remove_attribute(attribute_handle<T, K> h) {
        if (h.column != position_.column) attrs_.remove(h);
    }

    vertex_attribute<vec3> position_handle() const noexcept { return position_; }
    attribute_setup<vec3> positions() { return attrs_.setup(position_); }
    attribute_view<vec3> positions() const { return attrs_.view(position_); }
    template <names_journal Edit>
    attribute_accessor<vec3> positions(const Edit& edit) {
        return attribute(position_, edit);
    }
    const vec3& position(index_t v) const { return positions()[v]; }

    const attribute_registry& attributes() const noexcept { return attrs_; }

    // ---- mutation primitives for operations (journaled; attributes grow alongside) ----
    const Backend& connectivity() const noexcept { return conn_; }
    index_t add_vertex(undo_log& log, attribute_journal& attrs) {
        const index_t v = conn_.add_vertex(log);
        attrs_.ensure(simplex_kind::vertex, std::size_t(v) + 1);
        attrs_.reset_slot(simplex_kind::vertex, v, attrs);
        return v;
    }
    index_t add_tet(const tet_indices& t, undo_log& log, attribute_journal& attrs) {
        const index_t id = conn_.add_tet(t, log);
        attrs_.ensure(simplex_kind::tet, std::size_t(id) + 1);
        attrs_.ensure(simplex_kind::face, 4 * (std::size_t(id) + 1));
        attrs_.ensure(simplex_kind::edge, 6 * (std::size_t(id) + 1));
        attrs_.reset_slot(simplex_kind::tet, id, attrs);
        return id;
    }
    void remove_tet(index_t t, undo_log& log) { conn_.remove_tet(t, log); }
    void remove_vertex(index_t v, undo_log& log) { conn_.remove_vertex(v, log); }
    void set_tet(index_t t, const tet_indices& v, undo_log& log) { conn_.set_tet(t, v, log); }
    void touch_tet(index_t t, undo_log& log) { conn_.touch_tet(t, log); }
    void rollback(undo_log& log, std::size_t mark) { conn_.rollback(log, mark); }
    /// After mutations that glue new tets onto an untouched boundary (no operation of
    /// tet_ops.hpp does): lets a backend with face links find those twins.
    void settle(undo_log& log) {
        if constexpr (requires { conn_.settle(log); }) conn_.settle(log);
    }
    /// See indexed_tet::set_slot_recycling.
    void set_slot_recycling(bool on) noexcept { conn_.set_slot_recycling(on); }

    /// Whether the backend can hand out new slots to concurrent workers: from per-worker
    /// pools, the one an operation's undo log names (`log.pool`, set by the executor).
    static constexpr bool parallel_growth =
        requires(Backend b, unsigned w, index_t n, typename Backend::undo_log log) {
        b.begin_parallel(w, n, n);
        b.end_parallel();
        { b.has_room(n, n, 0u) } -> std::convertible_to<bool>;
        log.pool = w;
    };
    /// Grows every array once so `workers` workers can add up to the given numbers of
    /// vertices and tets concurrently (see the backend's begin_parallel).
    void begin_parallel(unsigned workers, index_t extra_vertices,
                        index_t extra_tets) requires parallel_growth {
        conn_.begin_parallel(workers, extra_vertices, extra_tets);
        grow_attributes();
    }
    /// The same with a quota per pool (a deterministic round: one pool per operation, in
    /// a fixed order, so new slots do not depend on which thread made them).
    void begin_parallel(std::span<const index_t> vertex_quotas,
                        std::span<const index_t> tet_quotas) requires parallel_growth {
        conn_.begin_parallel(vertex_quotas, tet_quotas);
        grow_attributes();
    }
    void end_parallel() requires parallel_growth { conn_.end_parallel(); }
    /// Whether slot pool `pool` (a parallel worker's) can serve an operation that adds up
    /// to these numbers of simplices (always outside a parallel phase).
    bool has_room(index_t vertices, index_t tets, unsigned pool) const noexcept {
        if constexpr (parallel_growth)
            return conn_.has_room(vertices, tets, pool);
        else
            return true;
    }
    void reserve(index_t vertices, index_t tets) {
        conn_.reserve(vertices, tets);
        attrs_.ensure(simplex_kind::vertex, vertices);
        attrs_.ensure(simplex_kind::tet, tets);
        attrs_.ensure(simplex_kind::face, 4 * std::size_t(tets));
        attrs_.ensure(simplex_kind::edge, 6 * std::size_t(tets));
    }

    // ---- export ----
    /// Live vertices (those with tets) and tets, renumbered densely in slot order.
    std::pair<std::vector<vec3>, std::vector<tet_indices>> to_arrays() const {
        std::vector<index_t> new_id(vertex_slots(), invalid_index);
        std::vector<vec3> V;
        for (index_t v = 0; v < vertex_slots(); ++v)
            if (conn_.vertex_alive(v) && !std::ranges::empty(conn_.vertex_tets(v)))
                new_id[v] = static_cast<index_t>(V.size()), V.push_back(position(v));
        std::vector<tet_indices> T;
        T.reserve(n_tets());
        for (index_t t = 0; t < tet_slots(); ++t)
            if (conn_.tet_alive(t)) {
                const auto& tv = conn_.tet_vertices(t);
                T.push_back({new_id[tv[0]], new_id[tv[1]], new_id[tv[2]], new_id[tv[3]]});
            }
        return {std::move(V), std::move(T)};
    }

    /// Removes dead slots, renumbering vertices, tets, faces and edges and every attribute
    /// with them. Invalidates all tuples.
    void consolidate() {
        std::vector<index_t> old_v, old_t, new_v(vertex_slots(), invalid_index);
        for (index_t v = 0; v < vertex_slots(); ++v)
            if (conn_.vertex_alive(v) && !std::ranges::empty(conn_.vertex_tets(v)))
                new_v[v] = static_cast<index_t>(old_v.size()), old_v.push_back(v);
        std::vector<tet_indices> T;
        std::vector<index_t> old_e, old_f; // old id of the simplex in each new slot
        for (index_t t = 0; t < tet_slots(); ++t)
            if (conn_.tet_alive(t)) {
                const auto& tv = conn_.tet_vertices(t);
                old_t.push_back(t);
                T.push_back({new_v[tv[0]], new_v[tv[1]], new_v[tv[2]], new_v[tv[3]]});
                for (std::uint8_t le = 0; le < 6; ++le)
                    old_e.push_back(eid(tuple_from_edge(t, le)));
                for (std::uint8_t lf = 0; lf < 4; ++lf)
                    old_f.push_back(fid(tuple_from_face(t, lf)));
            }
        Backend fresh;
        fresh.build(static_cast<index_t>(old_v.size()), T);
        conn_ = std::move(fresh);
        attrs_.remap(simplex_kind::vertex, old_v);
        attrs_.remap(simplex_kind::tet, old_t);
        // Every new slot of an edge or face takes the value of the simplex's old id.
        attrs_.remap(simplex_kind::edge, old_e);
        attrs_.remap(simplex_kind::face, old_f);
        grow_attributes();
    }

    friend bool operator==(const tet_mesh& a, const tet_mesh& b) = delete;

private:
    static void check_input(const std::vector<vec3>& vertices, const std::vector<tet_indices>& tets,
                            bool check_orientation) {
        if (vertices.size() >= invalid_index) throw input_error("too many vertices");
        if (tets.size() >= invalid_index / 6) throw input_error("too many tets");
        for (std::size_t i = 0; i < vertices.size(); ++i)
            if (!is_finite(vertices[i]))
                throw input_error("vertex " + std::to_string(i) + " has a non-finite coordinate");
        const auto tet_name = [](std::size_t t) { return "tet " + std::to_string(t); };
        // Each tet on its own, in parallel; the first tet (lowest index) with a problem
        // throws, as a serial scan would.
        const auto check_tet = [&](std::size_t t) {
            const auto& tv = tets[t];
            for (index_t v : tv)
                if (v >= vertices.size())
                    throw input_error(tet_name(t) + " references vertex " + std::to_string(v) +
                                      " but there are only " + std::to_string(vertices.size()) +
                                      " vertices");
            for (int i = 0; i < 4; ++i)
                for (int j = i + 1; j < 4; ++j)
                    if (tv[i] == tv[j])
                        throw input_error(tet_name(t) + " is degenerate: it uses vertex " +
                                          std::to_string(tv[i]) + " twice");
            if (!check_orientation) return;
            const int o =
                orient3d(vertices[tv[0]], vertices[tv[1]], vertices[tv[2]], vertices[tv[3]]);
            if (o == 0)
                throw input_error(tet_name(t) + " is degenerate: its vertices are coplanar");
            if (o < 0) throw input_error(tet_name(t) + " is inverted (negatively oriented)");
        };
        throw_first_refused(tets.size(), 4096, check_tet);
        // Every face as a sorted triple with the parity of its outward orientation: a
        // shared face must be seen in opposite directions from its two tets. Faces are
        // grouped by their smallest vertex (a counting sort), each group sorted and checked
        // on its own, in parallel; the problem at the smallest face is reported.
        const auto sorted_key = [&](std::size_t t, int lf, bool& odd) {
            const auto& f = tet_local::face_vertices[lf];
            tri_indices k = {tets[t][f[0]], tets[t][f[1]], tets[t][f[2]]};
            odd = false;
            if (k[0] > k[1]) std::swap(k[0], k[1]), odd = !odd;
            if (k[1] > k[2]) std::swap(k[1], k[2]), odd = !odd;
            if (k[0] > k[1]) std::swap(k[0], k[1]), odd = !odd;
            return k;
        };
        struct face_rec {
            index_t second, third, tet;
            bool odd;
        };
        std::vector<std::size_t> first(vertices.size() + 1, 0);
        for (const auto& tv : tets)
            for (int lf = 0; lf < 4; ++lf) {
                const auto& f = tet_local::face_vertices[lf];
                ++first[std::min({tv[f[0]], tv[f[1]], tv[f[2]]}) + 1];
            }
        for (std::size_t v = 0; v < vertices.size(); ++v) first[v + 1] += first[v];
        std::vector<face_rec> faces(first.back());
        {
            std::vector<std::size_t> fill(first.begin(), first.end() - 1);
            for (std::size_t t = 0; t < tets.size(); ++t)
                for (int lf = 0; lf < 4; ++lf) {
                    bool odd = false;
                    const tri_indices k = sorted_key(t, lf, odd);
                    faces[fill[k[0]]++] = {k[1], k[2], index_t(t), odd};
                }
        }
        const auto face_name = [](const tri_indices& k) {
            return "face (" + std::to_string(k[0]) + ", " + std::to_string(k[1]) + ", " +
                   std::to_string(k[2]) + ")";
        };
        // The faces of vertex v's group; throws at the group's first problem.
        const auto check_group = [&](std::size_t v) {
            const auto b = faces.begin() + std::ptrdiff_t(first[v]);
            const auto e = faces.begin() + std::ptrdiff_t(first[v + 1]);
            std::sort(b, e, [](const face_rec& x, const face_rec& y) {
                return std::tie(x.second, x.third, x.tet) < std::tie(y.second, y.third, y.tet);
            });
            for (auto i = b; i != e;) {
                auto j = i + 1;
                while (j != e && j->second == i->second && j->third == i->third) ++j;
                const tri_indices key = {index_t(v), i->second, i->third};
                if (j - i > 2)
                    throw input_error(face_name(key) + " is shared by " + std::to_string(j - i) +
                                      " tets (" + std::to_string(i->tet) + ", " +
                                      std::to_string((i + 1)->tet) + ", " +
                                      std::to_string((i + 2)->tet) + ")");
                if (j - i == 2 && i->odd == (i + 1)->odd)
                    throw input_error(tet_name(i->tet) + " and " + tet_name((i + 1)->tet) +
                                      " overlap: both lie on the same side of their shared " +
                                      face_name(key));
                i = j;
            }
        };
        throw_first_refused(vertices.size(), 1024, check_group);
    }
    /// Runs check(0) ... check(n - 1) in parallel blocks; if any throws input_error, the
    /// lowest one's is thrown again, so the message is the one a serial scan would give.
    template <class Check>
    static void throw_first_refused(std::size_t n, std::size_t grain, const Check& check) {
        using range = tbb::blocked_range<std::size_t>;
        const std::size_t first = tbb::parallel_reduce(
            range(0, n, grain), n,
            [&](const range& r, std::size_t bad) {
                for (std::size_t i = r.begin(); i != r.end() && i < bad; ++i) try {
                        check(i);
                    } catch (const input_error&) {
                        return i;
                    }
                return bad;
            },
            [](std::size_t x, std::size_t y) { return std::min(x, y); });
        if (first < n) check(first); // throws its message
    }
    void grow_attributes() {
        attrs_.ensure(simplex_kind::vertex, vertex_slots());
        attrs_.ensure(simplex_kind::tet, tet_slots());
        attrs_.ensure(simplex_kind::face, face_slots());
        attrs_.ensure(simplex_kind::edge, edge_slots());
    }
    index_t other_endpoint(const tuple& t) const noexcept {
        const auto& tv = conn_.tet_vertices(t.tid);
        const auto e = tet_local::edge_vertices[t.local_edge];
        return tv[e[0]] == t.vid ? tv[e[1]] : tv[e[0]];
    }
    /// Local index, in tet g, of the face g shares with face `lf` of tet t.
    std::uint8_t local_face_in(index_t g, index_t t, std::uint8_t lf) const noexcept {
        const auto& gv = conn_.tet_vertices(g);
        const auto& tv = conn_.tet_vertices(t);
        for (std::uint8_t i = 0; i < 4; ++i)
            if (!tet_local::contains(tv, gv[i]) || gv[i] == tv[lf]) return i;
        return 0;
    }
    template <class Visit>
    std::vector<tuple> collect(Visit&& visit) const {
        std::vector<tuple> out;
        visit([&](const tuple& t) { out.push_back(t); });
        return out;
    }

    Backend conn_;
    attribute_registry attrs_;
    vertex_attribute<vec3> position_;
};

/// Bit-for-bit equality of connectivity (including versions and incidence order) and of
/// every attribute value in live slot ranges. What rollback tests compare.
template <class Backend>
bool identical(const tet_mesh<Backend>& a, const tet_mesh<Backend>& b) {
    if (!(a.connectivity() == b.connectivity())) return false;
    const auto& ca = a.attributes().columns();
    const auto& cb = b.attributes().columns();
    if (ca.size() != cb.size()) return false;
    for (std::size_t i = 0; i < ca.size(); ++i) {
        if (!ca[i] || !cb[i]) {
            if (bool(ca[i]) != bool(cb[i])) return false;
            continue;
        }
        std::size_t slots = 0;
        switch (ca[i]->kind) {
        case simplex_kind::vertex:
            slots = a.vertex_slots();
            break;
        case simplex_kind::edge:
            slots = a.edge_slots();
            break;
        case simplex_kind::face:
            slots = a.face_slots();
            break;
        case simplex_kind::tet:
            slots = a.tet_slots();
            break;
        }
        if (ca[i]->kind != cb[i]->kind || ca[i]->stride != cb[i]->stride ||
            std::memcmp(ca[i]->data, cb[i]->data, slots * ca[i]->stride) != 0)
            return false;
    }
    return true;
}

} // namespace idas
