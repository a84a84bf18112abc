// A user's own operation kind, written outside the library: the 1-to-3 split of a face
// at a new vertex. Used by the contract tests and the parallel policy tests.
#pragma once

#include <idas/exec/executor.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include <optional>

namespace user_ops {

using namespace idas;

/// The face's three vertices keep their own corner each; the new vertex joins them.
struct split_face {
    static constexpr simplex_kind acts_on = simplex_kind::face;
    static constexpr index_t adds_vertices = 1, adds_faces = 2;
};
static_assert(operation_kind<split_face>);

/// Found by the executor through argument-dependent lookup on split_face.
template <class Mesh, class Spec>
auto apply(split_face, Mesh& m, const typename Mesh::tuple& t, Spec& spec, op_context<Mesh>& ctx) {
    if (!m.is_valid(t)) return std::optional<op_result<typename Mesh::tuple>>{};
    return run_operation<split_face>(m, t, spec, ctx, [&] {
        const index_t f = t.fid;
        const tri_indices old = m.face_vertices(f);
        const index_t nv = m.add_vertex(ctx.conn, ctx.attrs);
        m.set_face(f, {old[0], old[1], nv}, ctx.conn);
        const index_t g = m.add_face({old[1], old[2], nv}, ctx.conn, ctx.attrs);
        const index_t h = m.add_face({old[2], old[0], nv}, ctx.conn, ctx.attrs);
        for (index_t c : {f, g, h}) emit_cell(m, ctx, nv, c, f);
        ctx.pending_faces = 2, ctx.pending_vertices = 1;
        return m.tuple_in_face(nv, f);
    });
}

/// Splits the largest faces at their centroids until the mesh has `target_faces` faces.
struct split_largest_faces {
    using operations = op_list<split_face>;
    std::int64_t target_faces = 0;

    template <class Mesh>
    double priority(split_face, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto& f = m.face_vertices(t.fid);
        return -norm(
            cross(m.position(f[1]) - m.position(f[0]), m.position(f[2]) - m.position(f[0])));
    }
    template <class Mesh>
    std::optional<vec3> before(split_face, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto& f = m.face_vertices(t.fid);
        return (m.position(f[0]) + m.position(f[1]) + m.position(f[2])) / 3.0;
    }
    template <class Mesh>
    bool after(split_face, Mesh& m, const op_result<typename Mesh::tuple>& r, const vec3& c) const {
        m.positions(r).set(r.anchor.vid, c);
        return true;
    }
    template <class Mesh, class Push>
    void renew(split_face, const Mesh&, const op_result<typename Mesh::tuple>& r,
               Push& push) const {
        for (const auto& c : r.cells) push(split_face{}, c);
    }
    bool stop(const progress& p) const { return p.faces >= target_faces; }
    std::int64_t remaining(const progress& p) const { return (target_faces - p.faces + 1) / 2; }
};

} // namespace user_ops
