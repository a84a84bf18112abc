// Closest-point queries: idas::triangle_aabb_tree against CGAL's AABB_tree, on the
// armadillo (data/armadillo.obj, 86k faces).
//
// Method
// ------
// * Queries: 2^16 points near the surface (a uniform random point of a random face,
//   pushed along a random direction by up to 1% of the bounding-box diagonal), and 2^16
//   points uniform in the bounding box enlarged by 10% ("box"). Fixed seed.
// * One iteration is one query, cycling through the array; "Time" is ns per query.
// * Both libraries answer the same question (closest point on the surface; CGAL's
//   closest_point_and_primitive) and are checked to agree before timing: the fixture
//   compares every near query's squared distance (relative 1e-12) and aborts otherwise.
// * CGAL: AABB_tree over AABB_triangle_primitive of a vector of Triangle_3, kernel Epick
//   and Simple_cartesian<double> (the faster kernel for AABB constructions), with
//   accelerate_distance_queries() (its kd-tree of sample points finds the initial hint).
//   build/* times include that kd-tree.
// * hint variants: idas closest_point_near(q, face) with the face each near query was
//   generated from; CGAL closest_point(q, hint) with a point on that face.
#include <idas/core/aabb_tree.hpp>
#include <idas/io/io.hpp>

#include <benchmark/benchmark.h>

#if defined(IDAS_BENCH_WITH_CGAL)
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Simple_cartesian.h>
#endif

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

namespace {

using idas::index_t;
using idas::vec3;

struct fixture_data {
    std::vector<vec3> V;
    std::vector<idas::tri_indices> F;
    std::vector<vec3> near, box;
    std::vector<index_t> near_face; // face each near query came from
    std::vector<vec3> near_source;  // the surface point it came from
    idas::triangle_aabb_tree tree;
};

const fixture_data& fixture() {
    static const fixture_data d = [] {
        fixture_data f;
        auto s = idas::io::read_surface(std::string(IDAS_DATA_DIR) + "/armadillo.obj");
        f.V = std::move(s.vertices), f.F = std::move(s.faces);
        f.tree = idas::triangle_aabb_tree(f.V, f.F);
        const auto [lo, hi] = f.tree.bounds();
        const double diag = f.tree.diagonal();
        std::mt19937_64 rng(20240607);
        std::uniform_real_distribution<double> u(0, 1);
        std::normal_distribution<double> g(0, 1);
        const std::size_t n = std::size_t(1) << 16;
        for (std::size_t i = 0; i < n; ++i) {
            const auto fi = static_cast<index_t>(rng() % f.F.size());
            const auto& t = f.F[fi];
            double a = u(rng), b = u(rng);
            if (a + b > 1) a = 1 - a, b = 1 - b;
            const vec3 p = f.V[t[0]] + (f.V[t[1]] - f.V[t[0]]) * a + (f.V[t[2]] - f.V[t[0]]) * b;
            vec3 dir{g(rng), g(rng), g(rng)};
            dir = dir / idas::norm(dir);
            f.near.push_back(p + dir * (0.01 * diag * u(rng)));
            f.near_face.push_back(fi);
            f.near_source.push_back(p);
            const vec3 d = hi - lo;
            f.box.push_back(lo - d * 0.05 +
                            vec3{d.x * 1.1 * u(rng), d.y * 1.1 * u(rng), d.z * 1.1 * u(rng)});
        }
        return f;
    }();
    return d;
}

// ---- idas ----------------------------------------------------------------------------

void BM_idas_build(benchmark::State& state) {
    const auto& f = fixture();
    for (auto _ : state) {
        idas::triangle_aabb_tree t(f.V, f.F);
        benchmark::DoNotOptimize(t);
    }
    state.counters["faces"] = double(f.F.size());
}

template <int Kind>
void BM_idas_closest(benchmark::State& state) {
    const auto& f = fixture();
    const auto& Q = Kind == 1 ? f.box : f.near;
    std::size_t i = 0;
    double sum = 0;
    for (auto _ : state) {
        const vec3& q = Q[i];
        const auto r =
            Kind == 2 ? f.tree.closest_point_near(q, f.near_face[i]) : f.tree.closest_point(q);
        sum += r.squared_distance;
        i = (i + 1) & (Q.size() - 1);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
}

void BM_idas_squared_distance_parallel(benchmark::State& state) {
    const auto& f = fixture();
    std::size_t i = std::size_t(state.thread_index()) * 9973;
    double sum = 0;
    for (auto _ : state) {
        sum += f.tree.squared_distance(f.near[i & (f.near.size() - 1)]);
        ++i;
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
}

BENCHMARK(BM_idas_build)->Name("build/idas")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_idas_closest<0>)->Name("closest/idas/near");
BENCHMARK(BM_idas_closest<2>)->Name("closest/idas/near_with_face_hint");
BENCHMARK(BM_idas_closest<1>)->Name("closest/idas/box");
BENCHMARK(BM_idas_squared_distance_parallel)
    ->Name("closest/idas/near/threads")
    ->Threads(1)
    ->Threads(2)
    ->UseRealTime();

#if defined(IDAS_BENCH_WITH_CGAL)
// ---- CGAL ----------------------------------------------------------------------------

template <class K>
struct cgal_side {
    using triangle = typename K::Triangle_3;
    using point = typename K::Point_3;
    using iterator = typename std::vector<triangle>::const_iterator;
    using primitive = CGAL::AABB_triangle_primitive<K, iterator>;
    using tree_type = CGAL::AABB_tree<CGAL::AABB_traits<K, primitive>>;

    std::vector<triangle> tris;
    std::vector<point> near, box, hint;
    std::unique_ptr<tree_type> tree;

    static point P(const vec3& p) { return point(p.x, p.y, p.z); }

    explicit cgal_side(const fixture_data& f) {
        for (const auto& t : f.F) tris.emplace_back(P(f.V[t[0]]), P(f.V[t[1]]), P(f.V[t[2]]));
        for (const auto& q : f.near) near.push_back(P(q));
        for (const auto& q : f.box) box.push_back(P(q));
        for (const auto& q : f.near_source) hint.push_back(P(q));
        tree = build();
        // Both libraries must agree before anything is timed.
        std::size_t bad = 0;
        for (std::size_t i = 0; i < near.size(); ++i) {
            const double c =
                CGAL::to_double(CGAL::squared_distance(near[i], tree->closest_point(near[i])));
            const double d = f.tree.squared_distance(f.near[i]);
            if (std::abs(c - d) > 1e-12 * std::max(1.0, d) + 1e-15) ++bad;
        }
        if (bad) {
            std::fprintf(stderr, "bench_aabb: CGAL and idas disagree on %zu of %zu queries\n", bad,
                         near.size());
            std::abort();
        }
    }
    std::unique_ptr<tree_type> build() const {
        auto t = std::make_unique<tree_type>(tris.begin(), tris.end());
        t->build();
        t->accelerate_distance_queries();
        return t;
    }
};

template <class K>
const cgal_side<K>& cgal_fixture() {
    static const cgal_side<K> c(fixture());
    return c;
}

template <class K>
void BM_cgal_build(benchmark::State& state) {
    const auto& c = cgal_fixture<K>();
    for (auto _ : state) {
        auto t = c.build();
        benchmark::DoNotOptimize(t);
    }
}

template <class K, int Kind>
void BM_cgal_closest(benchmark::State& state) {
    const auto& c = cgal_fixture<K>();
    const auto& Q = Kind == 1 ? c.box : c.near;
    std::size_t i = 0;
    double sum = 0;
    for (auto _ : state) {
        const auto p =
            Kind == 2 ? c.tree->closest_point(Q[i], c.hint[i]) : c.tree->closest_point(Q[i]);
        sum += CGAL::to_double(p.x());
        i = (i + 1) & (Q.size() - 1);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
}

template <class K>
void BM_cgal_parallel(benchmark::State& state) {
    const auto& c = cgal_fixture<K>();
    std::size_t i = std::size_t(state.thread_index()) * 9973;
    double sum = 0;
    for (auto _ : state) {
        sum += CGAL::to_double(c.tree->closest_point(c.near[i & (c.near.size() - 1)]).x());
        ++i;
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
}

using epick = CGAL::Exact_predicates_inexact_constructions_kernel;
using sc = CGAL::Simple_cartesian<double>;
BENCHMARK(BM_cgal_build<epick>)->Name("build/cgal_epick")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_cgal_build<sc>)->Name("build/cgal_sc")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_cgal_closest<epick, 0>)->Name("closest/cgal_epick/near");
BENCHMARK(BM_cgal_closest<epick, 2>)->Name("closest/cgal_epick/near_with_point_hint");
BENCHMARK(BM_cgal_closest<epick, 1>)->Name("closest/cgal_epick/box");
BENCHMARK(BM_cgal_closest<sc, 0>)->Name("closest/cgal_sc/near");
BENCHMARK(BM_cgal_closest<sc, 2>)->Name("closest/cgal_sc/near_with_point_hint");
BENCHMARK(BM_cgal_closest<sc, 1>)->Name("closest/cgal_sc/box");
BENCHMARK(BM_cgal_parallel<sc>)
    ->Name("closest/cgal_sc/near/threads")
    ->Threads(1)
    ->Threads(2)
    ->UseRealTime();
#endif

} // namespace

BENCHMARK_MAIN();
