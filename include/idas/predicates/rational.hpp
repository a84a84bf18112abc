// Exact rational points (GMP mpq) and the helpers TetWild-style insertion needs:
// exact conversion from doubles, correctly rounded conversion back, an exact orient3d on
// rational points and a check whether rounding a configuration to doubles keeps its
// orientation.
//
// orient3d here uses the same convention as idas::orient3d on doubles:
// sign det[b - a, c - a, d - a], +1 for a positively oriented tetrahedron (a, b, c, d).
//
// Thread safety: no shared mutable state; GMP is safe on distinct objects.
#pragma once

#include "idas/core/types.hpp"
#include "idas/predicates/orient.hpp"

#include <gmpxx.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <limits>

namespace idas {

/// Exact rational number.
using rational = mpq_class;

/// A point with exact rational coordinates.
struct rational_point {
    mpq_class x, y, z;

    const mpq_class& operator[](int i) const noexcept { return i == 0 ? x : (i == 1 ? y : z); }
    mpq_class& operator[](int i) noexcept { return i == 0 ? x : (i == 1 ? y : z); }

    friend bool operator==(const rational_point& a, const rational_point& b) {
        return a.x == b.x && a.y == b.y && a.z == b.z;
    }
};

/// Exact conversion (every finite double is a dyadic rational). Precondition: finite.
inline rational to_rational(double v) {
    assert(std::isfinite(v) && "to_rational: non-finite value");
    return rational(v); // mpq_set_d is exact
}

/// Exact conversion of a point. Precondition: finite coordinates.
inline rational_point to_rational(const vec3& p) {
    return {to_rational(p.x), to_rational(p.y), to_rational(p.z)};
}

namespace detail::predicates {

/// If q is exactly a double (dyadic, at most 53 significant bits, in range), stores it in
/// `out` and returns true. Allocation-free, so it is a cheap fast path.
inline bool exact_double(const mpq_class& q, double& out) noexcept {
    mpz_srcptr num = q.get_num_mpz_t();
    mpz_srcptr den = q.get_den_mpz_t(); // canonical: > 0
    if (mpz_sgn(num) == 0) {
        out = 0.0;
        return true;
    }
    const mp_bitcnt_t k = mpz_scan1(den, 0); // den == 2^k iff it has k + 1 bits
    if (mpz_sizeinbase(den, 2) != k + 1) return false;
    const mp_bitcnt_t t = mpz_scan1(num, 0); // trailing zeros (same for -num)
    const std::size_t bits = mpz_sizeinbase(num, 2);
    if (bits - t > 53) return false;
    const long lsb = static_cast<long>(t) - static_cast<long>(k);
    const long msb = static_cast<long>(bits) - 1 - static_cast<long>(k);
    if (lsb < -1074 || msb > 1023) return false;
    long e = 0;
    const double m = mpz_get_d_2exp(&e, num); // exact: at most 53 significant bits
    out = std::ldexp(m, static_cast<int>(e - static_cast<long>(k)));
    return true;
}

} // namespace detail::predicates

/// Nearest double to num / den (IEEE round-half-to-even), including gradual underflow
/// and overflow to +-infinity, for any den != 0: the fraction need not be reduced.
/// Scratch integers are kept per thread, so no allocation once they are large enough.
inline double to_double(const mpz_class& num, const mpz_class& den) {
    const int s = sgn(num) * sgn(den);
    if (s == 0) return 0.0;
    thread_local mpz_class n, d, lhs, rhs, quo, rem;
    mpz_abs(n.get_mpz_t(), num.get_mpz_t());
    mpz_abs(d.get_mpz_t(), den.get_mpz_t());

    // e = floor(log2(n / d)): start from the bit-length difference, which is e or e + 1.
    long e = static_cast<long>(mpz_sizeinbase(n.get_mpz_t(), 2)) -
             static_cast<long>(mpz_sizeinbase(d.get_mpz_t(), 2));
    // compare n with d * 2^e
    if (e >= 0) {
        mpz_mul_2exp(rhs.get_mpz_t(), d.get_mpz_t(), static_cast<mp_bitcnt_t>(e));
        if (mpz_cmp(n.get_mpz_t(), rhs.get_mpz_t()) < 0) --e;
    } else {
        mpz_mul_2exp(lhs.get_mpz_t(), n.get_mpz_t(), static_cast<mp_bitcnt_t>(-e));
        if (mpz_cmp(lhs.get_mpz_t(), d.get_mpz_t()) < 0) --e;
    }
    if (e > std::numeric_limits<double>::max_exponent) // >= 2^1025: certainly overflows
        return s * std::numeric_limits<double>::infinity();
    if (e < -1076) return s * 0.0; // below half the smallest subnormal: rounds to zero

    // ulp exponent of the result: 52 bits below the leading one, but not below 2^-1074.
    const long k = std::max(e - 52, -1074L);
    // Q = floor(|q| / 2^k), R = remainder, then round half to even.
    if (k < 0)
        mpz_mul_2exp(n.get_mpz_t(), n.get_mpz_t(), static_cast<mp_bitcnt_t>(-k));
    else
        mpz_mul_2exp(d.get_mpz_t(), d.get_mpz_t(), static_cast<mp_bitcnt_t>(k));
    mpz_tdiv_qr(quo.get_mpz_t(), rem.get_mpz_t(), n.get_mpz_t(), d.get_mpz_t());
    mpz_mul_2exp(rem.get_mpz_t(), rem.get_mpz_t(), 1);
    const int c = mpz_cmp(rem.get_mpz_t(), d.get_mpz_t());
    if (c > 0 || (c == 0 && mpz_odd_p(quo.get_mpz_t())))
        mpz_add_ui(quo.get_mpz_t(), quo.get_mpz_t(), 1);
    const double m = mpz_get_d(quo.get_mpz_t());   // quo <= 2^53: exact
    return s * std::ldexp(m, static_cast<int>(k)); // exact, or overflow to infinity
}

/// Nearest double to q (IEEE round-half-to-even), including gradual underflow and
/// overflow to +-infinity. (mpq_get_d truncates, so it is not used.)
inline double to_double(const mpq_class& q) {
    double exact = 0.0;
    if (detail::predicates::exact_double(q, exact)) return exact;
    return to_double(q.get_num(), q.get_den());
}

/// Rounds each coordinate to the nearest double.
inline vec3 to_vec3(const rational_point& p) {
    return {to_double(p.x), to_double(p.y), to_double(p.z)};
}

/// How far, at most, a point's coordinates lie from the doubles to_vec3 rounds them to,
/// given those doubles: half an ulp of the largest, doubled for room, and at least
/// 2^-1020 (more than half the spacing of subnormals, and itself a normal number).
inline double rounding_radius(const vec3& nearest) noexcept {
    const double largest =
        std::max({std::fabs(nearest.x), std::fabs(nearest.y), std::fabs(nearest.z)});
    return 0x1p-52 * largest + 0x1p-1020;
}

namespace detail::predicates {

/// Integer row proportional (by a positive factor) to p - a.
inline void rational_row(const rational_point& p, const rational_point& a,
                         std::array<mpz_class, 3>& row) {
    std::array<mpz_class, 3> num, den;
    for (int k = 0; k < 3; ++k) {
        const mpq_class& pk = p[k];
        const mpq_class& ak = a[k];
        if (pk.get_den() == ak.get_den()) {
            num[k] = pk.get_num() - ak.get_num();
            den[k] = pk.get_den();
        } else {
            num[k] = pk.get_num() * ak.get_den() - ak.get_num() * pk.get_den();
            den[k] = pk.get_den() * ak.get_den();
        }
    }
    if (den[0] == den[1] && den[1] == den[2]) {
        row = num; // multiply the row by den > 0
    } else {       // multiply the row by den0 * den1 * den2 > 0
        row[0] = num[0] * den[1] * den[2];
        row[1] = num[1] * den[0] * den[2];
        row[2] = num[2] * den[0] * den[1];
    }
}

/// orient3d on rational points with integer arithmetic only (no fast path).
inline int orient3d_rational_mpz(const rational_point& a, const rational_point& b,
                                 const rational_point& c, const rational_point& d) {
    // Scaling each row by a positive factor keeps the sign, so clear denominators per row
    // and work on integers (no gcd normalisation inside the determinant).
    std::array<mpz_class, 3> u, v, w;
    rational_row(b, a, u);
    rational_row(c, a, v);
    rational_row(d, a, w);
    const mpz_class det = u[0] * (v[1] * w[2] - v[2] * w[1]) + u[1] * (v[2] * w[0] - v[0] * w[2]) +
                          u[2] * (v[0] * w[1] - v[1] * w[0]);
    return sgn(det);
}

} // namespace detail::predicates

/// Exact sign of det[b - a, c - a, d - a] for rational points (same convention as
/// idas::orient3d on doubles). When every coordinate is exactly a double (e.g. points made
/// by to_rational), the exact double predicate is used; otherwise GMP integers.
inline int orient3d(const rational_point& a, const rational_point& b, const rational_point& c,
                    const rational_point& d) {
    namespace dp = detail::predicates;
    std::array<vec3, 4> pd;
    const std::array<const rational_point*, 4> pq{&a, &b, &c, &d};
    bool all_double = true;
    for (int i = 0; i < 4 && all_double; ++i)
        for (int k = 0; k < 3 && all_double; ++k)
            all_double = dp::exact_double((*pq[i])[k], pd[i][k]);
    if (all_double) return orient3d(pd[0], pd[1], pd[2], pd[3]);
    return dp::orient3d_rational_mpz(a, b, c, d);
}

/// Orientation of four rational points exactly and after rounding every coordinate to
/// the nearest double.
struct orient3d_rounding_result {
    int exact = 0;   ///< orient3d of the rational points
    int rounded = 0; ///< orient3d of the rounded points (exact predicate on the doubles)

    bool preserved() const noexcept { return exact == rounded; }
};

inline orient3d_rounding_result orient3d_with_rounding(const rational_point& a,
                                                       const rational_point& b,
                                                       const rational_point& c,
                                                       const rational_point& d) {
    return {orient3d(a, b, c, d), orient3d(to_vec3(a), to_vec3(b), to_vec3(c), to_vec3(d))};
}

/// True iff rounding all four points to doubles keeps the exact orientation sign (in
/// particular a rounded positive tet stays positive, and a degenerate one stays flat).
/// Precondition: the rounded coordinates are finite.
inline bool rounding_preserves_orient3d(const rational_point& a, const rational_point& b,
                                        const rational_point& c, const rational_point& d) {
    return orient3d_with_rounding(a, b, c, d).preserved();
}

} // namespace idas
