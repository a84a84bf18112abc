// Cost of the exact orientation predicates, per call, on the different evaluation paths.
//   g++ -std=c++20 -O2 -I include bench/bench_predicates.cpp -lbenchmark -lpthread -lgmpxx -lgmp
#include "idas/predicates/orient.hpp"
#include "idas/predicates/rational.hpp"

#include <benchmark/benchmark.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace {

using idas::vec3;
using pt2 = std::array<double, 2>;

constexpr std::size_t n_cases = 1024; // power of two, cycled through

using quad = std::array<vec3, 4>;
using triple = std::array<pt2, 3>;

std::vector<quad> random_quads() {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<quad> out(n_cases);
    for (auto& q : out)
        for (auto& p : q) p = {u(rng), u(rng), u(rng)};
    return out;
}

/// Exactly coplanar points on z = 2x - 3y. `bits` controls the coordinate size: x, y are
/// random integers below 2^bits times 2^-shift, so 2x - 3y is exact.
std::vector<quad> coplanar_quads(int bits, int shift) {
    std::mt19937_64 rng(2);
    std::uniform_int_distribution<std::int64_t> c(-(std::int64_t{1} << bits),
                                                  std::int64_t{1} << bits);
    std::vector<quad> out(n_cases);
    for (auto& q : out)
        for (auto& p : q) {
            const double x = std::ldexp(static_cast<double>(c(rng)), -shift);
            const double y = std::ldexp(static_cast<double>(c(rng)), -shift);
            p = {x, y, 2 * x - 3 * y};
        }
    return out;
}

/// Coplanar points on z = 2x with x near 2^470 and y near 2^-450: the dynamic range is
/// too wide for expansions, forcing the GMP stage.
std::vector<quad> extreme_quads() {
    std::mt19937_64 rng(5);
    std::uniform_int_distribution<std::int64_t> c(-(1 << 20), 1 << 20);
    std::vector<quad> out(n_cases);
    for (auto& q : out)
        for (auto& p : q) {
            const double x = std::ldexp(static_cast<double>(c(rng)), 450);
            const double y = std::ldexp(static_cast<double>(c(rng)), -450);
            p = {x, y, 2 * x};
        }
    return out;
}

std::vector<triple> random_triples() {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<triple> out(n_cases);
    for (auto& t : out)
        for (auto& p : t) p = {u(rng), u(rng)};
    return out;
}

/// Exactly collinear points on y = 3x with random 30-bit fractions.
std::vector<triple> collinear_triples() {
    std::mt19937_64 rng(4);
    std::uniform_int_distribution<std::int64_t> c(-(1 << 30), 1 << 30);
    std::vector<triple> out(n_cases);
    for (auto& t : out)
        for (auto& p : t) {
            const double x = std::ldexp(static_cast<double>(c(rng)), -30);
            p = {x, 3 * x};
        }
    return out;
}

[[gnu::always_inline]] inline int naive_orient3d(const vec3& a, const vec3& b, const vec3& c,
                                                 const vec3& d) {
    const vec3 u = b - a, v = c - a, w = d - a;
    const double det = u.x * (v.y * w.z - v.z * w.y) + u.y * (v.z * w.x - v.x * w.z) +
                       u.z * (v.x * w.y - v.y * w.x);
    return (det > 0) - (det < 0);
}

template <class F>
void run_quads(benchmark::State& state, const std::vector<quad>& qs, F&& f) {
    std::size_t i = 0;
    int acc = 0;
    for (auto _ : state) {
        const quad& q = qs[i++ & (n_cases - 1)];
        acc += f(q[0], q[1], q[2], q[3]);
        benchmark::DoNotOptimize(acc);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

template <class F>
void run_triples(benchmark::State& state, const std::vector<triple>& ts, F&& f) {
    std::size_t i = 0;
    int acc = 0;
    for (auto _ : state) {
        const triple& t = ts[i++ & (n_cases - 1)];
        acc += f(t[0], t[1], t[2]);
        benchmark::DoNotOptimize(acc);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

auto orient3d_fn = [](const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
    return idas::orient3d(a, b, c, d);
};
auto orient2d_fn = [](const pt2& a, const pt2& b, const pt2& c) { return idas::orient2d(a, b, c); };

void BM_orient3d_naive_random(benchmark::State& s) {
    run_quads(s, random_quads(), [](const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
        return naive_orient3d(a, b, c, d);
    });
}
void BM_orient3d_random_filtered(benchmark::State& s) {
    run_quads(s, random_quads(), orient3d_fn);
}
void BM_orient3d_coplanar_unit_exact(benchmark::State& s) {
    run_quads(s, coplanar_quads(30, 30), orient3d_fn); // coordinates in [-1, 1], 30 bits
}
void BM_orient3d_coplanar_1e15_exact(benchmark::State& s) {
    run_quads(s, coplanar_quads(49, 0), orient3d_fn); // integers up to 5.6e14
}
void BM_orient3d_coplanar_tiny_exact(benchmark::State& s) {
    run_quads(s, coplanar_quads(20, 1060), orient3d_fn); // subnormal: rescaled, no GMP
}
void BM_orient3d_extreme_bignum(benchmark::State& s) {
    run_quads(s, extreme_quads(), orient3d_fn);
}

void BM_orient2d_random_filtered(benchmark::State& s) {
    run_triples(s, random_triples(), orient2d_fn);
}
void BM_orient2d_collinear_exact(benchmark::State& s) {
    run_triples(s, collinear_triples(), orient2d_fn);
}

std::vector<std::array<idas::rational_point, 4>> to_rational(const std::vector<quad>& qs) {
    std::vector<std::array<idas::rational_point, 4>> out(qs.size());
    for (std::size_t i = 0; i < qs.size(); ++i)
        for (int k = 0; k < 4; ++k) out[i][k] = idas::to_rational(qs[i][k]);
    return out;
}

/// Genuine rationals: the points of a random quad moved by p + (q - p) / 3 etc.
std::vector<std::array<idas::rational_point, 4>> thirds(const std::vector<quad>& qs) {
    auto out = to_rational(qs);
    for (auto& q : out)
        for (int k = 0; k < 3; ++k) {
            q[3][k] = q[0][k] + mpq_class(1, 3) * (q[1][k] - q[0][k]) +
                      mpq_class(2, 7) * (q[2][k] - q[0][k]);
        }
    return out;
}

void run_rational(benchmark::State& state,
                  const std::vector<std::array<idas::rational_point, 4>>& qs) {
    std::size_t i = 0;
    int acc = 0;
    for (auto _ : state) {
        const auto& q = qs[i++ & (n_cases - 1)];
        acc += idas::orient3d(q[0], q[1], q[2], q[3]);
        benchmark::DoNotOptimize(acc);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

void BM_rational_orient3d_random_doubles(benchmark::State& s) {
    run_rational(s, to_rational(random_quads()));
}
void BM_rational_orient3d_coplanar_doubles(benchmark::State& s) {
    run_rational(s, to_rational(coplanar_quads(30, 30)));
}
void BM_rational_orient3d_coplanar_thirds(benchmark::State& s) {
    run_rational(s, thirds(random_quads()));
}
void BM_rational_orient3d_with_rounding(benchmark::State& s) {
    const auto qs = thirds(random_quads());
    std::size_t i = 0;
    int acc = 0;
    for (auto _ : s) {
        const auto& q = qs[i++ & (n_cases - 1)];
        acc += idas::rounding_preserves_orient3d(q[0], q[1], q[2], q[3]);
        benchmark::DoNotOptimize(acc);
    }
}
void BM_rational_to_double(benchmark::State& s) {
    const auto qs = thirds(random_quads());
    std::size_t i = 0;
    double acc = 0;
    for (auto _ : s) {
        acc += idas::to_double(qs[i++ & (n_cases - 1)][3].x);
        benchmark::DoNotOptimize(acc);
    }
}

} // namespace

BENCHMARK(BM_orient3d_naive_random);
BENCHMARK(BM_orient3d_random_filtered);
BENCHMARK(BM_orient3d_coplanar_unit_exact);
BENCHMARK(BM_orient3d_coplanar_1e15_exact);
BENCHMARK(BM_orient3d_coplanar_tiny_exact);
BENCHMARK(BM_orient3d_extreme_bignum);
BENCHMARK(BM_orient2d_random_filtered);
BENCHMARK(BM_orient2d_collinear_exact);
BENCHMARK(BM_rational_orient3d_random_doubles);
BENCHMARK(BM_rational_orient3d_coplanar_doubles);
BENCHMARK(BM_rational_orient3d_coplanar_thirds);
BENCHMARK(BM_rational_orient3d_with_rounding);
BENCHMARK(BM_rational_to_double);

BENCHMARK_MAIN();
