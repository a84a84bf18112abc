// Quality measures of tetrahedra, one tet at a time and summarized over a tet list:
// signed volume, the shape quality that the tet operations optimise, dihedral angles, and
// the conformal AMIPS energy.
//
// AMIPS (the "3D conformal AMIPS" energy of Hu et al., "Tetrahedral Meshing in the Wild",
// SIGGRAPH 2018). Let E = [b - a, c - a, d - a] (columns) and R the same matrix for the
// regular tet with unit edges, (0,0,0), (1,0,0), (1/2, sqrt(3)/2, 0),
// (1/2, sqrt(3)/6, sqrt(2/3)). With J = E R^-1 (the affine map from the regular tet),
//     amips(a, b, c, d) = tr(J^T J) / det(J)^(2/3).
// It is invariant under translation, rotation and uniform scaling; by the AM-GM
// inequality on the singular values of J it is >= 3, with equality exactly for regular
// tets (of any size); it grows without bound as the tet flattens, and it is +infinity
// for flat and inverted tets (det(J) <= 0), which the energy is meant to forbid.
#pragma once

#include "idas/core/types.hpp"
#include "idas/predicates/orient.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <span>

namespace idas {

/// Signed volume of the tet (a, b, c, d): positive when orient3d(a, b, c, d) > 0 (up to
/// rounding; use orient3d for an exact sign).
inline double tet_signed_volume(const vec3& a, const vec3& b, const vec3& c,
                                const vec3& d) noexcept {
    return dot(b - a, cross(c - a, d - a)) / 6;
}

/// Shape quality of the tet (a, b, c, d): 6·sqrt(2)·volume / (rms edge length)^3. Scale
/// invariant; 1 for the regular tet, 0 when flat, negative when inverted. The tet
/// operations maximise it (edge removal's triangulation, swaps' acceptance).
inline double tet_quality(const vec3& a, const vec3& b, const vec3& c, const vec3& d) noexcept {
    const vec3 u = b - a, v = c - a, w = d - a;
    const double six_volume = dot(u, cross(v, w));
    const double sum_sq = squared_norm(u) + squared_norm(v) + squared_norm(w) +
                          squared_norm(c - b) + squared_norm(d - b) + squared_norm(d - c);
    if (!(sum_sq > 0)) return 0;
    const double rms = std::sqrt(sum_sq / 6);
    return std::sqrt(2.0) * six_volume / (rms * rms * rms);
}

/// The local edges of a tet (a, b, c, d) = (p0, p1, p2, p3), in tet_mesh's local order.
inline constexpr std::array<std::array<int, 2>, 6> tet_edge_corners = {
    {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

/// The interior dihedral angles (radians, in [0, pi]) at the six edges, in the order of
/// tet_edge_corners. Unsigned, so an inverted tet has the angles of its mirror image; a
/// flat tet has angles 0 and pi; a zero-length edge gives 0 at the edges it spoils.
inline std::array<double, 6> tet_dihedral_angles(const vec3& a, const vec3& b, const vec3& c,
                                                 const vec3& d) noexcept {
    const std::array<vec3, 4> p = {a, b, c, d};
    std::array<double, 6> out{};
    for (std::size_t e = 0; e < 6; ++e) {
        const int i = tet_edge_corners[e][0], j = tet_edge_corners[e][1];
        int k = 0;
        while (k == i || k == j) ++k;
        const int l = 6 - i - j - k;
        // Normals of the two faces through edge ij; the angle between the half-planes
        // is the angle between them. atan2 stays accurate near 0 and pi.
        const vec3 axis = p[j] - p[i];
        const vec3 nk = cross(axis, p[k] - p[i]), nl = cross(axis, p[l] - p[i]);
        out[e] = std::atan2(norm(cross(nk, nl)), dot(nk, nl));
    }
    return out;
}

namespace detail {
/// The two terms of the AMIPS energy of tet (a, b, c, d): |J|_F^2 and det J.
struct amips_terms {
    double frobenius_sq, det;
};
inline amips_terms amips_terms_of(const vec3& a, const vec3& b, const vec3& c,
                                  const vec3& d) noexcept {
    const vec3 u = b - a, v = c - a, w = d - a;
    // Columns of J = E R^-1; R^-1 = [[1, -1/sqrt3, -1/sqrt6], [0, 2/sqrt3, -1/sqrt6],
    // [0, 0, 3/sqrt6]] (R is upper triangular), and det R^-1 = sqrt(2).
    const double inv_sqrt3 = 1 / std::numbers::sqrt3, inv_sqrt6 = 1 / std::sqrt(6.0);
    const vec3 j1 = u, j2 = (2 * v - u) * inv_sqrt3, j3 = (3 * w - u - v) * inv_sqrt6;
    return {squared_norm(j1) + squared_norm(j2) + squared_norm(j3),
            std::numbers::sqrt2 * dot(u, cross(v, w))};
}
} // namespace detail

/// The conformal AMIPS energy described at the top of this file: 3 for a regular tet,
/// larger for any other shape, +infinity when flat or inverted (computed det <= 0).
inline double tet_amips(const vec3& a, const vec3& b, const vec3& c, const vec3& d) noexcept {
    const auto [frobenius_sq, det] = detail::amips_terms_of(a, b, c, d);
    if (!(det > 0)) return std::numeric_limits<double>::infinity();
    return frobenius_sq / std::cbrt(det * det);
}

/// tet_amips(a, b, c, d) to the power 3/2, without a cube root: with f = |J|_F^2 and
/// g = det J > 0 the energy is f / g^(2/3), so this is f^(3/2) / g, computed as (f / g) sqrt f,
/// finite wherever the energy is (and on tets flat enough that the energy's det^2 underflows).
/// Orders tets as the energy does, up to rounding; +infinity when flat or inverted. For
/// comparisons: the collapse's energy test weighs every tet of two stars, and libm's cbrt
/// was 8% of a run.
inline double tet_amips_three_halves(const vec3& a, const vec3& b, const vec3& c,
                                     const vec3& d) noexcept {
    const auto [frobenius_sq, det] = detail::amips_terms_of(a, b, c, d);
    if (!(det > 0)) return std::numeric_limits<double>::infinity();
    return frobenius_sq / det * std::sqrt(frobenius_sq);
}

/// AMIPS of the tet (p, b, c, d) as a function of its first vertex p, with its gradient
/// and Hessian there, for Newton smoothing of p. With J as above, f = |J|_F^2 and
/// g = det J (affine in p):
///     grad f = -2 (j1 + j2 / sqrt3 + j3 / sqrt6),  Hess f = 3 I,
///     grad g = -sqrt2 (c - b) x (d - b),           Hess g = 0,
/// and E = f g^(-2/3) gives
///     grad E = g^(-2/3) grad f - 2/3 f g^(-5/3) grad g,
///     Hess E = g^(-2/3) Hess f - 2/3 g^(-5/3) (grad f grad g^T + grad g grad f^T)
///              + 10/9 f g^(-8/3) grad g grad g^T.
/// The energy is +infinity (and the derivatives zero) when the computed det J <= 0: a
/// flat or inverted tet is a barrier, never a minimum to move towards.
struct amips_derivatives {
    double energy = std::numeric_limits<double>::infinity();
    vec3 gradient{};
    std::array<double, 9> hessian{}; // row-major, symmetric
};

inline amips_derivatives tet_amips_derivatives(const vec3& p, const vec3& b, const vec3& c,
                                               const vec3& d) noexcept {
    amips_derivatives out;
    const vec3 u = b - p, v = c - p, w = d - p;
    const double inv_sqrt3 = 1 / std::numbers::sqrt3, inv_sqrt6 = 1 / std::sqrt(6.0);
    const vec3 j1 = u, j2 = (2 * v - u) * inv_sqrt3, j3 = (3 * w - u - v) * inv_sqrt6;
    const double g = std::numbers::sqrt2 * dot(u, cross(v, w));
    if (!(g > 0)) return out;
    const double f = squared_norm(j1) + squared_norm(j2) + squared_norm(j3);
    const vec3 gf = (j1 + j2 * inv_sqrt3 + j3 * inv_sqrt6) * -2.0;
    const vec3 gg = cross(c - b, d - b) * -std::numbers::sqrt2;
    const double g23 = 1 / std::cbrt(g * g); // g^(-2/3)
    const double g53 = g23 / g, g83 = g53 / g;
    out.energy = f * g23;
    out.gradient = gf * g23 - gg * (2.0 / 3.0 * f * g53);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            out.hessian[3 * i + j] = (i == j ? 3.0 * g23 : 0.0) -
                                     2.0 / 3.0 * g53 * (gf[i] * gg[j] + gg[i] * gf[j]) +
                                     10.0 / 9.0 * f * g83 * gg[i] * gg[j];
    return out;
}

/// Lower bounds of the bins of `tet_quality_summary::amips_histogram`: quarter steps from
/// the regular tet's 3 to fTetWild's default stop energy 10, then coarser; bin i holds the
/// energies in [bound i, bound i + 1), the last bin everything from 1000 up. Flat and
/// inverted tets (infinite energy) are in no bin.
inline constexpr std::array<double, 35> amips_histogram_bounds = {
    3.0, 3.25, 3.5, 3.75, 4.0,  4.25, 4.5,  4.75, 5.0,  5.25,  5.5,   5.75,
    6.0, 6.25, 6.5, 6.75, 7.0,  7.25, 7.5,  7.75, 8.0,  8.25,  8.5,   8.75,
    9.0, 9.25, 9.5, 9.75, 10.0, 12.0, 15.0, 20.0, 50.0, 100.0, 1000.0};

struct tet_quality_summary {
    struct range {
        double min = 0, mean = 0, max = 0;
    };
    std::size_t tets = 0;
    std::size_t inverted = 0; // exact orient3d < 0
    std::size_t flat = 0;     // exact orient3d == 0
    double total_volume = 0;  // signed sum
    range volume;
    range dihedral_deg; // over all six angles of every tet
    /// AMIPS over the tets whose energy is finite (`amips_finite` of them); all zero when
    /// there are none.
    range amips;
    std::size_t amips_finite = 0;
    /// The finite energies by bin of amips_histogram_bounds (an energy rounded below 3
    /// counts in the first).
    std::array<std::size_t, amips_histogram_bounds.size()> amips_histogram{};
    /// idas::tet_quality over all tets (negative for inverted ones).
    range quality;
};

/// Summary of the tets (a, b, c, d) = (vertices[t[0]], ..., vertices[t[3]]) of `tets`.
/// Precondition: every index is in range (as the volume readers guarantee). Ranges of an
/// empty list are all zero.
inline tet_quality_summary summarize_tet_quality(std::span<const vec3> vertices,
                                                 std::span<const tet_indices> tets) {
    tet_quality_summary s;
    s.tets = tets.size();
    if (tets.empty()) return s;
    constexpr double inf = std::numeric_limits<double>::infinity();
    constexpr double to_deg = 180.0 / std::numbers::pi;
    using range = tet_quality_summary::range;
    range vol{inf, 0, -inf}, dih{inf, 0, -inf}, amips{inf, 0, -inf}, q{inf, 0, -inf};
    double sum_amips = 0, sum_q = 0, sum_dih = 0;
    for (const tet_indices& t : tets) {
        const vec3 &a = vertices[t[0]], &b = vertices[t[1]], &c = vertices[t[2]],
                   &d = vertices[t[3]];
        const int o = orient3d(a, b, c, d);
        s.inverted += o < 0 ? 1 : 0;
        s.flat += o == 0 ? 1 : 0;
        const double v = tet_signed_volume(a, b, c, d);
        s.total_volume += v;
        vol.min = std::min(vol.min, v), vol.max = std::max(vol.max, v);
        for (double angle : tet_dihedral_angles(a, b, c, d)) {
            dih.min = std::min(dih.min, angle), dih.max = std::max(dih.max, angle);
            sum_dih += angle;
        }
        const double e = tet_amips(a, b, c, d);
        if (e < inf) {
            const auto above =
                std::upper_bound(amips_histogram_bounds.begin(), amips_histogram_bounds.end(), e);
            ++s.amips_histogram[std::max<std::ptrdiff_t>(0, above - amips_histogram_bounds.begin() -
                                                                1)];
            ++s.amips_finite, sum_amips += e;
            amips.min = std::min(amips.min, e), amips.max = std::max(amips.max, e);
        }
        const double qt = tet_quality(a, b, c, d);
        sum_q += qt;
        q.min = std::min(q.min, qt), q.max = std::max(q.max, qt);
    }
    const auto n = static_cast<double>(tets.size());
    s.volume = {vol.min, s.total_volume / n, vol.max};
    s.dihedral_deg = {dih.min * to_deg, sum_dih / (6 * n) * to_deg, dih.max * to_deg};
    if (s.amips_finite > 0)
        s.amips = {amips.min, sum_amips / static_cast<double>(s.amips_finite), amips.max};
    s.quality = {q.min, sum_q / n, q.max};
    return s;
}

} // namespace idas
