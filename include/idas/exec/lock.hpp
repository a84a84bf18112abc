// Lock policies: how a run's workers claim the vertices of an operation's region, and the
// phases a run goes through under that policy. A policy's `execute(run)` composes the
// run's pieces (exec/run.hpp: workers, queues, the one step function, the final serial
// pass), so a new strategy is a new policy type, not an edit of the executor; see
// tests/test_contract.cpp for one written in a test.
#pragma once

#include <idas/core/types.hpp>
#include <idas/exec/claim.hpp>
#include <idas/exec/run.hpp>

#include <tbb/spin_mutex.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <concepts>
#include <cstdint>
#include <limits>
#include <memory>
#include <thread>

namespace idas {

/// What every lock policy has: whether it runs workers in parallel, a constructor from
/// the vertex slot count, and a static `execute(run)` (a template over the run type, so
/// checked where the executor calls it) that composes the run's phases.
template <class L>
concept lock_policy = requires(std::size_t n) {
    { L::parallel } -> std::convertible_to<bool>;
    {L(n)};
};

/// A policy whose workers claim vertices: owner ids are 1-based worker numbers, 0 means
/// free.
template <class L>
concept claiming_lock_policy = lock_policy<L> && requires(L l, index_t v, std::uint32_t owner) {
    { l.try_lock(v, owner) } -> std::same_as<bool>;
    {l.unlock(v, owner)};
};

/// Whether a policy promises results that do not depend on the thread count.
template <class L>
inline constexpr bool deterministic_policy = requires {
    requires L::deterministic;
};

namespace lock {

/// Serial execution: claiming always succeeds and nothing is stored. Compiles to no
/// atomics at all.
struct none {
    static constexpr bool parallel = false;
    explicit none(std::size_t = 0) noexcept {}
    static constexpr bool try_lock(index_t, std::uint32_t) noexcept { return true; }
    static constexpr void unlock(index_t, std::uint32_t) noexcept {}

    template <class Run>
    static void execute(Run& run) {
        run.serial_phase();
    }
};

/// One atomic owner word per vertex; a worker claims a vertex by compare-and-swap and
/// gives up (rather than waits) if another worker holds it. Claiming a vertex it
/// already holds succeeds, so overlapping regions need no bookkeeping by the caller.
class vertex_try_lock {
public:
    static constexpr bool parallel = true;
    explicit vertex_try_lock(std::size_t n)
        : owner_(std::make_unique<std::atomic<std::uint32_t>[]>(n))
        , n_(n) {
        for (std::size_t i = 0; i < n; ++i) owner_[i].store(0, std::memory_order_relaxed);
    }
    bool try_lock(index_t v, std::uint32_t me) noexcept {
        std::uint32_t expected = 0;
        if (owner_[v].compare_exchange_strong(expected, me, std::memory_order_acquire,
                                              std::memory_order_relaxed))
            return true;
        return expected == me;
    }
    /// Like try_lock, but tells a fresh claim (1) from one `me` already held (0); -1 if
    /// another worker holds v. Lets callers keep their list of held vertices duplicate-free
    /// without searching it.
    IDAS_ALWAYS_INLINE int try_acquire(index_t v, std::uint32_t me) noexcept {
        // A plain load first: re-claims of held vertices (most claims of a tet star) and
        // claims of busy ones then cost no locked instruction. Only `me` writes `me`, so
        // seeing it is proof; a stale 0 just lets the CAS decide.
        const std::uint32_t seen = owner_[v].load(std::memory_order_relaxed);
        if (seen == me) return 0;
        if (seen != 0) return -1;
        std::uint32_t expected = 0;
        if (owner_[v].compare_exchange_strong(expected, me, std::memory_order_acquire,
                                              std::memory_order_relaxed))
            return 1;
        return expected == me ? 0 : -1;
    }
    void unlock(index_t v, std::uint32_t) noexcept {
        owner_[v].store(0, std::memory_order_release);
    }
    std::size_t size() const noexcept { return n_; }

    /// One thread: the serial phase. Several: the claiming phase, then the final serial
    /// pass of what kept losing races.
    template <class Run>
    static void execute(Run& run) {
        if (!run.parallel()) return run.serial_phase();
        run.parallel_run([&] {
            do claiming_phase(run);
            while (run.retake_set_aside());
        });
    }

    /// Lost races after which a worker gives up an entry cheaper than any other it has
    /// (one yield of the processor before each try): the most `queue_entry::retries` holds.
    static constexpr unsigned patient_retries = 254;

    /// Each worker drains its own part's queue, claiming every vertex of an operation's
    /// region with one compare-and-swap each (all or nothing). A lost race sets the entry
    /// aside: it is tried again once the queue runs dry, or (a spec with a goal) before
    /// the next entry if that one would cost more; after `max_retry` losses
    /// (`patient_retries` if it is the cheapest) it goes to the final serial pass. A worker
    /// whose queue is empty steals another part's best entry.
    template <class Run>
    static void claiming_phase(Run& run) {
        using entry = typename Run::entry;
        run.each_worker([&](typename Run::worker& me) {
            claimer<Run> claim{run, me.index + 1, {}};
            entry e;
            bool cheapest = false;
            while (!run.stopped() && pop_or_steal(run, me, e, cheapest)) {
                const step_outcome s =
                    run.template step<true>(me, e, claim, [](auto, const auto&) {});
                if (s == step_outcome::no_room) {
                    ++me.report.lock_failures, ++me.report.deferred_to_serial;
                    run.defer_to_final_pass(e);
                } else if (s == step_outcome::busy) {
                    ++me.report.lock_failures;
                    // The cheapest entry a worker has is given up late: the worker holding
                    // its region is inside one operation, or descheduled in it.
                    const unsigned limit = cheapest ? patient_retries : run.options().max_retry;
                    if (++e.retries > limit) {
                        ++me.report.deferred_to_serial;
                        run.defer_to_final_pass(e);
                    } else {
                        tbb::spin_mutex::scoped_lock lk(me.mutex);
                        me.deferred.push_back(e);
                        me.deferred_best = std::min(me.deferred_best, e.priority);
                    }
                }
            }
        });
    }

    /// Holds the vertices of one operation's region in the run's lock words.
    template <class Run>
    struct claimer {
        Run& run;
        std::uint32_t me;
        held_vertices held;

        template <class Op>
        claim_result claim(Op, typename Run::tuple& t) {
            auto take = [this](index_t v) { return this->take(v); };
            return run.template claim_footprint<Op>(t, take);
        }
        /// The vertices of Op's simplex only (the first stage of a two-stage claim).
        template <class Op>
        claim_result claim_seeds(Op, typename Run::tuple& t) {
            auto take = [this](index_t v) { return this->take(v); };
            return run.template claim_seeds<Op>(t, take);
        }
        IDAS_ALWAYS_INLINE bool take(index_t v) {
            auto& locks = run.locks();
            // Stars overlap (a triangle edge's region: ~36 claims of ~14 vertices; a
            // tet's: hundreds of a few dozen): the lock word itself says whether v is
            // already ours (28% cheaper claims on triangle meshes than a search).
            if constexpr (requires { locks.try_acquire(v, me); }) {
                const int r = locks.try_acquire(v, me);
                if (r > 0) held.push_back(v);
                return r >= 0;
            } else {
                if (std::find(held.begin(), held.end(), v) != held.end()) return true;
                if (!locks.try_lock(v, me)) return false;
                held.push_back(v);
                return true;
            }
        }
        void release() {
            for (index_t v : held) run.locks().unlock(v, me);
            held.clear();
        }
    };

    /// The worker's own next entry; the entries that lost races, when the queue is empty
    /// or, for a spec with a goal, when its next entry costs more than one of them
    /// (`cheapest` then says that the entry popped costs less than any other the worker
    /// has); then the best entry of another part. Retrying a cheaper entry rather than
    /// going on protects the greedy order where the goal stops the run: on a mesh
    /// decimated to a few hundred faces per worker, regions overlap and races are lost
    /// more often than won. A spec without a goal runs every entry anyway, so its worker
    /// goes on with its own part: retrying at once made each lost race a spin on the
    /// other worker's region (tet meshing's collapses on the sphere at 2 threads: 7,800
    /// lost races in 10,500 attempts, 2,500 without the retries, 6% less processor time).
    template <class Run>
    static bool pop_or_steal(Run& run, typename Run::worker& me, typename Run::entry& e,
                             bool& cheapest) {
        constexpr bool ordered = pops_in_priority_order<typename Run::queue_policy_type>;
        constexpr bool retry_cheaper = ordered && Run::hooks::has_goal;
        cheapest = false;
        bool popped = false;
        {
            tbb::spin_mutex::scoped_lock lk(me.mutex);
            popped = me.q.pop(e);
            if (popped && retry_cheaper && me.deferred_best < e.priority) {
                me.q.push(e); // after the cheaper ones
                requeue_deferred(me);
                me.q.pop(e);
                cheapest = true;
            } else if (!popped && !me.deferred.empty()) {
                requeue_deferred(me); // the queue ran dry: a retry after a backoff
                popped = me.q.pop(e);
            }
        }
        if (cheapest) {
            // The region's holder needs the core more than a retry does (more workers than
            // cores): let it finish first.
            std::this_thread::yield();
            me.level.store(e.priority, std::memory_order_relaxed);
            return true;
        }
        if (popped) {
            me.level.store(e.priority, std::memory_order_relaxed);
            if constexpr (ordered && Run::hooks::has_goal)
                if (take_from_cheaper_part(run, me, e)) ++me.report.stolen;
            return true;
        }
        me.level.store(std::numeric_limits<double>::infinity(), std::memory_order_relaxed);
        const unsigned P = run.parts();
        for (unsigned k = 1; k < P; ++k) {
            if (run.steal(run.worker_at((me.index + k) % P), e)) {
                ++me.report.stolen;
                return true;
            }
        }
        return false;
    }

    /// Factor by which a worker's next cost may exceed the cheapest other part's before
    /// the worker takes that part's best entry instead.
    static constexpr double cost_gap = 2;

private:
    template <class Worker>
    static void requeue_deferred(Worker& me) {
        me.report.pushed += me.deferred.size();
        for (const auto& d : me.deferred) me.q.push(d);
        me.deferred.clear();
        me.deferred_best = std::numeric_limits<double>::infinity();
    }

    /// A spec with a goal stops its workers after a number of successes, so which
    /// operations run first decides the result, as in the serial run's one global order.
    /// Each part's queue orders only its own entries: a worker whose part has run out of
    /// cheap operations (or whose neighbours' workers are descheduled) would go on with
    /// costly ones while cheap ones wait in another part. QSlim of a subdivided cube to
    /// 1%, which one thread returns exactly, then moved a corner (0.3 of the diagonal) in
    /// 3 to 7 runs of 100 on 2 threads under load. So when `e` costs more than `cost_gap` times the
    /// cheapest other part's last pop, the worker takes that part's best entry instead,
    /// if it is cheaper, and puts `e` back; its renewals then make the cheap region its
    /// own. Costs are taken to be non-negative (a decimation's); the other parts' levels
    /// are read again only once the worker's cost passes the last threshold.
    template <class Run>
    static bool take_from_cheaper_part(Run& run, typename Run::worker& me, typename Run::entry& e) {
        if (!(e.priority > me.others_checked_below)) return false;
        const unsigned P = run.parts();
        double floor = std::numeric_limits<double>::infinity();
        typename Run::worker* cheaper_part = nullptr;
        for (unsigned k = 1; k < P; ++k) {
            auto& w = run.worker_at((me.index + k) % P);
            const double level = w.level.load(std::memory_order_relaxed);
            if (level < floor) floor = level, cheaper_part = &w;
        }
        me.others_checked_below = cheaper_part == nullptr
                                      ? e.priority // no other part has work: look again later
                                      : std::max(cost_gap * std::max(floor, 0.0), floor);
        if (cheaper_part == nullptr || !(e.priority > me.others_checked_below)) return false;
        typename Run::entry cheaper;
        if (!run.pop(*cheaper_part, cheaper)) return false;
        cheaper_part->level.store(cheaper.priority, std::memory_order_relaxed);
        // Whichever entry is not taken goes back to its own queue.
        const bool better = cheaper.priority < e.priority;
        auto& back = better ? me : *cheaper_part;
        {
            tbb::spin_mutex::scoped_lock lk(back.mutex);
            back.q.push(better ? e : cheaper);
        }
        if (!better) return false; // its level was out of date
        e = cheaper;
        return true;
    }

    std::unique_ptr<std::atomic<std::uint32_t>[]> owner_;
    std::size_t n_;
};

/// Owner computes first, then claims. In a first phase each worker runs only the
/// operations whose every claimed vertex lies in its own part: a claim is a plain read of
/// the part map, with no locked instruction and no shared cache line written (on a tet
/// mesh a claim covers dozens of vertices). Vertices a worker creates join its part. The
/// operations that reach into another part wait for a second phase, which claims like
/// vertex_try_lock. Parts are spatially compact, so few operations wait.
class own_part_first : public vertex_try_lock {
public:
    using vertex_try_lock::vertex_try_lock;

    template <class Run>
    static void execute(Run& run) {
        if (!run.parallel()) return run.serial_phase();
        run.parallel_run([&] {
            owner_phase(run);
            claiming_phase(run);
        });
    }

    /// Each worker drains its own part's queue without locks, running only operations
    /// whose whole claim lies in its part. No worker steals, so no two ever touch a cell
    /// with a vertex of another part; cells made here hold only their maker's vertices.
    /// The rest waits for the claiming phase.
    template <class Run>
    static void owner_phase(Run& run) {
        const auto start = std::chrono::steady_clock::now();
        constexpr std::uint32_t unowned = ~std::uint32_t{0};
        auto& part = run.part_map();
        auto& m = run.mesh();
        for (index_t v = 0; v < part.size(); ++v)
            if (!m.vertex_alive(v)) part[v] = unowned; // future vertices: their maker's
        run.each_worker([&](typename Run::worker& me) {
            const std::uint32_t w = me.index;
            own_part<Run> claim{run, part, w};
            auto adopt_new_vertices = [&](auto op, const auto& r) {
                if constexpr (decltype(op)::adds_vertices > 0)
                    for (const auto& c : r.cells)
                        for (index_t v : cells::vertices(m, cells::of(m, c)))
                            if (part[v] == unowned) part[v] = w;
            };
            typename Run::entry e;
            while (!run.stopped() && run.pop(me, e)) {
                const step_outcome s = run.template step<true>(me, e, claim, adopt_new_vertices);
                if (s == step_outcome::busy || s == step_outcome::no_room) {
                    ++me.report.crossed_parts;
                    me.deferred.push_back(e);
                }
            }
            // What reached into other parts starts the claiming phase.
            me.report.pushed += me.deferred.size();
            for (const auto& d : me.deferred) me.q.push(d);
            me.deferred.clear();
        });
        run.report().owner_seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }

    /// Claims an operation's region if every vertex of it lies in the worker's part: a
    /// read of the part map, nothing written.
    template <class Run>
    struct own_part {
        Run& run;
        const std::vector<std::uint32_t>& part;
        std::uint32_t w;
        template <class Op>
        claim_result claim(Op, typename Run::tuple& t) {
            // A spec's extra lock words (past the vertices) belong to no part: operations
            // that take one wait for the claiming phase.
            auto mine = [&](index_t v) { return v < part.size() && part[v] == w; };
            return run.template claim_footprint<Op>(t, mine);
        }
        static constexpr void release() noexcept {}
    };
};

} // namespace lock

static_assert(claiming_lock_policy<lock::none>);
static_assert(claiming_lock_policy<lock::vertex_try_lock>);
static_assert(claiming_lock_policy<lock::own_part_first>);
static_assert(!deterministic_policy<lock::vertex_try_lock>);

} // namespace idas
