// Exact intersection tests between closed triangles, built only from the signs of
// orient3d and orient2d (predicates/orient.hpp), so no rounding decides an answer.
//
// Two faces of a mesh that share vertices always meet there; what counts is whether they
// meet anywhere else. So the tests come in three kinds, chosen by how many vertices the
// faces share (by index, not by position):
//   none   the closed triangles meet at all;
//   one    they meet beyond the shared vertex (a fold through the fan, an edge through
//          the other face, or coplanar faces whose corners at the shared vertex overlap);
//   two    they overlap beyond the shared edge (coplanar, on the same side of it);
//   three  the same face twice: always.
// A triangle whose corners are collinear has no plane to test against; where one would
// be needed the answer is "they meet" (conservative: an invariant then refuses).
#pragma once

#include <idas/core/types.hpp>
#include <idas/predicates/orient.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace idas {

namespace detail::intersection {

using point2 = std::array<double, 2>;

/// p seen along coordinate axis `drop` (0, 1 or 2).
inline point2 projected(const vec3& p, int drop) noexcept {
    return drop == 0 ? point2{p.y, p.z} : drop == 1 ? point2{p.x, p.z} : point2{p.x, p.y};
}

/// An axis along which triangle abc projects to a triangle of non-zero area (so 2D
/// orientations in that projection decide sides within abc's plane), or -1 if abc is
/// degenerate (collinear corners).
inline int projection_axis(const vec3& a, const vec3& b, const vec3& c) {
    for (int drop : {2, 1, 0})
        if (orient2d(projected(a, drop), projected(b, drop), projected(c, drop)) != 0) return drop;
    return -1;
}

/// r lies on closed segment pq, given that p, q, r are collinear.
inline bool within_box(const point2& p, const point2& q, const point2& r) noexcept {
    for (int i = 0; i < 2; ++i)
        if (r[i] < std::min(p[i], q[i]) || r[i] > std::max(p[i], q[i])) return false;
    return true;
}

/// Closed segments pq and rs meet (2D).
inline bool segments_meet(const point2& p, const point2& q, const point2& r, const point2& s) {
    const int o1 = orient2d(p, q, r), o2 = orient2d(p, q, s);
    const int o3 = orient2d(r, s, p), o4 = orient2d(r, s, q);
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    return (o1 == 0 && within_box(p, q, r)) || (o2 == 0 && within_box(p, q, s)) ||
           (o3 == 0 && within_box(r, s, p)) || (o4 == 0 && within_box(r, s, q));
}

/// p lies in the closed triangle abc (2D, abc not degenerate).
inline bool inside_triangle(const point2& a, const point2& b, const point2& c, const point2& p) {
    const int s = orient2d(a, b, c);
    return s * orient2d(a, b, p) >= 0 && s * orient2d(b, c, p) >= 0 && s * orient2d(c, a, p) >= 0;
}

/// Closed segment pq meets closed triangle abc, all in one plane.
inline bool coplanar_segment_meets_triangle(const vec3& p, const vec3& q, const vec3& a,
                                            const vec3& b, const vec3& c) {
    const int drop = projection_axis(a, b, c);
    if (drop < 0) return true; // degenerate triangle: conservative
    const point2 P = projected(p, drop), Q = projected(q, drop);
    const point2 A = projected(a, drop), B = projected(b, drop), C = projected(c, drop);
    return inside_triangle(A, B, C, P) || inside_triangle(A, B, C, Q) ||
           segments_meet(P, Q, A, B) || segments_meet(P, Q, B, C) || segments_meet(P, Q, C, A);
}

/// Direction x - v lies in the closed corner of triangle (v, c, d) at v; x lies in the
/// triangle's plane.
inline bool in_corner(const vec3& v, const vec3& c, const vec3& d, const vec3& x) {
    const int drop = projection_axis(v, c, d);
    if (drop < 0) return true; // degenerate triangle: conservative
    const point2 V = projected(v, drop), C = projected(c, drop), D = projected(d, drop);
    const point2 X = projected(x, drop);
    const int s = orient2d(V, C, D);
    return s * orient2d(V, C, X) >= 0 && s * orient2d(V, X, D) >= 0;
}

} // namespace detail::intersection

/// Closed segment pq meets closed triangle abc (exact). A degenerate triangle counts as
/// met when the segment lies in its line's planes (conservative).
inline bool segment_meets_triangle(const vec3& p, const vec3& q, const vec3& a, const vec3& b,
                                   const vec3& c) {
    const int sp = orient3d(a, b, c, p), sq = orient3d(a, b, c, q);
    if (sp * sq > 0) return false;
    if (sp == 0 && sq == 0)
        return detail::intersection::coplanar_segment_meets_triangle(p, q, a, b, c);
    // The line through p and q crosses the plane within [p, q]: inside the triangle iff it
    // passes each edge on the same side.
    const int o1 = orient3d(p, q, a, b), o2 = orient3d(p, q, b, c), o3 = orient3d(p, q, c, a);
    return (o1 >= 0 && o2 >= 0 && o3 >= 0) || (o1 <= 0 && o2 <= 0 && o3 <= 0);
}

/// Closed triangles abc and def meet (exact): some edge of one meets the other.
inline bool triangles_meet(const vec3& a, const vec3& b, const vec3& c, const vec3& d,
                           const vec3& e, const vec3& f) {
    // All three corners of one strictly on one side of the other's plane: apart.
    const int d1 = orient3d(a, b, c, d), e1 = orient3d(a, b, c, e), f1 = orient3d(a, b, c, f);
    if ((d1 > 0 && e1 > 0 && f1 > 0) || (d1 < 0 && e1 < 0 && f1 < 0)) return false;
    const int a1 = orient3d(d, e, f, a), b1 = orient3d(d, e, f, b), c1 = orient3d(d, e, f, c);
    if ((a1 > 0 && b1 > 0 && c1 > 0) || (a1 < 0 && b1 < 0 && c1 < 0)) return false;
    return segment_meets_triangle(a, b, d, e, f) || segment_meets_triangle(b, c, d, e, f) ||
           segment_meets_triangle(c, a, d, e, f) || segment_meets_triangle(d, e, a, b, c) ||
           segment_meets_triangle(e, f, a, b, c) || segment_meets_triangle(f, d, a, b, c);
}

/// Triangles (v, a, b) and (v, c, d), sharing corner v, meet somewhere other than v.
/// Their meeting set is convex and holds v; if it holds more, it reaches the boundary of
/// one of them away from v: an edge opposite v crossing the other triangle, or an edge
/// at v lying in the other's plane and inside its corner at v.
inline bool triangles_meet_beyond_vertex(const vec3& v, const vec3& a, const vec3& b, const vec3& c,
                                         const vec3& d) {
    using detail::intersection::in_corner;
    const int sa = orient3d(v, c, d, a), sb = orient3d(v, c, d, b);
    if (sa * sb <= 0 && segment_meets_triangle(a, b, v, c, d)) return true;
    const int sc = orient3d(v, a, b, c), sd = orient3d(v, a, b, d);
    if (sc * sd <= 0 && segment_meets_triangle(c, d, v, a, b)) return true;
    return (sa == 0 && in_corner(v, c, d, a)) || (sb == 0 && in_corner(v, c, d, b)) ||
           (sc == 0 && in_corner(v, a, b, c)) || (sd == 0 && in_corner(v, a, b, d));
}

/// Triangles (u, w, c) and (u, w, d), sharing edge uw, overlap beyond it: they are
/// coplanar and c and d lie on the same side of uw (or d on its line: a degenerate
/// triangle, conservatively).
inline bool triangles_meet_beyond_edge(const vec3& u, const vec3& w, const vec3& c, const vec3& d) {
    if (orient3d(u, w, c, d) != 0) return false;
    namespace di = detail::intersection;
    const int drop = di::projection_axis(u, w, c);
    if (drop < 0) return true;
    const auto U = di::projected(u, drop), W = di::projected(w, drop);
    return orient2d(U, W, di::projected(c, drop)) * orient2d(U, W, di::projected(d, drop)) >= 0;
}

namespace detail::intersection {

/// Cheap proofs that two faces do not meet, from 2D orientations in one projection (the
/// one along the largest component of the first face's normal): most neighbours of a
/// face are told apart this way, and exactly coplanar ones (flat regions of CAD models,
/// where orient3d needs its exact fallback) at the price of a filtered orient2d.
/// `apart(...)` true proves the faces meet nowhere but at shared vertices; false proves
/// nothing.
struct projection {
    int drop = -1;
    std::array<point2, 3> p, q;
    int sp = 0, sq = 0; // orientation of each projected face; 0 if degenerate

    projection(const std::array<vec3, 3>& P, const std::array<vec3, 3>& Q) {
        const vec3 n = cross(P[1] - P[0], P[2] - P[0]);
        const double ax = std::abs(n.x), ay = std::abs(n.y), az = std::abs(n.z);
        drop = ax >= ay && ax >= az ? 0 : ay >= az ? 1 : 2;
        for (int k = 0; k < 3; ++k) p[k] = projected(P[k], drop), q[k] = projected(Q[k], drop);
        sp = orient2d(p[0], p[1], p[2]), sq = orient2d(q[0], q[1], q[2]);
    }

    /// No shared vertex: an edge of one projected face has the other strictly outside.
    bool separated() const {
        if (sp == 0 || sq == 0) return false;
        auto outside = [](const std::array<point2, 3>& t, int s, const std::array<point2, 3>& o) {
            for (int e = 0; e < 3; ++e) {
                const point2 &a = t[e], &b = t[(e + 1) % 3];
                if (s * orient2d(a, b, o[0]) < 0 && s * orient2d(a, b, o[1]) < 0 &&
                    s * orient2d(a, b, o[2]) < 0)
                    return true;
            }
            return false;
        };
        return outside(p, sp, q) || outside(q, sq, p);
    }

    /// Shared vertex p[x] = q[y]: the projected corners there do not overlap. The
    /// projection is one-to-one on the first face, so a common point other than the vertex
    /// would show as one.
    bool corners_apart(int x, int y) const {
        if (sp == 0 || sq == 0) return false;
        const point2 &v = p[x], &a = p[(x + 1) % 3], &b = p[(x + 2) % 3];
        const point2 &c = q[(y + 1) % 3], &d = q[(y + 2) % 3];
        auto in = [&](const point2& r0, const point2& r1, int s, const point2& w) {
            return s * orient2d(v, r0, w) >= 0 && s * orient2d(v, w, r1) >= 0;
        };
        return !in(c, d, sq, a) && !in(c, d, sq, b) && !in(a, b, sp, c) && !in(a, b, sp, d);
    }

    /// Shared edge: the corners off it lie strictly on opposite sides of it (coplanar
    /// faces then do not overlap; others meet only along the edge anyway).
    bool opposite_sides(int u, int w, int c, int d) const {
        if (sp == 0) return false;
        return orient2d(p[u], p[w], p[c]) * orient2d(p[u], p[w], q[d]) < 0;
    }
};

} // namespace detail::intersection

/// A triangle's plane, kept to tell on which side points lie: the orient3d of the
/// triangle and a point, with the triangle's half of the work done once. side() is the
/// filter of orient3d (the same error bound, the determinant expanded along the point's
/// row), so it answers +1 or -1 only when that sign is proven, and 0 otherwise.
struct plane_filter {
    vec3 a, normal, weight; // weight[i]: the magnitudes that bound normal[i]'s rounding

    plane_filter() = default;
    plane_filter(const vec3& p0, const vec3& p1, const vec3& p2) noexcept
        : a(p0) {
        const vec3 u = p1 - p0, v = p2 - p0;
        normal = {u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
        weight = {std::abs(u.y * v.z) + std::abs(u.z * v.y),
                  std::abs(u.z * v.x) + std::abs(u.x * v.z),
                  std::abs(u.x * v.y) + std::abs(u.y * v.x)};
    }
    [[gnu::always_inline]] int side(const vec3& d) const noexcept {
        namespace dp = detail::predicates;
        const vec3 w = d - a;
        const double det = w.x * normal.x + w.y * normal.y + w.z * normal.z;
        const double ax = std::abs(w.x), ay = std::abs(w.y), az = std::abs(w.z);
        const double perm = ax * weight.x + ay * weight.y + az * weight.z;
        const double bound = dp::o3d_rel_bound * perm + (ax + ay + az + 1.0) * dp::underflow_bound;
        return det > bound ? 1 : -det > bound ? -1 : 0;
    }
};

/// A face as the self-intersection tests read it: corners, vertex ids, plane.
struct face_geometry {
    std::array<vec3, 3> p;
    std::array<index_t, 3> v;
    plane_filter plane;

    face_geometry() = default;
    face_geometry(const std::array<vec3, 3>& corners, const std::array<index_t, 3>& ids) noexcept
        : p(corners)
        , v(ids)
        , plane(corners[0], corners[1], corners[2]) {}
};

/// The corners of face (q, j) that f does not share lie strictly on one side of f's plane
/// (floating point proves it): then the faces meet at most in what they share. The cheap
/// first question of faces_meet, for a caller that has not built g's plane.
/// All three sides are found before any is looked at: the answers are near random (about
/// four in five pairs are parted), so branching on each costs more than computing it.
[[gnu::always_inline]] inline bool plane_separates(const face_geometry& f,
                                                   const std::array<vec3, 3>& q,
                                                   const std::array<index_t, 3>& j) noexcept {
    bool above = false, below = false, on = false;
    for (int k = 0; k < 3; ++k) {
        const bool shared = j[k] == f.v[0] || j[k] == f.v[1] || j[k] == f.v[2];
        const int s = f.plane.side(q[k]);
        above |= !shared && s > 0, below |= !shared && s < 0, on |= !shared && s == 0;
    }
    return above != below && !on;
}

/// Faces f and g meet anywhere but at the vertices they share: the test for a surface's
/// self-intersections. Most pairs are told apart first by a plane that floating point
/// alone puts the other's corners beyond, then by a 2D view; the exact tests decide the
/// rest. `f_plane_tried`: the caller has asked plane_separates(f, g) already (and it
/// did not part them), so f's plane is not asked again.
inline bool faces_meet(const face_geometry& f, const face_geometry& g, bool f_plane_tried = false) {
    const auto &p = f.p, &q = g.p;
    int shared = 0, pi[3] = {0, 0, 0}, qj[3] = {0, 0, 0}; // pi[k], qj[k]: k-th shared pair
    unsigned shared_p = 0, shared_q = 0;                  // bit k: corner k is shared
    for (int x = 0; x < 3; ++x)
        for (int y = 0; y < 3; ++y)
            if (f.v[x] == g.v[y])
                pi[shared] = x, qj[shared] = y, ++shared, shared_p |= 1u << x, shared_q |= 1u << y;
    if (shared == 3) return true; // the same three vertices twice
    // The corners of one face not shared with the other strictly on one side of the
    // other's plane: the faces meet at most in what they share.
    auto beyond = [](const plane_filter& plane, const std::array<vec3, 3>& o, unsigned skip) {
        int side = 0;
        for (int k = 0; k < 3; ++k) {
            if (skip >> k & 1u) continue;
            const int s = plane.side(o[k]);
            if (s == 0 || (side != 0 && s != side)) return false;
            side = s;
        }
        return true;
    };
    if ((!f_plane_tried && beyond(f.plane, q, shared_q)) || beyond(g.plane, p, shared_p))
        return false;
    const detail::intersection::projection seen(p, q);
    switch (shared) {
    case 0:
        return !seen.separated() && triangles_meet(p[0], p[1], p[2], q[0], q[1], q[2]);
    case 1: {
        const int x = pi[0], y = qj[0];
        return !seen.corners_apart(x, y) &&
               triangles_meet_beyond_vertex(p[x], p[(x + 1) % 3], p[(x + 2) % 3], q[(y + 1) % 3],
                                            q[(y + 2) % 3]);
    }
    default: {
        const int c = 3 - pi[0] - pi[1], d = 3 - qj[0] - qj[1]; // the corners not shared
        return !seen.opposite_sides(pi[0], pi[1], c, d) &&
               triangles_meet_beyond_edge(p[pi[0]], p[pi[1]], p[c], q[d]);
    }
    }
}

/// The same for faces given by corners and vertex ids.
inline bool faces_meet(const std::array<vec3, 3>& p, const std::array<index_t, 3>& i,
                       const std::array<vec3, 3>& q, const std::array<index_t, 3>& j) {
    return faces_meet(face_geometry(p, i), face_geometry(q, j));
}

} // namespace idas
