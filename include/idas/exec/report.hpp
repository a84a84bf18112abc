// What a run is told (options) and what it tells (live progress, the final report).
#pragma once

#include <chrono>
#include <cstdint>

namespace idas {

namespace detail {
/// Wall time since construction, for the reports' phase times.
class stopwatch {
public:
    double seconds() const noexcept {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    }

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};
} // namespace detail

/// Live counts the stopping criterion sees (`faces` counts top cells: tets on tet meshes).
/// Exact in serial; in parallel, refreshed every `check_every` successes per worker, so a
/// run may overshoot by a bounded amount.
struct progress {
    std::int64_t faces = 0, vertices = 0;
    std::uint64_t successes = 0;
};

struct exec_options {
    unsigned threads = 1;
    unsigned max_retry = 8;    // lock failures before an entry goes to the final serial pass
    unsigned check_every = 32; // successes between `stop` checks per worker (parallel only)
    unsigned parts_per_thread = 1;
    /// Set by the executor for a deterministic lock policy: a spec's `prepare` must then
    /// not plan by thread count (the result may not depend on it).
    bool deterministic = false;
    /// Deterministic rounds: candidates per round (0: a 1024th of the live cells, clamped
    /// to [1024, 65536]). Part of the result: the same value gives the same mesh.
    unsigned round_size = 0;
};

struct run_report {
    std::uint64_t pushed = 0, popped = 0, purged = 0, stale = 0, skipped = 0, attempted = 0,
                  succeeded = 0, refused = 0;
    std::uint64_t lock_failures = 0, deferred_to_serial = 0, stolen = 0;
    std::uint64_t crossed_parts = 0; // own_part_first: waited for the claiming phase
    std::uint64_t retaken = 0;       // set aside for the serial pass, then dealt out again
    double owner_seconds = 0;        // own_part_first: time of the lock-free phase
    std::uint64_t rounds = 0;        // deterministic_rounds: rounds run
    std::uint64_t grouped = 0;       // deterministic_rounds: attempted in groups of shards
    std::int64_t faces = 0, vertices = 0;
    unsigned threads = 1;
    double seconds = 0;
    // Where the wall time went: setting up (the spec's prepare, partitioning, seeding the
    // queues) and the serial tail (the final serial pass of a parallel run, the spec's
    // finish) run on one thread; the rest of `seconds` is the main phase. The serial share
    // (setup + tail) / seconds bounds the speedup by Amdahl's law.
    double setup_seconds = 0, tail_seconds = 0;

    /// Adds another run's counts (a worker's, or a phase's in a schedule); the live counts
    /// and thread count are the later run's.
    run_report& operator+=(const run_report& o) noexcept {
        pushed += o.pushed, popped += o.popped, purged += o.purged, stale += o.stale;
        skipped += o.skipped, attempted += o.attempted, succeeded += o.succeeded;
        refused += o.refused, lock_failures += o.lock_failures;
        deferred_to_serial += o.deferred_to_serial, stolen += o.stolen;
        crossed_parts += o.crossed_parts, retaken += o.retaken, owner_seconds += o.owner_seconds;
        rounds += o.rounds, grouped += o.grouped;
        seconds += o.seconds, setup_seconds += o.setup_seconds, tail_seconds += o.tail_seconds;
        return *this;
    }
};

} // namespace idas
