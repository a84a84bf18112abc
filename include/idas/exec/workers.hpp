// The threads a run works on.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
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

} // namespace idas::detail
