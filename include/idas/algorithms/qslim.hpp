// QSlim (Garland and Heckbert 1997): collapse the edge whose merged vertex has
// the least quadric error, placing it where that error is smallest.
//
//   I  link condition (always), no normal flip, optionally no self-intersection
//   D  priority: quadric error of the optimal placement, least first; with the file's
//      attributes and attribute_weight > 0, plus their error (attribute_quadric.hpp,
//      Hoppe 1999)
//   A  per-vertex quadric (sum of area-weighted plane quadrics of its faces, plus
//      boundary-constraint planes); merged vertex: Q = Qa + Qb, position = argmin of Q,
//      staying at the midpoint along directions where Q is (nearly) flat; a constrained
//      survivor (attribute_transfer) stays in place, priced there when attributes weigh
//   S  collapse every edge; renew the new star's edges; stop at the target face count
#pragma once

#include <idas/algorithms/attribute_quadric.hpp>
#include <idas/algorithms/decimation_common.hpp>
#include <idas/algorithms/quadric.hpp>
#include <idas/invariants/no_normal_flip.hpp>

#include <cmath>
#include <optional>
#include <string>

namespace idas::algorithms {

struct qslim_spec : collapse_schedule {
    using operations = op_list<op::collapse_edge>;

    vertex_attribute<quadric> Q;
    double boundary_weight = 100.0; // keeps open boundaries in place
    /// How much the attributes `transfer` carries weigh against the geometry: an error of
    /// an attribute's whole range as much as a distance of this times the bounding-box
    /// diagonal. 0: geometry only (the quadric of 1997). Finite and >= 0, or prepare()
    /// throws input_error.
    double attribute_weight = default_attribute_weight;
    /// The largest of 0.1, 0.2, 0.3, 0.5 that kept the 90th percentile of the distance to
    /// the input within 1.1x of geometry only, on textured blub and the coloured armadillo
    /// to 10% (bench/RESULTS.md); blub's texture error is a third lower with it.
    static constexpr double default_attribute_weight = 0.2;
    attribute_quadric appearance; // the run's own, when attributes weigh

    struct placement {
        vec3 position;
        double cost;
        quadric merged; // Qa + Qb: the merged vertex's quadric
    };

    /// Builds the vertex quadrics once, before the first priority is computed.
    template <class Mesh>
    void prepare(Mesh& m, const exec_options& o) {
        if (!(attribute_weight >= 0 && std::isfinite(attribute_weight)))
            throw input_error("qslim: the attribute weight must be a finite number >= 0, not " +
                              std::to_string(attribute_weight));
        forget_refusals(m);
        plan_serial_tail(o);
        Q = m.template add_vertex_attribute<quadric>("qslim_quadric");
        auto q = m.attribute(Q);
        for (index_t v = 0; v < m.vertex_slots(); ++v) q.raw(v) = {};
        m.for_each_face([&](const typename Mesh::tuple& t) {
            const auto& fv = m.face_vertices(t.fid);
            const vec3 &p0 = m.position(fv[0]), &p1 = m.position(fv[1]), &p2 = m.position(fv[2]);
            vec3 n = cross(p1 - p0, p2 - p0);
            const double twice_area = norm(n);
            if (twice_area == 0) return;
            n /= twice_area;
            const quadric k = quadric::plane(n, -dot(n, p0), 0.5 * twice_area);
            for (index_t v : fv) q.raw(v) += k;
            // A boundary edge adds a plane through it, perpendicular to the face.
            auto e = t;
            for (int i = 0; i < 3; ++i, e = m.switch_edge(m.switch_vertex(e))) {
                if (!m.is_boundary_edge(e)) continue;
                const auto [a, b] = m.edge_vertices(e);
                const vec3 d = m.position(b) - m.position(a);
                vec3 side = cross(d, n);
                const double len = norm(side);
                if (len == 0) continue;
                side /= len;
                const quadric kb =
                    quadric::plane(side, -dot(side, m.position(a)), boundary_weight * dot(d, d));
                q.raw(a) += kb, q.raw(b) += kb;
            }
        });
        if (transfer && attribute_weight > 0) appearance.attach(m, *transfer, attribute_weight, Q);
    }

    /// The quadrics are the run's own: removed when it ends.
    template <class Mesh>
    void finish(Mesh& m) {
        m.remove_attribute(Q);
        Q = {};
        appearance.detach(m);
    }

    template <class Mesh>
    placement place(const Mesh& m, index_t a, index_t b) const {
        const auto q = m.attribute(Q);
        const quadric sum = q[a] + q[b];
        const vec3 mid = (m.position(a) + m.position(b)) * 0.5;
        const vec3 p = sum.minimizer_near(mid);
        placement best{p, sum.error(p), sum};
        for (const vec3& x : {m.position(a), m.position(b)}) // guards against rounding
            if (const double e = sum.error(x); e < best.cost) best = {x, e, sum};
        return best;
    }

    /// The collapse of t's edge into t.vid, with the attributes' error when they weigh
    /// (then `merged` is left for `before` to fill: the terms hold the geometry too, so a
    /// priority reads them alone).
    template <class Mesh>
    placement place(const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        if (!appearance.active()) return place(m, a, b);
        if (transfer->constrained(m, a)) { // it stays, with its values of t's face
            const vec3& p = m.position(a);
            return {p, appearance.error_at(m, *transfer, t.fid, a, b, p), {}};
        }
        const quadric sum = appearance.reduced(m, a, b);
        const vec3 p = sum.minimizer_near((m.position(a) + m.position(b)) * 0.5);
        placement best{p, sum.error(p), {}};
        for (const vec3& x : {m.position(a), m.position(b)}) // guards against rounding
            if (const double e = sum.error(x); e < best.cost) best = {x, e, {}};
        return best;
    }

    template <class Mesh>
    double priority(op::collapse_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        return place(m, t).cost;
    }

    struct collapse_cache {
        placement p;
        attribute_quadric::merged terms; // the merged vertex's attribute terms
        carried_values carried;          // the file's attributes at p
    };

    template <class Mesh>
    std::optional<collapse_cache> before(op::collapse_edge, const Mesh& m,
                                         const typename Mesh::tuple& t) const {
        std::optional<collapse_cache> c(std::in_place);
        c->p = place(m, t);
        if (appearance.active()) {
            const auto [a, b] = m.edge_vertices(t);
            const auto q = m.attribute(Q);
            c->p.merged = q[a] + q[b];
            appearance.merge(m, *transfer, a, b, c->p.merged, c->terms);
        }
        if (transfer && !transfer->collapse_before(m, t, c->p.position, c->carried)) c.reset();
        return c;
    }

    template <class Mesh>
    bool after(op::collapse_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const collapse_cache& c) const {
        m.positions().set(r.anchor.vid, c.p.position);
        m.attribute(Q).set(r.anchor.vid, c.p.merged);
        if (appearance.active()) appearance.write(m, r.anchor.vid, c.terms);
        return !transfer || transfer->collapse_after(m, r, c.carried);
    }

    auto invariants() const {
        return invariant_set<no_normal_flip, no_self_intersection>{no_normal_flip{},
                                                                   self_intersections};
    }
};

template <class Mesh = tri_mesh<>, class Lock = lock::vertex_try_lock,
          class Queue = queue::dary_heap<4>, class Partition = partition::morton>
using qslim = executor<qslim_spec, Mesh, Lock, Queue, Partition>;

static_assert(spec_for<qslim_spec, tri_mesh<>>);

} // namespace idas::algorithms
