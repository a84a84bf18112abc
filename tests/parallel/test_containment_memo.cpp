// The tet optimization's shared memo of envelope verdicts (containment_memo in
// include/idas/algorithms/tet_optimization.hpp): one table for all threads, each slot a
// sequence lock. 8 threads on 2 cores, under TSan too: every answer must be the envelope's
// own for that very triangle, whatever other threads write into the same slots.
#include <doctest/doctest.h>

#include <idas/algorithms/tet_optimization.hpp>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <cstdint>

using namespace idas;

namespace {

/// A fake envelope whose verdict is a function of the triangle's corners (any order), so
/// that a verdict reused for another triangle shows.
struct parity_envelope {
    std::atomic<std::uint64_t>* calls;
    static bool verdict(const vec3& a, const vec3& b, const vec3& c) {
        const double s = a.x + b.x + c.x + 3 * (a.y + b.y + c.y) + 7 * (a.z + b.z + c.z);
        return (static_cast<std::int64_t>(s) & 1) == 0;
    }
    bool contains(const vec3& a, const vec3& b, const vec3& c) const {
        calls->fetch_add(1, std::memory_order_relaxed);
        return verdict(a, b, c);
    }
};
static_assert(algorithms::triangle_envelope<parity_envelope>);

} // namespace

TEST_CASE("parallel containment memo: 8 threads get the envelope's own verdicts") {
    auto triangle = [](int t) {
        return std::array<vec3, 3>{vec3{double(t), 1, 2}, vec3{3, double(t % 17), 5},
                                   vec3{7, 8, double(t % 5)}};
    };
    // Asks `questions` times about `distinct` triangles, in three corner orders, on 8 threads
    // sharing one table of 2^12 slots; returns how often the envelope was asked.
    auto hammer = [&](int questions, int distinct) {
        std::atomic<std::uint64_t> calls{0};
        const parity_envelope env{&calls};
        algorithms::containment_memo memo(1 << 12);
        std::atomic<int> wrong{0};
        tbb::task_arena arena(8);
        arena.execute([&] {
            tbb::parallel_for(0, questions, [&](int i) {
                const auto [a, b, c] = triangle(int((std::int64_t(i) * 7919) % distinct));
                const bool got = i % 3 == 0   ? memo.contains(env, a, b, c)
                                 : i % 3 == 1 ? memo.contains(env, c, a, b)
                                              : memo.contains(env, b, a, c);
                if (got != parity_envelope::verdict(a, b, c)) wrong.fetch_add(1);
            });
        });
        CHECK(wrong.load() == 0);
        return calls.load();
    };
    // Far more triangles than slots: writers keep overwriting the slots readers read.
    hammer(200000, 50000);
    // Fewer triangles than slots: most questions are answered from the table.
    CHECK(hammer(100000, 1000) < 100000 / 4);
}
