// The threads a run works on.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <system_error>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

namespace idas::detail {

/// Runs fn(0) ... fn(n - 1) on `threads` threads at once and waits for all; with more
/// indices than threads, each thread takes the next index when it is done.
/// Plain threads rather than oneTBB tasks: the executor's workers must run at the same
/// time (each owns a queue and a slot pool), and oneTBB only lets tasks run in parallel.
/// Under load its worker thread joined 0.1-0.6 s late or not at all: in remeshing's
/// short swap and smoothing phases one thread did every worker's part in turn. Starting
/// a thread costs tens of microseconds, once per executor run. (ThreadSanitizer also
/// sees these joins, which it cannot in Debian's uninstrumented libtbb.)
/// If the system refuses a thread (a process or memory limit), the threads already
/// started share the indices: fewer threads, same work, never std::terminate.
template <class Fn>
void run_workers(unsigned threads, unsigned n, Fn&& fn) {
    if (n == 0) return;
    std::atomic<unsigned> next{0};
    std::exception_ptr failure; // the first exception a worker threw, rethrown after the join
    std::mutex failure_mutex;
    auto work = [&] {
        try {
            for (unsigned i; (i = next.fetch_add(1, std::memory_order_relaxed)) < n;) fn(i);
        } catch (...) {
            const std::lock_guard lk(failure_mutex);
            if (!failure) failure = std::current_exception();
        }
    };
    std::vector<std::thread> pool;
    const unsigned extra = std::min(std::max(threads, 1u), n) - 1;
    try {
        pool.reserve(extra);
        for (unsigned t = 0; t < extra; ++t) pool.emplace_back(work);
    } catch (const std::system_error&) {
        // Fewer threads than asked for: those running and this one take every index.
    } catch (const std::bad_alloc&) {
    }
    work();
    for (auto& t : pool) t.join();
    if (failure) std::rethrow_exception(failure);
}

/// Threads kept for a run of many short parallel steps (the deterministic rounds: several
/// steps a round, thousands of rounds), where starting threads for each step would cost
/// more than the step: at 2 threads under load, tet meshing's rounds took twice the time
/// of 1 thread. `run(n, fn)` calls fn(0) ... fn(n - 1) on the pool's threads and the
/// caller's, each index once, and returns when all are done; an exception a call threw is
/// rethrown there. Idle threads sleep on an atomic (futex), they do not spin, and run()
/// never waits for a sleeping thread to wake: a step is open to helpers until its caller
/// is done with it, and only helpers that joined it are waited for. If the system refuses
/// a thread, the pool has fewer; the caller always works too.
class worker_pool {
public:
    explicit worker_pool(unsigned threads) {
        const unsigned extra = std::max(threads, 1u) - 1;
        try {
            helpers_.reserve(extra);
            for (unsigned t = 0; t < extra; ++t) helpers_.emplace_back([this] { serve(); });
        } catch (const std::system_error&) {
        } catch (const std::bad_alloc&) {
        }
    }
    worker_pool(const worker_pool&) = delete;
    worker_pool& operator=(const worker_pool&) = delete;
    ~worker_pool() {
        stop_.store(true, std::memory_order_relaxed);
        state_.fetch_add(step_unit, std::memory_order_release);
        state_.notify_all();
        for (auto& t : helpers_) t.join();
    }

    /// Threads that work in run(): the helpers and the caller.
    unsigned size() const noexcept { return unsigned(helpers_.size()) + 1; }

    template <class Fn>
    void run(unsigned n, Fn&& fn) {
        if (n == 0) return;
        if (helpers_.empty() || n == 1) {
            for (unsigned i = 0; i < n; ++i) fn(i);
            return;
        }
        n_ = n;
        next_.store(0, std::memory_order_relaxed);
        call_ = [](void* f, unsigned i) { (*static_cast<std::remove_reference_t<Fn>*>(f))(i); };
        fn_ = static_cast<void*>(std::addressof(fn));
        // A new step, open, nobody in it yet.
        const std::uint64_t step = (state_.load(std::memory_order_relaxed) & ~low_bits) + step_unit;
        state_.store(step, std::memory_order_release);
        state_.notify_all();
        work();
        // Close the step once the helpers in it are done; late ones stay out.
        for (std::uint64_t cur = state_.load(std::memory_order_acquire);;) {
            if ((cur & joined_mask) == 0) {
                if (state_.compare_exchange_weak(cur, cur | closed, std::memory_order_acq_rel,
                                                 std::memory_order_acquire))
                    break;
                continue;
            }
            state_.wait(cur, std::memory_order_acquire);
            cur = state_.load(std::memory_order_acquire);
        }
        if (failure_) {
            std::exception_ptr e = std::exchange(failure_, nullptr);
            std::rethrow_exception(e);
        }
    }

private:
    // state_: the step number (from bit 33), whether the step is closed (bit 32), and how
    // many helpers joined it (bits 0-31).
    static constexpr std::uint64_t joined_mask = 0xffffffffu, closed = std::uint64_t{1} << 32,
                                   low_bits = joined_mask | closed,
                                   step_unit = std::uint64_t{1} << 33;

    void work() {
        try {
            for (unsigned i; (i = next_.fetch_add(1, std::memory_order_relaxed)) < n_;)
                call_(fn_, i);
        } catch (...) {
            const std::lock_guard lk(failure_mutex_);
            if (!failure_) failure_ = std::current_exception();
        }
    }
    void serve() {
        std::uint64_t last_step = 0;
        for (;;) {
            std::uint64_t cur = state_.load(std::memory_order_acquire);
            while ((cur & ~low_bits) == last_step) {
                state_.wait(cur, std::memory_order_acquire);
                cur = state_.load(std::memory_order_acquire);
            }
            if (stop_.load(std::memory_order_relaxed)) return;
            last_step = cur & ~low_bits;
            bool joined = false;
            while (!joined && !(cur & closed) && (cur & ~low_bits) == last_step)
                joined = state_.compare_exchange_weak(cur, cur + 1, std::memory_order_acq_rel,
                                                      std::memory_order_acquire);
            if (!joined) continue;
            work();
            if (((state_.fetch_sub(1, std::memory_order_acq_rel) - 1) & joined_mask) == 0)
                state_.notify_all();
        }
    }

    std::vector<std::thread> helpers_;
    std::atomic<std::uint64_t> state_{closed};
    std::atomic<unsigned> next_{0};
    std::atomic<bool> stop_{false};
    // Written by run() before its step opens (release), read by helpers that joined it.
    unsigned n_ = 0;
    void (*call_)(void*, unsigned) = nullptr;
    void* fn_ = nullptr;
    std::exception_ptr failure_;
    std::mutex failure_mutex_;
};

} // namespace idas::detail
