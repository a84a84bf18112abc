// tri_mesh: a triangle mesh seen only through cell tuples. Connectivity lives in a
// swappable backend, data in journaled attribute columns.
#pragma once

#include <idas/core/attribute.hpp>
#include <idas/core/concepts.hpp>
#include <idas/core/tuple.hpp>
#include <idas/mesh/backend/corner_table_tri.hpp>
#include <idas/mesh/backend/indexed_tri.hpp>
#include <idas/mesh/surface_check.hpp>
#include <idas/mesh/topology_report.hpp>

#include <boost/container/small_vector.hpp>

#include <cassert>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace idas {

template <tri_connectivity Backend = backend::indexed_tri>
class tri_mesh {
public:
    using backend_type = Backend;
    using tuple = tri_tuple;
    using undo_log = typename Backend::undo_log;

    tri_mesh() { position_ = attrs_.add<vec3, simplex_kind::vertex>("position", 0); }

    /// Builds an editable mesh. Throws input_error, naming the offending elements, unless
    /// the faces form a consistently oriented 2-manifold (boundaries allowed) and every
    /// coordinate is finite.
    tri_mesh(const std::vector<vec3>& vertices, const std::vector<tri_indices>& faces)
        : tri_mesh() {
        for (std::size_t i = 0; i < vertices.size(); ++i)
            if (!is_finite(vertices[i]))
                throw input_error("vertex " + std::to_string(i) + " has a non-finite coordinate");
        // The quick check (parallel, stops at the first problem) passes every editable
        // face list; only a list it refuses pays for the diagnosis that names every problem.
        if (summarize_surface(vertices.size(), faces).problem) {
            const topology_report r = diagnose_topology(vertices.size(), faces);
            if (!r.editable()) throw input_error("mesh is " + describe_problems(r));
        }
        conn_.build(static_cast<index_t>(vertices.size()), faces);
        grow_attributes();
        auto p = positions();
        for (index_t v = 0; v < vertices.size(); ++v) p.raw(v) = vertices[v];
    }

    // ---- sizes ----
    index_t vertex_slots() const noexcept { return conn_.vertex_slots(); }
    index_t face_slots() const noexcept { return conn_.face_slots(); }
    /// Edge ids are half-edge slots (3 per face), so edge attributes need this many.
    std::size_t edge_slots() const noexcept { return 3 * std::size_t(conn_.face_slots()); }
    std::size_t n_vertices() const {
        std::size_t n = 0;
        for (index_t v = 0; v < vertex_slots(); ++v) n += conn_.vertex_alive(v) ? 1 : 0;
        return n;
    }
    std::size_t n_faces() const {
        std::size_t n = 0;
        for (index_t f = 0; f < face_slots(); ++f) n += conn_.face_alive(f) ? 1 : 0;
        return n;
    }
    std::size_t n_edges() const {
        std::size_t n = 0;
        for_each_edge([&](const tuple&) { ++n; });
        return n;
    }
    bool vertex_alive(index_t v) const noexcept { return conn_.vertex_alive(v); }
    bool face_alive(index_t f) const noexcept { return conn_.face_alive(f); }

    // ---- tuples ----
    /// Tuple at corner (le+1)%3 of face f, on its local edge le.
    tuple tuple_from_edge(index_t f, std::uint8_t le) const noexcept {
        return {conn_.face_vertices(f)[(le + 1) % 3], f, le, conn_.face_version(f)};
    }
    tuple tuple_from_face(index_t f) const noexcept { return tuple_from_edge(f, 0); }
    /// Tuple at vertex v in one of its faces; v must have at least one face.
    tuple tuple_from_vertex(index_t v) const noexcept {
        for (index_t f : conn_.vertex_faces(v)) return tuple_in_face(v, f);
        return {v, invalid_index, 0, 0};
    }
    /// Tuple at vertex v in face f (on the edge that follows v in the face's order).
    tuple tuple_in_face(index_t v, index_t f) const noexcept {
        const auto& fv = conn_.face_vertices(f);
        const std::uint8_t i = fv[0] == v ? 0 : (fv[1] == v ? 1 : 2);
        return {v, f, static_cast<std::uint8_t>((i + 2) % 3), conn_.face_version(f)};
    }

    /// False once the tuple's face was removed or changed by a later operation.
    IDAS_ALWAYS_INLINE bool is_valid(const tuple& t) const noexcept {
        if (t.fid >= face_slots() || t.local_edge > 2 || !conn_.face_alive(t.fid) ||
            conn_.face_version(t.fid) != t.version)
            return false;
        const auto& fv = conn_.face_vertices(t.fid);
        return fv[(t.local_edge + 1) % 3] == t.vid || fv[(t.local_edge + 2) % 3] == t.vid;
    }

    index_t vid(const tuple& t) const noexcept { return t.vid; }
    index_t fid(const tuple& t) const noexcept { return t.fid; }
    /// Edge identity: the smaller of the edge's two half-edge slots.
    IDAS_ALWAYS_INLINE index_t eid(const tuple& t) const noexcept {
        const index_t h = 3 * t.fid + t.local_edge;
        const auto [g, le] = opposite_edge(t);
        return g == invalid_index ? h : std::min(h, 3 * g + le);
    }

    /// Same edge and face, other vertex.
    tuple switch_vertex(const tuple& t) const noexcept {
        tuple r = t;
        r.vid = other_endpoint(t);
        return r;
    }
    /// Same vertex and face, the face's other edge at the vertex.
    tuple switch_edge(const tuple& t) const noexcept {
        const auto& fv = conn_.face_vertices(t.fid);
        const std::uint8_t corner = fv[0] == t.vid ? 0 : (fv[1] == t.vid ? 1 : 2);
        tuple r = t;
        // The edges through a corner are those opposite the two other corners.
        const std::uint8_t e1 = (corner + 1) % 3, e2 = (corner + 2) % 3;
        r.local_edge = t.local_edge == e1 ? e2 : e1;
        return r;
    }
    /// Same vertex and edge, the other face; nothing on the boundary.
    IDAS_ALWAYS_INLINE std::optional<tuple> switch_face(const tuple& t) const noexcept {
        const auto [g, le] = opposite_edge(t);
        if (g == invalid_index) return std::nullopt;
        return tuple{t.vid, g, le, conn_.face_version(g)};
    }

    bool is_boundary_edge(const tuple& t) const noexcept {
        return conn_.opposite_face(t.fid, t.local_edge) == invalid_index;
    }
    /// A manifold vertex is on the boundary iff its faces' fan is open: one more
    /// neighbour than faces.
    IDAS_ALWAYS_INLINE bool is_boundary_vertex(index_t v) const noexcept {
        if constexpr (requires {
                          { conn_.is_boundary_vertex(v) } -> std::convertible_to<bool>;
                      }) {
            return conn_.is_boundary_vertex(v); // a backend that circulates knows directly
        } else {
            // Around an interior vertex every neighbour follows v in one face and precedes
            // it in another; an open fan (a manifold vertex has one fan) starts and ends at
            // two different neighbours. So the sums of followers and predecessors differ
            // exactly on the boundary: O(valence), no search.
            std::uint64_t followers = 0, predecessors = 0;
            for (index_t f : conn_.vertex_faces(v)) {
                const auto& fv = conn_.face_vertices(f);
                const int i = fv[0] == v ? 0 : fv[1] == v ? 1 : 2;
                followers += fv[(i + 1) % 3], predecessors += fv[(i + 2) % 3];
            }
            return followers != predecessors;
        }
    }

    /// Appends the vertices adjacent to v (each once) to `out`.
    template <class Out>
    void one_ring_vertices(index_t v, Out& out) const {
        const auto start = out.size();
        for (index_t f : conn_.vertex_faces(v))
            for (index_t w : conn_.face_vertices(f))
                if (w != v && std::find(out.begin() + start, out.end(), w) == out.end())
                    out.push_back(w);
    }
    decltype(auto) vertex_faces(index_t v) const noexcept { return conn_.vertex_faces(v); }
    const tri_indices& face_vertices(index_t f) const noexcept { return conn_.face_vertices(f); }
    /// The two vertices of the tuple's edge, tuple's vertex first.
    std::pair<index_t, index_t> edge_vertices(const tuple& t) const noexcept {
        return {t.vid, other_endpoint(t)};
    }
    /// The vertex opposite the tuple's edge in the tuple's face.
    index_t opposite_vertex(const tuple& t) const noexcept {
        return conn_.face_vertices(t.fid)[t.local_edge];
    }

    // ---- iteration (one tuple per simplex) ----
    template <class F>
    void for_each_vertex(F&& f) const {
        for (index_t v = 0; v < vertex_slots(); ++v)
            if (conn_.vertex_alive(v) && !std::ranges::empty(conn_.vertex_faces(v)))
                f(tuple_from_vertex(v));
    }
    template <class F>
    void for_each_face(F&& f) const {
        for (index_t i = 0; i < face_slots(); ++i)
            if (conn_.face_alive(i)) f(tuple_from_face(i));
    }
    /// Each edge once, through its canonical half-edge (the one whose slot is its id).
    template <class F>
    void for_each_edge(F&& f) const {
        for (index_t i = 0; i < face_slots(); ++i) {
            if (!conn_.face_alive(i)) continue;
            for (std::uint8_t le = 0; le < 3; ++le) {
                const tuple t = tuple_from_edge(i, le);
                if (eid(t) == 3 * i + le) f(t);
            }
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
    index_t add_face(const tri_indices& f, undo_log& log, attribute_journal& attrs) {
        const index_t id = conn_.add_face(f, log);
        attrs_.ensure(simplex_kind::face, std::size_t(id) + 1);
        attrs_.ensure(simplex_kind::edge, 3 * (std::size_t(id) + 1));
        attrs_.reset_slot(simplex_kind::face, id, attrs);
        return id;
    }
    void remove_face(index_t f, undo_log& log) { conn_.remove_face(f, log); }
    void remove_vertex(index_t v, undo_log& log) { conn_.remove_vertex(v, log); }
    void set_face(index_t f, const tri_indices& v, undo_log& log) { conn_.set_face(f, v, log); }
    void touch_face(index_t f, undo_log& log) { conn_.touch_face(f, log); }
    void rollback(undo_log& log, std::size_t mark) { conn_.rollback(log, mark); }
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
    /// vertices and faces concurrently (see the backend's begin_parallel).
    void begin_parallel(unsigned workers, index_t extra_vertices,
                        index_t extra_faces) requires parallel_growth {
        conn_.begin_parallel(workers, extra_vertices, extra_faces);
        grow_attributes();
    }
    /// The same with a quota per pool (a deterministic round: one pool per operation, in
    /// a fixed order, so new slots do not depend on which thread made them).
    void begin_parallel(std::span<const index_t> vertex_quotas,
                        std::span<const index_t> face_quotas) requires parallel_growth {
        conn_.begin_parallel(vertex_quotas, face_quotas);
        grow_attributes();
    }
    void end_parallel() requires parallel_growth { conn_.end_parallel(); }
    /// Whether slot pool `pool` (a parallel worker's) can serve an operation that adds up
    /// to these numbers of simplices (always outside a parallel phase).
    bool has_room(index_t vertices, index_t faces, unsigned pool) const noexcept {
        if constexpr (parallel_growth)
            return conn_.has_room(vertices, faces, pool);
        else
            return true;
    }
    void reserve(index_t vertices, index_t faces) {
        conn_.reserve(vertices, faces);
        attrs_.ensure(simplex_kind::vertex, vertices);
        attrs_.ensure(simplex_kind::face, faces);
        attrs_.ensure(simplex_kind::edge, 3 * std::size_t(faces));
    }

    // ---- export ----
    /// Live vertices and faces, renumbered densely in slot order.
    std::pair<std::vector<vec3>, std::vector<tri_indices>> to_arrays() const {
        std::vector<index_t> new_id(vertex_slots(), invalid_index);
        std::vector<vec3> V;
        for (index_t v = 0; v < vertex_slots(); ++v)
            if (conn_.vertex_alive(v) && !std::ranges::empty(conn_.vertex_faces(v)))
                new_id[v] = static_cast<index_t>(V.size()), V.push_back(position(v));
        std::vector<tri_indices> F;
        F.reserve(n_faces());
        for (index_t f = 0; f < face_slots(); ++f)
            if (conn_.face_alive(f)) {
                const auto& fv = conn_.face_vertices(f);
                F.push_back({new_id[fv[0]], new_id[fv[1]], new_id[fv[2]]});
            }
        return {std::move(V), std::move(F)};
    }

    /// Removes dead slots, renumbering vertices, faces and edges and every attribute
    /// with them. Invalidates all tuples.
    void consolidate() {
        std::vector<index_t> old_v, old_f, new_v(vertex_slots(), invalid_index);
        for (index_t v = 0; v < vertex_slots(); ++v)
            if (conn_.vertex_alive(v) && !std::ranges::empty(conn_.vertex_faces(v)))
                new_v[v] = static_cast<index_t>(old_v.size()), old_v.push_back(v);
        std::vector<tri_indices> F;
        std::vector<index_t> old_e; // old edge id of each new half-edge slot
        for (index_t f = 0; f < face_slots(); ++f)
            if (conn_.face_alive(f)) {
                const auto& fv = conn_.face_vertices(f);
                old_f.push_back(f);
                F.push_back({new_v[fv[0]], new_v[fv[1]], new_v[fv[2]]});
                for (std::uint8_t le = 0; le < 3; ++le)
                    old_e.push_back(eid(tuple_from_edge(f, le)));
            }
        Backend fresh;
        fresh.build(static_cast<index_t>(old_v.size()), F);
        conn_ = std::move(fresh);
        attrs_.remap(simplex_kind::vertex, old_v);
        attrs_.remap(simplex_kind::face, old_f);
        // A new half-edge slot takes its edge's old value; both halves of an edge agree.
        attrs_.remap(simplex_kind::edge, old_e);
        grow_attributes();
    }

    friend bool operator==(const tri_mesh& a, const tri_mesh& b) = delete;

private:
    void grow_attributes() {
        attrs_.ensure(simplex_kind::vertex, vertex_slots());
        attrs_.ensure(simplex_kind::face, face_slots());
        attrs_.ensure(simplex_kind::edge, edge_slots());
    }
    /// The tuple's edge seen from the face across: that face and the edge's local index
    /// there, or {invalid_index, 0} on the boundary. A backend that stores opposite
    /// corners answers with one load; otherwise the face across is searched for.
    IDAS_ALWAYS_INLINE std::pair<index_t, std::uint8_t>
    opposite_edge(const tuple& t) const noexcept {
        if constexpr (requires {
                          {
                              conn_.opposite_edge(t.fid, t.local_edge)
                              } -> std::same_as<std::pair<index_t, std::uint8_t>>;
                      }) {
            return conn_.opposite_edge(t.fid, t.local_edge);
        } else {
            const index_t g = conn_.opposite_face(t.fid, t.local_edge);
            if (g == invalid_index) return {invalid_index, 0};
            return {g, local_edge_of(g, t.vid, other_endpoint(t))};
        }
    }
    index_t other_endpoint(const tuple& t) const noexcept {
        const auto& fv = conn_.face_vertices(t.fid);
        const index_t x = fv[(t.local_edge + 1) % 3];
        return x == t.vid ? fv[(t.local_edge + 2) % 3] : x;
    }
    /// Local index of edge (a, b) in face g: the corner holding neither.
    std::uint8_t local_edge_of(index_t g, index_t a, index_t b) const noexcept {
        const auto& gv = conn_.face_vertices(g);
        for (std::uint8_t i = 0; i < 3; ++i)
            if (gv[i] != a && gv[i] != b) return i;
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
bool identical(const tri_mesh<Backend>& a, const tri_mesh<Backend>& b) {
    if (!(a.connectivity() == b.connectivity())) return false;
    const auto& ca = a.attributes().columns();
    const auto& cb = b.attributes().columns();
    if (ca.size() != cb.size()) return false;
    for (std::size_t i = 0; i < ca.size(); ++i) {
        if (!ca[i] || !cb[i]) {
            if (bool(ca[i]) != bool(cb[i])) return false;
            continue;
        }
        const std::size_t slots = ca[i]->kind == simplex_kind::vertex ? a.vertex_slots()
                                  : ca[i]->kind == simplex_kind::face ? a.face_slots()
                                                                      : a.edge_slots();
        if (ca[i]->stride != cb[i]->stride ||
            std::memcmp(ca[i]->data, cb[i]->data, slots * ca[i]->stride) != 0)
            return false;
    }
    return true;
}

static_assert(tri_mesh_like<tri_mesh<backend::indexed_tri>>);
static_assert(tri_mesh_like<tri_mesh<backend::corner_table_tri>>);

} // namespace idas
