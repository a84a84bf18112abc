// Exact orientation predicates orient2d / orient3d on double inputs.
//
// Conventions (right-handed coordinates):
//   orient2d(a, b, c) = sign det[b - a, c - a]
//                     = sign((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x))
//     +1 when a, b, c turn counter-clockwise (c lies left of the directed line a->b),
//     -1 when clockwise, 0 when collinear.
//   orient3d(a, b, c, d) = sign det[b - a, c - a, d - a]   (the vectors are the rows)
//     +1 when the tetrahedron (a, b, c, d) is positively oriented, i.e. d lies on the side
//     of the plane through a, b, c from which a, b, c are seen counter-clockwise
//     (e.g. a = 0, b = e_x, c = e_y, d = e_z gives +1); -1 on the other side; 0 when
//     coplanar. NOTE: this is the opposite sign of Shewchuk's orient3d.
//
// Both results are exact for all finite inputs (no overflow, underflow or rounding
// failure). Non-finite inputs are a precondition violation (asserted; 0 in release).
//
// Evaluation proceeds in three stages:
//   1. Floating-point filter. The determinant is evaluated in doubles together with an
//      a-posteriori error bound built from the "permanent" (the same expression with every
//      term replaced by its absolute value), in the spirit of Shewchuk's stage A but with
//      our own constants and an additive term that keeps the bound valid under gradual
//      underflow. The sign is returned when |det| exceeds the bound. Overflow produces
//      inf/NaN in the bound, which makes the comparison fail and falls through.
//   2. Exact expansion arithmetic (two-sum, and two-product via std::fma). Every term of
//      the determinant is written as an exact sum of doubles and accumulated into a
//      non-overlapping expansion whose leading component gives the sign. This is exact
//      as long as no error term underflows or overflows, which a cheap range check on the
//      inputs guarantees; inputs are first rescaled by a power of two (which preserves
//      the sign) to bring them into that range when their dynamic range allows it.
//   3. GMP integers (mpz) for the rare inputs whose dynamic range is too wide for stage 2
//      (e.g. 1e-300 together with 1e300): every double is an integer multiple of 2^-1074,
//      so the determinant is evaluated exactly on scaled integers.
// Stage 2 was chosen over GMP as the main exact path because it avoids heap allocation
// and is several times faster (see bench/bench_predicates.cpp).
//
// Floating-point requirements: IEEE-754 binary64 with round-to-nearest and no excess
// precision (FLT_EVAL_METHOD == 0). The code is correct whether or not the compiler
// contracts a * b + c into fused multiply-adds (-ffp-contract=fast or off): the filter's
// error analysis covers both, and the error-free transforms use explicit std::fma and
// contain no contractible expressions. -ffast-math is rejected at compile time.
//
// Thread safety: no mutable global state. With IDAS_PREDICATE_STATS defined (it must then
// be defined in every translation unit), per-thread counters record which stage decided
// each call; see idas::predicate_counters().
#pragma once

#include "idas/core/types.hpp"

#include <gmpxx.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#if defined(__FAST_MATH__)
#error "idas/predicates/orient.hpp needs IEEE floating-point semantics; do not use -ffast-math"
#endif
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD != 0
#error "idas/predicates/orient.hpp needs FLT_EVAL_METHOD == 0 (no excess precision, e.g. SSE2)"
#endif

namespace idas {

#ifdef IDAS_PREDICATE_STATS
/// Which stage decided each predicate call, counted per thread.
struct predicate_stats {
    std::uint64_t orient2d_filtered = 0; ///< decided by the floating-point filter
    std::uint64_t orient2d_exact = 0;    ///< decided by expansion arithmetic
    std::uint64_t orient2d_bignum = 0;   ///< decided by GMP (extreme dynamic range)
    std::uint64_t orient3d_filtered = 0;
    std::uint64_t orient3d_exact = 0;
    std::uint64_t orient3d_bignum = 0;

    void reset() noexcept { *this = predicate_stats{}; }
};

/// The calling thread's counters (thread_local, so no synchronisation is needed).
inline predicate_stats& predicate_counters() noexcept {
    thread_local predicate_stats stats;
    return stats;
}
#define IDAS_DETAIL_PRED_COUNT(field) (++::idas::predicate_counters().field)
#else
#define IDAS_DETAIL_PRED_COUNT(field) ((void)0)
#endif

namespace detail::predicates {

// ---------------------------------------------------------------------------------------
// Filter constants. eps = 2^-53 is the unit roundoff.
//
// orient3d: det = ux*(vy*wz - vz*wy) + uy*(vz*wx - vx*wz) + uz*(vx*wy - vy*wx) with
// u = b - a, v = c - a, w = d - a. Before the last (sign-preserving, monotone) rounding,
// each of the six terms carries at most 7 relative roundings (3 differences, product,
// minor, outer product, one summation), also when products are fused into fmas. So
// |det_before_last_rounding - det| <= ((1+eps)^7 - 1) P + E_u, where P is the exact
// permanent and E_u collects underflow errors: each of the at most 9 product/fma
// roundings can add an absolute error <= 2^-1075, the six inside the minors amplified by
// |u_i|, so E_u <= (|ux|+|uy|+|uz| + 2) * 2^-1074 (with room to spare).
// The computed permanent P' >= P (1-eps)^8 (minus negligible underflow losses) and the
// computed bound carries 3 more roundings, so A (1-eps)^11 >= (1+eps)^7 - 1 is needed,
// i.e. A >= 7 eps + 98 eps^2 + O(eps^3); we use A = 7 eps + 128 eps^2. The additive
// term (|u~|_1 + 1) * 2^-1072 is four times the underflow bound, which absorbs the
// rounding/underflow losses incurred while computing the bound itself (the constant
// actually used is larger still, see below).
// Because the final rounding is monotone and the bound is a double, fl(det) > bound
// implies det_before_last_rounding > bound >= its error, so the sign is certain.
//
// orient2d: det = ux*vy - uy*vx; each term carries 3 roundings before the last one,
// P' >= P (1-eps)^4, the bound 2 more: A (1-eps)^6 >= (1+eps)^3 - 1, i.e.
// A >= 3 eps + 21 eps^2 + O(eps^3); we use 3 eps + 64 eps^2, plus 2^-1072 for the
// (at most two) underflowing products.
//
// Both analyses only need the underflow constant to be >= 2^-1072. We use the normal
// number 2^-1020 instead, so that neither it nor (|u|_1 + 1) * 2^-1020 is subnormal:
// subnormal operands or results cost a microcode assist (~100 cycles) on x86, which made
// the filter 7x slower in measurements. The larger constant only sends
// |det| < ~2^-1020 * (|u|_1 + 1) to the exact stage.
inline constexpr double o2d_rel_bound = (3.0 + 0x1p-47) * 0x1p-53;
inline constexpr double o3d_rel_bound = (7.0 + 0x1p-46) * 0x1p-53;
inline constexpr double underflow_bound = 0x1p-1020;

// ---------------------------------------------------------------------------------------
// Error-free transforms (round-to-nearest). None contains a contractible a*b+c.

/// s + e == a + b exactly, s = fl(a + b) (Knuth's branch-free two-sum).
inline void two_sum(double a, double b, double& s, double& e) noexcept {
    s = a + b;
    const double b_virtual = s - a;
    const double a_virtual = s - b_virtual;
    e = (a - a_virtual) + (b - b_virtual);
}

/// p + e == a * b exactly, p = fl(a * b); requires that the error is representable,
/// i.e. no underflow below 2^-1074 granularity and no overflow.
inline void two_product(double a, double b, double& p, double& e) noexcept {
    p = a * b;
    e = std::fma(a, b, -p);
}

/// A non-overlapping expansion grown one double at a time, with zero elimination.
/// Components are stored in increasing magnitude; the sign of the sum is the sign of the
/// largest component. Capacity N must be at least the number of doubles added.
template <std::size_t N>
struct sum_accumulator {
    std::array<double, N> c;
    std::size_t n = 0;

    // Branch-free zero elimination: whether a component vanishes is data dependent and
    // unpredictable, so compare-and-increment beats a branch.
    void add(double x) noexcept {
        const std::size_t len = n;
        std::size_t m = 0;
        for (std::size_t i = 0; i < len; ++i) {
            double s, e;
            two_sum(x, c[i], s, e);
            c[m] = e;
            m += e != 0.0;
            x = s;
        }
        c[m] = x; // m <= n < N: at most N doubles are ever added
        m += x != 0.0;
        n = m;
    }

    /// Adds sign * x * y * z exactly (4 doubles).
    void add_product3(double sign, double x, double y, double z) noexcept {
        double p, e, p1, e1, p2, e2;
        two_product(x, y, p, e);
        two_product(p, z, p1, e1);
        two_product(e, z, p2, e2);
        add(sign * e2);
        add(sign * e1);
        add(sign * p2);
        add(sign * p1);
    }

    /// Adds sign * x * y exactly (2 doubles).
    void add_product2(double sign, double x, double y) noexcept {
        double p, e;
        two_product(x, y, p, e);
        add(sign * e);
        add(sign * p);
    }

    int sign() const noexcept { return n == 0 ? 0 : (c[n - 1] > 0.0 ? 1 : -1); }
};

/// Range of ilogb() that makes degree-k expansion arithmetic exact. After rescaling,
/// every coordinate x must satisfy ilogb(|x|) <= max_exp, and every nonzero one
/// ilogb(|x|) >= min_exp: then all coordinates (and exact differences) are multiples of
/// 2^(min_exp - 52) and below 2^(max_exp + 2), so products of k of them have
/// representable errors (k * (min_exp - 52) >= -1074) and all sums stay below 2^1023.
///   degree 3: multiples of 2^-352 (3 * -352 = -1056), |x| < 2^330, |diff|^3 < 2^993.
///   degree 2: multiples of 2^-530 (2 * -530 = -1060), |x| < 2^500, |diff|^2 < 2^1002.
struct exact_range {
    int max_exp;
    int min_exp;
};
inline constexpr exact_range degree3_range{329, -300};
inline constexpr exact_range degree2_range{499, -478};

/// ilogb(a) for finite a > 0, reading the exponent field directly (libm's ilogb is an
/// out-of-line call); subnormals take the slow path.
inline int exponent_of(double a) noexcept {
    const auto biased = static_cast<int>((std::bit_cast<std::uint64_t>(a) >> 52) & 0x7ff);
    return biased != 0 ? biased - 1023 : std::ilogb(a);
}

/// Decides how to bring the coordinates into range: returns false when the dynamic
/// range is too wide (bignum needed); otherwise sets `scale` to the power of two to
/// apply (0 when already in range) and `all_zero` when every coordinate is zero.
template <std::size_t N>
inline bool choose_scale(const std::array<double, N>& x, exact_range r, int& scale,
                         bool& all_zero) noexcept {
    double hi = 0.0, lo = std::numeric_limits<double>::infinity();
    for (double v : x) {
        const double a = std::fabs(v);
        hi = std::max(hi, a);
        if (a != 0.0) lo = std::min(lo, a);
    }
    scale = 0;
    all_zero = hi == 0.0;
    if (all_zero) return true;
    const int ehi = exponent_of(hi), elo = exponent_of(lo);
    if (ehi <= r.max_exp && elo >= r.min_exp) return true;
    if (ehi - elo > r.max_exp - r.min_exp) return false;
    scale = r.max_exp - ehi;
    return true;
}

/// Exact integer m * 2^shift representing x, where x = m * 2^(exponent) and `min_exp` is
/// the smallest exponent among the inputs (so the shift is non-negative).
inline void to_scaled_mpz(double x, int exponent, int min_exp, mpz_class& out) {
    mpz_set_d(out.get_mpz_t(), x); // x here is an integer-valued mantissa, exact
    mpz_mul_2exp(out.get_mpz_t(), out.get_mpz_t(), static_cast<mp_bitcnt_t>(exponent - min_exp));
}

/// Converts all coordinates to integers sharing one power-of-two scale factor.
template <std::size_t N>
inline void to_common_mpz(const std::array<double, N>& x, std::array<mpz_class, N>& out) {
    std::array<double, N> mant{};
    std::array<int, N> expo{};
    int min_exp = 0;
    bool first = true;
    for (std::size_t i = 0; i < N; ++i) {
        if (x[i] == 0.0) continue;
        int e = 0;
        const double f = std::frexp(x[i], &e); // x = f * 2^e, 0.5 <= |f| < 1
        mant[i] = std::ldexp(f, 53);           // integer, |mant| < 2^53
        expo[i] = e - 53;                      // x = mant * 2^(e-53), exact
        min_exp = first ? expo[i] : std::min(min_exp, expo[i]);
        first = false;
    }
    for (std::size_t i = 0; i < N; ++i) {
        if (x[i] == 0.0)
            out[i] = 0;
        else
            to_scaled_mpz(mant[i], expo[i], min_exp, out[i]);
    }
}

inline bool all_finite(const double* x, std::size_t n) noexcept {
    for (std::size_t i = 0; i < n; ++i)
        if (!std::isfinite(x[i])) return false;
    return true;
}

// Coordinate layout used by the exact stages: orient2d {ax, ay, bx, by, cx, cy};
// orient3d {ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz}.

/// orient2d with GMP integers; exact for all finite inputs.
inline int orient2d_bignum(const std::array<double, 6>& x) {
    std::array<mpz_class, 6> z;
    to_common_mpz(x, z);
    const mpz_class ux = z[2] - z[0], uy = z[3] - z[1];
    const mpz_class vx = z[4] - z[0], vy = z[5] - z[1];
    const mpz_class det = ux * vy - uy * vx;
    return sgn(det);
}

/// orient3d with GMP integers; exact for all finite inputs.
inline int orient3d_bignum(const std::array<double, 12>& x) {
    std::array<mpz_class, 12> z;
    to_common_mpz(x, z);
    const mpz_class ux = z[3] - z[0], uy = z[4] - z[1], uz = z[5] - z[2];
    const mpz_class vx = z[6] - z[0], vy = z[7] - z[1], vz = z[8] - z[2];
    const mpz_class wx = z[9] - z[0], wy = z[10] - z[1], wz = z[11] - z[2];
    const mpz_class mx = vy * wz - vz * wy;
    const mpz_class my = vz * wx - vx * wz;
    const mpz_class mz = vx * wy - vy * wx;
    const mpz_class det = ux * mx + uy * my + uz * mz;
    return sgn(det);
}

/// Exact orient2d via expansions (GMP only for extreme dynamic range).
inline int orient2d_exact(const std::array<double, 6>& in) {
    assert(all_finite(in.data(), in.size()) && "orient2d: non-finite coordinate");
    if (!all_finite(in.data(), in.size())) return 0;
    int scale = 0;
    bool all_zero = false;
    if (!choose_scale(in, degree2_range, scale, all_zero)) {
        IDAS_DETAIL_PRED_COUNT(orient2d_bignum);
        return orient2d_bignum(in);
    }
    IDAS_DETAIL_PRED_COUNT(orient2d_exact);
    if (all_zero) return 0;
    std::array<double, 6> x = in;
    if (scale != 0)
        for (double& v : x) v = std::ldexp(v, scale); // exact by choice of scale

    // u = b - a, v = c - a as exact (hi, lo) pairs.
    double u[2][2], v[2][2]; // [coordinate][hi/lo]
    for (int k = 0; k < 2; ++k) {
        two_sum(x[2 + k], -x[k], u[k][0], u[k][1]);
        two_sum(x[4 + k], -x[k], v[k][0], v[k][1]);
    }
    // det = ux*vy - uy*vx: 2 terms x 4 (hi/lo) combinations x 2 doubles.
    sum_accumulator<16> acc;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            acc.add_product2(1.0, u[0][i], v[1][j]);
            acc.add_product2(-1.0, u[1][i], v[0][j]);
        }
    return acc.sign();
}

/// Exact orient3d via expansions (GMP only for extreme dynamic range).
inline int orient3d_exact(const std::array<double, 12>& in) {
    assert(all_finite(in.data(), in.size()) && "orient3d: non-finite coordinate");
    if (!all_finite(in.data(), in.size())) return 0;
    int scale = 0;
    bool all_zero = false;
    if (!choose_scale(in, degree3_range, scale, all_zero)) {
        IDAS_DETAIL_PRED_COUNT(orient3d_bignum);
        return orient3d_bignum(in);
    }
    IDAS_DETAIL_PRED_COUNT(orient3d_exact);
    if (all_zero) return 0;
    std::array<double, 12> x = in;
    if (scale != 0)
        for (double& v : x) v = std::ldexp(v, scale); // exact by choice of scale

    // Rows r[0] = b - a, r[1] = c - a, r[2] = d - a as exact (hi, lo) pairs.
    double r[3][3][2]; // [row][coordinate][hi/lo]
    bool has_lo = false;
    for (int row = 0; row < 3; ++row)
        for (int k = 0; k < 3; ++k) {
            two_sum(x[3 * (row + 1) + k], -x[k], r[row][k][0], r[row][k][1]);
            has_lo = has_lo || r[row][k][1] != 0.0;
        }

    // det = sum over permutations s of sgn(s) r0[s0] r1[s1] r2[s2].
    static constexpr int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},
                                       {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    static constexpr double perm_sign[6] = {1.0, 1.0, 1.0, -1.0, -1.0, -1.0};
    sum_accumulator<192> acc; // 6 permutations x 8 hi/lo choices x 4 doubles
    const int parts = has_lo ? 2 : 1;
    for (int p = 0; p < 6; ++p)
        for (int i = 0; i < parts; ++i)
            for (int j = 0; j < parts; ++j)
                for (int k = 0; k < parts; ++k)
                    acc.add_product3(perm_sign[p], r[0][perm[p][0]][i], r[1][perm[p][1]][j],
                                     r[2][perm[p][2]][k]);
    return acc.sign();
}

} // namespace detail::predicates

/// Sign of det[b - a, c - a]: +1 if a, b, c are counter-clockwise, -1 if clockwise, 0 if
/// collinear. Exact for all finite inputs.
inline int orient2d(const std::array<double, 2>& a, const std::array<double, 2>& b,
                    const std::array<double, 2>& c) {
    namespace dp = detail::predicates;
    const double ux = b[0] - a[0], uy = b[1] - a[1];
    const double vx = c[0] - a[0], vy = c[1] - a[1];
    const double t1 = ux * vy, t2 = uy * vx;
    const double det = t1 - t2;
    const double perm = std::fabs(t1) + std::fabs(t2);
    const double bound = dp::o2d_rel_bound * perm + dp::underflow_bound;
    if (det > bound) {
        IDAS_DETAIL_PRED_COUNT(orient2d_filtered);
        return 1;
    }
    if (-det > bound) {
        IDAS_DETAIL_PRED_COUNT(orient2d_filtered);
        return -1;
    }
    return dp::orient2d_exact({a[0], a[1], b[0], b[1], c[0], c[1]});
}

/// det[b - a, c - a, d - a] in doubles, with a bound on its error: the exact determinant
/// of the doubles lies within `bound` of `det` (the filter's analysis above).
struct orient3d_estimate {
    double det, bound;
};
inline orient3d_estimate orient3d_with_bound(const vec3& a, const vec3& b, const vec3& c,
                                             const vec3& d) noexcept {
    namespace dp = detail::predicates;
    const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
    const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
    const double wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
    const double vywz = vy * wz, vzwy = vz * wy;
    const double vzwx = vz * wx, vxwz = vx * wz;
    const double vxwy = vx * wy, vywx = vy * wx;
    const double det = ux * (vywz - vzwy) + uy * (vzwx - vxwz) + uz * (vxwy - vywx);
    const double aux = std::fabs(ux), auy = std::fabs(uy), auz = std::fabs(uz);
    const double perm = aux * (std::fabs(vywz) + std::fabs(vzwy)) +
                        auy * (std::fabs(vzwx) + std::fabs(vxwz)) +
                        auz * (std::fabs(vxwy) + std::fabs(vywx));
    return {det, dp::o3d_rel_bound * perm + (aux + auy + auz + 1.0) * dp::underflow_bound};
}

/// The sign of orient3d(a, b, c, d) where floating point alone proves it: +1 or -1, and 0
/// when it cannot tell (the points are coplanar or nearly so). Lets a caller try a
/// cheaper exact argument before paying for the exact fallback.
inline int orient3d_filtered(const vec3& a, const vec3& b, const vec3& c, const vec3& d) noexcept {
    const auto [det, bound] = orient3d_with_bound(a, b, c, d);
    return det > bound ? 1 : -det > bound ? -1 : 0;
}

/// The sign of orient3d(a*, b*, c*, d*) shared by every a* within `ra` of a in each
/// coordinate, b* within `rb` of b, and so on: +1 or -1 where floating point proves it, 0
/// when it cannot tell. With each radius the rounding error of a point's nearest double
/// (rounding_radius in predicates/rational.hpp), it decides the orientation of exact
/// rational points from their doubles, without the rational arithmetic.
///
/// The exact determinant of the doubles lies within orient3d_with_bound's bound of the
/// computed one. Moving the points moves each row (b - a, c - a, d - a) by at most
/// E = ra + rb (and so on) per coordinate, and each of the determinant's six products of
/// one entry per row, with entries at most M in magnitude, by at most
/// (M_u + E_u)(M_v + E_v)(M_w + E_w) - M_u M_v M_w, summed here term by term (all
/// positive, so no cancellation); M is the computed difference's magnitude raised by an
/// ulp, and the sum is raised by 2^-40 of itself for the roundings in computing it.
/// Overflow makes a bound infinite or NaN, and the answer 0.
inline int orient3d_within(const vec3& a, const vec3& b, const vec3& c, const vec3& d, double ra,
                           double rb, double rc, double rd) noexcept {
    const auto [det, bound] = orient3d_with_bound(a, b, c, d);
    const auto magnitude = [](const vec3& p, const vec3& q) {
        return std::max({std::fabs(p.x - q.x), std::fabs(p.y - q.y), std::fabs(p.z - q.z)}) *
               (1.0 + 0x1p-52);
    };
    const double mu = magnitude(b, a), mv = magnitude(c, a), mw = magnitude(d, a);
    const double eu = ra + rb, ev = ra + rc, ew = ra + rd;
    const double moved = 6.0 * (eu * (mv + ev) * (mw + ew) + mu * ev * (mw + ew) + mu * mv * ew);
    const double total = (bound + moved) * (1.0 + 0x1p-40);
    return det > total ? 1 : -det > total ? -1 : 0;
}

/// Sign of det[b - a, c - a, d - a]: +1 if the tetrahedron (a, b, c, d) is positively
/// oriented (d on the side from which a, b, c appear counter-clockwise), -1 if negatively,
/// 0 if coplanar. Exact for all finite inputs.
inline int orient3d(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    if (const int s = orient3d_filtered(a, b, c, d)) {
        IDAS_DETAIL_PRED_COUNT(orient3d_filtered);
        return s;
    }
    return detail::predicates::orient3d_exact(
        {a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, d.x, d.y, d.z});
}

} // namespace idas
