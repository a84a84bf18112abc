// The IDAS schedule as a compile-time executor. An algorithm is a type alias:
//
//   using my_algorithm = idas::executor<my_spec, idas::tri_mesh<>, idas::lock::vertex_try_lock,
//                                       idas::queue::binary_heap, idas::partition::morton>;
//
// The spec names its operations (`using operations = idas::op_list<...>`) and may give
//   priority(Op, mesh, tuple) -> double      lower runs first (default 0)
//   renew(Op, mesh, result, push)            what to enqueue after a success: push(Op{}, tuple)
//   stop(const progress&) -> bool            stopping criterion (default: queue exhausted)
//   remaining(const progress&) -> int64      successes still wanted, if known: parallel
//                                            workers then stop right after the success that
//                                            reaches the goal, so the overshoot is bounded by
//                                            the operations in flight (one per other worker)
//   should_process(Op, mesh, entry) -> bool  skip an entry (default: always process)
//   refused(Op, mesh, tuple)                 told when an operation was refused (its
//                                            region is still held)
//   initial(mesh, push)                      what to enqueue first (default: every edge for
//                                            edge operations, every face for 2-3 swaps,
//                                            every vertex for smoothing)
//   initial_at(mesh, v, push)                or the initial entries found at vertex v, for
//                                            every live vertex: parallel workers then build
//                                            their own queues, from the vertices of their part
//   prepare(mesh)                            one-off set-up before the first priority
//   prepare(mesh, options)                   or the same told the run's options, to share
//                                            the set-up out over its threads
//   lock_region(Op, mesh, tuple, claim)      vertices to hold (default: the closed stars of
//                                            the operation's vertices, see below)
//   parallel_growth(mesh)                    slots to set aside for new simplices in parallel:
//                                            extra vertices (cells: twice that), or a
//                                            std::pair {extra vertices, extra cells}
// The same executor runs triangle meshes (cells are faces) and tetrahedral meshes (cells
// are tets); `progress::faces` counts the mesh's top cells. For tet meshes the operation
// functions come from ops/tet_ops.hpp, found by argument-dependent lookup.
// plus the operation hooks (before/after/invariants) used by the operations themselves.
// Operation kinds are types and dispatch is a fold over them: no std::function, no
// virtual call, no string, and no allocation per operation once buffers are warm.
#pragma once

#include <idas/exec/lock.hpp>
#include <idas/exec/partition.hpp>
#include <idas/exec/queue.hpp>
#include <idas/ops/operation.hpp>
#include <idas/ops/tet_op_kinds.hpp>
#include <idas/ops/tri_ops.hpp>

#include <boost/container/small_vector.hpp>
#include <tbb/spin_mutex.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

namespace idas {

template <operation_kind... Ops>
struct op_list {};

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
};

struct run_report {
    std::uint64_t pushed = 0, popped = 0, purged = 0, stale = 0, skipped = 0, attempted = 0,
                  succeeded = 0, refused = 0;
    std::uint64_t lock_failures = 0, deferred_to_serial = 0, stolen = 0;
    std::uint64_t crossed_parts = 0; // own_part_first: waited for the claiming phase
    double owner_seconds = 0;        // own_part_first: time of the lock-free phase
    std::int64_t faces = 0, vertices = 0;
    unsigned threads = 1;
    double seconds = 0;
};

namespace detail {
template <class L>
struct op_list_traits;
template <class... Ops>
struct op_list_traits<op_list<Ops...>> {
    /// Calls fn(Op{}) for the Op whose id is `kind`; false if none matches.
    template <class Fn>
    static bool dispatch(std::uint8_t kind, Fn&& fn) {
        return ((kind == Ops::id ? (fn(Ops{}), true) : false) || ...);
    }
    template <class Fn>
    static void for_each(Fn&& fn) {
        (fn(Ops{}), ...);
    }
    static constexpr bool adds_simplices = ((Ops::adds_vertices + Ops::adds_faces > 0) || ...);
};

template <class Op>
inline constexpr bool is_vertex_op = std::is_same_v<Op, op::smooth_vertex>;
template <class Op>
inline constexpr bool is_face_op = std::is_same_v<Op, op::face_swap_23>;

/// Tet meshes are told apart by their tet incidence; everything else is a triangle mesh.
template <class M>
concept has_tets = requires(const M& m, index_t i) {
    { m.vertex_tets(i) } -> std::ranges::forward_range;
    { m.tet_vertices(i) } -> std::convertible_to<tet_indices>;
    { m.n_tets() } -> std::convertible_to<std::size_t>;
};

// The few places the executor looks at cells: the cells around a vertex, the vertices of
// a cell, the cell a tuple names, how many cells are live, how many slots they use.
template <class M>
decltype(auto) cells_around(const M& m, index_t v) {
    if constexpr (has_tets<M>)
        return m.vertex_tets(v);
    else
        return m.vertex_faces(v);
}
template <class M>
decltype(auto) cell_vertices(const M& m, index_t c) {
    if constexpr (has_tets<M>)
        return m.tet_vertices(c);
    else
        return m.face_vertices(c);
}
template <class M, class Tuple>
index_t cell_of(const M&, const Tuple& t) noexcept {
    if constexpr (has_tets<M>)
        return t.tid;
    else
        return t.fid;
}
template <class M>
std::size_t live_cells(const M& m) {
    if constexpr (has_tets<M>)
        return m.n_tets();
    else
        return m.n_faces();
}
template <class M>
std::size_t cell_slots(const M& m) {
    if constexpr (has_tets<M>)
        return m.tet_slots();
    else
        return m.face_slots();
}
/// Whether the tuple's cell changed since the tuple was made, read while other workers
/// may bump versions (only backends with relaxed version reads; see has_relaxed_versions).
template <class M, class Tuple>
bool version_moved_on(const M& m, const Tuple& t) noexcept {
    if constexpr (has_tets<M>)
        return m.connectivity().tet_version_relaxed(t.tid) != t.version;
    else
        return m.connectivity().face_version_relaxed(t.fid) != t.version;
}
template <class M>
inline constexpr bool has_relaxed_versions = requires(const M& m, index_t i) {
    m.connectivity().face_version_relaxed(i);
}
|| requires(const M& m, index_t i) {
    m.connectivity().tet_version_relaxed(i);
};

/// Runs fn(0) ... fn(n - 1) on `threads` threads at once and waits for all; with more
/// indices than threads, each thread takes the next index when it is done.
/// Plain threads rather than oneTBB tasks: the executor's workers must run at the same
/// time (each owns a queue and a slot pool), and oneTBB only lets tasks run in parallel.
/// Under load its worker thread joined 0.1-0.6 s late or not at all: in remeshing's
/// short swap and smoothing phases one thread did every worker's part in turn. Starting
/// a thread costs tens of microseconds, once per executor run. (ThreadSanitizer also
/// sees these joins, which it cannot in Debian's uninstrumented libtbb.)
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
    pool.reserve(extra);
    for (unsigned t = 0; t < extra; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    if (failure) std::rethrow_exception(failure);
}
} // namespace detail

namespace detail {
/// Stands in for the executor's push callbacks (lvalues) when asking what a spec takes.
template <class Tuple>
struct push_probe {
    template <class Op>
    void operator()(Op, const Tuple&) const noexcept {}
};
} // namespace detail

/// What the executor needs of a tetrahedral mesh (tet_mesh<B> models it).
template <class M>
concept tet_mesh_like = detail::has_tets<M> &&
    requires(M m, const M cm, typename M::tuple t, index_t v, bool on) {
    typename M::undo_log;
    { cm.is_valid(t) } -> std::convertible_to<bool>;
    { cm.vertex_slots() } -> std::convertible_to<index_t>;
    { cm.tet_slots() } -> std::convertible_to<index_t>;
    { cm.n_vertices() } -> std::convertible_to<std::size_t>;
    { cm.vertex_alive(v) } -> std::convertible_to<bool>;
    {cm.edge_vertices(t)};
    {cm.face_vertices(t)};
    { cm.position(v) } -> std::convertible_to<vec3>;
    {m.set_slot_recycling(on)};
};

/// Meshes the executor runs on: triangle or tetrahedral.
template <class M>
concept executable_mesh = tri_mesh_like<M> || tet_mesh_like<M>;

/// A spec the executor can run on Mesh: it lists its operations, each applicable.
template <class Spec, class Mesh>
concept schedule_spec = requires {
    typename Spec::operations;
}
&&requires {
    detail::op_list_traits<typename Spec::operations>{};
};

template <class Spec, executable_mesh Mesh, lock_policy Lock = lock::none,
          class Queue = queue::binary_heap, class Partition = partition::morton>
requires schedule_spec<Spec, Mesh> && queue_policy<Queue, queue_entry<typename Mesh::tuple>> &&
    partition_policy<Partition, Mesh>
class executor {
public:
    using tuple = typename Mesh::tuple;
    using entry = queue_entry<tuple>;
    using queue_type = typename Queue::template type<entry>;
    using ops = detail::op_list_traits<typename Spec::operations>;

    /// Runs the schedule to completion (or until `stop`). Serial when the lock policy is
    /// `lock::none` or one thread is asked for; otherwise on one thread per worker.
    static run_report run(Mesh& m, Spec& spec, const exec_options& options = {}) {
        const auto start = std::chrono::steady_clock::now();
        if constexpr (requires { spec.prepare(m, options); })
            spec.prepare(m, options);
        else if constexpr (requires { spec.prepare(m); })
            spec.prepare(m);
        run_report report;
        // Operations that create simplices run in parallel only on backends that can deal
        // out new slots to workers.
        constexpr bool can_run_parallel = !ops::adds_simplices || Mesh::parallel_growth;
        if constexpr (Lock::parallel && can_run_parallel) {
            if (options.threads > 1)
                report = run_parallel(m, spec, options);
            else
                report = run_serial(m, spec);
        } else {
            report = run_serial(m, spec);
        }
        report.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return report;
    }

    // ---- pieces shared by the serial and parallel loops ----

    template <class Op>
    static double priority_of(Spec& spec, const Mesh& m, const tuple& t) {
        if constexpr (requires { spec.priority(Op{}, m, t); })
            return static_cast<double>(spec.priority(Op{}, m, t));
        else
            return 0.0;
    }

    /// Enqueues the initial entries through `push(Op, tuple)`.
    template <class Push>
    static void initial(Spec& spec, const Mesh& m, Push&& push) {
        if constexpr (requires { spec.initial(m, push); }) {
            spec.initial(m, push);
        } else if constexpr (requires { spec.initial_at(m, index_t{}, push); }) {
            for (index_t v = 0; v < m.vertex_slots(); ++v)
                if (m.vertex_alive(v)) spec.initial_at(m, v, push);
        } else {
            ops::for_each([&](auto op) {
                using Op = decltype(op);
                if constexpr (detail::is_vertex_op<Op>)
                    m.for_each_vertex([&](const tuple& t) { push(Op{}, t); });
                else if constexpr (detail::is_face_op<Op>)
                    m.for_each_face([&](const tuple& t) { push(Op{}, t); });
                else
                    m.for_each_edge([&](const tuple& t) { push(Op{}, t); });
            });
        }
    }

    template <class Op, class Push>
    static void renew(Spec& spec, const Mesh& m, const op_result<tuple>& r, Push&& push) {
        if constexpr (requires { spec.renew(Op{}, m, r, push); }) spec.renew(Op{}, m, r, push);
    }

    /// A spec that knows how many successes it still wants lets parallel workers stop
    /// right after the success that reaches the goal, not at the next periodic check.
    static bool goal_reached(Spec& spec, const progress& p) {
        if constexpr (requires {
                          { spec.remaining(p) } -> std::convertible_to<std::int64_t>;
                      })
            return spec.remaining(p) <= 0;
        else
            return false;
    }

    /// Whether the spec stops on progress (a goal or a criterion). If not, parallel
    /// workers keep no shared live counts: one contended atomic add per success saved
    /// (the harmonic and remeshing phases run until their queues are empty).
    static constexpr bool watches_progress = requires(Spec & spec, const progress& p) {
        spec.remaining(p);
    }
    || requires(Spec& spec, const progress& p) { spec.stop(p); };

    static bool should_stop(Spec& spec, const progress& p) {
        if constexpr (requires {
                          { spec.stop(p) } -> std::convertible_to<bool>;
                      })
            return spec.stop(p);
        else
            return false;
    }

    template <class Op>
    static bool should_process(Spec& spec, const Mesh& m, const entry& e) {
        if constexpr (requires {
                          { spec.should_process(Op{}, m, e) } -> std::convertible_to<bool>;
                      })
            return spec.should_process(Op{}, m, e);
        else
            return true;
    }

    /// Tells the spec an operation was refused (in parallel its region is still held).
    template <class Op>
    static void refused(Spec& spec, const Mesh& m, const entry& e) {
        if constexpr (requires { spec.refused(Op{}, m, e.tuple); }) spec.refused(Op{}, m, e.tuple);
    }

    /// Runs the operation and counts it as attempted and then succeeded or refused (the
    /// spec hears of a refusal while the region is still held); the result if it succeeded.
    template <class Op>
    static auto attempt(Spec& spec, Mesh& m, const entry& e, op_context<Mesh>& ctx,
                        run_report& report) {
        ++report.attempted;
        auto r = apply(Op{}, m, e.tuple, spec, ctx);
        if (r) {
            ++report.succeeded;
        } else {
            ++report.refused;
            refused<Op>(spec, m, e);
        }
        return r;
    }

    static progress counts(const Mesh& m) {
        return {static_cast<std::int64_t>(detail::live_cells(m)),
                static_cast<std::int64_t>(m.n_vertices()), 0};
    }

private:
    // ---------------------------------------------------------------- serial ----
    static run_report run_serial(Mesh& m, Spec& spec) {
        auto& ctx = thread_context<Mesh>();
        queue_type q;
        q.reserve(3 * detail::cell_slots(m));
        run_report report;
        initial(spec, m, [&](auto op, const tuple& t) {
            using Op = decltype(op);
            q.push({priority_of<Op>(spec, m, t), t, Op::id, 0});
            ++report.pushed;
        });
        progress p = counts(m);
        drain_serial(m, spec, ctx, q, p, report);
        report.faces = p.faces, report.vertices = p.vertices;
        return report;
    }

    /// Whether the entry's operation kind acts on a vertex (smoothing).
    static bool is_vertex_entry(const entry& e) noexcept {
        bool vertex = false;
        ops::dispatch(e.kind, [&](auto op) { vertex = detail::is_vertex_op<decltype(op)>; });
        return vertex;
    }
    /// A vertex operation is about its vertex, not the cell its tuple was made in: moving
    /// a neighbour renews that cell, which must not cancel the entry (a smoothing pass
    /// would skip two thirds of the vertices). Other entries go stale with their cell.
    static bool still_wanted(const Mesh& m, const entry& e) noexcept {
        if (m.is_valid(e.tuple)) return true;
        return is_vertex_entry(e) && e.tuple.vid < m.vertex_slots() && m.vertex_alive(e.tuple.vid);
    }
    /// Makes the entry's tuple current (re-anchoring a vertex entry); false if it is stale.
    static bool current(const Mesh& m, entry& e) noexcept {
        if (m.is_valid(e.tuple)) return true;
        if (!still_wanted(m, e)) return false;
        e.tuple = m.tuple_from_vertex(e.tuple.vid);
        return m.is_valid(e.tuple);
    }

    static void drain_serial(Mesh& m, Spec& spec, op_context<Mesh>& ctx, queue_type& q, progress& p,
                             run_report& report) {
        if (should_stop(spec, p)) return;
        entry e;
        std::size_t pushed_since_sweep = 0;
        while (q.pop(e)) {
            ++report.popped;
            if (!current(m, e)) {
                ++report.stale;
                continue;
            }
            bool done = false;
            ops::dispatch(e.kind, [&](auto op) {
                using Op = decltype(op);
                if (!should_process<Op>(spec, m, e)) {
                    ++report.skipped;
                    return;
                }
                const auto fd = ctx.face_delta, vd = ctx.vertex_delta;
                auto r = attempt<Op>(spec, m, e, ctx, report);
                if (!r) return;
                ++p.successes;
                p.faces += ctx.face_delta - fd, p.vertices += ctx.vertex_delta - vd;
                renew<Op>(spec, m, *r, [&](auto nop, const tuple& t) {
                    using NOp = decltype(nop);
                    q.push({priority_of<NOp>(spec, m, t), t, NOp::id, 0});
                    ++report.pushed, ++pushed_since_sweep;
                });
                done = should_stop(spec, p);
            });
            if (done) break;
            // Every success makes the entries of its old star stale (about as many as it
            // pushes). Popping a stale entry costs a sift-down through a large heap;
            // dropping it in a linear sweep costs one version check. So sweep whenever the
            // pushes since the last sweep reach half the queue: a sweep then costs O(1) per
            // entry it is likely to drop. (Counting growth instead never swept once the
            // decimation specs stopped pushing unchanged rim edges: pops kept pace.)
            if (pushed_since_sweep > q.size() / 2 + 4096) {
                const std::size_t before = q.size();
                q.erase_if([&](const entry& x) { return !still_wanted(m, x); });
                report.purged += before - q.size();
                pushed_since_sweep = 0;
            }
        }
    }

    // -------------------------------------------------------------- parallel ----
    struct alignas(64) worker_state {
        queue_type q;
        tbb::spin_mutex mutex; // taken by the owner on every access, by thieves to steal
        std::vector<entry> deferred;
        op_context<Mesh> ctx;
        run_report report;
        std::atomic<std::uint64_t> successes{0};
        std::size_t pushed_since_purge = 0;
    };

    using held_vertices = boost::container::small_vector<index_t, 64>;

    enum class claim_result { ok, busy, stale };

    /// Claims the vertices an operation reads or writes: its own vertices first (so the
    /// tuple can be validated under lock), then every vertex of their stars. Writers of a
    /// cell hold all of its vertices, so holding a vertex freezes its star. The operation's
    /// vertices: the tuple's vertex for smoothing, its face's three for a 2-3 swap, its
    /// edge's two otherwise.
    template <class Op, class Take>
    static claim_result claim_with(Spec& spec, const Mesh& m, tuple& t, Take& take) {
        if (t.vid >= m.vertex_slots() || !take(t.vid)) return claim_result::busy;
        // Holding the vertex freezes its star, so a vertex entry can be re-anchored in it
        // (to a cell of that star). Other tuples must name a cell of the held star before
        // their version is read.
        if constexpr (detail::is_vertex_op<Op>) {
            if (!m.vertex_alive(t.vid)) return claim_result::stale;
            t = m.tuple_from_vertex(t.vid);
        } else {
            bool in_star = false;
            for (index_t f : detail::cells_around(m, t.vid)) in_star |= f == detail::cell_of(m, t);
            if (!in_star) return claim_result::stale;
        }
        if (!m.is_valid(t)) return claim_result::stale;
        if constexpr (requires { spec.lock_region(Op{}, m, t, take); }) {
            return spec.lock_region(Op{}, m, t, take) ? claim_result::ok : claim_result::busy;
        } else {
            index_t seeds[3] = {t.vid, t.vid, t.vid};
            std::size_t n_seeds = 1;
            if constexpr (detail::is_face_op<Op>) {
                const auto fv = m.face_vertices(t);
                seeds[1] = fv[1], seeds[2] = fv[2], n_seeds = 3;
            } else if constexpr (!detail::is_vertex_op<Op>) {
                seeds[1] = m.edge_vertices(t).second, n_seeds = 2;
            }
            for (std::size_t i = 1; i < n_seeds; ++i)
                if (!take(seeds[i])) return claim_result::busy;
            for (std::size_t i = 0; i < n_seeds; ++i)
                for (index_t f : detail::cells_around(m, seeds[i]))
                    for (index_t w : detail::cell_vertices(m, f))
                        if (!take(w)) return claim_result::busy;
            return claim_result::ok;
        }
    }

    /// The claim under the lock policy: held vertices are recorded for release.
    template <class Op>
    static claim_result claim(Spec& spec, const Mesh& m, tuple& t, Lock& locks, std::uint32_t me,
                              held_vertices& held) {
        auto take = [&](index_t v) {
            if constexpr (requires { locks.try_acquire(v, me); }) {
                // Stars overlap (a triangle edge's region: ~36 claims of ~14 vertices; a
                // tet's: hundreds of a few dozen): the lock word itself says whether v is
                // already ours (28% cheaper claims on triangle meshes than a search).
                const int r = locks.try_acquire(v, me);
                if (r > 0) held.push_back(v);
                return r >= 0;
            } else {
                if (std::find(held.begin(), held.end(), v) != held.end()) return true;
                if (!locks.try_lock(v, me)) return false;
                held.push_back(v);
                return true;
            }
        };
        return claim_with<Op>(spec, m, t, take);
    }

    static void release(Lock& locks, std::uint32_t me, held_vertices& held) {
        for (index_t v : held) locks.unlock(v, me);
        held.clear();
    }

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

    static run_report run_parallel(Mesh& m, Spec& spec, const exec_options& o) {
        const unsigned T = o.threads;
        const unsigned P = T * std::max(1u, o.parts_per_thread);
        m.set_slot_recycling(false);
        if constexpr (ops::adds_simplices) {
            // Room for the growth the spec expects (default: the mesh may double), dealt
            // out to the workers; an operation that does not fit waits for the serial pass.
            // Dead slots are dealt first, so passes in a row do not grow the arrays again.
            index_t extra_vertices = std::max<index_t>(4096, index_t(m.n_vertices()));
            index_t extra_cells = 2 * extra_vertices;
            if constexpr (requires { spec.parallel_growth(m).first; }) {
                const auto [v, c] = spec.parallel_growth(m);
                extra_vertices = static_cast<index_t>(v), extra_cells = static_cast<index_t>(c);
            } else if constexpr (requires { spec.parallel_growth(m); }) {
                extra_vertices = spec.parallel_growth(m), extra_cells = 2 * extra_vertices;
            }
            m.begin_parallel(P, extra_vertices, extra_cells);
        }
        Lock locks(m.vertex_slots()); // after growth: new vertices get lock words too
        std::vector<std::unique_ptr<worker_state>> workers;
        for (unsigned w = 0; w < P; ++w) workers.push_back(std::make_unique<worker_state>());

        // Initial entries go to the part of their tuple's vertex.
        std::vector<std::uint32_t> part = Partition::assign(m, P);
        std::uint64_t initial_count = 0;
        if constexpr (requires(detail::push_probe<tuple> & push) {
                          spec.initial_at(m, index_t{}, push);
                      }) {
            // Each worker finds the entries of its own part's vertices.
            std::vector<std::uint64_t> found(P, 0);
            detail::run_workers(T, P, [&](unsigned w) {
                auto& q = workers[w]->q;
                auto push = [&](auto op, const tuple& t) {
                    using Op = decltype(op);
                    q.push({priority_of<Op>(spec, m, t), t, Op::id, 0});
                    ++found[w];
                };
                for (index_t v = 0; v < m.vertex_slots(); ++v)
                    if (part[v] == w && m.vertex_alive(v)) spec.initial_at(m, v, push);
            });
            for (auto n : found) initial_count += n;
        } else {
            std::vector<entry> all;
            initial(spec, m, [&](auto op, const tuple& t) {
                using Op = decltype(op);
                all.push_back({0.0, t, Op::id, 0});
            });
            initial_count = all.size();
            detail::run_workers(T, P, [&](unsigned w) {
                auto& q = workers[w]->q;
                q.reserve(all.size() / P * 2 + 64);
                for (entry e : all) {
                    if (part[e.tuple.vid] != w) continue;
                    ops::dispatch(e.kind, [&](auto op) {
                        e.priority = priority_of<decltype(op)>(spec, m, e.tuple);
                    });
                    q.push(e);
                }
            });
        }

        const progress start = counts(m);
        std::atomic<bool> stop{should_stop(spec, start)};
        std::vector<entry> final_pass;
        tbb::spin_mutex final_mutex;

        // Live counts, updated after every success: one atomic add per operation buys an
        // exact view for the stopping criterion.
        // Faces in the high 32 bits and vertices in the low 32 of one word: a single
        // contended read-modify-write per success instead of two.
        std::atomic<std::int64_t> live{pack(start.faces, start.vertices)};
        auto global_progress = [&] {
            progress p = unpack(live.load(std::memory_order_relaxed));
            for (auto& w : workers) p.successes += w->successes.load(std::memory_order_relaxed);
            return p;
        };

        // Each worker purges its own queue of entries whose cell version moved on, as the
        // serial loop does. Versions may be bumped concurrently by other workers, so they
        // are read with relaxed atomics; a matching version keeps the entry (conservative).
        auto purge_if_bloated = [&](worker_state& me) {
            if constexpr (detail::has_relaxed_versions<Mesh>) {
                tbb::spin_mutex::scoped_lock lk(me.mutex);
                if (me.pushed_since_purge <= me.q.size() / 2 + 4096) return;
                const std::size_t before = me.q.size();
                // Vertex entries stay (see still_wanted); whether their vertex is still
                // alive is checked under its lock.
                me.q.erase_if([&](const entry& x) {
                    return !is_vertex_entry(x) && detail::version_moved_on(m, x.tuple);
                });
                me.report.purged += before - me.q.size();
                me.pushed_since_purge = 0;
            }
        };

        // After a success: the live counts and the stopping criterion, if the spec has one.
        auto count_success = [&](worker_state& me, std::int64_t fd, std::int64_t vd,
                                 std::uint64_t& since_check) {
            if constexpr (watches_progress) {
                const std::int64_t delta = pack(me.ctx.face_delta - fd, me.ctx.vertex_delta - vd);
                progress now = unpack(live.fetch_add(delta, std::memory_order_relaxed) + delta);
                me.successes.store(me.report.succeeded,
                                   std::memory_order_relaxed); // owner writes only
                if (goal_reached(spec, now)) stop.store(true, std::memory_order_relaxed);
                if (++since_check >= o.check_every) {
                    since_check = 0;
                    now.successes = global_progress().successes;
                    if (should_stop(spec, now)) stop.store(true, std::memory_order_relaxed);
                }
            } else {
                (void)me, (void)fd, (void)vd, (void)since_check;
            }
        };

        // Owner phase (own_part_first): each worker drains its own part's queue without
        // locks, running only operations whose whole claim lies in its part. No worker
        // steals, so no two ever touch a cell with a vertex of another part; cells made
        // here hold only their maker's vertices. The rest waits for the claiming phase.
        double owner_seconds = 0;
        if constexpr (owner_phase_lock<Lock>) {
            const auto owner_start = std::chrono::steady_clock::now();
            constexpr std::uint32_t unowned = ~std::uint32_t{0};
            auto drain_own_part = [&](unsigned w) {
                worker_state& me = *workers[w];
                detail::worker_index = w;
                auto mine = [&](index_t v) { return part[v] == w; };
                std::uint64_t since_check = 0;
                entry e;
                while (!stop.load(std::memory_order_relaxed) && me.q.pop(e)) {
                    ++me.report.popped;
                    ops::dispatch(e.kind, [&](auto op) {
                        using Op = decltype(op);
                        const claim_result c = claim_with<Op>(spec, m, e.tuple, mine);
                        if (c == claim_result::stale) {
                            ++me.report.stale;
                            return;
                        }
                        if (c == claim_result::busy ||
                            !m.has_room(Op::adds_vertices, Op::adds_faces)) {
                            ++me.report.crossed_parts;
                            me.deferred.push_back(e);
                            return;
                        }
                        if (!should_process<Op>(spec, m, e)) {
                            ++me.report.skipped;
                            return;
                        }
                        const std::int64_t fd = me.ctx.face_delta, vd = me.ctx.vertex_delta;
                        auto r = attempt<Op>(spec, m, e, me.ctx, me.report);
                        if (!r) return;
                        if constexpr (Op::adds_vertices > 0)
                            for (const auto& cell : r->cells)
                                for (index_t v : detail::cell_vertices(m, detail::cell_of(m, cell)))
                                    if (part[v] == unowned) part[v] = w;
                        renew<Op>(spec, m, *r, [&](auto nop, const tuple& t) {
                            using NOp = decltype(nop);
                            me.q.push({priority_of<NOp>(spec, m, t), t, NOp::id, 0});
                            ++me.report.pushed, ++me.pushed_since_purge;
                        });
                        count_success(me, fd, vd, since_check);
                        purge_if_bloated(me);
                    });
                }
                // What reached into other parts starts the claiming phase.
                me.report.pushed += me.deferred.size();
                for (const auto& d : me.deferred) me.q.push(d);
                me.deferred.clear();
            };
            for (index_t v = 0; v < part.size(); ++v)
                if (!m.vertex_alive(v)) part[v] = unowned; // future vertices: their maker's
            detail::run_workers(T, P, drain_own_part);
            owner_seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - owner_start)
                    .count();
        }

        auto drain = [&](unsigned w) {
            worker_state& me = *workers[w];
            detail::worker_index = w;
            const std::uint32_t owner = w + 1;
            held_vertices held;
            std::vector<entry> renewed;
            std::uint64_t since_check = 0;
            auto pop = [&](entry& e) {
                {
                    tbb::spin_mutex::scoped_lock lk(me.mutex);
                    if (me.q.pop(e)) return true;
                    if (!me.deferred.empty()) {
                        me.report.pushed += me.deferred.size();
                        for (const auto& d : me.deferred) me.q.push(d);
                        me.deferred.clear();
                        if (me.q.pop(e)) return true;
                    }
                }
                // Own work is done: steal the best entry of another part.
                for (unsigned k = 1; k < P; ++k) {
                    worker_state& other = *workers[(w + k) % P];
                    tbb::spin_mutex::scoped_lock lk(other.mutex);
                    if (other.q.pop(e)) {
                        ++me.report.stolen;
                        return true;
                    }
                }
                return false;
            };
            entry e;
            while (!stop.load(std::memory_order_relaxed) && pop(e)) {
                ++me.report.popped;
                ops::dispatch(e.kind, [&](auto op) {
                    using Op = decltype(op);
                    const claim_result c = claim<Op>(spec, m, e.tuple, locks, owner, held);
                    if (c != claim_result::ok) {
                        release(locks, owner, held);
                        if (c == claim_result::stale) {
                            ++me.report.stale;
                            return;
                        }
                        ++me.report.lock_failures;
                        if (++e.retries > o.max_retry) {
                            ++me.report.deferred_to_serial;
                            tbb::spin_mutex::scoped_lock lk(final_mutex);
                            final_pass.push_back(e);
                        } else {
                            tbb::spin_mutex::scoped_lock lk(me.mutex);
                            me.deferred.push_back(e); // retried once the queue runs dry: backoff
                        }
                        return;
                    }
                    if (!should_process<Op>(spec, m, e)) {
                        ++me.report.skipped;
                        release(locks, owner, held);
                        return;
                    }
                    if (!m.has_room(Op::adds_vertices, Op::adds_faces)) {
                        release(locks, owner, held);
                        ++me.report.lock_failures, ++me.report.deferred_to_serial;
                        tbb::spin_mutex::scoped_lock lk(final_mutex);
                        final_pass.push_back(e);
                        return;
                    }
                    const std::int64_t fd = me.ctx.face_delta, vd = me.ctx.vertex_delta;
                    auto r = attempt<Op>(spec, m, e, me.ctx, me.report); // holding the region
                    if (!r) {
                        release(locks, owner, held);
                        return;
                    }
                    renewed.clear();
                    renew<Op>(spec, m, *r, [&](auto nop, const tuple& t) {
                        using NOp = decltype(nop);
                        renewed.push_back({priority_of<NOp>(spec, m, t), t, NOp::id, 0});
                    });
                    release(locks, owner, held);
                    {
                        tbb::spin_mutex::scoped_lock lk(me.mutex);
                        for (const auto& x : renewed) me.q.push(x);
                        me.report.pushed += renewed.size();
                        me.pushed_since_purge += renewed.size();
                    }
                    count_success(me, fd, vd, since_check);
                    purge_if_bloated(me);
                });
            }
        };

        detail::run_workers(T, P, drain);
        if constexpr (!watches_progress) { // the live counts were not kept: sum them now
            std::int64_t faces = start.faces, vertices = start.vertices;
            for (auto& w : workers) {
                faces += w->ctx.face_delta, vertices += w->ctx.vertex_delta;
                w->successes.store(w->report.succeeded, std::memory_order_relaxed);
            }
            live.store(pack(faces, vertices), std::memory_order_relaxed);
        }

        run_report report;
        report.threads = T;
        report.pushed = initial_count;
        report.owner_seconds = owner_seconds;
        for (auto& w : workers) {
            auto& r = w->report;
            report.pushed += r.pushed, report.popped += r.popped, report.purged += r.purged,
                report.stale += r.stale, report.skipped += r.skipped;
            report.attempted += r.attempted, report.succeeded += r.succeeded,
                report.refused += r.refused;
            report.lock_failures += r.lock_failures,
                report.deferred_to_serial += r.deferred_to_serial;
            report.stolen += r.stolen, report.crossed_parts += r.crossed_parts;
        }
        if constexpr (ops::adds_simplices) m.end_parallel();
        m.set_slot_recycling(true);
        detail::worker_index = 0;

        // Final serial pass: entries that kept losing lock races, then anything left.
        progress p = global_progress();
        if (!stop.load() && !should_stop(spec, p)) {
            // Leftovers move over as they are; deferred and final-pass entries are pushed anew.
            queue_type q;
            for (const auto& x : final_pass) q.push(x);
            report.pushed += final_pass.size();
            for (auto& w : workers) {
                entry x;
                while (w->q.pop(x)) q.push(x);
                for (const auto& d : w->deferred) q.push(d);
                report.pushed += w->deferred.size();
            }
            drain_serial(m, spec, thread_context<Mesh>(), q, p, report);
        }
        report.faces = p.faces, report.vertices = p.vertices;
        return report;
    }
};

} // namespace idas
