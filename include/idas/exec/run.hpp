// One run of a schedule: its queues, workers, live counts and the one step every phase
// takes (claim -> should_process -> attempt -> renew -> push -> count). Lock policies
// compose their phases from these pieces (exec/lock.hpp); the executor only starts them.
#pragma once

#include <idas/exec/claim.hpp>
#include <idas/exec/hooks.hpp>
#include <idas/exec/op_list.hpp>
#include <idas/exec/partition.hpp>
#include <idas/exec/queue.hpp>
#include <idas/exec/report.hpp>
#include <idas/exec/workers.hpp>
#include <idas/mesh/cells.hpp>
#include <idas/ops/operation.hpp>

#include <tbb/spin_mutex.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <ranges>
#include <span>
#include <vector>

namespace idas {

/// What became of one step.
enum class step_outcome { stale, busy, no_room, skipped, refused, succeeded };

/// Where an operation's context comes from in serial runs: the calling thread's, so its
/// buffers stay warm from one run to the next. Found by argument-dependent lookup.
template <class Mesh>
op_context<Mesh>& thread_context();

template <class Spec, class Mesh, class Lock, class Queue, class Partition>
class schedule_run {
public:
    using mesh_type = Mesh;
    using spec_type = Spec;
    using queue_policy_type = Queue;
    using partition_type = Partition;
    using tuple = typename Mesh::tuple;
    using entry = queue_entry<tuple>;
    using queue_type = typename Queue::template type<entry>;
    using ops = detail::op_list_traits<typename Spec::operations>;
    using hooks = detail::hooks<Spec, Mesh>;

    /// One worker's share of a run: its part's queue and its operation context. The serial
    /// phase is a worker too, on the calling thread's context.
    struct alignas(64) worker {
        unsigned index = 0;
        queue_type q;
        tbb::spin_mutex mutex; // taken by the owner on every access, by thieves to steal
        std::vector<entry> deferred;
        double deferred_best = std::numeric_limits<double>::infinity(); // lowest priority there
        // The priority of the owner's last pop (infinity once its queue ran dry), read by
        // the other workers; and the level of the other parts above which the owner looks
        // for a cheaper part again.
        std::atomic<double> level{std::numeric_limits<double>::infinity()};
        double others_checked_below = -std::numeric_limits<double>::infinity();
        std::vector<entry> renewed;
        op_context<Mesh> own_ctx;
        op_context<Mesh>* ctx = &own_ctx;
        run_report report;
        std::atomic<std::uint64_t> successes{0};
        std::size_t pushed_since_purge = 0;
        std::uint64_t since_check = 0;
    };

    schedule_run(Mesh& m, Spec& spec, const exec_options& o)
        : m_(m)
        , spec_(spec)
        , options_(o) {}

    Mesh& mesh() noexcept { return m_; }
    Spec& spec() noexcept { return spec_; }
    const exec_options& options() const noexcept { return options_; }
    run_report& report() noexcept { return report_; }

    /// Whether this run may use several workers: a parallel lock policy, more than one
    /// thread, and a backend that deals out new slots if the operations create simplices.
    /// Not either when the spec's parallel goal is met before the start (a decimation
    /// that starts within its serial tail): workers would only be set up and stopped.
    bool parallel() const {
        constexpr bool can = Lock::parallel && (!ops::adds_simplices || Mesh::parallel_growth);
        return can && options_.threads > 1 && !hooks::goal_reached(spec_, hooks::counts(m_));
    }
    bool stopped() const noexcept { return stop_.load(std::memory_order_relaxed); }

    // ------------------------------------------------------------ serial ----

    /// Runs every initial entry on the calling thread, exactly: the stopping criterion
    /// sees every success.
    void serial_phase() {
        worker& me = serial_worker();
        me.q.reserve(3 * cells::slots(m_));
        auto push = [&](auto op, const tuple& t) {
            me.q.push(hooks::template make_entry<decltype(op)>(spec_, m_, t));
            ++me.report.pushed;
        };
        const detail::stopwatch seeding;
        hooks::initial(spec_, m_, push);
        live_ = hooks::counts(m_);
        report_.setup_seconds += seeding.seconds();
        drain_serial(me);
        report_ += me.report;
        report_.faces = live_.faces, report_.vertices = live_.vertices;
    }

    // ---------------------------------------------------------- parallel ----

    unsigned parts() const noexcept { return unsigned(workers_.size()); }
    worker& worker_at(unsigned w) noexcept { return *workers_[w]; }
    /// The part of every vertex slot (the owner phase moves new vertices into theirs).
    std::vector<std::uint32_t>& part_map() noexcept { return part_; }
    Lock& locks() noexcept { return *locks_; }

    /// Sets up the workers (slot pools, partition, initial entries per part), runs
    /// `phases()`, then gathers the workers' counts and drains what they left on this
    /// thread. Phases run the workers with `each_worker`.
    template <class Phases>
    void parallel_run(Phases&& phases) {
        const detail::stopwatch setup;
        start_workers();
        report_.setup_seconds += setup.seconds();
        phases();
        const detail::stopwatch tail;
        stop_workers();
        report_.tail_seconds += tail.seconds();
    }

    /// Runs fn(worker&) for every part, on the run's threads.
    template <class Fn>
    void each_worker(Fn&& fn) {
        detail::run_workers(options_.threads, parts(), [&](unsigned w) {
            worker& me = *workers_[w];
            me.ctx->worker = w;
            me.ctx->conn.pool = w; // new simplices come from the worker's own slots
            fn(me);
        });
    }

    /// Pops `me`'s next entry under its lock.
    bool pop(worker& me, entry& e) {
        tbb::spin_mutex::scoped_lock lk(me.mutex);
        return me.q.pop(e);
    }
    /// Takes an entry of another worker's queue, under its lock: from the far end where the
    /// queue has one (a FIFO's next entries lie next to what its owner is doing, so a thief
    /// taking them would race the owner), else its next.
    bool steal(worker& victim, entry& e) {
        tbb::spin_mutex::scoped_lock lk(victim.mutex);
        if constexpr (requires { victim.q.pop_back(e); })
            return victim.q.pop_back(e);
        else
            return victim.q.pop(e);
    }
    /// Sets an entry aside: for another phase on merged parts (retake_set_aside), or for
    /// the serial pass that ends the run.
    void defer_to_final_pass(const entry& e) {
        tbb::spin_mutex::scoped_lock lk(final_mutex_);
        final_pass_.push_back(e);
    }

    /// Between claiming phases, with no worker running: deals the entries set aside for
    /// the serial pass back out, and says whether it did. They lost their races at the
    /// borders of parts, while the neighbouring parts were busy (on 16 threads a tet mesh's
    /// smoothing set aside a fifth of its vertex entries, and the serial pass then took
    /// four fifths of the phase). Each time, neighbouring parts are merged in pairs (Morton
    /// parts are pieces of one curve), so the borders where they lost are inside one queue
    /// now; once two queues would become one (at once on 2 threads), what is left goes to
    /// the serial pass. Not after a stop (a goal leaves its last operations to the serial
    /// pass on purpose), nor for fewer than `set_aside_worth_a_phase` entries per queue.
    bool retake_set_aside() {
        const unsigned group = 2u << merged_levels_; // parts per queue in the next phase
        const unsigned queues = (parts() + group - 1) / group;
        const std::size_t n = final_pass_.size();
        if (stopped() || n < set_aside_worth_a_phase) return false;
        if constexpr (hooks::watches_progress) { // the workers check it only now and then
            if (hooks::should_stop(spec_, shared_progress())) {
                stop_.store(true, std::memory_order_relaxed);
                return false;
            }
        }
        if (queues < 2 || n < set_aside_worth_a_phase * queues) return deal_independent_set();
        ++merged_levels_;
        for (auto& w : workers_) // a new phase: the other parts' levels are read anew
            w->others_checked_below = -std::numeric_limits<double>::infinity();
        const unsigned P = parts();
        for (entry e : final_pass_) {
            e.retries = 0;
            const index_t v = e.tuple.vid;
            const unsigned p = v < part_.size() ? part_[v] : v % P;
            workers_[p / group * group]->q.push(e);
        }
        report_.pushed += n, retaken_ += n;
        final_pass_.clear();
        return true;
    }
    /// Entries per queue below which the set-aside entries go straight to the serial pass.
    static constexpr std::size_t set_aside_worth_a_phase = 16;

    /// The one step of every phase. `claimer.claim(Op{}, tuple&)` holds the operation's
    /// region (or says why not) and `claimer.release()` lets it go; `on_success(Op{},
    /// result)` runs while the region is still held. Shared: other workers may steal from
    /// `me`'s queue and read the live counts.
    template <bool Shared, class Claimer, class OnSuccess>
    step_outcome step(worker& me, entry& e, Claimer& claimer, OnSuccess&& on_success) {
        ++me.report.popped;
        step_outcome outcome = step_outcome::stale;
        ops::dispatch(e.kind, [&](auto op) {
            using Op = decltype(op);
            auto lost = [&](claim_result c) {
                claimer.release();
                if (c == claim_result::stale) ++me.report.stale;
                outcome = c == claim_result::stale ? step_outcome::stale : step_outcome::busy;
            };
            auto skip = [&] {
                claimer.release();
                ++me.report.skipped;
                outcome = step_outcome::skipped;
            };
            // A spec that decides from the stars of the operation's own vertices is asked
            // once those are held, before the rest of the region is claimed: tet meshing's
            // collapses skip five entries for each one they attempt, and each skip cost a
            // claim of two whole stars.
            constexpr bool decide_early =
                Shared && detail::decides_holding_seeds<Spec> && requires(tuple & t) {
                claimer.claim_seeds(Op{}, t);
            };
            if constexpr (decide_early) {
                const claim_result c = claimer.claim_seeds(Op{}, e.tuple);
                if (c != claim_result::ok) return lost(c);
                if (!hooks::template should_process<Op>(spec_, m_, e)) return skip();
            }
            const claim_result c = claimer.claim(Op{}, e.tuple);
            if (c != claim_result::ok) return lost(c);
            if constexpr (!decide_early)
                if (!hooks::template should_process<Op>(spec_, m_, e)) return skip();
            if constexpr (Shared) {
                if (!m_.has_room(Op::adds_vertices, Op::adds_faces, me.ctx->conn.pool)) {
                    claimer.release();
                    outcome = step_outcome::no_room;
                    return;
                }
            }
            op_context<Mesh>& ctx = *me.ctx;
            const std::int64_t fd = ctx.face_delta, vd = ctx.vertex_delta;
            ++me.report.attempted;
            auto r = apply(Op{}, m_, e.tuple, spec_, ctx);
            if (!r) {
                ++me.report.refused;
                hooks::template refused<Op>(spec_, m_, e.tuple); // the region is still held
                claimer.release();
                outcome = step_outcome::refused;
                return;
            }
            ++me.report.succeeded;
            on_success(Op{}, *r);
            renew<Op, Shared>(me, *r, claimer);
            count_success<Shared>(me, ctx.face_delta - fd, ctx.vertex_delta - vd);
            outcome = step_outcome::succeeded;
            purge_if_bloated<Shared>(me);
        });
        return outcome;
    }

    /// The footprint claim of Op (see exec/claim.hpp), taking vertices with `take`.
    template <class Op, class Take>
    claim_result claim_footprint(tuple& t, Take& take) {
        return idas::claim_footprint<Op>(spec_, m_, t, take);
    }
    /// The first stage of a two-stage claim: the vertices of Op's simplex.
    template <class Op, class Take>
    claim_result claim_seeds(tuple& t, Take& take) {
        return idas::claim_seeds<Op>(m_, t, take);
    }

    /// Claims nothing: the serial phase owns the mesh. A tuple is current, or a vertex
    /// entry is re-anchored at its vertex, or the entry is stale.
    struct serial_claimer {
        const Mesh& m;
        template <class Op>
        claim_result claim(Op, tuple& t) const noexcept {
            if (m.is_valid(t)) return claim_result::ok;
            if constexpr (Op::acts_on == simplex_kind::vertex) {
                if (t.vid < m.vertex_slots() && m.vertex_alive(t.vid)) {
                    t = m.tuple_from_vertex(t.vid);
                    if (m.is_valid(t)) return claim_result::ok;
                }
            }
            return claim_result::stale;
        }
        static constexpr void release() noexcept {}
    };

    /// A vertex operation is about its vertex, not the cell its tuple was made in: moving
    /// a neighbour renews that cell, which must not cancel the entry (a smoothing pass
    /// would skip two thirds of the vertices). Other entries go stale with their cell.
    IDAS_ALWAYS_INLINE bool still_wanted(const entry& e) const noexcept {
        if (m_.is_valid(e.tuple)) return true;
        return ops::acts_on_vertex(e.kind) && e.tuple.vid < m_.vertex_slots() &&
               m_.vertex_alive(e.tuple.vid);
    }

private:
    /// Once parts can merge no further: the set-aside entries whose regions are pairwise
    /// disjoint, taken greedily in their order, are dealt out to all workers in turn, and
    /// the others wait for the next such phase. What is left lost its races in crowded
    /// places, where parts' borders no longer matter (on 16 threads a tet mesh's smoothing
    /// left 3,900 vertex entries, a sixth of the phase's time, to the serial pass after
    /// three merged phases). Only for queues without an order (smoothing): an ordered run's
    /// set-aside entries keep their one global order in the serial pass. At most
    /// `independent_phases` times, and only while a phase gets two entries per worker.
    bool deal_independent_set() {
        if constexpr (pops_in_priority_order<Queue> ||
                      !requires(Lock & l, index_t v) { l.try_acquire(v, std::uint32_t{}); }) {
            return false;
        } else {
            if (independent_phases_done_ == independent_phases) return false;
            // Each entry claims under an id of its own (after the workers' ids), so a vertex
            // that an earlier chosen region holds is busy, and one of its own is not.
            std::uint32_t id = parts();
            held_vertices held;
            auto take = [&](index_t v) {
                const int r = locks().try_acquire(v, id);
                if (r > 0) held.push_back(v);
                return r >= 0;
            };
            std::vector<entry> chosen, rest;
            std::vector<index_t> taken; // every vertex the chosen regions hold
            for (const entry& e : final_pass_) {
                bool free = true;
                ++id;
                ops::dispatch(e.kind, [&](auto op) {
                    tuple t = e.tuple;
                    held.clear();
                    free = claim_footprint<decltype(op)>(t, take) != claim_result::busy;
                    if (!free) // partly claimed: give back what this entry took
                        for (index_t v : held) locks().unlock(v, id);
                    else
                        taken.insert(taken.end(), held.begin(), held.end());
                });
                (free ? chosen : rest).push_back(e);
            }
            for (index_t v : taken) locks().unlock(v, id);
            if (chosen.size() < 2 * std::size_t(parts())) return false;
            ++independent_phases_done_;
            for (auto& w : workers_)
                w->others_checked_below = -std::numeric_limits<double>::infinity();
            const unsigned P = parts();
            for (std::size_t i = 0; i < chosen.size(); ++i) {
                entry e = chosen[i];
                e.retries = 0;
                workers_[i % P]->q.push(e);
            }
            report_.pushed += chosen.size(), retaken_ += chosen.size();
            final_pass_ = std::move(rest);
            return true;
        }
    }
    static constexpr unsigned independent_phases = 8;

    struct no_action {
        template <class Op, class R>
        constexpr void operator()(Op, const R&) const noexcept {}
    };

    worker& serial_worker() {
        if (!serial_) {
            serial_ = std::make_unique<worker>();
            serial_->ctx = &thread_context<Mesh>();
        }
        return *serial_;
    }

    void drain_serial(worker& me) {
        if (hooks::should_stop(spec_, live_)) stop_.store(true, std::memory_order_relaxed);
        serial_claimer claimer{m_};
        entry e;
        while (!stopped() && me.q.pop(e)) step<false>(me, e, claimer, no_action{});
    }

    /// The spec's renewed entries after a success. Shared: made while the region is held
    /// (they read it), pushed after it is released, under the queue's lock. Serial: straight
    /// into the queue, in the same order.
    template <class Op, bool Shared, class Claimer>
    void renew(worker& me, const op_result<tuple>& r, Claimer& claimer) {
        std::size_t pushed = 0;
        if constexpr (Shared) me.renewed.clear();
        auto push = [&](auto nop, const tuple& t) {
            const entry e = hooks::template make_entry<decltype(nop)>(spec_, m_, t);
            if constexpr (Shared)
                me.renewed.push_back(e);
            else
                me.q.push(e);
            ++pushed;
        };
        hooks::template renew<Op>(spec_, m_, r, push);
        claimer.release();
        if constexpr (Shared) {
            tbb::spin_mutex::scoped_lock lk(me.mutex);
            for (const auto& x : me.renewed) me.q.push(x);
        }
        me.report.pushed += pushed;
        me.pushed_since_purge += pushed;
    }

    /// After a success: the live counts and the stopping criterion. Serial: exact, after
    /// every success. Shared: one atomic add per success (if the spec watches progress),
    /// the criterion every `check_every` successes and the goal after each.
    template <bool Shared>
    void count_success(worker& me, std::int64_t faces, std::int64_t vertices) {
        if constexpr (!Shared) {
            ++live_.successes, live_.faces += faces, live_.vertices += vertices;
            hooks::quiescent(spec_, m_, live_);
            if (hooks::should_stop(spec_, live_)) stop_.store(true, std::memory_order_relaxed);
        } else if constexpr (hooks::watches_progress) {
            const std::int64_t delta = pack(faces, vertices);
            progress now = unpack(live_packed_.fetch_add(delta, std::memory_order_relaxed) + delta);
            me.successes.store(me.report.succeeded, std::memory_order_relaxed); // owner writes
            if (hooks::goal_reached(spec_, now)) stop_.store(true, std::memory_order_relaxed);
            if (++me.since_check >= options_.check_every) {
                me.since_check = 0;
                now.successes = shared_progress().successes;
                if (hooks::should_stop(spec_, now)) stop_.store(true, std::memory_order_relaxed);
            }
        }
    }

    /// Every success makes the entries of its old star stale (about as many as it pushes).
    /// Popping a stale entry costs a sift-down through a large heap; dropping it in a
    /// linear sweep costs one version check. So sweep whenever the pushes since the last
    /// sweep reach half the queue: a sweep then costs O(1) per entry it is likely to drop.
    template <bool Shared>
    void purge_if_bloated(worker& me) {
        if constexpr (!Shared) {
            if (me.pushed_since_purge <= me.q.size() / 2 + 4096) return;
            const std::size_t before = me.q.size();
            me.q.erase_if([&](const entry& x) { return !still_wanted(x); });
            me.report.purged += before - me.q.size();
            me.pushed_since_purge = 0;
        } else if constexpr (cells::has_relaxed_versions<Mesh>) {
            // Versions may be bumped concurrently by other workers, so they are read with
            // relaxed atomics; a matching version keeps the entry (conservative). Vertex
            // entries stay; whether their vertex lives is checked under its claim.
            tbb::spin_mutex::scoped_lock lk(me.mutex); // thieves pop: read the size under it
            if (me.pushed_since_purge <= me.q.size() / 2 + 4096) return;
            const std::size_t before = me.q.size();
            me.q.erase_if([&](const entry& x) {
                return !ops::acts_on_vertex(x.kind) && cells::version_moved_on(m_, x.tuple);
            });
            me.report.purged += before - me.q.size();
            me.pushed_since_purge = 0;
        }
    }

    void start_workers() {
        const unsigned P = options_.threads * std::max(1u, options_.parts_per_thread);
        m_.set_slot_recycling(false);
        if constexpr (ops::adds_simplices) {
            // Room for the growth the spec expects (default: the mesh may double), dealt
            // out to the workers; an operation that does not fit waits for the serial pass.
            // Dead slots are dealt first, so passes in a row do not grow the arrays again.
            const auto [extra_vertices, extra_cells] = hooks::parallel_growth(spec_, m_);
            m_.begin_parallel(P, extra_vertices, extra_cells);
        }
        // After growth: new vertices too, and the spec's extra words.
        locks_ = std::make_unique<Lock>(hooks::lock_words(spec_, m_));
        for (unsigned w = 0; w < P; ++w) {
            workers_.push_back(std::make_unique<worker>());
            workers_.back()->index = w;
        }
        seed_workers();
        live_ = hooks::counts(m_);
        live_packed_.store(pack(live_.faces, live_.vertices), std::memory_order_relaxed);
        if (hooks::should_stop(spec_, live_)) stop_.store(true, std::memory_order_relaxed);
    }

    /// Cuts the vertices into parts and gives each part's queue the initial entries of its
    /// vertices. Where the partition policy can weigh vertices, each vertex weighs as many
    /// entries as it seeds, so the parts start with equal work rather than equal vertex
    /// counts (in a tet mesh's optimization the work lies along the surface and in
    /// clusters of bad tets, not in the background grid's vertices).
    void seed_workers() {
        const unsigned P = parts();
        const index_t n = m_.vertex_slots();
        std::vector<std::uint32_t> seeds(n, 0); // initial entries per vertex
        if constexpr (hooks::seeds_per_vertex && !detail::initial_hook<Spec, Mesh>) {
            // Found in blocks of vertices, in parallel; a block's entries are in vertex order.
            // At least four blocks a thread, so a small mesh's seeding is shared too (a tet
            // mesh of 8,000 vertices was two blocks of 4,096, and its collapse phase's seeding
            // took as long on 2 threads as on one).
            const index_t block =
                std::clamp<index_t>(n / (4 * std::max(1u, options_.threads)), 256, 4096);
            std::vector<std::vector<entry>> found((n + block - 1) / block);
            detail::run_workers(options_.threads, unsigned(found.size()), [&](unsigned k) {
                auto push = [&](auto op, const tuple& t) {
                    found[k].push_back(hooks::template make_entry<decltype(op)>(spec_, m_, t));
                };
                for (index_t v = k * block; v < std::min(n, (k + 1) * block); ++v) {
                    if (!m_.vertex_alive(v)) continue;
                    const std::size_t before = found[k].size();
                    hooks::initial_at(spec_, m_, v, push);
                    seeds[v] = std::uint32_t(found[k].size() - before);
                }
            });
            part_ = assign_parts(seeds, P);
            each_worker([&](worker& me) {
                // The part's entries, as runs of the blocks' (consecutive vertices of one
                // part), go straight into its queue, sized first, then one heap build, not
                // a sift per entry: fresh pages are a seeding's largest cost on small meshes,
                // and a copy gathered first doubled them (sphere, 2 threads: 4-5 ms).
                std::vector<std::span<const entry>> runs;
                std::size_t count = 0;
                for (std::size_t k = 0; k < found.size(); ++k) {
                    std::size_t i = 0, run_end = 0; // a run ends at i == run_end > 0
                    for (index_t v = index_t(k * block); i < found[k].size(); ++v) {
                        if (part_[v] == me.index && seeds[v] > 0) {
                            if (run_end > 0 && run_end == i)
                                runs.back() = {runs.back().data(), runs.back().size() + seeds[v]};
                            else
                                runs.emplace_back(found[k].data() + i, seeds[v]);
                            run_end = i + seeds[v];
                            count += seeds[v];
                        }
                        i += seeds[v];
                    }
                }
                me.q.reserve(me.q.size() + count);
                if constexpr (requires { me.q.push_all(runs | std::views::join); })
                    me.q.push_all(runs | std::views::join);
                else
                    for (const auto& run : runs)
                        for (const entry& e : run) me.q.push(e);
            });
            for (const auto& f : found) report_.pushed += f.size();
        } else {
            std::vector<entry> all;
            auto push = [&](auto op, const tuple& t) {
                all.push_back({0.0, t, ops::template id_of<decltype(op)>, 0});
            };
            hooks::initial(spec_, m_, push);
            report_.pushed += all.size();
            for (const entry& e : all)
                if (e.tuple.vid < n) ++seeds[e.tuple.vid];
            part_ = assign_parts(seeds, P);
            detail::run_workers(options_.threads, P, [&](unsigned w) {
                auto& q = workers_[w]->q;
                q.reserve(all.size() / P * 2 + 64);
                for (entry e : all) {
                    if (part_[e.tuple.vid] != w) continue;
                    ops::dispatch(e.kind, [&](auto op) {
                        e.priority = hooks::template priority<decltype(op)>(spec_, m_, e.tuple);
                    });
                    q.push(e);
                }
            });
        }
    }

    /// The partition, weighted by the seeds per vertex where the policy weighs vertices.
    std::vector<std::uint32_t> assign_parts(const std::vector<std::uint32_t>& seeds, unsigned P) {
        if constexpr (weighted_partition_policy<Partition, Mesh>)
            return Partition::assign(m_, P, seeds);
        else
            return Partition::assign(m_, P);
    }

    void stop_workers() {
        if constexpr (!hooks::watches_progress) { // the live counts were not kept: sum them
            std::int64_t faces = live_.faces, vertices = live_.vertices;
            for (auto& w : workers_) {
                faces += w->ctx->face_delta, vertices += w->ctx->vertex_delta;
                w->successes.store(w->report.succeeded, std::memory_order_relaxed);
            }
            live_packed_.store(pack(faces, vertices), std::memory_order_relaxed);
        }
        report_.threads = options_.threads;
        for (auto& w : workers_) report_ += w->report;
        // Set aside and dealt out again: not the serial pass's.
        report_.retaken += retaken_, report_.deferred_to_serial -= retaken_, retaken_ = 0;
        if constexpr (ops::adds_simplices) m_.end_parallel();
        m_.set_slot_recycling(true);

        // Final serial pass: entries that kept losing lock races, then anything left.
        // Leftovers move over as they are; deferred and final-pass entries are pushed anew.
        // A spec may reach its parallel goal (`remaining`) before its stopping criterion,
        // leaving its last operations to this pass, in one global order.
        live_ = shared_progress();
        stop_.store(false, std::memory_order_relaxed);
        if (!hooks::should_stop(spec_, live_)) {
            hooks::quiescent(spec_, m_, live_);
            worker& me = serial_worker();
            for (const auto& x : final_pass_) me.q.push(x);
            report_.pushed += final_pass_.size();
            for (auto& w : workers_) {
                entry x;
                while (w->q.pop(x)) me.q.push(x);
                for (const auto& d : w->deferred) me.q.push(d);
                report_.pushed += w->deferred.size();
            }
            drain_serial(me);
            report_ += me.report;
        }
        report_.faces = live_.faces, report_.vertices = live_.vertices;
    }

    progress shared_progress() const {
        progress p = unpack(live_packed_.load(std::memory_order_relaxed));
        for (auto& w : workers_) p.successes += w->successes.load(std::memory_order_relaxed);
        return p;
    }

    // Faces in the high 32 bits and vertices in the low 32 of one word: a single contended
    // read-modify-write per success instead of two.
    static constexpr std::int64_t pack(std::int64_t faces, std::int64_t vertices) noexcept {
        return faces * (std::int64_t{1} << 32) + vertices;
    }
    static constexpr progress unpack(std::int64_t x) noexcept {
        const auto vertices =
            static_cast<std::int64_t>(static_cast<std::int32_t>(static_cast<std::uint32_t>(x)));
        return {(x - vertices) / (std::int64_t{1} << 32), vertices, 0};
    }
    static_assert(unpack(pack(12345, -3)).faces == 12345 && unpack(pack(12345, -3)).vertices == -3);
    static_assert(unpack(pack(-7, 99)).faces == -7 && unpack(pack(-7, 99)).vertices == 99);

    Mesh& m_;
    Spec& spec_;
    exec_options options_;
    run_report report_;
    progress live_;                            // serial phases: exact
    std::atomic<std::int64_t> live_packed_{0}; // parallel phases: packed faces and vertices
    std::atomic<bool> stop_{false};
    std::unique_ptr<worker> serial_;
    std::vector<std::unique_ptr<worker>> workers_;
    std::vector<std::uint32_t> part_;
    std::unique_ptr<Lock> locks_;
    std::vector<entry> final_pass_;
    unsigned merged_levels_ = 0;           // retake_set_aside: parts merged in pairs so many times
    unsigned independent_phases_done_ = 0; // deal_independent_set: phases so far
    std::size_t retaken_ = 0;
    tbb::spin_mutex final_mutex_;
};

} // namespace idas
