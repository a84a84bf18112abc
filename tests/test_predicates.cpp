// Exact orientation predicates: idas/predicates/orient.hpp and rational.hpp.
#include <doctest/doctest.h>

#include "idas/predicates/orient.hpp"
#include "idas/predicates/rational.hpp"

#include <gmpxx.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace {

using idas::vec3;
using pt2 = std::array<double, 2>;
namespace dp = idas::detail::predicates;

// ---- independent references (plain mpq arithmetic on the exact input values) ----

int ref_orient2d(const pt2& a, const pt2& b, const pt2& c) {
    const mpq_class ux = mpq_class(b[0]) - mpq_class(a[0]), uy = mpq_class(b[1]) - mpq_class(a[1]);
    const mpq_class vx = mpq_class(c[0]) - mpq_class(a[0]), vy = mpq_class(c[1]) - mpq_class(a[1]);
    return sgn(mpq_class(ux * vy - uy * vx));
}

int ref_orient3d_q(const std::array<mpq_class, 3>& a, const std::array<mpq_class, 3>& b,
                   const std::array<mpq_class, 3>& c, const std::array<mpq_class, 3>& d) {
    std::array<std::array<mpq_class, 3>, 3> m;
    for (int k = 0; k < 3; ++k) {
        m[0][k] = b[k] - a[k];
        m[1][k] = c[k] - a[k];
        m[2][k] = d[k] - a[k];
    }
    const mpq_class det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                          m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                          m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return sgn(det);
}

std::array<mpq_class, 3> q3(const vec3& p) {
    return {mpq_class(p.x), mpq_class(p.y), mpq_class(p.z)};
}

int ref_orient3d(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    return ref_orient3d_q(q3(a), q3(b), q3(c), q3(d));
}

// ---- naive double evaluation of the same formulas (to show they fail) ----

[[gnu::noinline]] int naive_orient2d(const pt2& a, const pt2& b, const pt2& c) {
    const double det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    return (det > 0) - (det < 0);
}

[[gnu::noinline]] int naive_orient3d(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    const vec3 u = b - a, v = c - a, w = d - a;
    const double det = u.x * (v.y * w.z - v.z * w.y) + u.y * (v.z * w.x - v.x * w.z) +
                       u.z * (v.x * w.y - v.y * w.x);
    return (det > 0) - (det < 0);
}

std::array<double, 6> flat2(const pt2& a, const pt2& b, const pt2& c) {
    return {a[0], a[1], b[0], b[1], c[0], c[1]};
}
std::array<double, 12> flat3(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    return {a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, d.x, d.y, d.z};
}

/// All evaluation paths (filtered, expansion, bignum) against the mpq reference.
void check_all_paths2(const pt2& a, const pt2& b, const pt2& c) {
    const int r = ref_orient2d(a, b, c);
    REQUIRE(idas::orient2d(a, b, c) == r);
    REQUIRE(dp::orient2d_exact(flat2(a, b, c)) == r);
    REQUIRE(dp::orient2d_bignum(flat2(a, b, c)) == r);
}
void check_all_paths3(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    const int r = ref_orient3d(a, b, c, d);
    REQUIRE(idas::orient3d(a, b, c, d) == r);
    REQUIRE(dp::orient3d_exact(flat3(a, b, c, d)) == r);
    REQUIRE(dp::orient3d_bignum(flat3(a, b, c, d)) == r);
}

/// Permutation consistency: odd permutations flip the sign, even ones keep it.
void check_permutations3(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    using idas::orient3d;
    const int s = orient3d(a, b, c, d);
    REQUIRE(orient3d(b, a, c, d) == -s);
    REQUIRE(orient3d(a, c, b, d) == -s);
    REQUIRE(orient3d(a, b, d, c) == -s);
    REQUIRE(orient3d(d, b, c, a) == -s);
    REQUIRE(orient3d(b, c, a, d) == s);
    REQUIRE(orient3d(c, a, b, d) == s);
    REQUIRE(orient3d(b, a, d, c) == s);
    REQUIRE(orient3d(a, c, d, b) == s);
    REQUIRE(orient3d(d, c, b, a) == s);
}
void check_permutations2(const pt2& a, const pt2& b, const pt2& c) {
    using idas::orient2d;
    const int s = orient2d(a, b, c);
    REQUIRE(orient2d(b, a, c) == -s);
    REQUIRE(orient2d(a, c, b) == -s);
    REQUIRE(orient2d(c, b, a) == -s);
    REQUIRE(orient2d(b, c, a) == s);
    REQUIRE(orient2d(c, a, b) == s);
}

} // namespace

TEST_CASE("orient2d/orient3d: sign conventions") {
    CHECK(idas::orient2d({0, 0}, {1, 0}, {0, 1}) == 1);
    CHECK(idas::orient2d({0, 0}, {0, 1}, {1, 0}) == -1);
    CHECK(idas::orient2d({0, 0}, {1, 1}, {3, 3}) == 0);
    CHECK(idas::orient2d({2, 2}, {2, 2}, {2, 2}) == 0);

    const vec3 o{0, 0, 0}, ex{1, 0, 0}, ey{0, 1, 0}, ez{0, 0, 1};
    CHECK(idas::orient3d(o, ex, ey, ez) == 1);
    CHECK(idas::orient3d(o, ey, ex, ez) == -1);
    CHECK(idas::orient3d(o, ex, ey, vec3{0, 0, -1}) == -1);
    CHECK(idas::orient3d(o, ex, ey, vec3{5, 7, 0}) == 0);
    CHECK(idas::orient3d(o, o, o, o) == 0);
    CHECK(idas::orient3d(vec3{1e300, -1e300, 0}, vec3{-1e300, 1e300, 1}, vec3{1, 1, 1e300},
                         vec3{0, 0, 0}) == ref_orient3d(vec3{1e300, -1e300, 0},
                                                        vec3{-1e300, 1e300, 1}, vec3{1, 1, 1e300},
                                                        vec3{0, 0, 0}));
}

TEST_CASE("orient2d: classic ulp grid around (0.5, 0.5) against (12, 12), (24, 24)") {
    const pt2 q{12, 12}, r{24, 24};
    int naive_wrong = 0, zeros = 0;
    double x = 0.5;
    for (int i = 0; i < 256; ++i, x = std::nextafter(x, HUGE_VAL)) {
        double y = 0.5;
        for (int j = 0; j < 256; ++j, y = std::nextafter(y, HUGE_VAL)) {
            const pt2 p{x, y};
            const int ref = ref_orient2d(p, q, r);
            REQUIRE(idas::orient2d(p, q, r) == ref);
            REQUIRE(idas::orient2d(q, r, p) == ref);
            REQUIRE(idas::orient2d(r, p, q) == ref);
            REQUIRE(idas::orient2d(q, p, r) == -ref);
            naive_wrong += naive_orient2d(p, q, r) != ref;
            zeros += ref == 0;
        }
    }
    CHECK(zeros == 256); // exactly the diagonal i == j is collinear
    CHECK(naive_wrong > 0);
    MESSAGE("naive orient2d wrong on " << naive_wrong << " of 65536 grid points");
}

TEST_CASE("orient3d: ulp grid around a point near the line (12,12,12)-(24,24,24)") {
    const vec3 q{12, 12, 12}, r{24, 24, 24}, s{1, 2, 3}, t{-7, 0.25, 5};
    int naive_wrong = 0, zeros = 0;
    double x = 0.5;
    for (int i = 0; i < 32; ++i, x = std::nextafter(x, HUGE_VAL)) {
        double y = 0.5;
        for (int j = 0; j < 32; ++j, y = std::nextafter(y, HUGE_VAL)) {
            double z = 0.5;
            for (int k = 0; k < 4; ++k, z = std::nextafter(z, HUGE_VAL)) {
                const vec3 p{x, y, z};
                for (const vec3& d : {s, t}) {
                    const int ref = ref_orient3d(p, q, r, d);
                    REQUIRE(idas::orient3d(p, q, r, d) == ref);
                    REQUIRE(idas::orient3d(q, r, p, d) == ref);
                    REQUIRE(idas::orient3d(d, q, r, p) == -ref);
                    naive_wrong += naive_orient3d(p, q, r, d) != ref;
                    zeros += ref == 0;
                }
            }
        }
    }
    CHECK(zeros > 0);
    CHECK(naive_wrong > 0);
    MESSAGE("naive orient3d wrong on " << naive_wrong << " of " << 32 * 32 * 4 * 2 << " points");
}

TEST_CASE("orient3d: points pushed off a plane by single ulps") {
    // a, b, c span the plane z = 2x - 3y (exactly representable); d lies on it and is
    // then moved by -3..3 ulps in each coordinate.
    std::mt19937_64 rng(7);
    std::uniform_int_distribution<std::int64_t> coord(-(1LL << 20), 1LL << 20);
    auto on_plane = [&](double scale) {
        const double x = static_cast<double>(coord(rng)) * scale;
        const double y = static_cast<double>(coord(rng)) * scale;
        return vec3{x, y, 2 * x - 3 * y};
    };
    int naive_wrong = 0, total = 0;
    for (double scale : {1.0, 1.0 / 3.0, 1e-7, 1e9}) {
        for (int rep = 0; rep < 40; ++rep) {
            const vec3 a = on_plane(scale), b = on_plane(scale), c = on_plane(scale);
            const vec3 d0 = on_plane(scale);
            for (int axis = 0; axis < 3; ++axis)
                for (int steps = -3; steps <= 3; ++steps) {
                    vec3 d = d0;
                    for (int s = 0; s < std::abs(steps); ++s)
                        d[axis] = std::nextafter(d[axis], steps > 0 ? HUGE_VAL : -HUGE_VAL);
                    check_all_paths3(a, b, c, d);
                    check_permutations3(a, b, c, d);
                    naive_wrong += naive_orient3d(a, b, c, d) != ref_orient3d(a, b, c, d);
                    ++total;
                }
        }
    }
    MESSAGE("naive orient3d wrong on " << naive_wrong << " of " << total << " perturbed points");
    CHECK(naive_wrong > 0);
}

TEST_CASE("orient3d/orient2d: exactly degenerate inputs with huge and tiny coordinates") {
    std::mt19937_64 rng(11);
    // Integers below 2^50 ~ 1.1e15; z = 2x - 3y stays below 2^53, hence exact.
    std::uniform_int_distribution<std::int64_t> big(-(1LL << 50) + 1, (1LL << 50) - 1);
    std::uniform_int_distribution<std::int64_t> small(-(1LL << 20), 1LL << 20);
    auto plane_point = [](double x, double y) { return vec3{x, y, 2 * x - 3 * y}; };
    int naive_nonzero = 0;
    for (int rep = 0; rep < 300; ++rep) {
        std::array<vec3, 4> p;
        for (auto& v : p)
            v = plane_point(static_cast<double>(big(rng)), static_cast<double>(big(rng)));
        REQUIRE(ref_orient3d(p[0], p[1], p[2], p[3]) == 0);
        REQUIRE(idas::orient3d(p[0], p[1], p[2], p[3]) == 0);
        check_all_paths3(p[0], p[1], p[2], p[3]);
        naive_nonzero += naive_orient3d(p[0], p[1], p[2], p[3]) != 0;

        // Lift one point by one unit: no longer coplanar.
        vec3 lifted = p[3];
        lifted.z += 1.0;
        check_all_paths3(p[0], p[1], p[2], lifted);
        check_permutations3(p[0], p[1], p[2], lifted);

        // Same configurations scaled by powers of two: 2^k * integer is exact even in the
        // subnormal range as long as the integer times 2^k is a multiple of 2^-1074.
        for (int k : {-1000, -1050, -1070, -1074, 300, 900, 960}) {
            std::array<vec3, 4> s;
            for (int i = 0; i < 4; ++i)
                s[i] = vec3{std::ldexp(static_cast<double>(small(rng)), k),
                            std::ldexp(static_cast<double>(small(rng)), k), 0};
            for (auto& v : s) v.z = 2 * v.x - 3 * v.y; // exact: small integers * 2^k
            REQUIRE(idas::orient3d(s[0], s[1], s[2], s[3]) == 0);
            check_all_paths3(s[0], s[1], s[2], s[3]);
            vec3 off = s[3];
            off.z = std::nextafter(off.z, HUGE_VAL);
            check_all_paths3(s[0], s[1], s[2], off);
            check_permutations3(s[0], s[1], s[2], off);
            // 2D: collinear on y = 3x at this scale, then nudged.
            const pt2 a{s[0].x, 3 * s[0].x}, b{s[1].x, 3 * s[1].x}, c{s[2].x, 3 * s[2].x};
            REQUIRE(idas::orient2d(a, b, c) == 0);
            check_all_paths2(a, b, c);
            const pt2 c2{c[0], std::nextafter(c[1], -HUGE_VAL)};
            check_all_paths2(a, b, c2);
            check_permutations2(a, b, c2);
        }
    }
    MESSAGE("naive orient3d nonzero on " << naive_nonzero << " of 300 coplanar 1e15 quadruples");
    CHECK(naive_nonzero > 0);
}

TEST_CASE("orient3d: underflow in the minors must not fool the filter") {
    // det = 2^1000 * (3*2^-1076 - 5*2^-1077) - 2^-80 = 2^-77 - 2^-80 > 0, but both minor
    // products round to 2^-1074, so doubles see only the -2^-80 term.
    const vec3 a{0, 0, 0};
    const vec3 u{0x1p1000, 1, 0};
    const vec3 v{0x1p456, 3 * 0x1p-540, 5 * 0x1p-540};
    const vec3 w{0, 0x1p-537, 0x1p-536};
    CHECK(ref_orient3d(a, u, v, w) == 1);
    CHECK(naive_orient3d(a, u, v, w) == -1);
    CHECK(idas::orient3d(a, u, v, w) == 1);
    check_all_paths3(a, u, v, w);
    check_permutations3(a, u, v, w);

    // Products entirely below the subnormal range: det is nonzero but underflows to 0.
    const vec3 t0{0, 0, 0}, t1{0x1p-1074, 0, 0}, t2{0, 0x1p-1074, 0}, t3{0, 0, 0x1p-1074};
    CHECK(idas::orient3d(t0, t1, t2, t3) == 1);
    CHECK(idas::orient3d(t0, t2, t1, t3) == -1);
    CHECK(idas::orient2d({0, 0}, {0x1p-1074, 0}, {0, 0x1p-1074}) == 1);
    CHECK(idas::orient2d({0, 0}, {0x1p-1074, 0x1p-1074}, {0x1p-1073, 0x1p-1073}) == 0);
    // Huge coordinates whose differences overflow.
    const double m = std::numeric_limits<double>::max();
    check_all_paths3({-m, -m, -m}, {m, -m, -m}, {-m, m, -m}, {-m, -m, m});
    check_all_paths3({-m, -m, -m}, {m, m, m}, {m, m, m}, {-m, -m, m});
    check_all_paths2({-m, -m}, {m, -m}, {-m, m});
    check_all_paths2({-m, -m}, {m, m}, {0, 0});
}

TEST_CASE("orient3d/orient2d: random consistency against the mpq reference") {
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::uniform_int_distribution<int> grid(-3, 3);
    std::uniform_int_distribution<int> expo(-1100, 1000);
    std::uniform_int_distribution<int> kind_d(0, 4);

    auto random_point = [&](int kind) -> vec3 {
        switch (kind) {
        case 0:
            return {unit(rng), unit(rng), unit(rng)};
        case 1: // small grid: many exact degeneracies
            return {double(grid(rng)), double(grid(rng)), double(grid(rng))};
        case 2: // wildly mixed magnitudes
            return {std::ldexp(unit(rng), expo(rng)), std::ldexp(unit(rng), expo(rng)),
                    std::ldexp(unit(rng), expo(rng))};
        case 3: // moderate magnitudes, same order
            return vec3{unit(rng), unit(rng), unit(rng)} * 1e6;
        default: // grid with tiny offsets
            return {double(grid(rng)) + 1e-17 * grid(rng), double(grid(rng)),
                    double(grid(rng)) * (1 + 0x1p-52 * grid(rng))};
        }
    };
    for (int rep = 0; rep < 4000; ++rep) {
        const int kind = kind_d(rng);
        vec3 a = random_point(kind), b = random_point(kind), c = random_point(kind);
        vec3 d = random_point(kind);
        if (rep % 3 == 0) { // d rounded from a point of the plane abc: nearly coplanar
            const double s = unit(rng), t = unit(rng);
            d = a + s * (b - a) + t * (c - a);
        }
        check_all_paths3(a, b, c, d);
        check_permutations3(a, b, c, d);

        const pt2 a2{a.x, a.y}, b2{b.x, b.y};
        pt2 c2{c.x, c.y};
        if (rep % 3 == 0) { // nearly collinear
            const double s = unit(rng);
            c2 = {a.x + s * (b.x - a.x), a.y + s * (b.y - a.y)};
        }
        check_all_paths2(a2, b2, c2);
        check_permutations2(a2, b2, c2);
    }
}

TEST_CASE("rational: exact conversion and correctly rounded to_double") {
    CHECK(idas::to_double(mpq_class(1, 3)) == 1.0 / 3.0);
    CHECK(idas::to_double(mpq_class(-2, 3)) == -2.0 / 3.0);
    CHECK(idas::to_double(mpq_class(0)) == 0.0);
    // Ties round to even.
    const mpq_class one(1), half_ulp(mpq_class(1) / mpz_class(mpz_class(1) << 53));
    CHECK(idas::to_double(one + half_ulp) == 1.0);
    CHECK(idas::to_double(one + 3 * half_ulp) == 1.0 + 0x1p-51);
    CHECK(idas::to_double(one + half_ulp + half_ulp / 1024) == 1.0 + 0x1p-52);
    // Subnormal range and rounding to zero / to the smallest subnormal.
    const mpq_class tiny = idas::to_rational(0x1p-1074);
    CHECK(idas::to_double(tiny / 2) == 0.0);
    CHECK(idas::to_double(tiny * 3 / 4) == 0x1p-1074);
    CHECK(idas::to_double(tiny * 3 / 2) == 0x1p-1073);
    CHECK(idas::to_double(tiny * 5 / 2) == 0x1p-1073);
    CHECK(idas::to_double(-tiny / 3) == 0.0);
    CHECK(std::signbit(idas::to_double(-tiny / 3)));
    // Overflow.
    const mpq_class maxd = idas::to_rational(std::numeric_limits<double>::max());
    CHECK(idas::to_double(maxd) == std::numeric_limits<double>::max());
    CHECK(idas::to_double(maxd * 2) == HUGE_VAL);
    CHECK(idas::to_double(-maxd * 2) == -HUGE_VAL);

    // IEEE arithmetic is correctly rounded, so the exact result rounded by to_double must
    // equal the double result bit for bit (including underflow and overflow).
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> unit(0.5, 1.0);
    std::uniform_int_distribution<int> expo(-1074, 1023);
    std::uniform_int_distribution<int> coin(0, 1);
    auto random_double = [&] {
        const double v = std::ldexp(unit(rng), expo(rng));
        return coin(rng) ? -v : v;
    };
    for (int rep = 0; rep < 20000; ++rep) {
        const double x = random_double(), y = random_double();
        const mpq_class qx = idas::to_rational(x), qy = idas::to_rational(y);
        REQUIRE(idas::to_double(qx) == x);
        const double quo = idas::to_double(mpq_class(qx / qy));
        REQUIRE(quo == x / y);
        REQUIRE(std::signbit(quo) == std::signbit(x / y));
        const double prod = idas::to_double(mpq_class(qx * qy));
        REQUIRE(prod == x * y);
        REQUIRE(std::signbit(prod) == std::signbit(x * y));
        const double x2 = std::ldexp(x, -std::ilogb(x) + std::ilogb(y) + coin(rng));
        REQUIRE(idas::to_double(mpq_class(idas::to_rational(x2) + qy)) == x2 + y);
    }

    const vec3 p{0.1, -1e-310, 3e300};
    const idas::rational_point rp = idas::to_rational(p);
    CHECK(rp.x == mpq_class(0.1));
    CHECK(idas::to_vec3(rp) == p);
}

TEST_CASE("rational: detection of rationals that are exactly doubles") {
    double out = -1;
    auto exact = [&](const mpq_class& q) { return dp::exact_double(q, out); };
    CHECK(exact(mpq_class(0)));
    CHECK(out == 0.0);
    CHECK(exact(mpq_class(-5, 8)));
    CHECK(out == -0.625);
    CHECK(exact(idas::to_rational(0x1p-1074)));
    CHECK(out == 0x1p-1074);
    CHECK(exact(idas::to_rational(-0x1.fffffffffffffp1023)));
    CHECK(out == -0x1.fffffffffffffp1023);
    CHECK(exact(idas::to_rational(0x1.0000000000001p-1000)));
    CHECK(out == 0x1.0000000000001p-1000);
    CHECK_FALSE(exact(mpq_class(1, 3)));
    CHECK_FALSE(exact(idas::to_rational(0x1p-1074) / 2));  // below the subnormal grid
    CHECK_FALSE(exact(idas::to_rational(0x1p1023) * 2));   // 2^1024 overflows
    CHECK_FALSE(exact(mpq_class(mpz_class(1) << 53) + 1)); // 54 significant bits
    CHECK(exact(mpq_class(mpz_class(1) << 53) + 2));       // 53 bits
    CHECK(exact(mpq_class(mpz_class(3) << 1000)));
    CHECK(out == 0x3p1000);
    CHECK(exact(idas::to_rational(0x1p-1060) * 3 / 4)); // subnormal 3 * 2^-1062
    CHECK(out == 0x3p-1062);
    CHECK_FALSE(exact(idas::to_rational(0x1p-1074) * 3 / 2)); // 3 * 2^-1075
}

TEST_CASE("rational: orient3d agrees with the double predicate and the reference") {
    std::mt19937_64 rng(2024);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::uniform_int_distribution<int> grid(-2, 2);
    for (int rep = 0; rep < 2000; ++rep) {
        std::array<vec3, 4> p;
        for (auto& v : p)
            v = rep % 2 ? vec3{unit(rng), unit(rng), unit(rng)}
                        : vec3{double(grid(rng)), double(grid(rng)), 0.5 * grid(rng)};
        if (rep % 4 == 1) p[3] = p[0] + 0.25 * (p[1] - p[0]) + 0.375 * (p[2] - p[0]);
        const int s = idas::orient3d(p[0], p[1], p[2], p[3]);
        const idas::rational_point q0 = idas::to_rational(p[0]), q1 = idas::to_rational(p[1]),
                                   q2 = idas::to_rational(p[2]), q3 = idas::to_rational(p[3]);
        REQUIRE(idas::orient3d(q0, q1, q2, q3) == s);            // double fast path
        REQUIRE(dp::orient3d_rational_mpz(q0, q1, q2, q3) == s); // integer path
        REQUIRE(s == ref_orient3d(p[0], p[1], p[2], p[3]));
    }
    // Genuine rationals with unrelated denominators.
    std::uniform_int_distribution<int> num(-50, 50), den(1, 12);
    for (int rep = 0; rep < 2000; ++rep) {
        std::array<idas::rational_point, 4> p;
        std::array<std::array<mpq_class, 3>, 4> ref;
        for (int i = 0; i < 4; ++i)
            for (int k = 0; k < 3; ++k) {
                mpq_class q(num(rng), den(rng));
                q.canonicalize();
                p[i][k] = q;
                ref[i][k] = q;
            }
        if (rep % 3 == 0) { // exactly coplanar
            for (int k = 0; k < 3; ++k) {
                p[3][k] = p[0][k] + mpq_class(1, 3) * (p[1][k] - p[0][k]) +
                          mpq_class(-2, 7) * (p[2][k] - p[0][k]);
                ref[3][k] = p[3][k];
            }
        }
        const int s = idas::orient3d(p[0], p[1], p[2], p[3]);
        REQUIRE(s == ref_orient3d_q(ref[0], ref[1], ref[2], ref[3]));
        REQUIRE(dp::orient3d_rational_mpz(p[0], p[1], p[2], p[3]) == s);
        REQUIRE(idas::orient3d(p[1], p[0], p[2], p[3]) == -s);
        REQUIRE(idas::orient3d(p[1], p[2], p[0], p[3]) == s);
        if (rep % 3 == 0) REQUIRE(s == 0);
    }
}

TEST_CASE("rational: does rounding keep the orientation?") {
    using idas::rational_point;
    const rational_point a{0, 0, 0}, b{1, 0, 0}, c{0, 3, 1};
    // d on the plane z = y / 3; the nearest double to 1/3 is below 1/3, so the rounded
    // point falls off the plane.
    const rational_point d_on{0, 1, mpq_class(1, 3)};
    const auto r = idas::orient3d_with_rounding(a, b, c, d_on);
    CHECK(r.exact == 0);
    CHECK(r.rounded != 0);
    CHECK(r.rounded ==
          idas::orient3d(vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{0, 3, 1}, vec3{0, 1, 1.0 / 3.0}));
    CHECK_FALSE(idas::rounding_preserves_orient3d(a, b, c, d_on));

    // A point above the plane by less than the rounding error ends up below it.
    // The rounded z is RN(1/3) < 1/3, so the rounded tet is negative.
    const rational_point d_close{0, 1,
                                 mpq_class(1, 3) + mpq_class(mpz_class(1), mpz_class(1) << 60)};
    CHECK(idas::orient3d(a, b, c, d_close) == 1);
    CHECK(idas::orient3d_with_rounding(a, b, c, d_close).rounded == -1);
    CHECK_FALSE(idas::rounding_preserves_orient3d(a, b, c, d_close));

    // Dyadic coordinates round exactly; clearly off-plane points survive rounding.
    const rational_point d_exact{0, 1, mpq_class(1, 2)};
    CHECK(idas::rounding_preserves_orient3d(a, b, c, d_exact));
    const rational_point d_far{mpq_class(1, 7), mpq_class(2, 3), mpq_class(5, 3)};
    CHECK(idas::rounding_preserves_orient3d(a, b, c, d_far));
}

TEST_CASE("rational: the nearest doubles decide the orientation where rounding cannot change it") {
    // Rational points at five scales, with the tet's last point placed exactly on the
    // plane of the others, or off it by a relative 2^-80 (rounding decides nothing there),
    // 2^-30 or anywhere. Where orient3d_within gives a sign it must be the exact one;
    // exactly coplanar points must get 0; well-separated ones must be decided.
    std::mt19937_64 rng(53);
    std::uniform_int_distribution<long> num(-1000003, 1000003), den(1, 999983);
    std::uniform_int_distribution<int> which(0, 3);
    const auto random_q = [&] {
        mpq_class q(num(rng), den(rng));
        q.canonicalize();
        return q;
    };
    int decided_far = 0, far = 0;
    // Scales 2^-600 and 2^600 underflow or overflow the determinant's doubles (the exact
    // test decides there); within 2^-150 to 2^150 the doubles must decide far points.
    for (const int exponent : {-600, -150, 0, 150, 600}) {
        const mpq_class scale = exponent < 0 ? mpq_class(mpz_class(1), mpz_class(1) << -exponent)
                                             : mpq_class(mpz_class(1) << exponent);
        for (int rep = 0; rep < 1500; ++rep) {
            // Points before rational_from are doubles (radius 0), as in a mesh.
            const int rational_from = which(rng);
            std::array<idas::rational_point, 4> p;
            for (int i = 0; i < 4; ++i) {
                p[i] = {random_q() * scale, random_q() * scale, random_q() * scale};
                if (i < rational_from) p[i] = idas::to_rational(idas::to_vec3(p[i]));
            }
            const int placement = rep % 4; // 0 on the plane, 1 and 2 just off it, 3 anywhere
            if (placement < 3) {
                const mpq_class s = random_q(), t = random_q();
                for (int k = 0; k < 3; ++k)
                    p[3][k] = p[0][k] + s * (p[1][k] - p[0][k]) + t * (p[2][k] - p[0][k]);
                if (placement > 0) {
                    const int shift = placement == 1 ? 80 : 30;
                    p[3].z += scale / mpq_class(mpz_class(1) << shift);
                }
            }
            std::array<vec3, 4> nearest;
            std::array<double, 4> radius{};
            for (int i = 0; i < 4; ++i) {
                nearest[i] = idas::to_vec3(p[i]);
                if (i < rational_from) continue;
                radius[i] = idas::rounding_radius(nearest[i]);
                for (int k = 0; k < 3; ++k) // the radius holds the rounding error
                    REQUIRE(abs(p[i][k] - idas::to_rational(nearest[i][k])) <=
                            idas::to_rational(radius[i]));
            }
            const int exact = idas::orient3d(p[0], p[1], p[2], p[3]);
            const int within = idas::orient3d_within(nearest[0], nearest[1], nearest[2], nearest[3],
                                                     radius[0], radius[1], radius[2], radius[3]);
            CAPTURE(placement);
            if (within != 0) REQUIRE(within == exact);
            if (placement == 0) CHECK(within == 0);
            if (placement == 3 && std::abs(exponent) <= 150) ++far, decided_far += within != 0;
        }
    }
    CHECK(decided_far >= far * 99 / 100);
    // Points of the rounding test above: on the plane, and above it by less than rounding.
    const vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 3, 1}, d{0, 1, 1.0 / 3.0};
    CHECK(idas::orient3d_within(a, b, c, d, 0, 0, 0, idas::rounding_radius(d)) == 0);
    const idas::rational_point e{mpq_class(1, 7), mpq_class(2, 3), mpq_class(5, 3)};
    const vec3 e_nearest = idas::to_vec3(e);
    CHECK(idas::orient3d_within(a, b, c, e_nearest, 0, 0, 0, idas::rounding_radius(e_nearest)) ==
          idas::orient3d(idas::to_rational(a), idas::to_rational(b), idas::to_rational(c), e));
}

#ifdef IDAS_PREDICATE_STATS
TEST_CASE("orient3d: stage counters") {
    auto& st = idas::predicate_counters();
    st.reset();
    CHECK(idas::orient3d(vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{0, 1, 0}, vec3{0, 0, 1}) == 1);
    CHECK(st.orient3d_filtered == 1);
    CHECK(idas::orient3d(vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{0, 1, 0}, vec3{1, 1, 0}) == 0);
    CHECK(st.orient3d_exact == 1);
    CHECK(idas::orient3d(vec3{0, 0, 0}, vec3{0x1p1000, 0, 0}, vec3{0, 0x1p-1000, 0},
                         vec3{1, 1, 0}) == 0);
    CHECK(st.orient3d_bignum == 1);
    CHECK(idas::orient2d({0, 0}, {1, 0}, {0, 1}) == 1);
    CHECK(idas::orient2d({0, 0}, {1, 1}, {2, 2}) == 0);
    CHECK(idas::orient2d({0, 0}, {0x1p1000, 0x1p1000}, {0x1p-1000, 0x1p-1000}) == 0);
    CHECK(st.orient2d_filtered == 1);
    CHECK(st.orient2d_exact == 1);
    CHECK(st.orient2d_bignum == 1);
}
#endif
