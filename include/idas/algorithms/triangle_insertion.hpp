// Exact insertion of a triangle soup into a background tet mesh: the front end of
// TetWild-style meshing (Hu et al. 2018, 2020), done so that it cannot fail.
//
// Every tet is cut by the planes of the input triangles that may meet it (a binary space
// partition of the tet into convex cells, with exact rational arithmetic); the facets on
// a triangle's plane are then split along the triangle's edge lines, so that each input
// triangle is exactly a union of facets. Conformity between tets comes from the
// construction, not from repair:
//   - a face shared by tets A and B is split, from both sides, by the same lines: the
//     planes of A and of B, and the edge lines of the triangles lying on the face;
//   - every point created on a tet's face or edge is handed to the tets sharing that face
//     or edge, which put it on their polygon sides;
//   - polygons and cells are triangulated by canonical rules that depend only on their
//     points (fan from the smallest corner whose sides hold no extra point, else from a
//     Steiner point built from the corners), so both sides agree.
// Each convex cell becomes tets by a cone from one of its corners, or from an interior
// Steiner point when no corner sees every boundary triangle. All tets are positively
// oriented by an exact orient3d on their rational corners.
//
// Phases (each parallel over tets with oneTBB; the result does not depend on the number
// of threads): (0) which triangles may meet which tet, by a walk from each triangle's
// first corner; (1) cut each tet and split its facets; (2) gather the points of the
// neighbours, triangulate, cone; then a serial assembly numbers the vertices in tet order.
#pragma once

#include <idas/core/types.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/predicates/orient.hpp>
#include <idas/predicates/rational.hpp>

#include <boost/container/small_vector.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

namespace idas::insertion {

/// A background tet mesh and a triangle soup whose corners are among its vertices.
struct insertion_input {
    std::vector<vec3> vertices;
    std::vector<tet_indices> tets;      ///< positively oriented, conforming, a manifold
    std::vector<tri_indices> triangles; ///< non-degenerate, corners in `vertices`
};

/// An exact point in homogeneous integers, (X, Y, Z) / W with W != 0, not reduced. A
/// cut point comes from three integer planes by Cramer's rule, so its integers are
/// bounded by the planes' sizes without the gcd that reducing each coordinate costs, and
/// a plane's value at it is n . X - off W: four products, where a canonical rational
/// point needs twelve on integers three times as long.
struct homogeneous_point {
    std::array<mpz_class, 3> X;
    mpz_class W;
};

/// The background mesh with every input triangle inserted.
struct inserted_mesh {
    /// Nearest doubles of the vertex positions (exact for every vertex not in `exact`).
    std::vector<vec3> vertices;
    /// Exact positions of the vertices whose coordinates are not doubles, reduced.
    std::unordered_map<index_t, rational_point> exact;
    /// The same for created vertices not reduced yet, as the insertion made them:
    /// round_vertices() rounds most of them to doubles and reduces only the rest into
    /// `exact` (a gcd per coordinate, for a few vertices instead of all). A vertex is in
    /// one of the two at most.
    std::unordered_map<index_t, homogeneous_point> unreduced;
    /// Positively oriented by an exact orient3d on the exact positions.
    std::vector<tet_indices> tets;
    /// The tracked surface: faces of `tets` that cover input triangles. Face i covers the
    /// input triangles tracked_by[tracked_first[i] .. tracked_first[i + 1]).
    std::vector<tri_indices> tracked;
    std::vector<index_t> tracked_first{0};
    std::vector<index_t> tracked_by;
    /// Background tets cut by at least one plane, and those re-tetrahedralized only
    /// because a neighbour put points on their faces or edges.
    std::size_t cut_tets = 0, refined_tets = 0;

    bool is_exact_double(index_t v) const { return !exact.contains(v) && !unreduced.contains(v); }
    std::size_t rational_vertices() const { return exact.size() + unreduced.size(); }
    rational_point exact_position(index_t v) const;
    homogeneous_point exact_homogeneous(index_t v) const;
};

namespace detail {

// ---- exact planes ------------------------------------------------------------------------

/// The plane {x : n . x = off}, oriented by n, with integer n and off: its value on a
/// rational point is a fraction built from products alone (plane_value()), where
/// canonical rationals would run a gcd on every operation. Planes through three double
/// points keep them for the exact double orient3d, the fast path on double points, and
/// get n and off on first use (make_exact()).
struct exact_plane {
    std::array<mpz_class, 3> n;
    mpz_class off;
    bool has_exact = false;
    bool by_points = false;
    /// by_points: the three points; otherwise, when points_on is 2, p[0] and p[1] lie on
    /// the plane (an edge plane's edge ends): a zero known without arithmetic.
    std::array<vec3, 3> p{};
    std::uint8_t points_on = 0;
    // In doubles, for the floating-point filter: the normal (each component within
    // normal_error of the exact one, up to the positive scale of n) and a double point
    // on the plane.
    vec3 normal, anchor;
    double normal_error = INFINITY;
};

/// orient3d with repeated points answered at once: the triangle's own corners lie on
/// its plane, and the exact stage of orient3d would otherwise prove each such zero.
inline int o3d(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    if (d == a || d == b || d == c || a == b || a == c || b == c) return 0;
    return orient3d(a, b, c, d);
}

inline std::array<mpq_class, 3> cross(const std::array<mpq_class, 3>& u,
                                      const std::array<mpq_class, 3>& v) {
    return {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
}
inline std::array<mpq_class, 3> minus(const rational_point& a, const rational_point& b) {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline mpq_class dot(const std::array<mpq_class, 3>& n, const rational_point& x) {
    return n[0] * x.x + n[1] * x.y + n[2] * x.z;
}

using int_vector = std::array<mpz_class, 3>;

/// out = u x v, into integers that keep their storage (no allocation once they are large
/// enough).
inline void cross_into(int_vector& out, const int_vector& u, const int_vector& v) {
    for (std::size_t i = 0; i < 3; ++i) {
        const std::size_t j = (i + 1) % 3, k = (i + 2) % 3;
        mpz_mul(out[i].get_mpz_t(), u[j].get_mpz_t(), v[k].get_mpz_t());
        mpz_submul(out[i].get_mpz_t(), u[k].get_mpz_t(), v[j].get_mpz_t());
    }
}
inline int_vector cross(const int_vector& u, const int_vector& v) {
    int_vector out;
    cross_into(out, u, v);
    return out;
}
inline mpz_class dot(const int_vector& u, const int_vector& v) {
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
}

/// The exponent of the lowest bit a double x != 0 can hold: x = M 2^lowest_bit(x) with
/// an integer M below 2^53.
inline int lowest_bit(double x) {
    int e = 0;
    std::frexp(x, &e); // x = m 2^e, 0.5 <= |m| < 1: bits down to 2^(e - 53)
    return e - 53;
}

/// out = x / 2^low, an integer for any low <= lowest_bit(x).
inline void set_scaled(mpz_class& out, double x, int low) {
    if (x == 0) {
        mpz_set_ui(out.get_mpz_t(), 0);
        return;
    }
    int e = 0;
    const double m = std::frexp(x, &e);
    mpz_set_d(out.get_mpz_t(), std::ldexp(m, 53)); // exact: an integer below 2^53
    mpz_mul_2exp(out.get_mpz_t(), out.get_mpz_t(), mp_bitcnt_t(e - 53 - low));
}

/// Double points as exact integers on a common scale: p = P * 2^low, where 2^low is the
/// lowest bit of any of their coordinates.
struct scaled_points {
    int low = 0;
    std::array<int_vector, 3> P;

    scaled_points() = default;
    explicit scaled_points(const std::array<vec3, 3>& p) { assign(p); }

    /// Into the integers already held (no allocation once they are long enough).
    void assign(const std::array<vec3, 3>& p) {
        low = std::numeric_limits<int>::max();
        for (const vec3& x : p)
            for (int k = 0; k < 3; ++k)
                if (x[k] != 0) low = std::min(low, lowest_bit(x[k]));
        if (low == std::numeric_limits<int>::max()) low = 0;
        for (std::size_t i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) set_scaled(P[i][std::size_t(k)], p[i][k], low);
    }

    /// The plane with normal n (in scaled space) through scaled point A, as an integer
    /// plane on unscaled points: n . (x / 2^low) - n . A, times a power of two.
    void set_plane(exact_plane& pl, const int_vector& n, const int_vector& A) const {
        mpz_ptr off = pl.off.get_mpz_t();
        mpz_mul(off, n[0].get_mpz_t(), A[0].get_mpz_t());
        mpz_addmul(off, n[1].get_mpz_t(), A[1].get_mpz_t());
        mpz_addmul(off, n[2].get_mpz_t(), A[2].get_mpz_t());
        for (std::size_t i = 0; i < 3; ++i)
            mpz_mul_2exp(pl.n[i].get_mpz_t(), n[i].get_mpz_t(), mp_bitcnt_t(std::max(-low, 0)));
        mpz_mul_2exp(off, off, mp_bitcnt_t(std::max(low, 0)));
        pl.has_exact = true;
    }

    /// (P[1] - P[0]) x (P[2] - P[0]) into n, with u and v as scratch.
    void normal_into(int_vector& n, int_vector& u, int_vector& v) const {
        for (std::size_t k = 0; k < 3; ++k) {
            mpz_sub(u[k].get_mpz_t(), P[1][k].get_mpz_t(), P[0][k].get_mpz_t());
            mpz_sub(v[k].get_mpz_t(), P[2][k].get_mpz_t(), P[0][k].get_mpz_t());
        }
        cross_into(n, u, v);
    }
};

/// Per-thread scratch for building planes: each triangle's and face's plane then
/// allocates only its own integers.
struct plane_scratch {
    scaled_points s;
    int_vector u, v, n, m;
    static plane_scratch& local() {
        thread_local plane_scratch scratch;
        return scratch;
    }
};

/// Oriented like orient3d(a, b, c, x): positive where that is positive.
inline void make_exact(exact_plane& pl) {
    if (pl.has_exact) return;
    plane_scratch& w = plane_scratch::local();
    w.s.assign(pl.p);
    w.s.normal_into(w.n, w.u, w.v);
    w.s.set_plane(pl, w.n, w.s.P[0]);
}

/// The value of plane pl at x as N / D, D > 0: a positive multiple of n . x - off.
inline void plane_value(const exact_plane& pl, const rational_point& x, mpz_class& N,
                        mpz_class& D) {
    const mpz_class &qx = x.x.get_den(), &qy = x.y.get_den(), &qz = x.z.get_den();
    const mpz_class qyz = qy * qz;
    D = qx * qyz;
    N = pl.n[0] * x.x.get_num() * qyz;
    N += pl.n[1] * x.y.get_num() * (qx * qz);
    N += pl.n[2] * x.z.get_num() * (qx * qy);
    N -= pl.off * D;
}

/// The double point p exactly: X = p 2^s, W = 2^s with the least s >= 0 that makes X
/// integer.
inline homogeneous_point to_homogeneous(const vec3& p) {
    homogeneous_point h;
    int low = 0; // the lowest bit of any coordinate, as an exponent (capped at 2^0)
    for (int k = 0; k < 3; ++k)
        if (p[k] != 0) low = std::min(low, lowest_bit(p[k]));
    for (int k = 0; k < 3; ++k) set_scaled(h.X[std::size_t(k)], p[k], low);
    h.W = 1;
    mpz_mul_2exp(h.W.get_mpz_t(), h.W.get_mpz_t(), mp_bitcnt_t(-low));
    return h;
}

/// Reduced to a canonical rational point (a gcd per coordinate).
inline rational_point canonical(const homogeneous_point& h) {
    rational_point q;
    for (int k = 0; k < 3; ++k) {
        mpz_set(q[k].get_num_mpz_t(), h.X[std::size_t(k)].get_mpz_t());
        mpz_set(q[k].get_den_mpz_t(), h.W.get_mpz_t());
        q[k].canonicalize(); // also makes the denominator positive
    }
    return q;
}

/// Nearest doubles, coordinate by coordinate.
inline vec3 to_vec3(const homogeneous_point& h) {
    return {to_double(h.X[0], h.W), to_double(h.X[1], h.W), to_double(h.X[2], h.W)};
}

/// X_k / W == x, exactly (x finite).
inline bool equals_double(const mpz_class& X, const mpz_class& W, double x) {
    if (x == 0) return sgn(X) == 0;
    thread_local mpz_class lhs, rhs;
    const int low = std::min(lowest_bit(x), 0); // x = rhs 2^low: X == rhs W 2^low
    set_scaled(rhs, x, low);
    mpz_mul(rhs.get_mpz_t(), rhs.get_mpz_t(), W.get_mpz_t());
    mpz_mul_2exp(lhs.get_mpz_t(), X.get_mpz_t(), mp_bitcnt_t(-low));
    return mpz_cmp(lhs.get_mpz_t(), rhs.get_mpz_t()) == 0;
}

/// Sign of a_k - b_k, coordinate k of points a and b (X_a,k / W_a - X_b,k / W_b).
inline int compare_coordinate(const homogeneous_point& a, const homogeneous_point& b, int k) {
    thread_local mpz_class t;
    mpz_mul(t.get_mpz_t(), a.X[std::size_t(k)].get_mpz_t(), b.W.get_mpz_t());
    mpz_submul(t.get_mpz_t(), b.X[std::size_t(k)].get_mpz_t(), a.W.get_mpz_t());
    return sgn(t) * sgn(a.W) * sgn(b.W);
}

inline bool same_point(const homogeneous_point& a, const homogeneous_point& b) {
    for (int k = 0; k < 3; ++k)
        if (compare_coordinate(a, b, k) != 0) return false;
    return true;
}

/// Same position as the canonical rational point q.
inline bool same_point(const homogeneous_point& a, const rational_point& q) {
    thread_local mpz_class l, r;
    for (std::size_t k = 0; k < 3; ++k) {
        mpz_mul(l.get_mpz_t(), a.X[k].get_mpz_t(), q[int(k)].get_den_mpz_t());
        mpz_mul(r.get_mpz_t(), q[int(k)].get_num_mpz_t(), a.W.get_mpz_t());
        if (mpz_cmp(l.get_mpz_t(), r.get_mpz_t()) != 0) return false;
    }
    return true;
}

/// An integer row that is a positive multiple of b - a: X_b W_a - X_a W_b, times the
/// sign of W_a W_b.
inline void difference_row(const homogeneous_point& b, const homogeneous_point& a,
                           int_vector& row) {
    const bool flip = sgn(a.W) * sgn(b.W) < 0;
    for (std::size_t k = 0; k < 3; ++k) {
        mpz_mul(row[k].get_mpz_t(), b.X[k].get_mpz_t(), a.W.get_mpz_t());
        mpz_submul(row[k].get_mpz_t(), a.X[k].get_mpz_t(), b.W.get_mpz_t());
        if (flip) mpz_neg(row[k].get_mpz_t(), row[k].get_mpz_t());
    }
}

/// N = n . X - off W: the plane's value at x times W.
inline void plane_numerator(const exact_plane& pl, const homogeneous_point& x, mpz_class& N) {
    mpz_ptr v = N.get_mpz_t();
    mpz_mul(v, pl.n[0].get_mpz_t(), x.X[0].get_mpz_t());
    mpz_addmul(v, pl.n[1].get_mpz_t(), x.X[1].get_mpz_t());
    mpz_addmul(v, pl.n[2].get_mpz_t(), x.X[2].get_mpz_t());
    mpz_submul(v, pl.off.get_mpz_t(), x.W.get_mpz_t());
}

/// Sign of plane pl at x (scratch: an integer that keeps its storage).
inline int plane_sign(const exact_plane& pl, const homogeneous_point& x, mpz_class& scratch) {
    plane_numerator(pl, x, scratch);
    return sgn(scratch) * sgn(x.W);
}

/// orient3d of four exact points (rows of positive multiples of b - a, c - a, d - a).
inline int orient_exact(const homogeneous_point& a, const homogeneous_point& b,
                        const homogeneous_point& c, const homogeneous_point& d) {
    thread_local std::array<int_vector, 3> rows;
    thread_local int_vector vw;
    thread_local mpz_class det;
    difference_row(b, a, rows[0]), difference_row(c, a, rows[1]), difference_row(d, a, rows[2]);
    cross_into(vw, rows[1], rows[2]);
    mpz_mul(det.get_mpz_t(), rows[0][0].get_mpz_t(), vw[0].get_mpz_t());
    mpz_addmul(det.get_mpz_t(), rows[0][1].get_mpz_t(), vw[1].get_mpz_t());
    mpz_addmul(det.get_mpz_t(), rows[0][2].get_mpz_t(), vw[2].get_mpz_t());
    return sgn(det);
}

/// sum_i w_i p_i / sum_i w_i, over the common denominator of the points.
inline homogeneous_point average(std::initializer_list<const homogeneous_point*> ps,
                                 std::initializer_list<int> weights) {
    homogeneous_point r;
    r.W = 1;
    int total = 0;
    for (int w : weights) total += w;
    auto wi = weights.begin();
    for (const homogeneous_point* p : ps) {
        // r / W_r + w p: r X times W_p, plus w X_p times W_r, over W_r W_p.
        for (std::size_t k = 0; k < 3; ++k) {
            r.X[k] *= p->W;
            r.X[k] += *wi * p->X[k] * r.W;
        }
        r.W *= p->W;
        ++wi;
    }
    r.W *= total;
    return r;
}

constexpr double unit_roundoff = 0x1p-53;

inline double max_abs(const vec3& v) {
    return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
}
inline double sum_abs(const vec3& v) {
    return std::abs(v.x) + std::abs(v.y) + std::abs(v.z);
}

/// A bound on each component's error of cross(u, v) computed in doubles, where u is within
/// u_error and v within v_error (per component, absolute) of exact vectors, and u and v
/// are at most u_max and v_max in each component. The last term covers gradual
/// underflow, which errs by at most 2^-1075 per operation.
inline double cross_error(double u_max, double u_error, double v_max, double v_error) {
    const double e = 2 * (u_max * v_error + v_max * u_error + u_error * v_error) +
                     4 * unit_roundoff * u_max * v_max;
    return 1.01 * e + 1e-300;
}

/// A bound on |value - exact value| for a plane's filter: value = normal . d with
/// d = x - anchor computed in doubles from a point x that is within x_error (per
/// component) of the exact point. Twice the bound, for the rounding of the bound itself,
/// plus a term for gradual underflow.
inline double filter_bound(const vec3& normal, double normal_error, const vec3& d, double x_error) {
    const double en = normal_error, n1 = sum_abs(normal), dmax = max_abs(d);
    // (normal - exact) . d, exact . (d - exact d), and the dot product's own rounding.
    const double b = en * sum_abs(d) +
                     (n1 + 3 * en) * (1.01 * unit_roundoff * dmax + 1.01 * x_error) +
                     3.01 * unit_roundoff * n1 * dmax;
    return 2 * b + 1e-300;
}
inline double filter_bound(const exact_plane& pl, const vec3& d, double x_error) {
    return filter_bound(pl.normal, pl.normal_error, d, x_error);
}

/// The normal of triangle (a, b, c) in doubles, and its error bound per component.
inline std::pair<vec3, double> approximate_normal(const vec3& a, const vec3& b, const vec3& c) {
    const vec3 u = b - a, v = c - a; // each within one rounding of the exact difference
    return {cross(u, v), cross_error(max_abs(u), unit_roundoff * max_abs(u), max_abs(v),
                                     unit_roundoff * max_abs(v))};
}

inline exact_plane plane_through(const vec3& a, const vec3& b, const vec3& c) {
    exact_plane pl;
    pl.by_points = true;
    pl.p = {a, b, c};
    std::tie(pl.normal, pl.normal_error) = approximate_normal(a, b, c);
    pl.anchor = a;
    return pl;
}

/// The planes through the edges of triangle tri (edge e from corner e to corner e + 1),
/// each with the triangle's third corner on its negative side. Each holds its edge and
/// the coordinate axis u along which the triangle's normal n is largest (signed so that
/// n . u > 0): its normal (e1 - e0) x u is two of the edge's own differences, so the
/// plane's integers are as short as the corners' and the points cut with it stay short
/// too. Edge planes only ever separate points of the triangle's plane, where any plane
/// through the edge but not along the triangle draws the same line. With `plane` (the
/// triangle's, from plane_through()), its exact form too, from the same integers.
inline std::array<exact_plane, 3> edge_planes(const std::array<vec3, 3>& tri,
                                              exact_plane* plane = nullptr) {
    plane_scratch& w = plane_scratch::local();
    const scaled_points& s = w.s;
    const int_vector& n = w.n;
    w.s.assign(tri);
    w.s.normal_into(w.n, w.u, w.v);
    if (plane != nullptr && !plane->has_exact) s.set_plane(*plane, n, s.P[0]);
    std::size_t axis = 0;
    for (std::size_t k = 1; k < 3; ++k)
        if (mpz_cmpabs(n[k].get_mpz_t(), n[axis].get_mpz_t()) > 0) axis = k;
    // Third corner c: ((e1 - e0) x u) . (c - e0) = -(n . u), negative for n[axis] u > 0.
    // (Input triangles are not flat: n != 0.)
    const int up = sgn(n[axis]) < 0 ? -1 : 1;
    const std::size_t j = (axis + 1) % 3, k = (axis + 2) % 3;
    std::array<exact_plane, 3> out;
    for (std::size_t e = 0; e < 3; ++e) {
        const std::size_t f = (e + 1) % 3;
        exact_plane& pl = out[e];
        // d x u for u = up * axis: component j is up * d_k, component k is -up * d_j.
        int_vector& m = w.m;
        mpz_set_ui(m[axis].get_mpz_t(), 0);
        mpz_sub(m[j].get_mpz_t(), s.P[f][k].get_mpz_t(), s.P[e][k].get_mpz_t());
        mpz_sub(m[k].get_mpz_t(), s.P[e][j].get_mpz_t(), s.P[f][j].get_mpz_t());
        if (up < 0)
            mpz_neg(m[j].get_mpz_t(), m[j].get_mpz_t()),
                mpz_neg(m[k].get_mpz_t(), m[k].get_mpz_t());
        s.set_plane(pl, m, s.P[e]);
        const vec3 d = tri[f] - tri[e]; // within one rounding of the exact difference
        pl.normal = vec3{};
        pl.normal[int(j)] = up * d[int(k)];
        pl.normal[int(k)] = -up * d[int(j)];
        pl.normal_error = 1.01 * unit_roundoff * max_abs(d) + 1e-300;
        pl.anchor = tri[e];
        pl.p = {tri[e], tri[f], tri[f]};
        pl.points_on = 2;
    }
    return out;
}

// ---- candidate pairs (triangle, tet) --------------------------------------------------------

/// False only if the boxes of triangle (a, b, c) and tet (p0..p3) are disjoint.
inline bool boxes_overlap(const vec3& a, const vec3& b, const vec3& c,
                          const std::array<vec3, 4>& p) {
    for (int k = 0; k < 3; ++k) {
        const double tlo = std::min({a[k], b[k], c[k]}), thi = std::max({a[k], b[k], c[k]});
        const double plo = std::min({p[0][k], p[1][k], p[2][k], p[3][k]});
        const double phi = std::max({p[0][k], p[1][k], p[2][k], p[3][k]});
        if (thi < plo || tlo > phi) return false;
    }
    return true;
}

/// How triangle (a, b, c) meets a positively oriented tet (p0..p3), given `s`, the sides of
/// the tet's corners of the triangle's plane (orient3d(a, b, c, p_i)):
/// - `misses`: certainly not (a conservative test, since cutting by an extra plane costs
///   tets, not correctness);
/// - `touches`: perhaps, but not in a piece of positive area (the walk goes on through it);
/// - `with_area`: the triangle's interior meets the tet's interior, or it overlaps one of
///   the tet's faces. Only such tets need its plane; a triangle that touches a tet at a
///   corner or along an edge is covered by other tets. Exact: a separating-line test in
///   the triangle's plane (the tet's section by that plane against the triangle), with
///   the edge lines of the triangle evaluated in floating point first and exactly (GMP)
///   only when that is not conclusive.
enum class meeting : std::uint8_t { misses, touches, with_area };

/// An input triangle's plane and the planes through its edges (edge_planes()), exact and
/// in doubles, built once per triangle for the walk and for every tet the triangle cuts.
struct triangle_planes {
    exact_plane plane;
    std::array<exact_plane, 3> edges;
};

/// The value of plane pl at x as N / D, D > 0: a positive multiple of n . x - off.
inline void plane_value(const exact_plane& pl, const homogeneous_point& x, mpz_class& N,
                        mpz_class& D) {
    plane_numerator(pl, x, N);
    D = x.W;
    if (sgn(D) < 0) N = -N, D = -D;
}

/// `shares_corner`: a corner of the triangle is a corner of the tet, so they meet.
/// `exact`: the triangle's exact planes, for the cases the filters cannot decide.
inline meeting how_triangle_meets(const vec3& a, const vec3& b, const vec3& c,
                                  const triangle_planes& exact, const std::array<vec3, 4>& p,
                                  const std::array<int, 4>& s, bool shares_corner) {
    int pos = 0, neg = 0, zero = 0;
    for (int i = 0; i < 4; ++i) pos += s[i] > 0, neg += s[i] < 0, zero += s[i] == 0;
    if (pos == 4 || neg == 4) return meeting::misses;
    // Most tets of a walk are around the triangle's corners. One that the triangle's plane
    // meets only in a corner or an edge touches it: the tests below would say so too.
    if (shares_corner && (pos == 0 || neg == 0) && zero != 3) return meeting::touches;
    // Each face's plane against the triangle's corners. Every face of a positively oriented
    // tet, as face_vertices lists it, has the opposite corner on its negative side (the
    // four permutations (face, opposite corner) are odd).
    constexpr int inside = -1;
    std::array<std::array<int, 3>, 4> face_side{};
    for (std::uint8_t f = 0; f < 4; ++f) {
        const auto& fv = tet_local::face_vertices[f];
        const vec3 &x = p[fv[0]], &y = p[fv[1]], &z = p[fv[2]];
        assert(o3d(x, y, z, p[f]) == inside);
        face_side[f] = {o3d(x, y, z, a), o3d(x, y, z, b), o3d(x, y, z, c)};
        if (face_side[f][0] == -inside && face_side[f][1] == -inside && face_side[f][2] == -inside)
            return meeting::misses;
    }
    // Separation by the plane through an edge: floating point beyond its proven error
    // bound, so it only ever drops tets that are outside.
    const vec3& n = exact.plane.normal;
    const double n_error = exact.plane.normal_error;
    const std::array<vec3, 3> tri{a, b, c};
    for (std::size_t e = 0; e < 3; ++e) {
        const vec3& e0 = tri[e];
        const vec3& m = exact.edges[e].normal;
        const double m_error = exact.edges[e].normal_error;
        bool outside = true;
        for (const vec3& q : p) {
            const vec3 d = q - e0;
            if (!(dot(m, d) > filter_bound(m, m_error, d, 0))) {
                outside = false;
                break;
            }
        }
        if (outside) return meeting::misses;
    }

    if ((pos == 0 || neg == 0) && zero != 3) return meeting::touches;
    // The lines of the section's sides are the tet's face planes.
    for (std::uint8_t f = 0; f < 4; ++f) {
        const auto [sa, sb, sc] = face_side[f];
        const bool on_face = sa == 0 && sb == 0 && sc == 0; // overlaps it, or not at all
        if (!on_face && sa != inside && sb != inside && sc != inside) return meeting::touches;
    }
    // The section's corners: tet corners on the plane and crossings of its edges.
    struct corner {
        int u, v; // u == v: tet corner u
    };
    std::array<corner, 6> sec{};
    int ns = 0;
    for (int i = 0; i < 4; ++i)
        if (s[i] == 0) sec[ns++] = {i, i};
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j)
            if (s[i] * s[j] < 0) sec[ns++] = {i, j};
    mpz_class Nfu, Dfu, Nfv, Dfv, Ngu, Dgu, Ngv, Dgv;
    for (std::size_t e = 0; e < 3; ++e) {
        const vec3 &e0 = tri[e], &e1 = tri[(e + 1) % 3];
        const vec3& m = exact.edges[e].normal;
        const double m_error = exact.edges[e].normal_error;
        auto edge_value = [&](const homogeneous_point& x, mpz_class& N, mpz_class& D) {
            plane_value(exact.edges[e], x, N, D);
        };
        // Sign of the edge plane at section corner k.
        auto side = [&](const corner& k) {
            if (k.u == k.v) {
                const vec3& x = p[k.u];
                if (x == e0 || x == e1) return 0;
                const vec3 d = x - e0;
                const double val = dot(m, d), tol = filter_bound(m, m_error, d, 0);
                if (val > tol) return 1;
                if (val < -tol) return -1;
                edge_value(to_homogeneous(x), Ngu, Dgu);
                return sgn(Ngu);
            }
            // The crossing x = u + t (v - u), t = fu / (fu - fv), of the triangle's plane
            // (values fu, fv, of opposite signs) with tet edge (u, v), in doubles first:
            // t is within dt of the exact one when fu and fv are within their bounds.
            const vec3 &u = p[k.u], &v = p[k.v];
            const vec3 du = u - a, dv = v - a;
            const double fu = dot(n, du), fv = dot(n, dv);
            const double efu = filter_bound(n, n_error, du, 0),
                         efv = filter_bound(n, n_error, dv, 0);
            const double sure = std::abs(fu) + std::abs(fv) - efu - efv;
            if (std::abs(fu) > efu && std::abs(fv) > efv && sure > 0) {
                const double t = fu / (fu - fv);
                const double dt = (efu + efv) / sure + 2.01 * unit_roundoff;
                const vec3 uv = v - u;
                const vec3 x = u + uv * t, d = x - e0;
                const double x_error =
                    1.01 * (max_abs(uv) * (dt + 3 * unit_roundoff) + unit_roundoff * max_abs(x));
                const double val = dot(m, d), tol = filter_bound(m, m_error, d, x_error);
                if (std::isfinite(val) && val > tol) return 1;
                if (std::isfinite(val) && val < -tol) return -1;
            }
            // Exactly: the edge plane's value at x has the sign of
            // (fu gv - fv gu) / (fu - fv), with g the edge plane's values at u and v.
            const homogeneous_point U = to_homogeneous(u), V = to_homogeneous(v);
            plane_value(exact.plane, U, Nfu, Dfu);
            plane_value(exact.plane, V, Nfv, Dfv);
            edge_value(U, Ngu, Dgu);
            edge_value(V, Ngv, Dgv);
            const mpz_class lhs = Nfu * Ngv * Dfv * Dgu, rhs = Nfv * Ngu * Dfu * Dgv;
            return sgn(mpz_class(lhs - rhs)) * sgn(mpz_class(Nfu * Dfv - Nfv * Dfu));
        };
        bool separated = true;
        for (int k = 0; k < ns && separated; ++k) separated = side(sec[k]) >= 0;
        if (separated) return meeting::touches;
    }
    return meeting::with_area;
}

/// Face adjacency of a tet list: for (tet t, local face f), the tet across it and its
/// local face, or invalid_index for boundary faces.
struct tet_adjacency {
    std::vector<index_t> across; // 4 per tet: neighbour tet
    std::vector<std::uint8_t> across_face;
    std::vector<index_t> star_first, star; // tets around each vertex (CSR)
};

/// The tets around each vertex, as offsets and a list (CSR): tets of vertex v are
/// star[first[v] .. first[v + 1]).
inline std::pair<std::vector<index_t>, std::vector<index_t>>
vertex_stars(std::size_t n_vertices, const std::vector<tet_indices>& tets) {
    std::vector<index_t> first(n_vertices + 1, 0), star(4 * tets.size());
    for (const auto& t : tets)
        for (index_t v : t) ++first[v + 1];
    for (std::size_t v = 0; v < n_vertices; ++v) first[v + 1] += first[v];
    std::vector<index_t> fill(first.begin(), first.end() - 1);
    for (std::size_t t = 0; t < tets.size(); ++t)
        for (index_t v : tets[t]) star[fill[v]++] = index_t(t);
    return {std::move(first), std::move(star)};
}

inline tet_adjacency build_adjacency(std::size_t n_vertices, const std::vector<tet_indices>& tets) {
    tet_adjacency a;
    const std::size_t m = tets.size();
    a.across.assign(4 * m, invalid_index);
    a.across_face.assign(4 * m, tet_local::none);
    struct key {
        std::array<index_t, 3> v;
        index_t slot;
        bool operator<(const key& o) const { return v < o.v; }
    };
    std::vector<key> keys(4 * m);
    tbb::parallel_for(std::size_t{0}, m, [&](std::size_t t) {
        for (std::uint8_t f = 0; f < 4; ++f) {
            const auto& fv = tet_local::face_vertices[f];
            std::array<index_t, 3> v{tets[t][fv[0]], tets[t][fv[1]], tets[t][fv[2]]};
            std::sort(v.begin(), v.end());
            keys[4 * t + f] = {v, index_t(4 * t + f)};
        }
    });
    std::sort(keys.begin(), keys.end());
    for (std::size_t i = 0; i + 1 < keys.size(); ++i)
        if (keys[i].v == keys[i + 1].v) {
            const index_t x = keys[i].slot, y = keys[i + 1].slot;
            a.across[x] = y / 4, a.across_face[x] = std::uint8_t(y % 4);
            a.across[y] = x / 4, a.across_face[y] = std::uint8_t(x % 4);
            ++i;
        }
    std::tie(a.star_first, a.star) = vertex_stars(n_vertices, tets);
    return a;
}

/// The planes that cut one tet: the input triangles that may meet it, grouped by their
/// (exact) supporting plane. groups of tet t: group_first[t] .. group_first[t + 1];
/// triangles of group g: group_tris[tri_first[g] .. tri_first[g + 1]) (the first one
/// represents the plane).
struct cutting_planes {
    std::vector<index_t> group_first, tri_first, group_tris;
    /// Per input triangle: its plane and the planes through its edges, exact, built once
    /// for every tet that the triangle cuts.
    std::vector<triangle_planes> planes;
};

/// The tet and its local face whose corners are the triangle's, if the triangle is a face
/// of the mesh (a face lies in the star of each of its corners).
inline std::optional<std::pair<index_t, std::uint8_t>>
face_spanned_by(const insertion_input& in, const tet_adjacency& adj, const tri_indices& tri) {
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) return std::nullopt;
    for (index_t s = adj.star_first[tri[0]]; s < adj.star_first[tri[0] + 1]; ++s) {
        const index_t t = adj.star[s];
        const auto& tv = in.tets[t];
        const std::uint8_t i1 = tet_local::index_of(tv, tri[1]),
                           i2 = tet_local::index_of(tv, tri[2]);
        if (i1 == tet_local::none || i2 == tet_local::none) continue;
        // Local indices sum to 6: the face is opposite the fourth corner.
        return std::pair{t, std::uint8_t(6 - tet_local::index_of(tv, tri[0]) - i1 - i2)};
    }
    return std::nullopt;
}

inline cutting_planes find_cutting_planes(const insertion_input& in, const tet_adjacency& adj) {
    const auto& V = in.vertices;
    const std::size_t m = in.tets.size();
    // Exact planes first: the walk needs them where its filters cannot decide.
    std::vector<triangle_planes> planes(in.triangles.size());
    tbb::parallel_for(std::size_t{0}, in.triangles.size(), [&](std::size_t t) {
        const auto& tri = in.triangles[t];
        auto& tp = planes[t];
        tp.plane = plane_through(V[tri[0]], V[tri[1]], V[tri[2]]);
        tp.edges = edge_planes({V[tri[0]], V[tri[1]], V[tri[2]]}, &tp.plane);
    });
    struct local {
        std::vector<std::uint32_t> stamp;
        // A vertex's side of the current triangle's plane, valid where side_stamp is the
        // triangle's mark: the tets of a walk share their corners about five times over.
        std::vector<std::uint32_t> side_stamp;
        std::vector<std::int8_t> side;
        std::vector<std::pair<index_t, index_t>> pairs; // (tet, triangle)
        std::vector<index_t> queue;
    };
    tbb::enumerable_thread_specific<local> scratch;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, in.triangles.size(), 64),
        [&](const tbb::blocked_range<std::size_t>& r) {
            local& L = scratch.local();
            if (L.stamp.size() != m) L.stamp.assign(m, 0);
            if (L.side_stamp.size() != V.size()) {
                L.side_stamp.assign(V.size(), 0);
                L.side.assign(V.size(), 0);
            }
            for (std::size_t ti = r.begin(); ti != r.end(); ++ti) {
                const auto& tri = in.triangles[ti];
                const vec3 &a = V[tri[0]], &b = V[tri[1]], &c = V[tri[2]];
                const std::uint32_t mark = std::uint32_t(ti + 1);
                L.queue.clear();
                auto visit = [&](index_t t) {
                    if (L.stamp[t] == mark) return;
                    L.stamp[t] = mark;
                    const auto& tv = in.tets[t];
                    const std::array<vec3, 4> p{V[tv[0]], V[tv[1]], V[tv[2]], V[tv[3]]};
                    // Walk the tets that meet the closed triangle (they are connected
                    // through faces); keep those that share an area with it.
                    if (!boxes_overlap(a, b, c, p)) return;
                    std::array<int, 4> s{};
                    for (int i = 0; i < 4; ++i) {
                        const index_t v = tv[std::size_t(i)];
                        if (L.side_stamp[v] != mark) {
                            L.side_stamp[v] = mark;
                            L.side[v] = std::int8_t(o3d(a, b, c, V[v]));
                        }
                        s[std::size_t(i)] = L.side[v];
                    }
                    const bool shares_corner = tet_local::contains(tv, tri[0]) ||
                                               tet_local::contains(tv, tri[1]) ||
                                               tet_local::contains(tv, tri[2]);
                    const meeting how =
                        how_triangle_meets(a, b, c, planes[ti], p, s, shares_corner);
                    if (how == meeting::misses) return;
                    L.queue.push_back(t);
                    if (how == meeting::with_area) L.pairs.emplace_back(t, index_t(ti));
                };
                // A triangle that is a face of the background (most of a dense input's are
                // faces of its Delaunay tetrahedralization) meets the one or two tets on
                // that face in area, and every other tet in an edge or a corner at most.
                if (const auto face = face_spanned_by(in, adj, tri)) {
                    const auto [t, f] = *face;
                    L.pairs.emplace_back(t, index_t(ti));
                    if (const index_t nb = adj.across[4 * t + f]; nb != invalid_index)
                        L.pairs.emplace_back(nb, index_t(ti));
                    continue;
                }
                for (index_t s = adj.star_first[tri[0]]; s < adj.star_first[tri[0] + 1]; ++s)
                    visit(adj.star[s]);
                for (std::size_t q = 0; q < L.queue.size(); ++q)
                    for (std::uint8_t f = 0; f < 4; ++f) {
                        const index_t nb = adj.across[4 * L.queue[q] + f];
                        if (nb != invalid_index) visit(nb);
                    }
            }
        });
    std::vector<std::pair<index_t, index_t>> pairs;
    for (auto& L : scratch) pairs.insert(pairs.end(), L.pairs.begin(), L.pairs.end());
    std::sort(pairs.begin(), pairs.end());

    cutting_planes cp;
    cp.group_first.assign(m + 1, 0);
    cp.tri_first.push_back(0);
    std::size_t i = 0;
    std::vector<std::vector<index_t>> groups;
    for (std::size_t t = 0; t < m; ++t) {
        groups.clear();
        for (; i < pairs.size() && pairs[i].first == t; ++i) {
            const auto& tri = in.triangles[pairs[i].second];
            bool placed = false;
            for (auto& g : groups) {
                const auto& rep = in.triangles[g.front()];
                const vec3 &a = V[rep[0]], &b = V[rep[1]], &c = V[rep[2]];
                if (o3d(a, b, c, V[tri[0]]) == 0 && o3d(a, b, c, V[tri[1]]) == 0 &&
                    o3d(a, b, c, V[tri[2]]) == 0) {
                    g.push_back(pairs[i].second);
                    placed = true;
                    break;
                }
            }
            if (!placed) groups.push_back({pairs[i].second});
        }
        for (auto& g : groups) {
            cp.group_tris.insert(cp.group_tris.end(), g.begin(), g.end());
            cp.tri_first.push_back(index_t(cp.group_tris.size()));
        }
        cp.group_first[t + 1] = cp.group_first[t] + index_t(groups.size());
    }
    cp.planes = std::move(planes);
    return cp;
}

/// orient3d's sign on the exact positions when the vertices' doubles decide it, 0 when they
/// do not. A rational vertex lies within one ulp of its doubles in each coordinate, so the
/// determinant of the doubles' differences u, v, w (each coordinate at most M in size and
/// off by at most E, the two vertices' ulps) is within 6 E (3 M^2 + 3 M E + E^2) of the
/// exact one; orient3d's filter bounds its own rounding. Most tets with rational corners
/// are decided here, without GMP.
inline int orientation_from_doubles(const std::array<vec3, 4>& p,
                                    const std::array<bool, 4>& exact) {
    std::array<double, 4> slack{};
    for (std::size_t i = 0; i < 4; ++i) {
        if (exact[i]) continue;
        for (int k = 0; k < 3; ++k) {
            const double a = std::abs(p[i][k]);
            slack[i] = std::max(slack[i], std::nextafter(a, INFINITY) - a);
        }
    }
    double m = 0, e = 0;
    for (std::size_t i = 1; i < 4; ++i)
        for (int k = 0; k < 3; ++k) m = std::max(m, std::abs(p[i][k] - p[0][k]));
    m *= 1 + 0x1p-52; // the exact differences, not their rounding
    for (std::size_t i = 1; i < 4; ++i) e = std::max(e, slack[0] + slack[i]);
    // Far from underflow and overflow, where the bound below is itself accurate.
    if (!(m > 1e-80 && m < 1e80) || !(e < m)) return 0;
    const auto [det, rounding] = orient3d_with_bound(p[0], p[1], p[2], p[3]);
    // 1% more covers the rounding of this sum.
    const double bound = 1.01 * (rounding + 6 * e * (3 * m * m + 3 * m * e + e * e));
    return det > bound ? 1 : -det > bound ? -1 : 0;
}

// ---- cutting one tet -----------------------------------------------------------------------

struct point {
    vec3 approx;            ///< nearest doubles
    bool is_double = true;  ///< approx is the point exactly
    std::uint8_t faces = 0; ///< bit f: lies on the tet's face f (opposite local vertex f)

    /// The exact position. A point on doubles builds it on first use only: most never
    /// need it. Not thread-safe on a double point: each cutter reads only its own
    /// points' positions.
    const homogeneous_point& h() const {
        if (!exact) exact = std::make_shared<const homogeneous_point>(to_homogeneous(approx));
        return *exact;
    }
    /// A copy for another cutter: a double point's position is left to be built there;
    /// an exact one is shared, not copied (a cutter's points on its faces and edges are
    /// handed to every neighbour there, and the first phase holds all of them at once).
    point handed_on(std::uint8_t on_faces) const {
        point r{approx, is_double, on_faces, {}};
        if (!is_double) r.exact = exact;
        return r;
    }
    /// Same position, comparing exact positions only where the doubles are equal.
    bool same_position(const point& o) const {
        return approx == o.approx && is_double == o.is_double &&
               (is_double || same_point(*exact, *o.exact));
    }

    /// Always set when !is_double; never changed once set (cutters share it).
    mutable std::shared_ptr<const homogeneous_point> exact;
};

/// A convex polygon: corners in cyclic order; support >= 0 is a plane of the tet's
/// table, support < 0 is the tet's face -1 - support.
struct polygon {
    boost::container::small_vector<std::uint32_t, 6> v; // most have 3 to 6 corners
    std::int32_t support = 0;
};

/// Input triangles (most facets lie in the plane of none or one).
using triangle_list = boost::container::small_vector<index_t, 4>;
/// A facet split along lines (most are not split: one part inline).
using facet_parts = boost::container::small_vector<polygon, 1>;

/// A convex cell while the tet is cut: its facets, kept inside it where they fit.
struct cell {
    boost::container::small_vector<polygon, 6> facets;
};

/// Points a tet hands to its neighbours: on its face f (face >= 0) or on its local edge
/// (face < 0: edge -1 - face).
struct exported_point {
    std::int8_t where;
    point p; ///< its `faces` are the exporting tet's
};

/// What a tet becomes: tets and tracked faces over its local points.
struct tet_output {
    std::vector<point> points; // the first four are the tet's corners
    std::vector<std::array<std::uint32_t, 4>> tets;
    std::vector<std::array<std::uint32_t, 3>> tracked;
    std::vector<triangle_list> tracked_by;
};

inline point make_point(const vec3& p, std::uint8_t faces) {
    return {p, true, faces, {}};
}
inline point make_point(homogeneous_point q, std::uint8_t faces) {
    point r;
    r.approx = to_vec3(q);
    r.is_double = true;
    for (std::size_t k = 0; k < 3 && r.is_double; ++k)
        r.is_double = equals_double(q.X[k], q.W, r.approx[int(k)]);
    r.exact = std::make_shared<const homogeneous_point>(std::move(q));
    r.faces = faces;
    return r;
}

class tet_cutter {
public:
    tet_cutter(const insertion_input& in, const cutting_planes& cp, const tet_adjacency& adj,
               index_t tet)
        : in_(in)
        , cp_(cp)
        , adj_(adj)
        , tet_(tet) {
        const auto& tv = in.tets[tet];
        pts_.reserve(8);
        for (std::uint8_t i = 0; i < 4; ++i)
            pts_.push_back(make_point(in.vertices[tv[i]], std::uint8_t(0xF & ~(1u << i))));
        cell c;
        for (std::int32_t f = 0; f < 4; ++f) {
            const auto& fv = tet_local::face_vertices[std::size_t(f)];
            c.facets.push_back({{fv[0], fv[1], fv[2]}, -1 - f});
        }
        cells_.push_back(std::move(c));
    }

    /// Phase 1: cut by the tet's planes, split the facets along lines.
    void cut() {
        for (index_t g = cp_.group_first[tet_]; g < cp_.group_first[tet_ + 1]; ++g) {
            const std::uint32_t k = triangle_plane(cp_.group_tris[cp_.tri_first[g]]);
            group_plane_.emplace_back(g, k);
            cut_cells(k);
        }
        triangle_list on_plane;
        facet_parts parts;
        for (const cell& c : cells_) {
            packed_.push_back(std::uint32_t(c.facets.size()));
            for (const polygon& f : c.facets) {
                split_facet(f, on_plane, parts);
                pack_facet(f, on_plane, parts);
                on_plane.clear();
            }
        }
        // The cutters of the first phase live on into the second: their cells, packed
        // now, and their scratch go back to the heap, for the next cutters to take.
        std::vector<cell>().swap(cells_);
        std::vector<polygon>().swap(next_parts_);
        std::vector<std::uint32_t>().swap(lines_);
    }

    /// Points on the tet's faces and edges, for the neighbours.
    std::vector<exported_point> exports() const {
        std::vector<exported_point> out;
        for (std::size_t i = 4; i < pts_.size(); ++i) {
            const int bits = std::popcount(unsigned(pts_[i].faces));
            if (bits == 1)
                out.push_back({std::int8_t(std::countr_zero(unsigned(pts_[i].faces))),
                               pts_[i].handed_on(pts_[i].faces)});
            if (bits == 2) {
                // On the edge shared by the two faces: the corners not opposite them.
                std::array<std::uint8_t, 2> e{};
                int k = 0;
                for (std::uint8_t v = 0; v < 4; ++v)
                    if (pts_[i].faces & (1u << v)) e[k++] = v;
                const auto ends = tet_local::edge_complement(tet_local::edge_of[e[0]][e[1]]);
                out.push_back({std::int8_t(-1 - tet_local::edge_of[ends[0]][ends[1]]),
                               pts_[i].handed_on(pts_[i].faces)});
            }
        }
        return out;
    }

    /// Adds a point of a neighbour on the tet's face or edge, unless it is known.
    void import(const point& x, std::uint8_t faces) {
        // Equal points have equal nearest doubles: GMP only compares those.
        for (const point& p : pts_)
            if (p.faces == faces && p.same_position(x)) return;
        pts_.push_back(x.handed_on(faces));
    }
    static std::uint8_t edge_faces(std::uint8_t local_edge) {
        const auto& e = tet_local::edge_vertices[local_edge];
        return std::uint8_t(0xF & ~(1u << e[0]) & ~(1u << e[1]));
    }

    /// Phase 2: triangulate the polygons with every point on their sides, cone the cells.
    tet_output finish() {
        tet_output out;
        for (std::size_t at = 0; at < packed_.size();) at = cone(at, out);
        for (auto& [key, entry] : triangulations_)
            if (!entry.tracked_by.empty())
                for (const auto& t : entry.triangles) {
                    out.tracked.push_back(t);
                    out.tracked_by.push_back(entry.tracked_by);
                }
        out.points = std::move(pts_);
        return out;
    }

private:
    const insertion_input& in_;
    const cutting_planes& cp_;
    const tet_adjacency& adj_;
    index_t tet_;
    std::vector<point> pts_;
    std::vector<cell> cells_; // while cutting
    // The cells once cut, in one list: per cell its number of facets, per facet its
    // corners (count, then each), its input triangles (count, then each) and its parts
    // along lines (count, then per part its support and corners): tens of numbers a
    // cell, where its lists inline took a kilobyte (why size matters: below).
    std::vector<std::uint32_t> packed_;
    // Per plane: itself (every one exact), its key (4 * triangle + (0 | edge + 1), or a
    // face's), its sign at each point (2: not known yet). A cut tet has a few dozen at
    // most, so lists searched in order beat maps, and most live inside the cutter.
    // The first phase's cutters all live into the second, so their size is the stage's
    // memory, and first-touch page faults are much of its time: inline lists sized for
    // the common tet (a few planes and points), the face planes made on first use.
    boost::container::small_vector<const exact_plane*, 8> planes_;
    boost::container::small_vector<std::uint64_t, 8> plane_keys_;
    boost::container::small_vector<boost::container::small_vector<std::int8_t, 16>, 8> signs_;
    std::unique_ptr<std::array<exact_plane, 4>> face_planes_;
    mpz_class num_; // scratch for exact_sign
    // Points made where a plane crosses a segment: key (a, b, plane), point.
    boost::container::small_vector<std::pair<std::uint64_t, std::uint32_t>, 8> edge_points_;
    boost::container::small_vector<std::pair<index_t, std::uint32_t>, 4> group_plane_;
    struct triangulation {
        boost::container::small_vector<std::array<std::uint32_t, 3>, 8> triangles;
        triangle_list tracked_by;
        // A point strictly inside the polygon, from its corners alone: (c0 + c1) / 2 if
        // inner_is_midpoint, else (2 c0 + c1 + c2) / 4. Built exactly only when needed.
        std::array<std::uint32_t, 3> inner_corners{};
        bool inner_is_midpoint = false;
        std::int32_t support = 0;
    };
    using corner_list = boost::container::small_vector<std::uint32_t, 8>;
    std::map<corner_list, triangulation> triangulations_; // by sorted corners
    std::unordered_map<std::uint64_t, corner_list> side_points_;
    std::vector<std::uint32_t> by_x_;  // the points by their x in doubles (side_points)
    std::vector<std::uint32_t> lines_; // scratch of lines_for()
    std::vector<polygon> next_parts_;  // scratch of split_facet()
    boost::container::small_vector<bool, 8> crossed_; // scratch of cut_cells()

    std::optional<std::uint32_t> known_plane(std::uint64_t key) const {
        const auto it = std::find(plane_keys_.begin(), plane_keys_.end(), key);
        if (it == plane_keys_.end()) return std::nullopt;
        return std::uint32_t(it - plane_keys_.begin());
    }
    std::uint32_t add_plane(std::uint64_t key, const exact_plane& pl) {
        if (const auto k = known_plane(key)) return *k;
        planes_.push_back(&pl);
        plane_keys_.push_back(key);
        signs_.emplace_back();
        return std::uint32_t(planes_.size() - 1);
    }
    std::uint32_t triangle_plane(index_t t) { return add_plane(4ull * t, cp_.planes[t].plane); }
    /// The plane of edge e of triangle t.
    std::uint32_t triangle_edge_plane(index_t t, int e) {
        return add_plane(4ull * t + std::uint64_t(e) + 1, cp_.planes[t].edges[std::size_t(e)]);
    }

    /// Sign of plane k at x, exactly.
    int exact_sign(std::uint32_t k, const homogeneous_point& x) {
        return plane_sign(*planes_[k], x, num_);
    }

    int sign(std::uint32_t p, std::uint32_t k) {
        auto& s = signs_[k];
        if (s.size() <= p) s.resize(pts_.size(), 2);
        if (s[p] != 2) return s[p];
        const exact_plane& pl = *planes_[k];
        const point& x = pts_[p];
        int r;
        if (pl.by_points && x.is_double) {
            r = o3d(pl.p[0], pl.p[1], pl.p[2], x.approx);
        } else if (x.is_double && pl.points_on > 0 &&
                   (x.approx == pl.p[0] || x.approx == pl.p[1])) {
            r = 0; // the edge planes' edge ends (a neighbour triangle's corners)
        } else {
            // Floating-point filter, then GMP. x.approx is the nearest double of x.
            const vec3 d = x.approx - pl.anchor;
            const double val = dot(pl.normal, d);
            const double tol = filter_bound(pl, d, unit_roundoff * max_abs(x.approx));
            if (val > tol)
                r = 1;
            else if (val < -tol)
                r = -1;
            else
                r = exact_sign(k, x.h());
        }
        s[p] = std::int8_t(r);
        return r;
    }

    /// The plane of the tet's face f (opposite local corner f), for the lines on it.
    std::uint32_t face_plane(std::uint8_t f) {
        const std::uint64_t key = (std::uint64_t(1) << 63) | f;
        if (const auto k = known_plane(key)) return *k;
        const auto& tv = in_.tets[tet_];
        const auto& fv = tet_local::face_vertices[f];
        const auto& V = in_.vertices;
        if (!face_planes_) face_planes_ = std::make_unique<std::array<exact_plane, 4>>();
        exact_plane& pl = (*face_planes_)[f];
        pl = plane_through(V[tv[fv[0]]], V[tv[fv[1]]], V[tv[fv[2]]]);
        make_exact(pl);
        return add_plane(key, pl);
    }

    /// True when planes i and j are not parallel (so they meet in a line): from their
    /// normals in doubles where the filter can tell, else exactly.
    bool independent(std::uint32_t i, std::uint32_t j) {
        const exact_plane &P = *planes_[i], &Q = *planes_[j];
        const vec3 c = idas::cross(P.normal, Q.normal);
        if (max_abs(c) >
            cross_error(max_abs(P.normal), P.normal_error, max_abs(Q.normal), Q.normal_error))
            return true;
        const int_vector e = cross(P.n, Q.n);
        return sgn(e[0]) != 0 || sgn(e[1]) != 0 || sgn(e[2]) != 0;
    }

    /// Two planes through both a and b that meet in their line, if the tet knows them: the
    /// tet's faces that hold both, and the planes whose sign is known to be 0 at both.
    std::optional<std::array<std::uint32_t, 2>> line_through(std::uint32_t a, std::uint32_t b) {
        std::array<std::uint32_t, 8> found{};
        std::size_t n = 0;
        const unsigned faces = pts_[a].faces & pts_[b].faces;
        for (std::uint8_t f = 0; f < 4 && n < found.size(); ++f)
            if (faces & (1u << f)) found[n++] = face_plane(f);
        for (std::uint32_t k = 0; k < signs_.size() && n < found.size(); ++k) {
            const auto& s = signs_[k];
            if (s.size() > std::max(a, b) && s[a] == 0 && s[b] == 0) found[n++] = k;
        }
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t j = i + 1; j < n; ++j)
                if (independent(found[i], found[j])) return std::array{found[i], found[j]};
        return std::nullopt;
    }

    /// The point where planes p, q and r meet, by Cramer's rule. Its integers are bounded
    /// by the planes' sizes; a point cut from a segment between two cut points has factors
    /// of both in it, over a thousand bits on 100071_sf, that only a long gcd removes.
    homogeneous_point meet(std::uint32_t p, std::uint32_t q, std::uint32_t r) {
        const exact_plane &P = *planes_[p], &Q = *planes_[q], &R = *planes_[r];
        // Scratch integers kept per thread (1-5% faster than fresh ones on bunny and
        // 100071_sf): a cut tet meets planes a few dozen times.
        thread_local std::array<int_vector, 3> c; // Q x R, R x P, P x Q
        cross_into(c[0], Q.n, R.n), cross_into(c[1], R.n, P.n), cross_into(c[2], P.n, Q.n);
        homogeneous_point x;
        mpz_mul(x.W.get_mpz_t(), P.n[0].get_mpz_t(), c[0][0].get_mpz_t());
        mpz_addmul(x.W.get_mpz_t(), P.n[1].get_mpz_t(), c[0][1].get_mpz_t());
        mpz_addmul(x.W.get_mpz_t(), P.n[2].get_mpz_t(), c[0][2].get_mpz_t());
        for (std::size_t i = 0; i < 3; ++i) {
            mpz_ptr num = x.X[i].get_mpz_t();
            mpz_mul(num, P.off.get_mpz_t(), c[0][i].get_mpz_t());
            mpz_addmul(num, Q.off.get_mpz_t(), c[1][i].get_mpz_t());
            mpz_addmul(num, R.off.get_mpz_t(), c[2][i].get_mpz_t());
        }
        return x;
    }

    /// The point where plane k crosses segment (a, b), whose ends are strictly on
    /// opposite sides.
    std::uint32_t crossing(std::uint32_t a, std::uint32_t b, std::uint32_t k) {
        const std::uint64_t key =
            (std::uint64_t(std::min(a, b)) << 42) | (std::uint64_t(std::max(a, b)) << 20) | k;
        for (const auto& [known, id] : edge_points_)
            if (known == key) return id;
        // Between two double points (a tet's edge, mostly) from the ends: integers of
        // the plane's size and twice the points', shorter than a meet of the tet's face
        // planes, which need building too. Between cut points from the planes through
        // the segment's line, if known: the ends' own integers would multiply.
        homogeneous_point x;
        std::optional<std::array<std::uint32_t, 2>> line;
        if (!(pts_[a].is_double && pts_[b].is_double)) line = line_through(a, b);
        if (line) {
            x = meet((*line)[0], (*line)[1], k);
        } else {
            // x = (fa B - fb A) / (fa - fb), where the plane's value at A = X_A / W_A is
            // fa = Na / W_A with Na = n . X_A - off W_A (fb likewise): over W_A W_B,
            // x = (Na X_B - Nb X_A) / (Na W_B - Nb W_A). (Between cut points, not reached
            // on the meshes of data/: every such segment's line was known.)
            const homogeneous_point &A = pts_[a].h(), &B = pts_[b].h();
            const exact_plane& pl = *planes_[k];
            thread_local mpz_class Na, Nb;
            plane_numerator(pl, A, Na), plane_numerator(pl, B, Nb);
            for (std::size_t i = 0; i < 3; ++i) {
                mpz_mul(x.X[i].get_mpz_t(), Na.get_mpz_t(), B.X[i].get_mpz_t());
                mpz_submul(x.X[i].get_mpz_t(), Nb.get_mpz_t(), A.X[i].get_mpz_t());
            }
            mpz_mul(x.W.get_mpz_t(), Na.get_mpz_t(), B.W.get_mpz_t());
            mpz_submul(x.W.get_mpz_t(), Nb.get_mpz_t(), A.W.get_mpz_t());
        }
        point made = make_point(std::move(x), std::uint8_t(pts_[a].faces & pts_[b].faces));
        // One id per position: where another segment on this line was crossed at the same
        // point by another plane (two input triangles sharing an edge whose line meets the
        // tet's edge there), two ids at one position made a facet triangle degenerate, and
        // its cone a flat tet (a seeded soup of open boxes, bench/make_soups.py).
        std::uint32_t id = 0;
        while (id < pts_.size() && !pts_[id].same_position(made)) ++id;
        if (id < pts_.size()) {
            pts_[id].faces |= made.faces;
        } else {
            pts_.push_back(std::move(made));
        }
        // Every plane through a and b holds x.
        for (auto& s : signs_)
            if (s.size() > std::max(a, b) && s[a] == 0 && s[b] == 0) {
                s.resize(pts_.size(), 2);
                s[id] = 0;
            }
        signs_[k].resize(pts_.size(), 2);
        signs_[k][id] = 0;
        edge_points_.emplace_back(key, id);
        return id;
    }

    /// Splits a convex polygon by plane k. Returns false (and leaves pos/neg alone) when
    /// the plane does not separate two of its corners.
    bool split(const polygon& P, std::uint32_t k, polygon& pos, polygon& neg, int& side) {
        bool has_pos = false, has_neg = false;
        for (std::uint32_t v : P.v) {
            const int s = sign(v, k);
            has_pos |= s > 0, has_neg |= s < 0;
        }
        side = has_pos ? 1 : (has_neg ? -1 : 0);
        if (!(has_pos && has_neg)) return false;
        pos.v.clear(), neg.v.clear();
        pos.support = neg.support = P.support;
        const std::size_t n = P.v.size();
        for (std::size_t i = 0; i < n; ++i) {
            const std::uint32_t a = P.v[i], b = P.v[(i + 1) % n];
            const int sa = sign(a, k), sb = sign(b, k);
            if (sa >= 0) pos.v.push_back(a);
            if (sa <= 0) neg.v.push_back(a);
            if (sa * sb < 0) {
                const std::uint32_t x = crossing(a, b, k);
                pos.v.push_back(x), neg.v.push_back(x);
            }
        }
        return true;
    }

    /// Orders points of a convex polygon on plane k (all corners) cyclically.
    template <class Corners>
    void order_on_plane(Corners& v, const int_vector& n) {
        // Drop the axis where the normal is largest: an exact affine bijection onto 2D.
        int drop = 0;
        for (int a = 1; a < 3; ++a)
            if (cmp(abs(n[a]), abs(n[drop])) > 0) drop = a;
        const int u = (drop + 1) % 3, w = (drop + 2) % 3;
        auto first = std::min_element(v.begin(), v.end(), [&](std::uint32_t a, std::uint32_t b) {
            if (int c = compare(pts_[a], pts_[b], u)) return c < 0;
            return compare(pts_[a], pts_[b], w) < 0;
        });
        std::iter_swap(v.begin(), first);
        const point& O = pts_[v[0]];
        std::sort(v.begin() + 1, v.end(), [&](std::uint32_t a, std::uint32_t b) {
            const point &PA = pts_[a], &PB = pts_[b];
            if (const int s = cross_sign(O.approx, PA.approx, PB.approx, u, w)) return s > 0;
            // Rows of positive multiples of A - O and B - O keep the sign.
            thread_local int_vector ra, rb;
            difference_row(PA.h(), O.h(), ra), difference_row(PB.h(), O.h(), rb);
            return sgn(ra[std::size_t(u)] * rb[std::size_t(w)] -
                       ra[std::size_t(w)] * rb[std::size_t(u)]) > 0;
        });
    }

    /// A cell with corners strictly on both sides of plane k.
    bool crossed_by(const cell& c, std::uint32_t k) {
        bool has_pos = false, has_neg = false;
        for (const polygon& f : c.facets)
            for (std::uint32_t v : f.v) {
                const int s = sign(v, k);
                has_pos |= s > 0, has_neg |= s < 0;
            }
        return has_pos && has_neg;
    }

    /// Splits every cell that plane k crosses into its two sides, in place and in order
    /// (the positive side first): the cells it misses are not moved unless a cell before
    /// them was split.
    void cut_cells(std::uint32_t k) {
        crossed_.clear();
        std::size_t splits = 0;
        for (const cell& c : cells_) {
            crossed_.push_back(crossed_by(c, k));
            splits += crossed_.back() ? 1 : 0;
        }
        if (splits == 0) return;
        const std::size_t old_size = cells_.size();
        cells_.resize(old_size + splits);
        std::size_t to = cells_.size();
        for (std::size_t i = old_size; i-- > 0;) {
            if (!crossed_[i]) {
                if (--to != i) cells_[to] = std::move(cells_[i]);
                continue;
            }
            cell P, N;
            polygon pos, neg;
            polygon cap;
            auto& section = cap.v;
            for (const polygon& f : cells_[i].facets) {
                int side = 0;
                if (split(f, k, pos, neg, side)) {
                    P.facets.push_back(pos), N.facets.push_back(neg);
                } else {
                    (side > 0 ? P : N).facets.push_back(f);
                }
            }
            for (const polygon& f : P.facets)
                for (std::uint32_t v : f.v)
                    if (sign(v, k) == 0 &&
                        std::find(section.begin(), section.end(), v) == section.end())
                        section.push_back(v);
            order_on_plane(section, planes_[k]->n);
            cap.support = std::int32_t(k);
            P.facets.push_back(cap), N.facets.push_back(cap);
            cells_[--to] = std::move(N);
            cells_[--to] = std::move(P);
        }
    }

    void pack_facet(const polygon& f, const triangle_list& on_plane, const facet_parts& parts) {
        packed_.push_back(std::uint32_t(f.v.size()));
        packed_.insert(packed_.end(), f.v.begin(), f.v.end());
        packed_.push_back(std::uint32_t(on_plane.size()));
        packed_.insert(packed_.end(), on_plane.begin(), on_plane.end());
        packed_.push_back(std::uint32_t(parts.size()));
        for (const polygon& p : parts) {
            packed_.push_back(std::bit_cast<std::uint32_t>(p.support));
            packed_.push_back(std::uint32_t(p.v.size()));
            packed_.insert(packed_.end(), p.v.begin(), p.v.end());
        }
    }

    /// The lines that split a facet, as planes crossing its plane: edge planes of the
    /// triangles on it; on a face of the tet, also the neighbour's cutting planes.
    const std::vector<std::uint32_t>& lines_for(const polygon& f, triangle_list& on_plane) {
        std::vector<std::uint32_t>& lines = lines_;
        lines.clear();
        auto add_edges = [&](index_t t) {
            on_plane.push_back(t);
            for (int e = 0; e < 3; ++e) lines.push_back(triangle_edge_plane(t, e));
        };
        if (f.support >= 0) {
            for (const auto& [g, k] : group_plane_)
                if (k == std::uint32_t(f.support))
                    for (index_t i = cp_.tri_first[g]; i < cp_.tri_first[g + 1]; ++i)
                        add_edges(cp_.group_tris[i]);
            return lines;
        }
        const std::uint8_t face = std::uint8_t(-1 - f.support);
        const auto& tv = in_.tets[tet_];
        const auto& fv = tet_local::face_vertices[face];
        const vec3 &x = in_.vertices[tv[fv[0]]], &y = in_.vertices[tv[fv[1]]],
                   &z = in_.vertices[tv[fv[2]]];
        auto on_face = [&](index_t t) {
            const auto& tri = in_.triangles[t];
            const vec3 &a = in_.vertices[tri[0]], &b = in_.vertices[tri[1]],
                       &c = in_.vertices[tri[2]];
            return o3d(a, b, c, x) == 0 && o3d(a, b, c, y) == 0 && o3d(a, b, c, z) == 0;
        };
        auto groups_of = [&](index_t t, bool neighbour) {
            for (index_t g = cp_.group_first[t]; g < cp_.group_first[t + 1]; ++g) {
                const index_t rep = cp_.group_tris[cp_.tri_first[g]];
                if (on_face(rep)) {
                    for (index_t i = cp_.tri_first[g]; i < cp_.tri_first[g + 1]; ++i)
                        add_edges(cp_.group_tris[i]);
                } else if (neighbour) {
                    lines.push_back(triangle_plane(rep));
                }
            }
        };
        groups_of(tet_, false);
        const index_t nb = adj_.across[4 * tet_ + face];
        if (nb != invalid_index) groups_of(nb, true);
        std::sort(on_plane.begin(), on_plane.end());
        on_plane.erase(std::unique(on_plane.begin(), on_plane.end()), on_plane.end());
        return lines;
    }

    void split_facet(const polygon& f, triangle_list& on_plane, facet_parts& parts) {
        const std::vector<std::uint32_t>& lines = lines_for(f, on_plane);
        parts.assign(1, f);
        std::vector<polygon>& next = next_parts_;
        polygon pos, neg;
        for (std::uint32_t k : lines) {
            next.clear();
            for (const polygon& p : parts) {
                int side = 0;
                if (split(p, k, pos, neg, side))
                    next.push_back(pos), next.push_back(neg);
                else
                    next.push_back(p);
            }
            parts.assign(next.begin(), next.end());
        }
    }

    // ---- phase 2 ----

    /// Points strictly inside segment (a, b), in order from a.
    const corner_list& side_points(std::uint32_t a, std::uint32_t b) {
        const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
        auto [it, fresh] = side_points_.try_emplace(key);
        corner_list& found = it->second;
        if (fresh) {
            const std::uint32_t lo = std::min(a, b), hi = std::max(a, b);
            const point &A = pts_[lo], &B = pts_[hi];
            const std::uint8_t mask = A.faces & B.faces;
            int axis = 0; // an axis along which the segment is not constant
            for (int k = 0; k < 3; ++k)
                if (compare(A, B, k) != 0) axis = k;
            const bool up = compare(A, B, axis) < 0;
            vec3 blo, bhi;
            for (int k = 0; k < 3; ++k) {
                const double pad = 1e-9 * (std::abs(A.approx[k]) + std::abs(B.approx[k])) + 1e-300;
                blo[k] = std::min(A.approx[k], B.approx[k]) - pad;
                bhi[k] = std::max(A.approx[k], B.approx[k]) + pad;
            }
            // Exactly, when first needed: integer rows proportional to B - A and W - A.
            std::optional<int_vector> d;
            int_vector w_row;
            // Only the points whose x lies in the box's range: a tet cut many times has
            // hundreds of points and sides, too many to scan every point for every side
            // (bench/RESULTS.md, session 32).
            if (by_x_.size() != pts_.size()) {
                by_x_.resize(pts_.size());
                std::iota(by_x_.begin(), by_x_.end(), std::uint32_t{0});
                std::sort(by_x_.begin(), by_x_.end(), [&](std::uint32_t x, std::uint32_t y) {
                    return pts_[x].approx.x < pts_[y].approx.x;
                });
            }
            auto from = std::partition_point(by_x_.begin(), by_x_.end(), [&](std::uint32_t x) {
                return pts_[x].approx.x < blo.x;
            });
            for (auto at = from; at != by_x_.end() && !(pts_[*at].approx.x > bhi.x); ++at) {
                const std::uint32_t w = *at;
                if (w == lo || w == hi) continue;
                const point& W = pts_[w];
                if ((W.faces & mask) != mask) continue;
                bool in_box = true;
                for (int k = 1; k < 3 && in_box; ++k)
                    in_box = W.approx[k] >= blo[k] && W.approx[k] <= bhi[k];
                if (!in_box) continue;
                const int lo_side = compare(W, A, axis), hi_side = compare(W, B, axis);
                if (up ? !(lo_side > 0 && hi_side < 0) : !(lo_side < 0 && hi_side > 0)) continue;
                if (surely_not_collinear(A.approx, B.approx, W.approx)) continue;
                if (!d) difference_row(B.h(), A.h(), d.emplace());
                difference_row(W.h(), A.h(), w_row);
                const int_vector& u = *d;
                if (u[0] * w_row[1] != u[1] * w_row[0] || u[1] * w_row[2] != u[2] * w_row[1] ||
                    u[2] * w_row[0] != u[0] * w_row[2])
                    continue;
                found.push_back(w);
            }
            std::sort(found.begin(), found.end(), [&](std::uint32_t x, std::uint32_t y) {
                const int c = compare(pts_[x], pts_[y], axis);
                return up ? c < 0 : c > 0;
            });
        }
        return found;
    }

    /// Sign of P[k] - Q[k]. Rounding to the nearest double is monotone, so distinct
    /// roundings order the exact values; GMP only for equal ones.
    static int compare(const point& P, const point& Q, int k) {
        if (P.approx[k] != Q.approx[k]) return P.approx[k] < Q.approx[k] ? -1 : 1;
        if (P.is_double && Q.is_double) return 0;
        return compare_coordinate(P.h(), Q.h(), k);
    }

    /// Sign of component (u, w) of the cross product (a - o) x (b - o) of three exact points,
    /// judged from their nearest doubles o, a, b; 0 when the doubles cannot tell. Each
    /// coordinate is off by at most u = 2^-53 relative, so with M the largest magnitude the
    /// computed value is within about 50 u M^2 of the exact one; the margin is 1e-12 M^2
    /// (about 180 times that), and tiny magnitudes, where underflow breaks the relative
    /// bound, are left to GMP.
    static int cross_sign(const vec3& o, const vec3& a, const vec3& b, int u, int w) {
        const double M = std::max({std::abs(o[u]), std::abs(o[w]), std::abs(a[u]), std::abs(a[w]),
                                   std::abs(b[u]), std::abs(b[w])});
        const double M2 = M * M;
        if (!(M2 > 1e-200)) return 0;
        const double c = (a[u] - o[u]) * (b[w] - o[w]) - (a[w] - o[w]) * (b[u] - o[u]);
        const double margin = 1e-12 * M2;
        return c > margin ? 1 : (c < -margin ? -1 : 0);
    }

    /// True when points a, b, w (nearest doubles of exact points) are certainly not on one
    /// line: some component of (b - a) x (w - a) is certainly not zero.
    static bool surely_not_collinear(const vec3& a, const vec3& b, const vec3& w) {
        return cross_sign(a, b, w, 1, 2) != 0 || cross_sign(a, b, w, 2, 0) != 0 ||
               cross_sign(a, b, w, 0, 1) != 0;
    }

    std::uint32_t add_point(homogeneous_point q, std::uint8_t faces) {
        pts_.push_back(make_point(std::move(q), faces));
        return std::uint32_t(pts_.size() - 1);
    }

    homogeneous_point inner_point(const triangulation& T) const {
        const auto& c = T.inner_corners;
        if (T.inner_is_midpoint) return average({&pts_[c[0]].h(), &pts_[c[1]].h()}, {1, 1});
        return average({&pts_[c[0]].h(), &pts_[c[1]].h(), &pts_[c[2]].h()}, {2, 1, 1});
    }

    /// True iff T's inner point is in the closed input triangle t (its edge planes),
    /// judged from doubles where the filter allows: approx is within x_error of it.
    bool inside_triangle(const triangulation& T, const vec3& approx, double x_error, index_t t,
                         std::optional<homogeneous_point>& exact) {
        for (int e = 0; e < 3; ++e) {
            const std::uint32_t k = triangle_edge_plane(t, e);
            const exact_plane& pl = *planes_[k];
            const vec3 d = approx - pl.anchor;
            const double val = dot(pl.normal, d);
            const double tol = filter_bound(pl, d, x_error);
            if (val > tol) return false;
            if (val < -tol) continue;
            if (!exact) exact = inner_point(T);
            if (exact_sign(k, *exact) > 0) return false;
        }
        return true;
    }

    /// Triangulation of a facet part, the same for every tet and cell that holds it.
    const triangulation& triangulate(const polygon& P, std::span<const index_t> on_plane) {
        const auto& v = P.v;
        corner_list key(v.begin(), v.end());
        std::sort(key.begin(), key.end());
        // GCC 12 cannot bound the size of a key held inline when it moves it into the
        // node, and warns of a read past the inline room that the move never makes.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wstringop-overread"
#endif
        auto [it, fresh] = triangulations_.try_emplace(std::move(key));
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
        triangulation& T = it->second;
        if (!fresh) return T;
        const std::size_t m = v.size();
        // Canonical corner cycle: from the smallest corner towards its smaller neighbour.
        std::size_t s = 0;
        for (std::size_t i = 1; i < m; ++i)
            if (smaller(v[i], v[s])) s = i;
        const bool forward = smaller(v[(s + 1) % m], v[(s + m - 1) % m]);
        corner_list corners(m);
        for (std::size_t i = 0; i < m; ++i) corners[i] = v[forward ? (s + i) % m : (s + m - i) % m];
        // Boundary with every point on the sides; clear[i]: side (i, i + 1) has none.
        boost::container::small_vector<std::uint32_t, 16> boundary;
        boost::container::small_vector<bool, 8> clear(m);
        for (std::size_t i = 0; i < m; ++i) {
            boundary.push_back(corners[i]);
            const auto& extra = side_points(corners[i], corners[(i + 1) % m]);
            clear[i] = extra.empty();
            if (corners[i] < corners[(i + 1) % m])
                boundary.insert(boundary.end(), extra.begin(), extra.end());
            else
                boundary.insert(boundary.end(), extra.rbegin(), extra.rend());
        }
        // An interior point from the corners alone: the midpoint of a diagonal, or a
        // weighted centre of a triangle.
        std::uint8_t mask = 0xF;
        for (std::uint32_t c : corners) mask &= pts_[c].faces;
        T.inner_is_midpoint = m >= 4;
        T.inner_corners = {corners[0], corners[m >= 4 ? m / 2 : 1], corners[m >= 4 ? 0 : 2]};
        if (!on_plane.empty()) {
            // The inner point in doubles, within 4 u M of the exact one (M: the corners'
            // largest coordinate; each corner is within u M, the sums round twice).
            const vec3 &a = pts_[T.inner_corners[0]].approx, &b = pts_[T.inner_corners[1]].approx,
                       &c = pts_[T.inner_corners[2]].approx;
            const vec3 approx = T.inner_is_midpoint ? (a + b) * 0.5 : (a * 2.0 + b + c) * 0.25;
            const double error =
                4.04 * unit_roundoff * std::max({max_abs(a), max_abs(b), max_abs(c)});
            std::optional<homogeneous_point> exact;
            for (index_t t : on_plane)
                if (inside_triangle(T, approx, error, t, exact)) T.tracked_by.push_back(t);
        }
        T.support = P.support;
        // Fan from the smallest corner whose two sides hold no extra point, else from an
        // interior Steiner point.
        std::size_t apex = m;
        for (std::size_t i = 0; i < m && apex == m; ++i)
            if (clear[i] && clear[(i + m - 1) % m]) apex = i;
        const std::size_t nb = boundary.size();
        if (apex < m) {
            const std::uint32_t a = corners[apex];
            const auto at =
                std::size_t(std::find(boundary.begin(), boundary.end(), a) - boundary.begin());
            for (std::size_t i = 1; i + 1 < nb; ++i)
                T.triangles.push_back({a, boundary[(at + i) % nb], boundary[(at + i + 1) % nb]});
        } else {
            const std::uint32_t c = add_point(inner_point(T), mask);
            for (std::size_t i = 0; i < nb; ++i)
                T.triangles.push_back({c, boundary[i], boundary[(i + 1) % nb]});
        }
        return T;
    }

    /// Total order on exact points (x, then y, then z): the canonical "smallest corner".
    /// On doubles when both are doubles; else compare() decides from the doubles too
    /// unless they are equal.
    bool smaller(std::uint32_t a, std::uint32_t b) const {
        const point &A = pts_[a], &B = pts_[b];
        if (A.is_double && B.is_double)
            return std::tie(A.approx.x, A.approx.y, A.approx.z) <
                   std::tie(B.approx.x, B.approx.y, B.approx.z);
        for (int k = 0; k < 3; ++k)
            if (const int c = compare(A, B, k)) return c < 0;
        return false;
    }

    bool on_support(std::uint32_t x, std::int32_t support) {
        if (support < 0) return (pts_[x].faces >> (-1 - support)) & 1u;
        return sign(x, std::uint32_t(support)) == 0;
    }

    int orient(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) const {
        const point &A = pts_[a], &B = pts_[b], &C = pts_[c], &D = pts_[d];
        if (A.is_double && B.is_double && C.is_double && D.is_double)
            return orient3d(A.approx, B.approx, C.approx, D.approx);
        if (const int s =
                orientation_from_doubles({A.approx, B.approx, C.approx, D.approx},
                                         {A.is_double, B.is_double, C.is_double, D.is_double}))
            return s;
        return orient_exact(A.h(), B.h(), C.h(), D.h());
    }

    void emit(std::uint32_t apex, const std::array<std::uint32_t, 3>& t, tet_output& out) const {
        const int s = orient(t[0], t[1], t[2], apex);
        if (s == 0) throw std::logic_error("triangle insertion: a cone made a flat tet");
        out.tets.push_back(s > 0 ? std::array<std::uint32_t, 4>{t[0], t[1], t[2], apex}
                                 : std::array<std::uint32_t, 4>{t[0], t[2], t[1], apex});
    }

    /// Tets of the convex cell packed at `at`; returns where the next cell starts.
    std::size_t cone(std::size_t at, tet_output& out) {
        boost::container::small_vector<const triangulation*, 16> parts;
        boost::container::small_vector<std::uint32_t, 16> corners;
        const std::uint32_t* x = packed_.data() + at;
        polygon part;
        auto take = [&](std::uint32_t n) {
            const std::span<const std::uint32_t> r(x, n);
            x += n;
            return r;
        };
        for (std::uint32_t facets = *x++; facets > 0; --facets) {
            const auto facet = take(*x++);
            corners.insert(corners.end(), facet.begin(), facet.end());
            const auto on_plane = take(*x++);
            for (std::uint32_t n = *x++; n > 0; --n) {
                part.support = std::bit_cast<std::int32_t>(*x++);
                const auto corners_of_part = take(*x++);
                part.v.assign(corners_of_part.begin(), corners_of_part.end());
                parts.push_back(&triangulate(part, on_plane));
            }
        }
        cone({parts.data(), parts.size()}, corners, out);
        return std::size_t(x - packed_.data());
    }

    /// Tets of a convex cell (its facet parts' triangulations and its corners): a cone
    /// from its smallest corner that sees every boundary triangle not containing it, else
    /// from a point inside.
    void cone(std::span<const triangulation* const> parts,
              boost::container::small_vector<std::uint32_t, 16>& corners, tet_output& out) {
        std::sort(corners.begin(), corners.end());
        corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
        std::sort(corners.begin(), corners.end(),
                  [&](std::uint32_t a, std::uint32_t b) { return smaller(a, b); });
        for (std::uint32_t x : corners) {
            bool sees_all = true;
            for (const triangulation* T : parts) {
                if (!on_support(x, T->support)) continue;
                for (const auto& t : T->triangles)
                    if (t[0] != x && t[1] != x && t[2] != x) sees_all = false;
                if (!sees_all) break;
            }
            if (!sees_all) continue;
            for (const triangulation* T : parts)
                if (!on_support(x, T->support))
                    for (const auto& t : T->triangles) emit(x, t, out);
            return;
        }
        // No corner works: the midpoint of the smallest corner and a point inside a facet
        // part not on its plane is inside the cell.
        const std::uint32_t x = corners.front();
        for (const triangulation* T : parts)
            if (!on_support(x, T->support)) {
                const homogeneous_point inner = inner_point(*T);
                const std::uint32_t s = add_point(average({&pts_[x].h(), &inner}, {1, 1}), 0);
                for (const triangulation* U : parts)
                    for (const auto& t : U->triangles) emit(s, t, out);
                return;
            }
        throw std::logic_error("triangle insertion: a cell with every facet through one corner");
    }
};

struct sorted_triple_hash {
    std::size_t operator()(const std::array<index_t, 3>& k) const noexcept {
        std::uint64_t h = (std::uint64_t(k[0]) << 32 | k[1]) * 0x9E3779B97F4A7C15ull;
        h ^= (h >> 29) + std::uint64_t(k[2]) * 0xC2B2AE3D27D4EB4Full;
        return std::size_t(h ^ (h >> 32));
    }
};

/// Vertices of the result that the insertion created, found by exact position.
class new_vertex_index {
public:
    /// `expected`: about how many vertices will be added.
    new_vertex_index(inserted_mesh& m, std::size_t expected)
        : m_(m)
        , first_(m.vertices.size()) {
        by_approx_.reserve(expected);
        next_.reserve(expected);
        exact_.reserve(expected);
    }
    index_t find_or_add(const point& p) {
        // Most positions have one vertex: the first by its doubles in the table, any
        // others (distinct exact points with the same nearest doubles) chained after it.
        const auto [it, fresh] = by_approx_.try_emplace(key{p.approx.x, p.approx.y, p.approx.z},
                                                        index_t(m_.vertices.size()));
        if (!fresh) {
            index_t last = invalid_index;
            for (index_t id = it->second; id != invalid_index; id = next_[id - first_]) {
                const auto& q = exact_[id - first_];
                // A point handed from tet to tet is one object: compared by address first.
                if (p.is_double ? q == nullptr
                                : q != nullptr && (q == p.exact || same_point(*p.exact, *q)))
                    return id;
                last = id;
            }
            next_[last - first_] = index_t(m_.vertices.size());
        }
        const index_t id = index_t(m_.vertices.size());
        m_.vertices.push_back(p.approx);
        next_.push_back(invalid_index);
        exact_.push_back(p.is_double ? nullptr : p.exact);
        return id;
    }
    /// Hands the mesh the exact positions of the vertices added.
    void finish() {
        m_.unreduced.reserve(
            m_.unreduced.size() +
            std::size_t(std::count_if(exact_.begin(), exact_.end(),
                                      [](const auto& q) { return q != nullptr; })));
        for (std::size_t i = 0; i < exact_.size(); ++i)
            if (exact_[i] != nullptr) m_.unreduced.emplace(index_t(first_ + i), *exact_[i]);
        exact_.clear();
    }

private:
    struct key {
        double x, y, z;
        bool operator==(const key&) const = default;
    };
    struct key_hash {
        std::size_t operator()(const key& k) const noexcept {
            std::uint64_t h = 1469598103934665603ull;
            for (double d : {k.x, k.y, k.z}) {
                std::uint64_t b = 0;
                std::memcpy(&b, &d, sizeof b);
                h = (h ^ b) * 1099511628211ull;
                h ^= h >> 29;
            }
            return std::size_t(h);
        }
    };
    inserted_mesh& m_;
    std::size_t first_; // the first vertex this index adds
    std::unordered_map<key, index_t, key_hash> by_approx_;
    std::vector<index_t> next_; // per added vertex: the next with the same doubles
    std::vector<std::shared_ptr<const homogeneous_point>> exact_; // per added vertex
};

} // namespace detail

/// Inserts every triangle of `in` into its background tets, exactly. Throws
/// std::invalid_argument for indices out of range; the background is trusted to be a
/// valid positively oriented tet mesh containing every triangle.
inline inserted_mesh insert_triangles(const insertion_input& in) {
    using namespace detail;
    const std::size_t n = in.vertices.size(), m = in.tets.size();
    for (const auto& t : in.triangles)
        for (index_t v : t)
            if (v >= n)
                throw std::invalid_argument("triangle insertion: corner index out of range");
    const tet_adjacency adj = build_adjacency(n, in.tets);
    const cutting_planes cp = find_cutting_planes(in, adj);
    auto has_planes = [&](index_t t) { return cp.group_first[t + 1] > cp.group_first[t]; };

    // Phase 1: the tets with planes of their own or of a face neighbour.
    std::vector<index_t> first_list, slot(m, invalid_index);
    for (index_t t = 0; t < m; ++t) {
        bool touched = has_planes(t);
        for (std::uint8_t f = 0; f < 4 && !touched; ++f) {
            const index_t nb = adj.across[4 * t + f];
            touched = nb != invalid_index && has_planes(nb);
        }
        if (touched) slot[t] = index_t(first_list.size()), first_list.push_back(t);
    }
    std::vector<std::unique_ptr<tet_cutter>> cutters(first_list.size());
    std::vector<std::vector<exported_point>> exports(first_list.size());
    tbb::parallel_for(std::size_t{0}, first_list.size(), [&](std::size_t i) {
        cutters[i] = std::make_unique<tet_cutter>(in, cp, adj, first_list[i]);
        cutters[i]->cut();
        exports[i] = cutters[i]->exports();
    });

    // Points on edges, by edge, for every tet around it.
    auto edge_key = [&](index_t t, std::uint8_t le) {
        const auto& e = tet_local::edge_vertices[le];
        const index_t a = in.tets[t][e[0]], b = in.tets[t][e[1]];
        return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
    };
    std::vector<std::pair<std::uint64_t, const exported_point*>> on_edges;
    for (std::size_t i = 0; i < first_list.size(); ++i)
        for (const auto& x : exports[i])
            if (x.where < 0)
                on_edges.emplace_back(edge_key(first_list[i], std::uint8_t(-1 - x.where)), &x);
    std::stable_sort(on_edges.begin(), on_edges.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    auto edge_range = [&](std::uint64_t key) {
        return std::equal_range(on_edges.begin(), on_edges.end(),
                                std::pair<std::uint64_t, const exported_point*>{key, nullptr},
                                [](const auto& a, const auto& b) { return a.first < b.first; });
    };

    // Phase 2: those and every tet with a point on an edge.
    std::vector<index_t> second_list;
    for (index_t t = 0; t < m; ++t) {
        bool touched = slot[t] != invalid_index;
        for (std::uint8_t le = 0; le < 6 && !touched; ++le) {
            auto [lo, hi] = edge_range(edge_key(t, le));
            touched = lo != hi;
        }
        if (touched) second_list.push_back(t);
    }
    std::vector<tet_output> outputs(second_list.size());
    tbb::parallel_for(std::size_t{0}, second_list.size(), [&](std::size_t i) {
        const index_t t = second_list[i];
        std::unique_ptr<tet_cutter> own;
        tet_cutter* c = nullptr;
        if (slot[t] != invalid_index) {
            c = cutters[slot[t]].get();
        } else {
            own = std::make_unique<tet_cutter>(in, cp, adj, t);
            own->cut();
            c = own.get();
        }
        for (std::uint8_t f = 0; f < 4; ++f) {
            const index_t nb = adj.across[4 * t + f];
            if (nb == invalid_index || slot[nb] == invalid_index) continue;
            for (const auto& x : exports[slot[nb]])
                if (x.where == std::int8_t(adj.across_face[4 * t + f]))
                    c->import(x.p, std::uint8_t(1u << f));
        }
        for (std::uint8_t le = 0; le < 6; ++le) {
            auto [lo, hi] = edge_range(edge_key(t, le));
            for (auto it = lo; it != hi; ++it) c->import(it->second->p, tet_cutter::edge_faces(le));
        }
        outputs[i] = c->finish();
        if (own == nullptr) cutters[slot[t]].reset();
    });

    // Assembly, in tet order: the numbering does not depend on the threads.
    inserted_mesh r;
    r.vertices = in.vertices;
    std::size_t tets = m - second_list.size(), new_points = 0, tracked = 0;
    for (const tet_output& o : outputs) {
        tets += o.tets.size(), tracked += o.tracked.size();
        new_points += o.points.size() - 4;
    }
    r.tets.reserve(tets);
    // A new point is in every tet around it: a few tets' outputs each.
    new_vertex_index index(r, new_points / 2);
    std::unordered_map<std::array<index_t, 3>, std::size_t, sorted_triple_hash> tracked_at;
    tracked_at.reserve(tracked / 2 + 1);
    std::vector<std::vector<index_t>> tags;
    std::vector<index_t> local;
    std::size_t next = 0;
    for (index_t t = 0; t < m; ++t) {
        if (next < second_list.size() && second_list[next] == t) {
            // Each output goes back to the heap once numbered, for the mesh to take.
            const tet_output o = std::move(outputs[next++]);
            local.assign(o.points.size(), invalid_index);
            for (std::uint8_t i = 0; i < 4; ++i) local[i] = in.tets[t][i];
            auto global = [&](std::uint32_t p) {
                if (local[p] == invalid_index) local[p] = index.find_or_add(o.points[p]);
                return local[p];
            };
            for (const auto& x : o.tets)
                r.tets.push_back({global(x[0]), global(x[1]), global(x[2]), global(x[3])});
            for (std::size_t k = 0; k < o.tracked.size(); ++k) {
                tri_indices f{global(o.tracked[k][0]), global(o.tracked[k][1]),
                              global(o.tracked[k][2])};
                std::array<index_t, 3> key = f;
                std::sort(key.begin(), key.end());
                auto [it, fresh] = tracked_at.try_emplace(key, r.tracked.size());
                if (fresh) r.tracked.push_back(f), tags.emplace_back();
                auto& tg = tags[it->second];
                tg.insert(tg.end(), o.tracked_by[k].begin(), o.tracked_by[k].end());
            }
        } else {
            r.tets.push_back(in.tets[t]);
        }
    }
    index.finish();
    for (index_t t = 0; t < m; ++t) r.cut_tets += has_planes(t) ? 1 : 0;
    r.refined_tets = second_list.size() - r.cut_tets;
    for (auto& tg : tags) {
        std::sort(tg.begin(), tg.end());
        tg.erase(std::unique(tg.begin(), tg.end()), tg.end());
        r.tracked_by.insert(r.tracked_by.end(), tg.begin(), tg.end());
        r.tracked_first.push_back(index_t(r.tracked_by.size()));
    }
    return r;
}

// ---- checks and rounding --------------------------------------------------------------------

namespace detail {

/// p exactly, over the product of its denominators.
inline homogeneous_point to_homogeneous(const rational_point& p) {
    homogeneous_point h;
    h.W = p.x.get_den() * p.y.get_den() * p.z.get_den();
    for (std::size_t k = 0; k < 3; ++k) h.X[k] = p[int(k)].get_num() * (h.W / p[int(k)].get_den());
    return h;
}

/// orient3d's sign on the exact positions of a tet of the result when its doubles
/// decide it, 0 when they cannot.
inline int orientation_from_doubles(const inserted_mesh& r, const tet_indices& t) {
    std::array<vec3, 4> p;
    std::array<bool, 4> exact{};
    for (std::size_t i = 0; i < 4; ++i) {
        p[i] = r.vertices[t[i]];
        exact[i] = r.is_exact_double(t[i]);
    }
    return orientation_from_doubles(p, exact);
}

} // namespace detail

inline rational_point inserted_mesh::exact_position(index_t v) const {
    if (auto it = exact.find(v); it != exact.end()) return it->second;
    if (auto it = unreduced.find(v); it != unreduced.end()) return detail::canonical(it->second);
    return to_rational(vertices[v]);
}

inline homogeneous_point inserted_mesh::exact_homogeneous(index_t v) const {
    if (auto it = unreduced.find(v); it != unreduced.end()) return it->second;
    if (auto it = exact.find(v); it != exact.end()) return detail::to_homogeneous(it->second);
    return detail::to_homogeneous(vertices[v]);
}

/// Exact orient3d of a tet of the result.
inline int orientation(const inserted_mesh& r, const tet_indices& t) {
    bool doubles = true;
    for (index_t v : t) doubles = doubles && r.is_exact_double(v);
    if (doubles)
        return orient3d(r.vertices[t[0]], r.vertices[t[1]], r.vertices[t[2]], r.vertices[t[3]]);
    if (const int sign = detail::orientation_from_doubles(r, t); sign != 0) return sign;
    return detail::orient_exact(r.exact_homogeneous(t[0]), r.exact_homogeneous(t[1]),
                                r.exact_homogeneous(t[2]), r.exact_homogeneous(t[3]));
}

/// Tets whose exact orientation is not positive.
inline std::size_t count_inverted(const inserted_mesh& r) {
    std::atomic<std::size_t> bad{0};
    tbb::parallel_for(std::size_t{0}, r.tets.size(), [&](std::size_t i) {
        if (orientation(r, r.tets[i]) <= 0) bad.fetch_add(1, std::memory_order_relaxed);
    });
    return bad.load();
}

/// Rounds every rational vertex to the nearest doubles whose tets all stay positive
/// (exact orient3d), repeating while some vertex could be rounded. Returns how many
/// vertices stay rational; their positions are reduced into `exact` (`unreduced` is
/// empty after).
inline std::size_t round_vertices(inserted_mesh& r) {
    const auto [first, star] = detail::vertex_stars(r.vertices.size(), r.tets);
    std::vector<index_t> pending;
    for (const auto& [v, q] : r.exact) pending.push_back(v);
    for (const auto& [v, h] : r.unreduced) pending.push_back(v);
    std::sort(pending.begin(), pending.end());
    for (bool progress = true; progress && !pending.empty();) {
        progress = false;
        std::vector<index_t> still;
        for (index_t v : pending) {
            // Take it out of the map that holds it: try the nearest doubles (r.vertices[v]).
            std::optional<rational_point> q;
            std::optional<homogeneous_point> h;
            if (auto it = r.exact.find(v); it != r.exact.end()) {
                q = std::move(it->second);
                r.exact.erase(it);
            } else {
                auto at = r.unreduced.find(v);
                h = std::move(at->second);
                r.unreduced.erase(at);
            }
            bool ok = true;
            for (index_t s = first[v]; s < first[v + 1] && ok; ++s)
                ok = orientation(r, r.tets[star[s]]) > 0;
            if (ok) {
                progress = true;
            } else {
                if (q) r.exact.emplace(v, std::move(*q));
                if (h) r.unreduced.emplace(v, std::move(*h));
                still.push_back(v);
            }
        }
        pending = std::move(still);
    }
    for (auto& [v, h] : r.unreduced) r.exact.emplace(v, detail::canonical(h));
    r.unreduced.clear();
    return r.exact.size();
}

} // namespace idas::insertion
