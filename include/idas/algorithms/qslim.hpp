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

#include <boost/container/small_vector.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
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
        plan_serial_tail(o, std::int64_t(m.n_faces()));
        Q = m.template add_vertex_attribute<quadric>("qslim_quadric");
        auto q = m.attribute(Q);
        // Each vertex sums its own terms (in parallel, the same sums at any thread count):
        // its faces' planes, and the planes through its boundary edges, found in its ring
        // (an edge (v, x) is on the boundary if x follows v in one face of the ring and
        // precedes it in none, or the other way round), not by a search across each edge.
        struct corner {
            index_t next, prev; // the face's corners after v
            vec3 normal;        // unit, or zero for a face of no area
        };
        tbb::parallel_for(tbb::blocked_range<index_t>(0, m.vertex_slots(), 2048),
                          [&](const tbb::blocked_range<index_t>& r) {
                              boost::container::small_vector<corner, 16> ring;
                              for (index_t v = r.begin(); v < r.end(); ++v) {
                                  q.raw(v) =
                                      m.vertex_alive(v) ? vertex_quadric(m, v, ring) : quadric{};
                              }
                          });
        if (transfer && attribute_weight > 0) appearance.attach(m, *transfer, attribute_weight, Q);
    }

    /// Vertex v's quadric: its faces' area-weighted planes, and the planes through its
    /// boundary edges. `ring` is scratch space for v's faces' corners.
    template <class Mesh, class Ring>
    quadric vertex_quadric(const Mesh& m, index_t v, Ring& ring) const {
        quadric sum{};
        ring.clear();
        for (index_t f : m.vertex_faces(v)) {
            const auto& fv = m.face_vertices(f);
            const int i = fv[0] == v ? 0 : fv[1] == v ? 1 : 2;
            const vec3& p0 = m.position(fv[0]);
            vec3 n = cross(m.position(fv[1]) - p0, m.position(fv[2]) - p0);
            const double twice_area = norm(n);
            n = twice_area == 0 ? vec3{0, 0, 0} : n / twice_area;
            ring.push_back({fv[(i + 1) % 3], fv[(i + 2) % 3], n});
            if (twice_area != 0) sum += quadric::plane(n, -dot(n, p0), 0.5 * twice_area);
        }
        for (const auto& c : ring) {
            if (c.normal.x == 0 && c.normal.y == 0 && c.normal.z == 0) continue;
            // (v, next) runs v -> next in its face, (prev, v) prev -> v.
            if (std::none_of(ring.begin(), ring.end(),
                             [&](const auto& o) { return o.prev == c.next; }))
                sum += boundary_plane(m.position(v), m.position(c.next), c.normal);
            if (std::none_of(ring.begin(), ring.end(),
                             [&](const auto& o) { return o.next == c.prev; }))
                sum += boundary_plane(m.position(c.prev), m.position(v), c.normal);
        }
        return sum;
    }
    /// The plane through boundary edge a -> b perpendicular to its face (normal n),
    /// weighted by boundary_weight and the squared length.
    quadric boundary_plane(const vec3& a, const vec3& b, const vec3& n) const {
        const vec3 d = b - a;
        vec3 side = cross(d, n);
        const double len = norm(side);
        if (len == 0) return quadric{};
        side /= len;
        return quadric::plane(side, -dot(side, a), boundary_weight * dot(d, d));
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
        m.positions(r).set(r.anchor.vid, c.p.position);
        m.attribute(Q, r).set(r.anchor.vid, c.p.merged);
        if (appearance.active()) appearance.write(m, r, c.terms);
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
