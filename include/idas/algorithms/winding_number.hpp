// The generalized winding number of a triangle soup (Jacobson et al. 2013): the sum of
// the signed solid angles of its triangles seen from a point, over 4 pi. 1 inside a
// closed outward-oriented surface, 0 outside, and a smooth, sensible in-between for open
// surfaces and soups.
//
// Evaluated with the fast hierarchical approximation of Barill et al. 2018: a bounding
// volume hierarchy whose far nodes contribute the first three terms of the Taylor
// expansion of their triangles' integral about the node's centre (the dipole of the
// area-weighted normals, then their first and second moments about the centre, exact
// for flat triangles), and whose near leaves are summed exactly. With three terms a node
// counts as far at twice its radius (first order alone needed four times for the same
// accuracy), which leaves about a third of the exact solid angles. Queries are const and
// may run concurrently.
#pragma once

#include <idas/core/types.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <numeric>
#include <vector>

namespace idas {

/// Van Oosterom and Strackee's two terms for triangle (a, b, c) seen from p: den + i det
/// has half the triangle's signed solid angle as its argument.
struct half_solid_angle {
    double det, den;
};
inline half_solid_angle half_solid_angle_of(const vec3& p, const vec3& a, const vec3& b,
                                            const vec3& c) {
    const vec3 x = a - p, y = b - p, z = c - p;
    const double lx = norm(x), ly = norm(y), lz = norm(z);
    return {dot(x, cross(y, z)), lx * ly * lz + dot(x, y) * lz + dot(y, z) * lx + dot(z, x) * ly};
}

/// Signed solid angle of triangle (a, b, c) seen from p: positive when the triangle turns
/// counter-clockwise seen from p.
inline double solid_angle(const vec3& p, const vec3& a, const vec3& b, const vec3& c) {
    const auto [det, den] = half_solid_angle_of(p, a, b, c);
    return 2.0 * std::atan2(det, den);
}

/// A sum of solid angles without an arctangent per triangle: the product of the
/// triangles' den + i det has the sum of their half angles as its argument, up to whole
/// turns, which are counted where the product crosses the negative real axis. One atan2
/// per query instead of one per triangle (bench/RESULTS.md, session 32).
class solid_angle_sum {
public:
    void add(const vec3& p, const vec3& a, const vec3& b, const vec3& c) {
        const auto [det, den] = half_solid_angle_of(p, a, b, c);
        if (det == 0) {
            // On the real axis (p in the triangle's plane): a half angle of 0 or pi, whose
            // side of the cut only atan2 knows.
            rest_ += 2.0 * std::atan2(det, den);
            return;
        }
        // The factor scaled to |den| + |det| = 1 (its division is off the product's
        // chain of dependent operations), so the product shrinks by at most 1/sqrt(2) a
        // factor and never overflows; a power of two brings it back from far below 1.
        const double scale = 1.0 / (std::abs(den) + std::abs(det));
        const double wr = den * scale, wi = det * scale;
        // Both half angles in (0, pi] ("upper", by the sign bit as atan2 reads it) sum
        // beyond pi when the product turns lower, both lower below -pi when it turns upper.
        const bool z_upper = !std::signbit(im_), w_upper = det > 0;
        const double re = re_ * wr - im_ * wi, im = re_ * wi + im_ * wr;
        re_ = re, im_ = im;
        if (z_upper == w_upper && z_upper == std::signbit(im_)) turns_ += z_upper ? 1 : -1;
        if (std::abs(re_) + std::abs(im_) < 0x1p-500) re_ *= 0x1p500, im_ *= 0x1p500;
    }
    /// The sum of the solid angles added.
    double value() const {
        return 2.0 * (std::atan2(im_, re_) + 2.0 * std::numbers::pi * double(turns_)) + rest_;
    }

private:
    double re_ = 1.0, im_ = 0.0;
    long turns_ = 0;
    double rest_ = 0.0;
};

class winding_number {
public:
    /// `accuracy` is Barill's beta: a node is far when the point is more than beta
    /// times its radius away (errors of about 1e-3 at 2).
    winding_number(const std::vector<vec3>& vertices, const std::vector<tri_indices>& faces,
                   double accuracy = 2.0)
        : v_(vertices)
        , f_(faces)
        , beta2_(accuracy * accuracy) {
        order_.resize(faces.size());
        std::iota(order_.begin(), order_.end(), index_t{0});
        centroid_.resize(faces.size());
        for (std::size_t i = 0; i < faces.size(); ++i)
            centroid_[i] = (v_[faces[i][0]] + v_[faces[i][1]] + v_[faces[i][2]]) * (1.0 / 3.0);
        if (!faces.empty()) build(0, index_t(faces.size()));
    }

    /// The winding number at p (exact sum of solid angles near p, dipoles far away).
    double operator()(const vec3& p) const { return at(p, beta2_); }

    /// The winding number at p as far as it decides "above 1/2": first at a coarser
    /// accuracy (beta 1.5, about half the cost; within 0.05 of beta 2 on every input of
    /// bench/RESULTS.md), and again at full accuracy only within `label_margin` of 1/2.
    /// Most points are well inside or outside, so the labels of a mesh cost about half.
    double for_label(const vec3& p) const {
        if (beta2_ <= coarse_beta2) return at(p, beta2_);
        const double coarse = at(p, coarse_beta2);
        return std::abs(coarse - 0.5) >= label_margin ? coarse : at(p, beta2_);
    }
    static constexpr double coarse_beta2 = 1.5 * 1.5, label_margin = 0.1;

private:
    double at(const vec3& p, double beta2) const {
        if (nodes_.empty()) return 0.0;
        double sum = 0.0;
        solid_angle_sum near;
        index_t stack[128];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const node& n = nodes_[stack[--top]];
            const vec3 d = n.center - p;
            const double d2 = dot(d, d);
            if (d2 > beta2 * n.radius2) {
                sum += far_field(n, d, d2);
                continue;
            }
            if (n.left == invalid_index || top + 2 > 128) {
                for (index_t i = n.begin; i < n.end; ++i) {
                    const auto& t = f_[order_[i]];
                    near.add(p, v_[t[0]], v_[t[1]], v_[t[2]]);
                }
                continue;
            }
            stack[top++] = n.left;
            stack[top++] = n.left + 1;
        }
        return (sum + near.value()) / (4.0 * std::numbers::pi);
    }

    /// A symmetric 3x3 matrix: xx, yy, zz, xy, xz, yz.
    using symmetric = std::array<double, 6>;
    /// e e^T.
    static symmetric outer(const vec3& e) {
        return {e.x * e.x, e.y * e.y, e.z * e.z, e.x * e.y, e.x * e.z, e.y * e.z};
    }
    static vec3 times(const symmetric& s, const vec3& d) {
        return {s[0] * d.x + s[3] * d.y + s[4] * d.z, s[3] * d.x + s[1] * d.y + s[5] * d.z,
                s[4] * d.x + s[5] * d.y + s[2] * d.z};
    }

    struct node {
        vec3 center, normal; // area-weighted centroid; sum of area vectors A (half cross)
        // First moment: rows i of sum over triangles of (centroid - center)_i A; second
        // moment: for each component i of A, the sum of A_i times the triangle's second
        // moment of area about the center, per unit area (Q below).
        std::array<vec3, 3> moment{};
        std::array<symmetric, 3> second{};
        double radius2 = 0; // squared distance from center to the farthest corner
        index_t begin = 0, end = 0, left = invalid_index;
    };
    const std::vector<vec3>& v_;
    const std::vector<tri_indices>& f_;
    double beta2_;
    std::vector<index_t> order_;
    std::vector<vec3> centroid_;
    std::vector<node> nodes_;

    /// A far node's contribution (times 4 pi), d = center - p: the integral of n . f over
    /// its triangles with f(x) = (x - p) / |x - p|^3 = grad phi, phi = -1 / |x - p|,
    /// expanded about the center to second order in x - center. phi's derivatives there:
    /// H = I / r^3 - 3 d d^T / r^5 and
    /// T_ijk = -3 (delta_ij d_k + delta_ik d_j + delta_jk d_i) / r^5 + 15 d_i d_j d_k / r^7.
    static double far_field(const node& n, const vec3& d, double d2) {
        // Powers of 1 / r from one division and one square root.
        const double inv_r2 = 1.0 / d2, inv_r3 = inv_r2 * std::sqrt(inv_r2);
        const double inv_r5 = inv_r3 * inv_r2, inv_r7 = inv_r5 * inv_r2;
        const auto& M = n.moment;
        const vec3 Md{dot(M[0], d), dot(M[1], d), dot(M[2], d)};
        const double first = dot(n.normal, d) * inv_r3;
        const double second = (M[0].x + M[1].y + M[2].z) * inv_r3 - 3 * dot(d, Md) * inv_r5;
        double t1 = 0, t2 = 0, t3 = 0;
        for (int i = 0; i < 3; ++i) {
            const symmetric& S = n.second[std::size_t(i)];
            const vec3 Sd = times(S, d);
            t1 += Sd[i];
            t2 += d[i] * (S[0] + S[1] + S[2]);
            t3 += d[i] * dot(d, Sd);
        }
        const double third = 0.5 * (-3 * (2 * t1 + t2) * inv_r5 + 15 * t3 * inv_r7);
        return first + second + third;
    }

    // Children of a node are stored next to each other (left, left + 1).
    void build(index_t begin, index_t end) {
        nodes_.push_back({});
        std::vector<std::pair<index_t, index_t>> todo{{0, 0}};
        nodes_[0].begin = begin, nodes_[0].end = end;
        for (std::size_t k = 0; k < todo.size(); ++k) {
            const index_t id = todo[k].first;
            node n = nodes_[id];
            double area = 0;
            vec3 c{}, normal{};
            vec3 lo = centroid_[order_[n.begin]], hi = lo;
            for (index_t i = n.begin; i < n.end; ++i) {
                const auto& t = f_[order_[i]];
                const vec3 a2 = cross(v_[t[1]] - v_[t[0]], v_[t[2]] - v_[t[0]]);
                const double w = norm(a2) * 0.5;
                area += w;
                c += centroid_[order_[i]] * w;
                normal += a2 * 0.5;
                for (int ax = 0; ax < 3; ++ax)
                    lo[ax] = std::min(lo[ax], centroid_[order_[i]][ax]),
                    hi[ax] = std::max(hi[ax], centroid_[order_[i]][ax]);
            }
            n.center = area > 0 ? c * (1.0 / area) : centroid_[order_[n.begin]];
            n.normal = normal;
            for (index_t i = n.begin; i < n.end; ++i) {
                const auto& t = f_[order_[i]];
                const vec3& g = centroid_[order_[i]];
                const vec3 A = cross(v_[t[1]] - v_[t[0]], v_[t[2]] - v_[t[0]]) * 0.5;
                const vec3 x = g - n.center;
                // Q = x x^T + (1/12) sum over corners of (corner - g)(corner - g)^T: the
                // triangle's second moment of area about the center, divided by its area.
                symmetric Q = outer(x);
                for (index_t v : t) {
                    const symmetric E = outer(v_[v] - g);
                    for (int k = 0; k < 6; ++k) Q[std::size_t(k)] += E[std::size_t(k)] / 12.0;
                }
                for (int row = 0; row < 3; ++row) {
                    n.moment[std::size_t(row)] += A * x[row];
                    for (int k = 0; k < 6; ++k)
                        n.second[std::size_t(row)][std::size_t(k)] += A[row] * Q[std::size_t(k)];
                }
            }
            for (index_t i = n.begin; i < n.end; ++i)
                for (index_t v : f_[order_[i]])
                    n.radius2 = std::max(n.radius2, squared_norm(v_[v] - n.center));
            if (n.end - n.begin > 8) {
                int axis = 0;
                for (int ax = 1; ax < 3; ++ax)
                    if (hi[ax] - lo[ax] > hi[axis] - lo[axis]) axis = ax;
                const index_t mid = n.begin + (n.end - n.begin) / 2;
                std::nth_element(
                    order_.begin() + n.begin, order_.begin() + mid, order_.begin() + n.end,
                    [&](index_t x, index_t y) { return centroid_[x][axis] < centroid_[y][axis]; });
                n.left = index_t(nodes_.size());
                nodes_.push_back({});
                nodes_.push_back({});
                nodes_[n.left].begin = n.begin, nodes_[n.left].end = mid;
                nodes_[n.left + 1].begin = mid, nodes_[n.left + 1].end = n.end;
                todo.push_back({n.left, 0});
                todo.push_back({n.left + 1, 0});
            }
            nodes_[id] = n;
        }
    }
};

} // namespace idas
