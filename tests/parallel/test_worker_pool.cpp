// The deterministic rounds' thread pool (exec/workers.hpp): every index once per step,
// thousands of short steps in a row, exceptions passed to the caller, more threads than
// cores. Run under TSan by scripts/test.sh.
#include <idas/exec/workers.hpp>

#include <doctest/doctest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

TEST_CASE("parallel worker_pool: each index once per step, over many short steps") {
    for (unsigned threads : {1u, 2u, 5u}) {
        INFO(threads << " threads");
        idas::detail::worker_pool pool(threads);
        CHECK(pool.size() == threads);
        std::vector<std::atomic<unsigned>> hits(64);
        unsigned long long sum = 0;
        for (unsigned step = 0; step < 3000; ++step) {
            const unsigned n = 1 + step % 64;
            std::vector<unsigned> value(n, 0); // plain writes, read after run() returns
            pool.run(n, [&](unsigned i) {
                hits[i].fetch_add(1, std::memory_order_relaxed);
                // Some steps long enough for the helpers to wake up and join.
                if (step % 100 == 0) {
                    volatile unsigned spin = 0;
                    for (unsigned k = 0; k < 20000; ++k) spin = spin + k;
                }
                value[i] = i + 1;
            });
            for (unsigned v : value) sum += v;
        }
        // Step s covers indices 0..s%64: index i is hit in every step with n > i.
        unsigned long long expected = 0;
        for (unsigned step = 0; step < 3000; ++step) {
            const unsigned n = 1 + step % 64;
            expected += 1ull * n * (n + 1) / 2;
        }
        CHECK(sum == expected);
        for (unsigned i = 0; i < 64; ++i) {
            unsigned steps = 0;
            for (unsigned step = 0; step < 3000; ++step) steps += 1 + step % 64 > i;
            CHECK(hits[i].load() == steps);
        }
    }
}

TEST_CASE("parallel worker_pool: an exception reaches the caller and the pool goes on") {
    idas::detail::worker_pool pool(3);
    std::atomic<unsigned> calls{0};
    CHECK_THROWS_AS(pool.run(100,
                             [&](unsigned i) {
                                 calls.fetch_add(1, std::memory_order_relaxed);
                                 if (i == 37) throw std::runtime_error("index 37");
                             }),
                    std::runtime_error);
    CHECK(calls.load() >= 1);
    unsigned done = 0;
    std::atomic<unsigned> again{0};
    pool.run(10, [&](unsigned) { again.fetch_add(1, std::memory_order_relaxed); });
    done = again.load();
    CHECK(done == 10);
}
