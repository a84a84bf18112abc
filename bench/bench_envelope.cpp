// The envelope invariant's containment check on the armadillo (data/armadillo.obj, 86k
// faces, eps = 1e-3 of the bounding-box diagonal): CGAL::Polyhedral_envelope alone
// (envelope::contains_exact) against idas' filter in front of it (envelope::contains).
//
// Method
// ------
// * Query triangles look like remeshing's: an equilateral triangle of side L centred on a
//   random surface point, in that face's plane, its corners then projected onto the
//   surface (so it is a chord of the surface; larger L bulges out of the envelope more
//   often). L = 2, 5 and 10 eps (remeshing armadillo at 0.005 of the diagonal is L = 5
//   eps). 2048 triangles per size, fixed seed; one iteration is one triangle.
// * Both variants give the same answers (checked before timing: abort otherwise); the
//   "inside" counter is the fraction of triangles inside the envelope, "undecided" the
//   fraction the filter passes on to CGAL.
// * threads: one envelope shared by 1 or 2 threads, each checking its own triangles.
#include <benchmark/benchmark.h>

#if defined(IDAS_BENCH_WITH_CGAL)
#include <idas/core/aabb_tree.hpp>
#include <idas/invariants/envelope.hpp>
#include <idas/io/io.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

namespace {

using idas::vec3;
using triangle = std::array<vec3, 3>;

struct fixture_data {
    idas::envelope env;
    std::vector<std::vector<triangle>> queries; // per size
    std::vector<double> inside, undecided;
};

constexpr double sizes[] = {2, 5, 10};

const fixture_data& fixture() {
    static const fixture_data d = [] {
        fixture_data f;
        const auto s = idas::io::read_surface(std::string(IDAS_DATA_DIR) + "/armadillo.obj");
        f.env = idas::envelope::relative(s.vertices, s.faces, 1e-3);
        const idas::triangle_aabb_tree tree(s.vertices, s.faces);
        std::mt19937_64 rng(7);
        std::uniform_real_distribution<double> u(0, 1);
        for (double size : sizes) {
            const double L = size * f.env.eps();
            std::vector<triangle> Q;
            while (Q.size() < 2048) {
                const auto& t = s.faces[rng() % s.faces.size()];
                const vec3 A = s.vertices[t[0]], B = s.vertices[t[1]], C = s.vertices[t[2]];
                double a = u(rng), b = u(rng);
                if (a + b > 1) a = 1 - a, b = 1 - b;
                const vec3 p = A + (B - A) * a + (C - A) * b;
                const vec3 n = cross(B - A, C - A) / idas::norm(cross(B - A, C - A));
                const vec3 e1 = (B - A) / idas::norm(B - A), e2 = cross(n, e1);
                const double phi = 6.283185307179586 * u(rng);
                triangle q;
                for (int k = 0; k < 3; ++k) {
                    const double ang = phi + k * 2.0943951023931953;
                    q[k] = tree.closest_point(p + (e1 * std::cos(ang) + e2 * std::sin(ang)) *
                                                      (L / std::sqrt(3.0)))
                               .point;
                }
                Q.push_back(q);
            }
            std::size_t in = 0, undecided = 0;
            for (const auto& q : Q) {
                const bool exact = f.env.contains_exact(q[0], q[1], q[2]);
                if (exact != f.env.contains(q[0], q[1], q[2])) {
                    std::fprintf(stderr, "bench_envelope: filter and CGAL disagree\n");
                    std::abort();
                }
                in += exact;
                undecided +=
                    f.env.fast_verdict(q[0], q[1], q[2]) == idas::envelope::verdict::unknown;
            }
            f.inside.push_back(double(in) / Q.size());
            f.undecided.push_back(double(undecided) / Q.size());
            f.queries.push_back(std::move(Q));
        }
        return f;
    }();
    return d;
}

void BM_build(benchmark::State& state) {
    const auto s = idas::io::read_surface(std::string(IDAS_DATA_DIR) + "/armadillo.obj");
    for (auto _ : state) {
        auto e = idas::envelope::relative(s.vertices, s.faces, 1e-3);
        e.prepare_exact(); // CGAL's part too, as the build measured before it became lazy
        benchmark::DoNotOptimize(e);
    }
}

template <bool Filtered>
void BM_check(benchmark::State& state) {
    const auto& f = fixture();
    const auto k = static_cast<std::size_t>(state.range(0));
    const auto& Q = f.queries[k];
    std::size_t i = std::size_t(state.thread_index()) * 997, in = 0;
    for (auto _ : state) {
        const auto& q = Q[i++ & (Q.size() - 1)];
        in += Filtered ? f.env.contains(q[0], q[1], q[2]) : f.env.contains_exact(q[0], q[1], q[2]);
    }
    benchmark::DoNotOptimize(in);
    state.SetItemsProcessed(state.iterations());
    // Averaged over threads (counters are summed by default).
    const auto avg = benchmark::Counter::kAvgThreads;
    state.counters["L/eps"] = benchmark::Counter(sizes[k], avg);
    state.counters["inside"] = benchmark::Counter(f.inside[k], avg);
    if (Filtered) state.counters["undecided"] = benchmark::Counter(f.undecided[k], avg);
}

BENCHMARK(BM_build)->Name("envelope/build")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_check<false>)->Name("envelope/cgal")->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_check<true>)
    ->Name("envelope/filtered")
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_check<true>)
    ->Name("envelope/filtered/threads")
    ->Arg(1)
    ->Threads(1)
    ->Threads(2)
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

} // namespace

BENCHMARK_MAIN();

#else
#include <cstdio>
int main() {
    std::puts("bench_envelope: built without CGAL, nothing to measure");
    return 0;
}
#endif
