// Local operations on triangle meshes. Each one runs, in order: the tuple's validity
// and the operation's own topological preconditions; the invariants' `before` and the
// spec's `before` (old mesh); the connectivity change; the spec's `after` (new mesh,
// writes new simplices' attributes); the invariants' `after` on the new faces. Any
// failure restores connectivity and every attribute exactly (journal rollback).
#pragma once

#include <idas/invariants/link_condition.hpp>
#include <idas/mesh/tri_mesh.hpp>
#include <idas/ops/operation.hpp>

#include <optional>
#include <utility>

namespace idas {

namespace detail {

template <class Op, class Mesh, class Spec, class Change>
std::optional<op_result<typename Mesh::tuple>>
run_tri_operation(Mesh& m, const typename Mesh::tuple& t, Spec& spec, op_context<Mesh>& ctx,
                  Change&& change) {
    decltype(auto) inv = spec_invariants(spec);
    typename std::remove_cvref_t<decltype(inv)>::states st{};
    if (!inv.template before<Op>(std::as_const(m), t, st)) return std::nullopt;

    transaction<Mesh> tx(m, ctx);
    auto cache = run_before<Op>(spec, std::as_const(m), t);
    if (!cache) return std::nullopt;

    ctx.cells.clear(), ctx.origins.clear();
    ctx.pending_faces = ctx.pending_vertices = 0;
    const auto anchor = change();
    op_result<typename Mesh::tuple> r{anchor, ctx.cells, ctx.origins, &ctx.attrs};
    if (!run_after<Op>(spec, m, r, *cache)) return std::nullopt;
    if (!inv.template after<Op>(std::as_const(m), r, st)) return std::nullopt;
    tx.commit();
    ctx.face_delta += ctx.pending_faces, ctx.vertex_delta += ctx.pending_vertices;
    r.journal = nullptr; // committed: later writes are no longer this operation's
    return r;
}

/// Records face f as a result cell (tuple at v), coming from `origin`.
template <class Mesh>
void emit(const Mesh& m, op_context<Mesh>& ctx, index_t v, index_t f, index_t origin) {
    ctx.cells.push_back(m.tuple_in_face(v, f));
    ctx.origins.push_back(origin);
}

inline tri_indices replaced(tri_indices f, index_t from, index_t to) {
    for (auto& v : f)
        if (v == from) v = to;
    return f;
}

} // namespace detail

/// Splits the tuple's edge ab at a new vertex m. New faces: the (up to) four faces
/// around m. Anchor: m, on the edge (a, m). `after` must set m's position. Refused when
/// both faces of ab have the same opposite vertex c (a double triangle, two faces on the
/// same three vertices): m would be joined to c twice, making m-c an edge of four faces.
template <class Mesh, class Spec = no_spec>
std::optional<op_result<typename Mesh::tuple>> split_edge(Mesh& m, const typename Mesh::tuple& t,
                                                          Spec&& spec, op_context<Mesh>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    if (const auto g = m.switch_face(t); g && m.opposite_vertex(t) == m.opposite_vertex(*g))
        return std::nullopt;
    return detail::run_tri_operation<op::split_edge>(m, t, spec, ctx, [&] {
        const auto [a, b] = m.edge_vertices(t);
        const auto g = m.switch_face(t);
        const index_t f = t.fid;
        const index_t nv = m.add_vertex(ctx.conn, ctx.attrs);
        auto split_face = [&](index_t face) {
            const tri_indices old = m.face_vertices(face);
            m.set_face(face, detail::replaced(old, b, nv), ctx.conn);
            const index_t other = m.add_face(detail::replaced(old, a, nv), ctx.conn, ctx.attrs);
            detail::emit(m, ctx, nv, face, face);
            detail::emit(m, ctx, nv, other, face);
        };
        split_face(f);
        if (g) split_face(g->fid);
        ctx.pending_faces = g ? 2 : 1, ctx.pending_vertices = 1;
        // In f, (a, nv) is opposite the same corner as ab was.
        return typename Mesh::tuple{nv, f, t.local_edge, m.connectivity().face_version(f)};
    });
}

/// Collapses the tuple's edge ab into a (the tuple's vertex survives, b is removed).
/// Refused unless the link condition holds. New faces: the whole new star of a.
/// Anchor: a. `after` sets a's new position (and other attributes).
template <class Mesh, class Spec = no_spec>
std::optional<op_result<typename Mesh::tuple>> collapse_edge(Mesh& m, const typename Mesh::tuple& t,
                                                             Spec&& spec, op_context<Mesh>& ctx) {
    if (!m.is_valid(t) || !link_condition_holds(m, t)) return std::nullopt;
    return detail::run_tri_operation<op::collapse_edge>(m, t, spec, ctx, [&] {
        const auto [a, b] = m.edge_vertices(t);
        auto& faces_b = ctx.scratch;
        faces_b.assign(m.vertex_faces(b).begin(), m.vertex_faces(b).end());
        for (index_t f : faces_b) {
            const auto& fv = m.face_vertices(f);
            if (fv[0] == a || fv[1] == a || fv[2] == a)
                m.remove_face(f, ctx.conn), --ctx.pending_faces;
            else
                m.set_face(f, detail::replaced(fv, b, a), ctx.conn);
        }
        m.remove_vertex(b, ctx.conn);
        ctx.pending_vertices = -1;
        // a moves, so every face of its new star changes; moved-in faces were bumped already.
        for (index_t f : m.vertex_faces(a)) {
            if (std::find(faces_b.begin(), faces_b.end(), f) == faces_b.end())
                m.touch_face(f, ctx.conn);
            detail::emit(m, ctx, a, f, f);
        }
        return m.tuple_in_face(a, ctx.cells.front().fid);
    });
}

/// Flips the interior edge ab of faces (a,b,c), (b,a,d) to cd. Refused on the boundary
/// or if cd already exists. New faces: the two faces on cd. Anchor: c, on edge cd.
template <class Mesh, class Spec = no_spec>
std::optional<op_result<typename Mesh::tuple>> swap_edge(Mesh& m, const typename Mesh::tuple& t,
                                                         Spec&& spec, op_context<Mesh>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    const auto g = m.switch_face(t);
    if (!g) return std::nullopt;
    const index_t c = m.opposite_vertex(t), d = m.opposite_vertex(*g);
    if (c == d) return std::nullopt; // a double triangle: cd would be a loop
    for (index_t f : m.vertex_faces(c)) {
        const auto& fv = m.face_vertices(f);
        if (fv[0] == d || fv[1] == d || fv[2] == d) return std::nullopt; // cd exists
    }
    return detail::run_tri_operation<op::swap_edge>(m, t, spec, ctx, [&] {
        const index_t f = t.fid, h = g->fid;
        const auto& fv = m.face_vertices(f);
        // f reads (c, x, y) from corner c; h then reads (d, y, x). The quad is c x d y.
        const index_t x = fv[(t.local_edge + 1) % 3], y = fv[(t.local_edge + 2) % 3];
        m.set_face(f, {c, x, d}, ctx.conn);
        m.set_face(h, {d, y, c}, ctx.conn);
        detail::emit(m, ctx, c, f, f);
        detail::emit(m, ctx, d, h, h);
        return typename Mesh::tuple{c, f, 1, m.connectivity().face_version(f)};
    });
}

/// Moves the tuple's vertex: `after` writes its new position. Connectivity is unchanged
/// but every face of its star is renewed (new version). Anchor: the vertex.
template <class Mesh, class Spec = no_spec>
std::optional<op_result<typename Mesh::tuple>> smooth_vertex(Mesh& m, const typename Mesh::tuple& t,
                                                             Spec&& spec, op_context<Mesh>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    return detail::run_tri_operation<op::smooth_vertex>(m, t, spec, ctx, [&] {
        const index_t v = t.vid;
        for (index_t f : m.vertex_faces(v)) {
            m.touch_face(f, ctx.conn);
            detail::emit(m, ctx, v, f, f);
        }
        return m.tuple_in_face(v, t.fid);
    });
}

// Operation kinds map to their functions by overload, so a scheduler can dispatch on
// the kind type at compile time.
template <class Mesh, class Spec>
auto apply(op::split_edge, Mesh& m, const typename Mesh::tuple& t, Spec& s, op_context<Mesh>& c) {
    return split_edge(m, t, s, c);
}
template <class Mesh, class Spec>
auto apply(op::collapse_edge, Mesh& m, const typename Mesh::tuple& t, Spec& s,
           op_context<Mesh>& c) {
    return collapse_edge(m, t, s, c);
}
template <class Mesh, class Spec>
auto apply(op::swap_edge, Mesh& m, const typename Mesh::tuple& t, Spec& s, op_context<Mesh>& c) {
    return swap_edge(m, t, s, c);
}
template <class Mesh, class Spec>
auto apply(op::smooth_vertex, Mesh& m, const typename Mesh::tuple& t, Spec& s,
           op_context<Mesh>& c) {
    return smooth_vertex(m, t, s, c);
}

/// Runs a user's operation kind Op under the library's transaction, as the built-in
/// operations do: invariants' and the spec's `before` on the old mesh, `change()` (which
/// edits connectivity through the mesh's journaled primitives with `ctx.conn` and
/// `ctx.attrs`, records the
/// new cells with `emit_cell`, sets `ctx.pending_faces` / `ctx.pending_vertices` to the
/// net change and returns the anchor tuple), then `after` and the invariants on the new
/// cells; any refusal rolls everything back. Overload `apply(Op, Mesh&, tuple, Spec&,
/// op_context&)` in Op's namespace to let the executor find it.
template <operation_kind Op, class Mesh, class Spec, class Change>
std::optional<op_result<typename Mesh::tuple>> run_operation(Mesh& m, const typename Mesh::tuple& t,
                                                             Spec& spec, op_context<Mesh>& ctx,
                                                             Change&& change) {
    return detail::run_tri_operation<Op>(m, t, spec, ctx, std::forward<Change>(change));
}

/// Records face f as a new or changed cell of the running operation, seen from its vertex
/// v, made from face `origin`.
template <class Mesh>
void emit_cell(const Mesh& m, op_context<Mesh>& ctx, index_t v, index_t f, index_t origin) {
    detail::emit(m, ctx, v, f, origin);
}

/// The calling thread's default operation context for meshes of type Mesh.
template <class Mesh>
op_context<Mesh>& thread_context() {
    thread_local op_context<Mesh> ctx;
    return ctx;
}

// Convenience overloads that use the calling thread's default context.
template <class Mesh, class Spec = no_spec>
auto split_edge(Mesh& m, const typename Mesh::tuple& t, Spec&& spec = {}) {
    return split_edge(m, t, spec, thread_context<Mesh>());
}
template <class Mesh, class Spec = no_spec>
auto collapse_edge(Mesh& m, const typename Mesh::tuple& t, Spec&& spec = {}) {
    return collapse_edge(m, t, spec, thread_context<Mesh>());
}
template <class Mesh, class Spec = no_spec>
auto swap_edge(Mesh& m, const typename Mesh::tuple& t, Spec&& spec = {}) {
    return swap_edge(m, t, spec, thread_context<Mesh>());
}
template <class Mesh, class Spec = no_spec>
auto smooth_vertex(Mesh& m, const typename Mesh::tuple& t, Spec&& spec = {}) {
    return smooth_vertex(m, t, spec, thread_context<Mesh>());
}

} // namespace idas
