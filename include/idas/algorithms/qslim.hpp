// QSlim (Garland and Heckbert 1997): collapse the edge whose merged vertex has
// the least quadric error, placing it where that error is smallest.
//
//   I  link condition (always), no normal flip, optionally no self-intersection
//   D  priority: quadric error of the optimal placement, least first
//   A  per-vertex quadric (sum of area-weighted plane quadrics of its faces,
//   plus
//      boundary-constraint planes); merged vertex: Q = Qa + Qb, position =
//      argmin of Q, staying at the midpoint along directions where Q is
//      (nearly) flat
//   S  collapse every edge; renew the new star's edges; stop at the target face
//   count
#pragma once

#include <idas/algorithms/decimation_common.hpp>
#include <idas/invariants/no_normal_flip.hpp>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <optional>

namespace idas::algorithms {

/// A symmetric 4x4 error quadric stored as its 10 distinct entries. Trivially
/// copyable, so it is a journaled attribute like any other.
struct quadric {
    // | a00 a01 a02 b0 |
    // |     a11 a12 b1 |
    // |         a22 b2 |
    // |             c  |
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, b0 = 0, b1 = 0, b2 = 0, c = 0;

    /// w * (n·x + d)^2 for the plane n·x + d = 0.
    static quadric plane(const vec3& n, double d, double w) {
        return {w * n.x * n.x, w * n.x * n.y, w * n.x * n.z, w * n.y * n.y, w * n.y * n.z,
                w * n.z * n.z, w * n.x * d,   w * n.y * d,   w * n.z * d,   w * d * d};
    }
    quadric& operator+=(const quadric& o) {
        a00 += o.a00, a01 += o.a01, a02 += o.a02, a11 += o.a11, a12 += o.a12, a22 += o.a22;
        b0 += o.b0, b1 += o.b1, b2 += o.b2, c += o.c;
        return *this;
    }
    friend quadric operator+(quadric a, const quadric& b) { return a += b; }

    double error(const vec3& p) const {
        const double x = p.x, y = p.y, z = p.z;
        const double e = a00 * x * x + 2 * a01 * x * y + 2 * a02 * x * z + a11 * y * y +
                         2 * a12 * y * z + a22 * z * z + 2 * (b0 * x + b1 * y + b2 * z) + c;
        return std::max(e, 0.0); // rounding can dip below zero
    }

    /// The minimiser nearest to `near`. Where the quadric is flat in some
    /// direction (a plane, a crease: the 3x3 block is singular there) the error
    /// does not change along it and the exact minimiser runs off or does not
    /// exist; so the point stays where `near` is along directions whose
    /// eigenvalue is below 1e-3 of the largest (a truncated pseudo-inverse, as in
    /// Lindstrom 2000). Measured against the plain inverse with a fallback to the
    /// best of a, b and the midpoint: half the refused collapses on subdivided
    /// inputs, 5-35% smaller Hausdorff distance, twice the cost of a priority.
    vec3 minimizer_near(const vec3& near) const {
        Eigen::Matrix3d a;
        a << a00, a01, a02, a01, a11, a12, a02, a12, a22;
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
        eigen.computeDirect(a);
        const Eigen::Vector3d x0(near.x, near.y, near.z);
        const Eigen::Vector3d residual = -(a * x0 + Eigen::Vector3d(b0, b1, b2));
        const auto& lambda = eigen.eigenvalues(); // ascending
        Eigen::Vector3d x = x0;
        for (int i = 0; i < 3; ++i)
            if (lambda[i] > 1e-3 * lambda[2]) {
                const auto u = eigen.eigenvectors().col(i);
                x += u * (u.dot(residual) / lambda[i]);
            }
        const vec3 p{x[0], x[1], x[2]};
        return is_finite(p) ? p : near;
    }

    /// The minimiser, if the 3x3 block is well conditioned.
    std::optional<vec3> minimizer() const {
        const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22,
                     c02 = a01 * a12 - a02 * a11;
        const double det = a00 * c00 + a01 * c01 + a02 * c02;
        const double scale = std::max({std::abs(a00), std::abs(a11), std::abs(a22)});
        if (!(std::abs(det) > 1e-10 * scale * scale * scale)) return std::nullopt;
        const double c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12,
                     c22 = a00 * a11 - a01 * a01;
        const double inv = -1.0 / det;
        vec3 p{(c00 * b0 + c01 * b1 + c02 * b2) * inv, (c01 * b0 + c11 * b1 + c12 * b2) * inv,
               (c02 * b0 + c12 * b1 + c22 * b2) * inv};
        if (!is_finite(p)) return std::nullopt;
        return p;
    }
};

struct qslim_spec : collapse_schedule {
    using operations = op_list<op::collapse_edge>;

    vertex_attribute<quadric> Q;
    double boundary_weight = 100.0; // keeps open boundaries in place

    struct placement {
        vec3 position;
        double cost;
        quadric merged; // Qa + Qb: the merged vertex's quadric
    };

    /// Builds the vertex quadrics once, before the first priority is computed.
    template <class Mesh>
    void prepare(Mesh& m, const exec_options& o) {
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
    }

    /// The quadrics are the run's own: removed when it ends.
    template <class Mesh>
    void finish(Mesh& m) {
        m.remove_attribute(Q);
        Q = {};
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

    template <class Mesh>
    double priority(op::collapse_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return place(m, a, b).cost;
    }

    struct collapse_cache {
        placement p;
        carried_values carried; // the file's attributes at p
    };

    template <class Mesh>
    std::optional<collapse_cache> before(op::collapse_edge, const Mesh& m,
                                         const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        std::optional<collapse_cache> c(std::in_place, collapse_cache{place(m, a, b), {}});
        if (transfer && !transfer->collapse_before(m, t, c->p.position, c->carried)) c.reset();
        return c;
    }

    template <class Mesh>
    bool after(op::collapse_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const collapse_cache& c) const {
        m.positions().set(r.anchor.vid, c.p.position);
        m.attribute(Q).set(r.anchor.vid, c.p.merged);
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
