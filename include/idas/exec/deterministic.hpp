// Deterministic parallel execution: the same mesh, byte for byte, at any thread count.
//
// The run goes in rounds. Each round takes the best queued entries (the `round_size`
// first in priority order), finds which of them are best among every candidate whose
// lock region overlaps theirs, and runs those in parallel: their regions are disjoint,
// so no claim can fail and none is needed. The others wait for the next round. Nothing
// in a round depends on the thread count or on timing:
//
//  - the queue is a fixed number of shards (parts of a Morton order of the vertices),
//    each a priority queue whose pops depend only on what was pushed (queue.hpp's
//    `pops_before`), filled and drained one thread per shard;
//  - the winners are found with one word per vertex holding the best candidate that
//    touches it (a compare-and-swap minimum; the final words do not depend on the order);
//  - new vertices and cells come from one slot pool per winner, dealt in candidate order
//    (the backends' quota `begin_parallel`), so their numbers do not depend on the thread
//    that made them;
//  - a spec's goal (`remaining`) caps the winners of a round, best first, so a target
//    face count is met exactly, as in a serial run.
//
// Before the rounds, a phase whose operations add no vertex lets fixed groups of shards
// run what stays inside them, the groups in parallel (own_shards_first); with a goal, in
// priority bands, each shard with a budget (run_in_bands), and the last bands, on a mesh
// grown small, as one group: the serial order (serial_tail_faces).
//
// On one thread the rounds run the same way, so one thread and N give the same mesh.
#pragma once

#include <idas/exec/claim.hpp>
#include <idas/exec/hooks.hpp>
#include <idas/exec/lock.hpp>
#include <idas/exec/queue.hpp>
#include <idas/exec/report.hpp>
#include <idas/exec/run.hpp>
#include <idas/exec/workers.hpp>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

namespace idas::lock {

/// The deterministic execution policy: rounds of non-overlapping best operations (see the
/// file comment). Takes no locks, so it has no try_lock; its `execute` runs the rounds.
struct deterministic_rounds {
    static constexpr bool parallel = true;
    static constexpr bool deterministic = true;
    explicit deterministic_rounds(std::size_t = 0) noexcept {}

    /// Shards of the queue: fixed, so the rounds do not depend on the thread count; more
    /// than any machine's cores here, so every thread has shards to fill and drain.
    static constexpr unsigned shards = 64;
    /// A spec with a goal runs its groups in bands while it still wants this many
    /// operations (deterministic_engine::run_in_bands): to the last one, as the rounds of
    /// a band pick only among the band's entries, closer to the serial order than
    /// unbounded rounds: with the last 1,024 collapses in those, the mean distance to the
    /// input was 6.6% above the serial run's, now 1.9% (bench/RESULTS.md, "Session 37").
    static constexpr std::int64_t min_band_goal = 1;
    /// Once a spec with a goal has at most this many live faces (256 a shard), its bands
    /// run as one group of the whole mesh: the serial order, on one thread. Shards this
    /// small put a seam through every neighbourhood, and the last collapses, the
    /// costliest, decide the distance to the input: on 24 decimations the Hausdorff
    /// distance went from 8.3% above the serial run's to 3.4% (geometric means; the mean
    /// distance from 2.6% to 0.2%), and meshes this small give the serial result. Twice
    /// as many (512 a shard) moved larger meshes' figures both ways, as any change of
    /// order does, and cost bunny's 2-thread runs 12% more (bench/RESULTS.md, "Session
    /// 42"). Counts alone decide it, never the threads.
    static constexpr std::int64_t serial_tail_faces = 256 * shards;
    /// Whether a run of `Spec` with this many live faces is in its serial tail.
    template <class Spec>
    static constexpr bool in_serial_tail(std::int64_t faces) noexcept {
        return detail::remaining_hook<Spec> && faces <= serial_tail_faces;
    }

    template <class Run>
    static void execute(Run& run);
};

} // namespace idas::lock

namespace idas::detail {

/// Runs fn(begin, end, thread) over [0, n) in chunks on the pool's threads.
template <class Fn>
void parallel_chunks(worker_pool& pool, std::size_t n, std::size_t chunk, Fn&& fn) {
    if (n == 0) return;
    const unsigned T =
        static_cast<unsigned>(std::min<std::size_t>(pool.size(), (n + chunk - 1) / chunk));
    if (T <= 1) return fn(std::size_t{0}, n, 0u);
    std::atomic<std::size_t> next{0};
    pool.run(T, [&](unsigned t) {
        for (std::size_t b; (b = next.fetch_add(chunk, std::memory_order_relaxed)) < n;)
            fn(b, std::min(n, b + chunk), t);
    });
}

template <class Run>
class deterministic_engine {
    using Mesh = typename Run::mesh_type;
    using Spec = typename Run::spec_type;
    using tuple = typename Run::tuple;
    /// The run's entry, with ties spread over the mesh (queue.hpp: spreads_ties).
    struct entry : Run::entry {
        static constexpr bool spreads_ties = true;
    };
    using hooks = typename Run::hooks;
    using ops = typename Run::ops;
    using queue_policy = std::conditional_t<pops_in_priority_order<typename Run::queue_policy_type>,
                                            typename Run::queue_policy_type, queue::binary_heap>;
    using queue_type = typename queue_policy::template type<entry>;
    static constexpr unsigned K = lock::deterministic_rounds::shards;
    static_assert(K <= 256, "idas: a vertex's shard is kept in a byte (part_)");
    static_assert(!ops::adds_simplices || Mesh::parallel_growth,
                  "idas: lock::deterministic_rounds runs operations that add simplices only on a "
                  "backend that deals slot pools (begin_parallel)");

    struct shard {
        queue_type q;
        // Entries taken out of q in earlier rounds that did not run, in pop order: they are
        // merged with q's pops instead of going back into it (a push and a pop each).
        std::vector<entry> front, next_front;
        std::vector<entry> popped;     // this round's pops, best first
        std::vector<entry> reanchored; // vertex entries moved to a current tuple
        std::size_t taken = 0;         // how many of them became candidates
        std::size_t first = 0;         // index of its first candidate
        std::size_t pushed_since_purge = 0;
        std::int64_t budget = 0;        // successes its group may make in the open band
        std::vector<double> priorities; // open_band: those of its entries still wanted
        run_report report;
    };
    /// A thread's context and its pushes, by shard.
    struct alignas(64) thread_state {
        op_context<Mesh> own_ctx;
        op_context<Mesh>* ctx = &own_ctx;
        std::vector<std::vector<entry>> out = std::vector<std::vector<entry>>(K);
        run_report report;
        // Vertices already in the region being recorded (record_regions): region_seen[v]
        // equals region_tag. 16 bits a vertex; cleared when the tag wraps.
        std::vector<std::uint16_t> region_seen;
        std::uint16_t region_tag = 0;
        // run_group's queue, in plain priority order (ties by slot): what the group
        // starts with, sorted, and a heap of what its operations renew; and what its
        // successes changed of the live counts.
        std::vector<typename Run::entry> group_sorted;
        typename queue::binary_heap::template type<typename Run::entry> group_renewed;
        std::int64_t group_face_delta = 0, group_vertex_delta = 0;
    };
    /// What became of a candidate this round; all but `ran` go back to their shard.
    enum class fate : std::uint8_t { waits, beaten, blocked, won_now, wins, ran };
    /// Passes of the winners' selection in one round (see select_winners).
    static constexpr unsigned max_passes = 3;

public:
    explicit deterministic_engine(Run& run)
        : run_(run)
        , m_(run.mesh())
        , spec_(run.spec())
        , T_(std::max(1u, run.options().threads)) {
        for (unsigned t = 0; t < T_; ++t) threads_.push_back(std::make_unique<thread_state>());
        if (T_ == 1) threads_[0]->ctx = &thread_context<Mesh>(); // warm buffers
    }

    void run() {
        // Dead slots are not recycled during the run, whatever the thread count: the free
        // list would be shared state, and numbering must not depend on the threads.
        m_.set_slot_recycling(false);
        const stopwatch seeding;
        seed();
        live_ = hooks::counts(m_);
        const double seeded = seeding.seconds();
        if constexpr (groups_apply) {
            if constexpr (remaining_hook<Spec>) {
                run_in_bands();
            } else if (!hooks::should_stop(spec_, live_)) {
                hooks::quiescent(spec_, m_, live_);
                own_shards_first();
            }
        }
        run_rounds();
        run_report& r = run_.report();
        r.threads = T_;
        for (auto& s : shards_) r += s.report;
        for (auto& t : threads_) r += t->report;
        r.faces = live_.faces, r.vertices = live_.vertices;
        r.rounds += rounds_;
        r.setup_seconds += seeded;
        m_.set_slot_recycling(true);
    }

private:
    // ------------------------------------------------------------ seeding ----

    /// Initial entries go to the shard of their tuple's vertex (a Morton part).
    void seed() {
        const std::vector<std::uint32_t> assigned = Run::partition_type::assign(m_, K);
        part_.assign(assigned.begin(), assigned.end());
        const std::vector<std::uint8_t>& part = part_;
        if constexpr (hooks::seeds_per_vertex && !initial_hook<Spec, Mesh>) {
            std::vector<std::vector<index_t>> by_shard(K);
            for (index_t v = 0; v < m_.vertex_slots(); ++v)
                if (m_.vertex_alive(v)) by_shard[part[v]].push_back(v);
            each_shard([&](unsigned s, unsigned) {
                auto& sh = shards_[s];
                auto push = [&](auto op, const tuple& t) {
                    seed_into(sh, entry{hooks::template make_entry<decltype(op)>(spec_, m_, t)});
                    ++sh.report.pushed;
                };
                for (index_t v : by_shard[s]) hooks::initial_at(spec_, m_, v, push);
            });
        } else {
            std::vector<std::vector<entry>> by_shard(K);
            auto push = [&](auto op, const tuple& t) {
                by_shard[part[t.vid]].push_back({0.0, t, ops::template id_of<decltype(op)>, 0});
            };
            hooks::initial(spec_, m_, push);
            each_shard([&](unsigned s, unsigned) {
                auto& sh = shards_[s];
                sh.q.reserve(by_shard[s].size() * 2 + 64);
                for (entry e : by_shard[s]) {
                    ops::dispatch(e.kind, [&](auto op) {
                        e.priority = hooks::template priority<decltype(op)>(spec_, m_, e.tuple);
                    });
                    seed_into(sh, e);
                }
                sh.report.pushed += by_shard[s].size();
            });
        }
    }

    /// Where a seed waits: in its shard's front when the groups run first and take every
    /// entry (their sort does not care in what order), a vector's push instead of a heap's;
    /// else in the shard's queue.
    void seed_into(shard& sh, const entry& e) {
        if constexpr (seeds_wait_in_fronts)
            sh.front.push_back(e);
        else
            sh.q.push(e);
    }

    /// Rounds until the spec stops or no entry is left (in a band: none inside it).
    void run_rounds() {
        while (!hooks::should_stop(spec_, live_)) {
            // Between rounds no operation runs, and the counts are the same at any thread
            // count, so what the spec refits here does not depend on the threads either.
            hooks::quiescent(spec_, m_, live_);
            if (fill_and_select() == 0) break;
            if (select_winners() == 0) continue; // cannot happen: the best candidate wins
            execute_winners();
            merge_round();
        }
    }

    // -------------------------------------------------- shards on their own ----

    /// Phases whose operations add no vertex (smoothing, collapses, flips and swaps) first
    /// let groups of shards run their own entries, those whose lock region lies in the
    /// group's vertices, the groups in parallel. Such an entry reads and writes only what
    /// its region freezes (claim.hpp), and no other group's entry holds any of it, so what
    /// a group does depends on its own entries only, never on the threads or on timing; no
    /// vertex is added, so every vertex stays in its shard, and new cells come from the
    /// group's own slot pool (deal_group_pools). An entry whose region crosses
    /// into another group (or into another group's space, an invariant's lock cells: see
    /// own_space) waits for the next level, where neighbouring groups on the Morton curve
    /// are merged in pairs (64 shards, then 32 groups, 16, 8, 4, 2), and what crosses even
    /// those runs last in one group of the whole mesh, on one thread. Rounds alone walk
    /// each region about twice (half the candidates of a smoothing round lose to an
    /// overlapping better one) and run a few hundred winners between serial steps:
    /// harmonic smoothing of 200k points took 2.9 times as long as the try-lock executor's,
    /// with the groups first 1.5 times (bench/RESULTS.md). What crosses the halves lies
    /// along one seam, so a round found few winners in it: one thread runs it faster than
    /// rounds did on two (bench/RESULTS.md, "Session 31"). A spec with a goal
    /// (`remaining`) runs the groups in bands (run_in_bands). Not for a spec whose
    /// invariant claims space it cannot locate.
    using invariants_type = std::remove_cvref_t<decltype(spec_invariants(std::declval<Spec&>()))>;
    static constexpr bool groups_apply =
        invariants_type::locates_space &&
        (!ops::adds_simplices || (Mesh::parallel_growth && !ops::adds_vertices));
    static constexpr unsigned group_levels = 7; // groups of 1, 2, 4, ... 64 shards
    static constexpr bool seeds_wait_in_fronts = groups_apply && !remaining_hook<Spec>;

    /// A spec with a goal (a decimation to a face count) must stop where a serial order
    /// would, best first, so its groups run in priority bands: the queued entries' priority
    /// below which lie half the operations still wanted bounds a band; each shard gets a
    /// budget of the goal in proportion to its entries inside the band (so the groups
    /// together cannot pass the goal), the groups run what lies inside the band within
    /// their budgets (a budget left over goes with the shard into the next level's group),
    /// and rounds bounded by the band run what the budgets left. Then the next band, until
    /// the goal is met: the last bands are a handful of operations, and their rounds, best
    /// first, make them as a serial run would. Budgets, bands and groups depend on counts
    /// alone, never on the threads.
    /// Rounds alone made QSlim to 10% of armadillo x4 1.5 times as slow as the try-lock
    /// executor (bench/RESULTS.md, "Session 31").
    static constexpr std::int64_t band_share_inverse = 2; // a band: half the goal's entries
    static constexpr unsigned max_bands = 64;             // then rounds, unbounded, finish

    void run_in_bands() {
        for (unsigned band = 0; band < max_bands && !hooks::should_stop(spec_, live_); ++band) {
            const std::int64_t goal = spec_.remaining(live_);
            if (goal < lock::deterministic_rounds::min_band_goal) break;
            hooks::quiescent(spec_, m_, live_);
            const std::uint64_t successes = live_.successes;
            if (!open_band(goal)) break;
            own_shards_first();
            run_rounds();
            band_open_ = false;
            if (live_.successes == successes) break;
        }
    }

    /// Purges every shard's queue of stale entries, bounds the band by the priority of the
    /// (goal / band_share_inverse)-th best entry still wanted, and gives each shard its
    /// budget. False if no entry is left.
    bool open_band(std::int64_t goal) {
        each_shard([&](unsigned s, unsigned) {
            shard& sh = shards_[s];
            sh.priorities.clear();
            const std::size_t before = sh.q.size();
            sh.q.erase_if([&](const entry& x) {
                if (!run_.still_wanted(x)) return true;
                sh.priorities.push_back(x.priority);
                return false;
            });
            sh.report.purged += before - sh.q.size();
            sh.pushed_since_purge = 0;
            for (const entry& x : sh.front)
                if (run_.still_wanted(x)) sh.priorities.push_back(x.priority);
        });
        band_priorities_.clear();
        for (const shard& sh : shards_)
            band_priorities_.insert(band_priorities_.end(), sh.priorities.begin(),
                                    sh.priorities.end());
        const std::size_t k =
            static_cast<std::size_t>(std::max<std::int64_t>(1, goal / band_share_inverse));
        if (band_priorities_.size() > k) {
            std::nth_element(band_priorities_.begin(),
                             band_priorities_.begin() + std::ptrdiff_t(k - 1),
                             band_priorities_.end());
            band_bound_ = band_priorities_[k - 1];
        } else {
            band_bound_ = std::numeric_limits<double>::infinity();
        }
        std::int64_t inside = 0;
        for (shard& sh : shards_) {
            sh.budget = std::count_if(sh.priorities.begin(), sh.priorities.end(),
                                      [&](double p) { return !(p > band_bound_); });
            inside += sh.budget;
        }
        if (inside == 0) return false;
        for (shard& sh : shards_) sh.budget = goal * sh.budget / inside;
        band_open_ = true;
        return true;
    }

    /// Whether an entry lies inside the open band (every entry does when none is open, and
    /// always for a spec without a goal, which never opens one).
    bool in_band(const typename Run::entry& e) const noexcept {
        if constexpr (remaining_hook<Spec>)
            return !band_open_ || !(e.priority > band_bound_);
        else
            return true;
    }
    /// Whether a group's budget in the open band is spent.
    bool budget_spent(std::int64_t budget) const noexcept {
        if constexpr (remaining_hook<Spec>)
            return band_open_ && budget == 0;
        else
            return false;
    }

    void own_shards_first() {
        // The cells keep their owners from band to band while their number stays: any
        // fixed owner is correct, and sorting the curve again for every band took a tenth
        // of a banded decimation (x4, shortest edge to 1%).
        if constexpr (invariants_type::claims_space)
            if (spec_invariants(spec_).extra_lock_words(m_) != space_owner_.size())
                own_space(part_.size());
        const bool serial_tail = lock::deterministic_rounds::in_serial_tail<Spec>(live_.faces);
        const unsigned first_level = serial_tail ? group_levels - 1 : 0;
        for (unsigned level = first_level; level < group_levels; ++level) {
            const unsigned width = 1u << level;
            if constexpr (ops::adds_simplices) deal_group_pools(level, level == first_level);
            const std::size_t V = part_.size();
            parallel_chunks(pool_, K / width, 1, [&](std::size_t b, std::size_t e, unsigned th) {
                for (std::size_t g = b; g < e; ++g)
                    run_group(static_cast<unsigned>(g), level, V, *threads_[th], th);
            });
            if constexpr (ops::adds_simplices) {
                m_.end_parallel();
                m_.set_slot_recycling(false); // end_parallel turned it on
            }
        }
        std::uint64_t successes = 0;
        for (auto& t : threads_) {
            successes += t->report.succeeded;
            live_.faces += t->group_face_delta, live_.vertices += t->group_vertex_delta;
            t->group_face_delta = t->group_vertex_delta = 0;
        }
        live_.successes = successes;
    }

    /// Groups whose operations add cells (a 2-3 swap) take their slots from pools of their
    /// own, one a group, dealt before each level: the room the spec expects the phase to
    /// need (its parallel_growth), shared in proportion to the entries each group holds,
    /// and never more than those entries could use. So the new cells' numbers depend on the
    /// group's own operations only. An operation that finds its group's pool too small
    /// waits for the next level (after the last, for the rounds, which deal a pool per
    /// operation). Operations that add vertices (splits) are left to the rounds: a group
    /// would refine its side of a seam before the long edges across it, against the
    /// longest-first order, and the fans around those edges split again and again (the
    /// sphere's first tet-mesh split phase: 9,749 splits in rounds, 89,174 in groups).
    void deal_group_pools(unsigned level, bool first) {
        const unsigned groups = K >> level, width = 1u << level;
        if (first) phase_growth_ = hooks::parallel_growth(spec_, m_).second;
        group_entries_.assign(groups, 0);
        std::size_t all = 0;
        for (unsigned s = 0; s < K; ++s) {
            const std::size_t n = shards_[s].q.size() + shards_[s].front.size();
            group_entries_[s / width] += n, all += n;
        }
        vertex_quota_.assign(groups, 0), cell_quota_.assign(groups, 0);
        for (unsigned g = 0; g < groups; ++g) {
            const double n = double(group_entries_[g]);
            const double share =
                std::ceil(double(phase_growth_) * n / double(std::max<std::size_t>(all, 1)));
            cell_quota_[g] =
                static_cast<index_t>(std::min(share, n * double(ops::most_faces_added)));
        }
        m_.begin_parallel(std::span<const index_t>(vertex_quota_),
                          std::span<const index_t>(cell_quota_));
    }

    /// An invariant's space (the lock cells of a spatial index) goes to the groups too:
    /// each cell to the shard of the vertex before its centre along a Morton curve over
    /// both. Any fixed owner keeps two groups from sharing a word; following the vertices'
    /// shards keeps an operation's star and the space around it mostly in one group.
    void own_space(std::size_t V) {
        const auto inv = spec_invariants(spec_);
        const std::size_t C = inv.extra_lock_words(m_);
        space_owner_.assign(C, 0);
        std::vector<vec3> points;
        std::vector<index_t> vertex; // of each point, or invalid_index for a cell centre
        points.reserve(V + C), vertex.reserve(V + C);
        for (index_t v = 0; v < V; ++v)
            if (m_.vertex_alive(v)) points.push_back(m_.position(v)), vertex.push_back(v);
        for (std::size_t k = 0; k < C; ++k)
            points.push_back(inv.lock_cell_centre(k)), vertex.push_back(invalid_index);
        auto keyed = partition::morton::keys(points);
        std::sort(keyed.begin(), keyed.end());
        std::uint8_t last = 0;
        for (const auto& [code, i] : keyed) // cells before the first vertex: shard 0
            if (vertex[i] != invalid_index)
                last = static_cast<std::uint8_t>(part_[vertex[i]]);
            else
                space_owner_[i - (points.size() - C)] = last;
    }

    /// Group g of `level` (shards g * 2^level and on) runs every entry of its shards,
    /// queued or waiting, and what they renew, in priority order with ties by slot (not
    /// spread, as the rounds need: neighbours then follow each other, which the cache
    /// likes). What crosses out of the group waits in its vertex's shard's front. In a band,
    /// only the entries inside it, and no more successes than the group's budget.
    void run_group(unsigned g, unsigned level, std::size_t V, thread_state& me, unsigned th) {
        const unsigned width = 1u << level, first = g * width;
        // The group's entries are sorted once and merged with a heap of what its
        // operations renew: a smoothing pass renews nothing, and pushing every entry
        // through a heap (and before that, through its shard's queue, whose ties compare
        // by hash) cost harmonic smoothing a sixth of its time on one thread.
        auto& sorted = me.group_sorted;
        auto& renewed = me.group_renewed;
        sorted.clear(), renewed.clear();
        std::int64_t budget = 0; // successes left to the group in the open band
        for (unsigned s = first; s < first + width; ++s) {
            shard& sh = shards_[s];
            budget += std::exchange(sh.budget, 0);
            // The sort does not depend on the order it finds them in, so the front need
            // not be in pop order here (only the rounds merge it with the queue's pops).
            std::erase_if(sh.front, [&](const entry& x) {
                if (!in_band(x) || wake_level(x) > level) return false;
                sorted.push_back(x);
                return true;
            });
            sh.q.erase_if([&](const entry& x) {
                if (!in_band(x)) return false;
                sorted.push_back(x);
                return true;
            });
        }
        std::sort(sorted.begin(), sorted.end(),
                  [](const auto& a, const auto& b) { return pops_before(a, b); });
        std::size_t next_sorted = 0;
        // The group's best entry: the next sorted one or the renewed heap's top.
        auto pop = [&](typename Run::entry& out) {
            if (next_sorted < sorted.size() &&
                (renewed.size() == 0 || !pops_before(renewed.top(), sorted[next_sorted])))
                return out = sorted[next_sorted++], true;
            return renewed.pop(out);
        };
        op_context<Mesh>& ctx = *me.ctx;
        ctx.worker = th;
        if constexpr (ops::adds_simplices) ctx.conn.pool = g; // the group's own slots
        // The shard of a lock word (group_levels: none, so only the rounds can take it).
        auto shard_of = [&](index_t v) IDAS_ALWAYS_INLINE_LAMBDA -> unsigned {
            if (v < V) return part_[v];
            const std::size_t w = v - V;
            return w < space_owner_.size() ? space_owner_[w] : K;
        };
        auto in_group = [&](index_t v)
                            IDAS_ALWAYS_INLINE_LAMBDA { return (shard_of(v) >> level) == g; };
        index_t refused = invalid_index; // the word a claim found outside the group
        auto claimable = [&](index_t v) IDAS_ALWAYS_INLINE_LAMBDA {
            if (in_group(v)) return true;
            refused = v;
            return false;
        };
        // An entry that cannot run here waits in its vertex's shard (or the group's first).
        auto home_of = [&](const tuple& t) -> shard& {
            return shards_[in_group(t.vid) ? part_[t.vid] : first];
        };
        shard& home = shards_[first]; // its report counts the group's work
        for (typename Run::entry popped; pop(popped);) {
            entry e;
            static_cast<typename Run::entry&>(e) = popped;
            if (budget_spent(budget)) {
                home_of(e.tuple).front.push_back(e);
                continue;
            }
            ++home.report.popped;
            ops::dispatch(e.kind, [&](auto op) {
                using Op = decltype(op);
                tuple t = e.tuple;
                refused = invalid_index;
                const claim_result c = claim_footprint<Op>(spec_, m_, t, claimable);
                if (c == claim_result::stale) return void(++home.report.stale);
                if (c == claim_result::busy) {
                    // It waits for the first level whose group holds both its shard and
                    // the word it was refused: its region reached that word, and a region
                    // changes only where an operation next to it ran (never in a
                    // smoothing phase), so trying it at the levels between would mostly
                    // fail again. Harmonic smoothing of 200k points popped 543k entries
                    // when each went one level up, 309k now. The choice depends on the
                    // group's own mesh only.
                    shard& wait = home_of(e.tuple);
                    const unsigned across =
                        refused == invalid_index
                            ? 0u
                            : shard_of(refused) ^ unsigned(&wait - shards_.data());
                    wake_level(e) = static_cast<std::uint8_t>(
                        std::max<unsigned>(level + 1, std::bit_width(across)));
                    return wait.front.push_back(e);
                }
                entry current = e;
                current.tuple = t;
                if (!hooks::template should_process<Op>(spec_, m_, current))
                    return void(++home.report.skipped);
                if constexpr (Op::adds_vertices + Op::adds_faces > 0)
                    if (!m_.has_room(Op::adds_vertices, Op::adds_faces, g)) {
                        wake_level(e) = static_cast<std::uint8_t>(level + 1);
                        return home_of(e.tuple).front.push_back(e);
                    }
                const std::int64_t fd = ctx.face_delta, vd = ctx.vertex_delta;
                const std::uint64_t succeeded = me.report.succeeded;
                ++me.report.grouped;
                attempt<Op>(me, t, [&](const entry& fresh) {
                    if (in_band(fresh))
                        renewed.push(fresh);
                    else
                        home_of(fresh.tuple).q.push(fresh);
                    ++home.report.pushed;
                });
                budget -= std::int64_t(me.report.succeeded - succeeded);
                me.group_face_delta += ctx.face_delta - fd;
                me.group_vertex_delta += ctx.vertex_delta - vd;
            });
        }
        home.budget = budget;
        ctx.conn.pool = 0;
        // The rounds after the last level merge each front with its queue's pops, so the
        // fronts go into pop order there; the groups before take them in any order.
        if (level + 1 == group_levels)
            for (unsigned s = first; s < first + width; ++s) {
                auto& front = shards_[s].front;
                for (entry& x : front) wake_level(x) = 0;
                std::sort(front.begin(), front.end(),
                          [](const entry& a, const entry& b) { return pops_before(a, b); });
            }
    }

    /// The first level whose groups may try an entry that waits in a front (see run_group).
    /// Kept in the entry's `retries`, which no other part of this engine uses (and which no
    /// order reads).
    static std::uint8_t& wake_level(entry& e) noexcept { return e.retries; }
    static std::uint8_t wake_level(const entry& e) noexcept { return e.retries; }

    // ------------------------------------------------------------- rounds ----

    /// Every shard takes back what waited (into its front) and what the last round pushed
    /// (into its queue), then takes its best current entries; the round's candidates are
    /// the best `round_size` of all of them that no unpopped entry beats. Returns how many
    /// there are.
    std::size_t fill_and_select() {
        const std::size_t B = round_size();
        const std::size_t per_shard = (3 * B / 2 + K - 1) / K;
        each_shard([&](unsigned s, unsigned) {
            shard& sh = shards_[s];
            // What waited, what was popped but not taken and the old front stay in pop order.
            sh.next_front.clear();
            for (std::size_t i = sh.first; i < sh.first + sh.taken; ++i)
                if (fate_[i] != fate::ran) sh.next_front.push_back(cand_[i]);
            sh.next_front.insert(sh.next_front.end(), sh.popped.begin() + std::ptrdiff_t(sh.taken),
                                 sh.popped.end());
            sh.next_front.insert(sh.next_front.end(), sh.front.begin(), sh.front.end());
            std::swap(sh.front, sh.next_front);
            for (auto& t : threads_) {
                auto& out = t->out[s];
                for (const entry& e : out) sh.q.push(e);
                sh.report.pushed += out.size();
                sh.pushed_since_purge += out.size();
                out.clear();
            }
            purge_if_bloated(sh);
            sh.popped.clear();
            // The queue's pops merged with the front: the same sequence as if the front had
            // gone back into the queue. `next` holds the queue's best, popped ahead.
            entry next, e;
            bool queued = sh.q.pop(next);
            std::size_t f = 0;
            while (sh.popped.size() < per_shard) {
                const bool from_front =
                    f < sh.front.size() && (!queued || !pops_before(next, sh.front[f]));
                if (!from_front && !queued) break;
                if (!in_band(from_front ? sh.front[f] : next)) break; // the rest waits too
                if (from_front) {
                    e = sh.front[f++];
                } else {
                    e = next;
                    queued = sh.q.pop(next);
                }
                ++sh.report.popped;
                if (!m_.is_valid(e.tuple)) {
                    // A vertex entry follows its vertex into a current tuple; that changes
                    // its tie key, so it goes back to be popped in its new place (the
                    // popped list must stay in pop order).
                    if (reanchor(e)) {
                        sh.reanchored.push_back(e);
                    } else {
                        ++sh.report.stale;
                    }
                    continue;
                }
                bool wanted = true;
                ops::dispatch(e.kind, [&](auto op) {
                    wanted = hooks::template should_process<decltype(op)>(spec_, m_, e);
                });
                if (!wanted) {
                    ++sh.report.skipped;
                    continue;
                }
                sh.popped.push_back(e);
            }
            if (queued) sh.q.push(next); // popped ahead, not taken
            sh.front.erase(sh.front.begin(), sh.front.begin() + std::ptrdiff_t(f));
            for (const entry& x : sh.reanchored) sh.q.push(x); // after the pops, not among them
            sh.report.pushed += sh.reanchored.size();
            sh.reanchored.clear();
        });

        // A shard that could pop more bounds what is known to be best: nothing after its
        // last pop may be taken. Then at most B, best first.
        const entry* bound = nullptr;
        for (const shard& sh : shards_)
            if (sh.popped.size() == per_shard && (!bound || pops_before(sh.popped.back(), *bound)))
                bound = &sh.popped.back();
        keys_.clear();
        for (const shard& sh : shards_)
            for (const entry& e : sh.popped) {
                if (bound && pops_before(*bound, e)) break;
                keys_.push_back(e);
            }
        if (keys_.size() > B) {
            std::nth_element(keys_.begin(), keys_.begin() + std::ptrdiff_t(B - 1), keys_.end(),
                             [](const entry& a, const entry& b) { return pops_before(a, b); });
            last_ = keys_[B - 1];
            bound = &last_;
        }
        cand_.clear();
        cand_shard_.clear();
        for (unsigned s = 0; s < K; ++s) {
            shard& sh = shards_[s];
            sh.first = cand_.size();
            std::size_t n = 0;
            while (n < sh.popped.size() && !(bound && pops_before(*bound, sh.popped[n]))) ++n;
            sh.taken = n;
            cand_.insert(cand_.end(), sh.popped.begin(), sh.popped.begin() + std::ptrdiff_t(n));
            cand_shard_.insert(cand_shard_.end(), n, static_cast<std::uint8_t>(s));
        }
        fate_.assign(cand_.size(), fate::waits);
        return cand_.size();
    }

    /// The round's winners, in passes: each pass, the candidates still waiting whose
    /// regions meet no winner's find the best among them (mark_regions) and those best
    /// among every such candidate they overlap win (pick_winners). A candidate beaten in
    /// one pass by a candidate that then lost to a winner can win in the next: where the
    /// best candidates crowd around one place (the longest edges of a tet mesh around one
    /// vertex), one pass leaves a handful of winners per round. Each pass depends only on
    /// the candidates and the mesh, never on the threads. A spec's goal caps the winners,
    /// best first. Returns how many won.
    std::size_t select_winners() {
        ++rounds_;
        const std::size_t n = hooks::lock_words(spec_, m_);
        if (n > mark_size_) {
            mark_size_ = std::max<std::size_t>(n, mark_size_ * 3 / 2);
            marks_ = std::make_unique<std::atomic<std::uint64_t>[]>(mark_size_);
            taken_ = std::make_unique<std::uint32_t[]>(mark_size_);
            for (std::size_t v = 0; v < mark_size_; ++v)
                marks_[v].store(0, std::memory_order_relaxed), taken_[v] = 0;
        }
        record_regions();
        winners_.clear();
        for (unsigned pass = 0; pass < max_passes; ++pass) {
            const std::size_t before = winners_.size();
            mark_regions(pass > 0);
            pick_winners();
            if (winners_.size() == before || pass + 1 == max_passes) break;
            // The new winners' regions are taken; whoever was beaten waits again.
            parallel_chunks(pool_, winners_.size() - before, 256,
                            [&](std::size_t b, std::size_t e, unsigned) {
                                auto take = [&](index_t v) { return taken_[v] = rounds_, true; };
                                for (std::size_t w = before + b; w < before + e; ++w)
                                    walk_region(winners_[w], take);
                            });
            bool open = false;
            for (auto& f : fate_)
                if (f == fate::beaten) f = fate::waits, open = true;
            if (!open) break;
        }
        std::sort(winners_.begin(), winners_.end());
        if constexpr (remaining_hook<Spec>) {
            const std::int64_t goal = std::max<std::int64_t>(1, spec_.remaining(live_));
            if (std::int64_t(winners_.size()) > goal) {
                const auto cut = winners_.begin() + std::ptrdiff_t(goal);
                std::nth_element(winners_.begin(), cut - 1, winners_.end(),
                                 [&](std::size_t a, std::size_t b) { return better(a, b); });
                for (auto it = cut; it != winners_.end(); ++it) fate_[*it] = fate::waits;
                winners_.erase(cut, winners_.end());
                std::sort(winners_.begin(), winners_.end());
            }
        }
        return winners_.size();
    }

    /// Every waiting candidate writes itself into the mark of each vertex of its region
    /// unless a better candidate is there: afterwards each mark holds the best candidate
    /// touching it. After the first pass (`check_taken`), a candidate whose region meets a
    /// winner's is blocked until the next round and marks nothing.
    void mark_regions(bool check_taken) {
        ++epoch_;
        const std::uint64_t stamp = std::uint64_t(epoch_) << 32;
        parallel_chunks(pool_, cand_.size(), 256, [&](std::size_t b, std::size_t e, unsigned) {
            for (std::size_t i = b; i < e; ++i) {
                if (fate_[i] != fate::waits) continue;
                if (check_taken) {
                    auto free = [&](index_t v) { return taken_[v] != rounds_; };
                    if (!walk_region(i, free)) {
                        fate_[i] = fate::blocked;
                        continue;
                    }
                }
                const std::uint64_t mine = stamp | i;
                bool beaten = false;
                auto mark = [&](index_t v) {
                    std::uint64_t seen = marks_[v].load(std::memory_order_relaxed);
                    while ((seen >> 32) != epoch_ || better(i, seen & 0xffffffffu))
                        if (marks_[v].compare_exchange_weak(seen, mine, std::memory_order_relaxed))
                            return true;
                    beaten |= seen != mine;
                    // Mark the whole region even when beaten: which marks a candidate
                    // leaves must not depend on when the better one came by.
                    return true;
                };
                walk_region(i, mark);
                if (beaten) fate_[i] = fate::beaten; // no need to look again this pass
            }
        });
    }

    /// A waiting candidate wins if it holds the mark of every vertex of its region: it is
    /// better than every candidate of this pass it overlaps. The winners' regions are
    /// disjoint, and disjoint from earlier passes' winners'. Appends them to winners_, in
    /// candidate order.
    void pick_winners() {
        const std::uint64_t stamp = std::uint64_t(epoch_) << 32;
        parallel_chunks(pool_, cand_.size(), 256, [&](std::size_t b, std::size_t e, unsigned) {
            for (std::size_t i = b; i < e; ++i) {
                const std::uint64_t mine = stamp | i;
                auto held = [&](index_t v) {
                    return marks_[v].load(std::memory_order_relaxed) == mine;
                };
                if (fate_[i] == fate::waits && walk_region(i, held)) fate_[i] = fate::won_now;
            }
        });
        for (std::size_t i = 0; i < cand_.size(); ++i)
            if (fate_[i] == fate::won_now) fate_[i] = fate::wins, winners_.push_back(i);
    }

    /// Runs the winners in parallel, each taking new slots from its own pool.
    void execute_winners() {
        const std::size_t W = winners_.size();
        if constexpr (ops::adds_simplices) {
            vertex_quota_.resize(W), cell_quota_.resize(W);
            for (std::size_t w = 0; w < W; ++w)
                ops::dispatch(cand_[winners_[w]].kind, [&](auto op) {
                    vertex_quota_[w] = decltype(op)::adds_vertices;
                    cell_quota_[w] = decltype(op)::adds_faces;
                });
            m_.begin_parallel(std::span<const index_t>(vertex_quota_),
                              std::span<const index_t>(cell_quota_));
        }
        face_delta_.assign(W, 0), vertex_delta_.assign(W, 0);
        parallel_chunks(pool_, W, 16, [&](std::size_t b, std::size_t e, unsigned t) {
            thread_state& me = *threads_[t];
            op_context<Mesh>& ctx = *me.ctx;
            ctx.worker = t;
            for (std::size_t w = b; w < e; ++w) {
                ctx.conn.pool = static_cast<unsigned>(w); // the winner's own slots
                const std::size_t i = winners_[w];
                entry& en = cand_[i];
                auto& out = me.out[cand_shard_[i]];
                fate_[i] = fate::ran;
                const std::int64_t fd = ctx.face_delta, vd = ctx.vertex_delta;
                ops::dispatch(en.kind, [&](auto op) {
                    attempt<decltype(op)>(me, en.tuple,
                                          [&](const entry& renewed) { out.push_back(renewed); });
                });
                face_delta_[w] = ctx.face_delta - fd, vertex_delta_[w] = ctx.vertex_delta - vd;
            }
            ctx.conn.pool = 0;
        });
        if constexpr (ops::adds_simplices) {
            m_.end_parallel();
            m_.set_slot_recycling(false); // end_parallel turned it on
        }
    }

    /// Applies an operation of kind Op at t with `me`'s context (its region held, by a
    /// group or as a round's winner), counts it in me's report, tells a refusal to the
    /// spec and hands each renewed entry to `queue`. Groups and rounds share it.
    template <class Op, class Queue>
    void attempt(thread_state& me, const tuple& t, Queue&& queue) {
        ++me.report.attempted;
        auto r = apply(Op{}, m_, t, spec_, *me.ctx);
        if (!r) {
            ++me.report.refused;
            hooks::template refused<Op>(spec_, m_, t);
            return;
        }
        ++me.report.succeeded;
        auto push = [&](auto nop, const tuple& nt) {
            queue(entry{hooks::template make_entry<decltype(nop)>(spec_, m_, nt)});
        };
        hooks::template renew<Op>(spec_, m_, *r, push);
    }

    /// The live counts, as a serial run would have them after the round's successes.
    void merge_round() {
        for (std::size_t w = 0; w < winners_.size(); ++w)
            live_.faces += face_delta_[w], live_.vertices += vertex_delta_[w];
        std::uint64_t successes = 0;
        for (auto& t : threads_) successes += t->report.succeeded;
        live_.successes = successes;
    }

    // ------------------------------------------------------------ helpers ----

    /// Candidates per round: a fixed share of the mesh, never a function of the threads.
    /// Small: the winners of a round level off at a few hundred whatever the round size
    /// (the best candidates crowd together), and every loser is walked again next round,
    /// so a large round mostly adds work (armadillo x16, QSlim to 10%, 2 threads: 1,000
    /// candidates 14.3 s, the earlier 1/64 of the cells 28.5 s; bench/RESULTS.md).
    std::size_t round_size() const {
        if (run_.options().round_size > 0) return run_.options().round_size;
        const std::size_t cells = static_cast<std::size_t>(std::max<std::int64_t>(live_.faces, 0));
        return std::clamp<std::size_t>(cells / 1024, 1024, 65536);
    }

    /// Candidate a is better than candidate b: pops first, or the same entry queued
    /// earlier in candidate order.
    bool better(std::size_t a, std::size_t b) const noexcept {
        if (a == b) return false;
        if (pops_before(cand_[a], cand_[b])) return true;
        if (pops_before(cand_[b], cand_[a])) return false;
        return a < b;
    }

    /// Finds every candidate's lock region (claim.hpp) once per round, in the order a
    /// claim takes it, each vertex once (a claim takes a star's vertices once per cell
    /// around it: three to four times). The passes walk each region two to four times,
    /// and the walk itself (stars, and the grid cells of an invariant that claims space)
    /// cost more than the passes. The mesh does not change while the winners are chosen,
    /// so the regions stay as found. Every use of a region (mark, held, free, take) asks
    /// the same of a word each time it comes, so dropping repeats changes no answer.
    /// Stored per block of `region_block` candidates, each block filled by one thread;
    /// the buffers keep their capacity from round to round.
    void record_regions() {
        const std::size_t n = cand_.size();
        const std::size_t blocks = (n + region_block - 1) / region_block;
        if (region_words_.size() < blocks) region_words_.resize(blocks);
        region_of_.resize(n);
        const index_t vertices = m_.vertex_slots();
        parallel_chunks(pool_, n, region_block, [&](std::size_t b, std::size_t e, unsigned th) {
            thread_state& me = *threads_[th];
            if (me.region_seen.size() < vertices) me.region_seen.assign(vertices, 0);
            for (std::size_t i = b; i < e; ++i) {
                auto& words = region_words_[i / region_block];
                if (i % region_block == 0) words.clear();
                if (++me.region_tag == 0) {
                    std::fill(me.region_seen.begin(), me.region_seen.end(), std::uint16_t(0));
                    me.region_tag = 1;
                }
                const auto from = static_cast<std::uint32_t>(words.size());
                auto record = [&](index_t v) {
                    if (v < vertices) {
                        if (me.region_seen[v] == me.region_tag) return true;
                        me.region_seen[v] = me.region_tag;
                    }
                    return words.push_back(v), true;
                };
                bool ok = false;
                tuple t = cand_[i].tuple;
                ops::dispatch(cand_[i].kind, [&](auto op) {
                    ok = claim_footprint<decltype(op)>(spec_, m_, t, record) == claim_result::ok;
                });
                region_of_[i] = {from,
                                 ok ? static_cast<std::uint32_t>(words.size() - from) : no_region};
            }
        });
    }

    /// Walks candidate i's lock region with `take`, stopping at its first false (false
    /// too if its claim could not be made at all).
    template <class Take>
    bool walk_region(std::size_t i, Take& take) const {
        const auto [from, count] = region_of_[i];
        if (count == no_region) return false;
        const index_t* words = region_words_[i / region_block].data() + from;
        for (std::uint32_t k = 0; k < count; ++k)
            if (!take(words[k])) return false;
        return true;
    }

    /// Moves a vertex entry whose tuple went stale to a current tuple of its vertex; false
    /// if the entry is not a vertex entry or its vertex is gone.
    bool reanchor(entry& e) const noexcept {
        if (!run_.still_wanted(e)) return false; // (its tuple is stale, so it follows a vertex)
        e.tuple = m_.tuple_from_vertex(e.tuple.vid);
        return m_.is_valid(e.tuple);
    }

    /// As the serial executor: sweep stale entries out once pushes reach half the queue.
    void purge_if_bloated(shard& sh) {
        if (sh.pushed_since_purge <= sh.q.size() / 2 + 4096) return;
        const std::size_t before = sh.q.size();
        sh.q.erase_if([&](const entry& x) { return !run_.still_wanted(x); });
        sh.report.purged += before - sh.q.size();
        sh.pushed_since_purge = 0;
    }

    /// fn(shard, thread) for every shard, one thread per shard at a time.
    template <class Fn>
    void each_shard(Fn&& fn) {
        parallel_chunks(pool_, K, 1, [&](std::size_t b, std::size_t e, unsigned t) {
            for (std::size_t s = b; s < e; ++s) fn(unsigned(s), t);
        });
    }

    Run& run_;
    Mesh& m_;
    Spec& spec_;
    unsigned T_;
    worker_pool pool_{T_}; // the rounds' threads, started once
    std::vector<std::unique_ptr<thread_state>> threads_;
    std::vector<shard> shards_ = std::vector<shard>(K);
    progress live_;
    // Each vertex's shard, as seeded: a byte, so a group's claims (a star's hundred
    // reads) stay in cache.
    std::vector<std::uint8_t> part_;
    std::vector<std::uint8_t> space_owner_; // each lock word past the vertices: its shard
    bool band_open_ = false;                // run_in_bands: a band bounds what may run
    double band_bound_ = 0;                 // its largest priority
    std::vector<double> band_priorities_;
    std::uint32_t rounds_ = 0, epoch_ = 0;
    std::vector<entry> cand_, keys_;
    entry last_{};
    std::vector<std::uint8_t> cand_shard_;
    std::vector<fate> fate_;
    std::vector<std::size_t> winners_;
    // Each candidate's lock region this round (record_regions): where it starts in its
    // block's words, and how many (no_region: the claim failed).
    static constexpr std::size_t region_block = 256;
    static constexpr std::uint32_t no_region = ~std::uint32_t(0);
    std::vector<std::vector<index_t>> region_words_;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> region_of_;
    std::vector<index_t> vertex_quota_, cell_quota_; // a pool's slots: a winner's or a group's
    index_t phase_growth_ = 0; // the cells of the spec's parallel_growth, at the first level
    std::vector<std::size_t> group_entries_;
    std::vector<std::int64_t> face_delta_, vertex_delta_;
    std::unique_ptr<std::atomic<std::uint64_t>[]> marks_;
    std::unique_ptr<std::uint32_t[]> taken_; // the round whose winner's region holds it
    std::size_t mark_size_ = 0;
};

} // namespace idas::detail

namespace idas::lock {

template <class Run>
void deterministic_rounds::execute(Run& run) {
    // A spec with a goal that starts in its serial tail runs on the serial executor: the
    // order the tail's bands would follow, equal costs included, without the shards'
    // seeding (a twentieth of such a run; bench/RESULTS.md, "Session 42").
    if (in_serial_tail<typename Run::spec_type>(Run::hooks::counts(run.mesh()).faces)) {
        run.serial_phase();
        run.report().threads = std::max(1u, run.options().threads);
        return;
    }
    detail::deterministic_engine<Run> engine(run);
    engine.run();
}

} // namespace idas::lock

namespace idas {
static_assert(lock_policy<lock::deterministic_rounds>);
static_assert(deterministic_policy<lock::deterministic_rounds>);
static_assert(!claiming_lock_policy<lock::deterministic_rounds>); // it claims nothing
} // namespace idas
