// Benchmarks of the executor's policies (include/idas/exec/{lock,queue,partition}.hpp),
// alone and in whole runs. bench/run_policies.sh runs this and writes the "## Policies"
// section of bench/RESULTS.md.
//
// Method
// ------
// * lock/*: claiming an operation's region, the closed stars of an edge's two vertices
//   (every vertex of every face around either vertex), on data/bunny.obj.
//   - lock/region/<policy>: claim a precomputed, deduplicated vertex list of one region
//     and release it; the regions of all edges in a fixed random order. The lock's own
//     cost per claim.
//   - lock/walk/<policy>: claim as the executor does (walk both stars, skip vertices
//     already held); the lock's share of a real claim is the difference between policies.
//   - lock/contended/{overlapping,disjoint}/threads:T: T threads claim regions from pools
//     of 32 edges each, every thread in its own fixed random order. overlapping: all
//     threads share one pool of neighbouring edges (their regions overlap heavily);
//     disjoint: each thread has its own pool, sharing no vertex with another pool. A claim
//     that meets a vertex held by another thread releases what it took (as the executor
//     does) and counts as failed. Real time; ns/claim is per thread (T x wall / claims);
//     "success" is the fraction of claims that got their whole region. With 4 threads on
//     fewer cores, threads are also preempted while holding locks.
// * queue/replay_{sec,qslim}/<policy>: the queue traffic of a serial shortest edge collapse
//   (sec) or QSlim (qslim) of armadillo x4 to 10% (every push, pop and stale sweep of the
//   real run, recorded once through a recording queue policy) replayed on each queue
//   policy; a sweep removes the same entries as in the recorded run. The heaps pop in the
//   same order; fifo pops in push order, so its row is the cost of its operations on the
//   same traffic, not a decimation order.
// * partition/assign/<policy>/parts:P: assign() on armadillo x4. Counters (computed once,
//   outside the timing): cut = fraction of edges whose ends are in different parts;
//   boundary = fraction of vertices with a neighbour in another part; cross_region =
//   fraction of edges whose claim region (see lock/*) spans two parts or more, i.e.
//   operations that can meet another part's worker; imbalance = largest part / mean part.
// * run/*: whole executor runs on armadillo x4 (each on a fresh copy; manual time = the
//   run_report's seconds, which include the partition and filling the queues):
//   - run/sec_serial/<queue>, run/qslim_serial/<queue>: shortest edge collapse and QSlim
//     to 10%, 1 thread, one row per queue policy;
//   - run/sec_2t/<partition>: shortest edge collapse to 10% at 2 threads;
//   - run/remesh_2t/<partition>: one iteration of isotropic remeshing (target length
//     0.01 x bounding-box diagonal, the idas tool's default) at 2 threads, the four phases'
//     run_reports summed; the split and collapse phases use the default dary_heap<4>, swap
//     and smooth fifo, as in isotropic_remeshing.
//   Counters are the run_report's (lock_failures, stolen, deferred_to_serial, ...), and
//   cpu_s, the process's CPU time over the run (all threads), steadier than wall time on
//   a loaded machine.
//   armadillo x4 is armadillo (86,482 faces) after one 1-to-4 midpoint subdivision
//   (345,928 faces), as in bench_decimation.
#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/core/aabb_tree.hpp>
#include <idas/io/io.hpp>

#include <benchmark/benchmark.h>
#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <string>
#include <utility>
#include <vector>

using namespace idas;
using namespace idas::algorithms;

namespace {

using mesh_t = tri_mesh<>;
using tuple_t = mesh_t::tuple;
using entry_t = queue_entry<tuple_t>;

// ------------------------------------------------------------------ inputs ----

io::surface load_surface(const char* name) {
    try {
        return io::read_surface(std::string(IDAS_DATA_DIR) + "/" + name);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_policies: %s\n", e.what());
        std::exit(2);
    }
}

/// 1-to-4 midpoint subdivision: the new vertices lie on the old surface.
io::surface subdivide(const io::surface& in) {
    io::surface out;
    out.vertices = in.vertices;
    std::map<std::pair<index_t, index_t>, index_t> mid;
    auto midpoint = [&](index_t a, index_t b) {
        const auto key = std::minmax(a, b);
        auto [it, fresh] = mid.try_emplace({key.first, key.second}, index_t(out.vertices.size()));
        if (fresh) out.vertices.push_back((in.vertices[a] + in.vertices[b]) * 0.5);
        return it->second;
    };
    out.faces.reserve(4 * in.faces.size());
    for (const auto& f : in.faces) {
        const index_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]),
                      ca = midpoint(f[2], f[0]);
        out.faces.push_back({f[0], ab, ca});
        out.faces.push_back({ab, f[1], bc});
        out.faces.push_back({ca, bc, f[2]});
        out.faces.push_back({ab, bc, ca});
    }
    return out;
}

const mesh_t& bunny() {
    static const mesh_t m = [] {
        const auto s = load_surface("bunny.obj");
        return mesh_t(s.vertices, s.faces);
    }();
    return m;
}

const mesh_t& armadillo_x4() {
    static const mesh_t m = [] {
        const auto s = subdivide(load_surface("armadillo.obj"));
        return mesh_t(s.vertices, s.faces);
    }();
    return m;
}

// ------------------------------------------------------------------- locks ----

/// The vertices an operation on edge t claims: every vertex of every face around either
/// end, deduplicated (the executor's default lock_region).
void region_of(const mesh_t& m, const tuple_t& t, std::vector<index_t>& out) {
    out.clear();
    const auto [a, b] = m.edge_vertices(t);
    for (index_t s : {a, b})
        for (index_t f : m.vertex_faces(s))
            for (index_t w : m.face_vertices(f))
                if (std::find(out.begin(), out.end(), w) == out.end()) out.push_back(w);
}

/// Regions in compressed rows: region i is verts[offset[i] .. offset[i + 1]).
struct regions {
    std::vector<tuple_t> edges;
    std::vector<std::size_t> offset{0};
    std::vector<index_t> verts;

    void add(const mesh_t& m, const tuple_t& t) {
        static std::vector<index_t> r;
        region_of(m, t, r);
        edges.push_back(t);
        verts.insert(verts.end(), r.begin(), r.end());
        offset.push_back(verts.size());
    }
    std::size_t size() const noexcept { return edges.size(); }
    std::size_t vertex_count() const noexcept { return verts.size(); }
};

/// Every edge of bunny in a fixed random order.
const regions& all_regions() {
    static const regions r = [] {
        const auto& m = bunny();
        std::vector<tuple_t> edges;
        m.for_each_edge([&](const tuple_t& t) { edges.push_back(t); });
        std::shuffle(edges.begin(), edges.end(), std::mt19937(7));
        regions out;
        for (const auto& t : edges) out.add(m, t);
        return out;
    }();
    return r;
}

/// Claims region i; on a busy vertex releases what it took. Returns success. The ids
/// claimed are summed into `checksum`, so with lock::none (no code at all) the row still
/// reads the region, as a claim would.
template <class Lock>
bool claim_region(Lock& locks, const regions& r, std::size_t i, std::uint32_t me,
                  std::size_t& checksum) {
    const index_t* v = r.verts.data() + r.offset[i];
    const std::size_t n = r.offset[i + 1] - r.offset[i];
    for (std::size_t k = 0; k < n; ++k) {
        checksum += v[k];
        if (!locks.try_lock(v[k], me)) {
            for (std::size_t j = 0; j < k; ++j) locks.unlock(v[j], me);
            return false;
        }
    }
    for (std::size_t k = 0; k < n; ++k) locks.unlock(v[k], me);
    return true;
}

template <class Lock>
void BM_lock_region(benchmark::State& st) {
    const auto& r = all_regions();
    Lock locks(bunny().vertex_slots());
    std::size_t i = 0, ok = 0, checksum = 0;
    for (auto _ : st) {
        ok += claim_region(locks, r, i, 1, checksum);
        if (++i == r.size()) i = 0;
    }
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(checksum);
    st.SetItemsProcessed(st.iterations());
    st.counters["vertices/claim"] = double(r.vertex_count()) / double(r.size());
}

template <class Lock>
void BM_lock_walk(benchmark::State& st) {
    const auto& m = bunny();
    const auto& r = all_regions();
    Lock locks(m.vertex_slots());
    boost::container::small_vector<index_t, 64> held;
    std::size_t i = 0, ok = 0;
    for (auto _ : st) {
        const tuple_t& t = r.edges[i];
        bool good = true;
        auto take = [&](index_t v) {
            if (std::find(held.begin(), held.end(), v) != held.end()) return true;
            if (!locks.try_lock(v, 1)) return false;
            held.push_back(v);
            return true;
        };
        const auto [a, b] = m.edge_vertices(t);
        good = take(a) && take(b);
        for (index_t s : {a, b})
            for (index_t f : m.vertex_faces(s))
                for (index_t w : m.face_vertices(f)) good = good && take(w);
        ok += good;
        for (index_t v : held) locks.unlock(v, 1);
        held.clear();
        if (++i == r.size()) i = 0;
    }
    benchmark::DoNotOptimize(ok);
    st.SetItemsProcessed(st.iterations());
}

/// As lock/walk, but the lock word says whether a vertex is already held (try_acquire,
/// where the policy has it) instead of a search of the held list.
template <class Lock>
void BM_lock_walk_acquire(benchmark::State& st) {
    const auto& m = bunny();
    const auto& r = all_regions();
    Lock locks(m.vertex_slots());
    if constexpr (requires { locks.try_acquire(index_t{}, std::uint32_t{}); }) {
        boost::container::small_vector<index_t, 64> held;
        std::size_t i = 0, ok = 0;
        for (auto _ : st) {
            const tuple_t& t = r.edges[i];
            auto take = [&](index_t v) {
                const int got = locks.try_acquire(v, 1);
                if (got > 0) held.push_back(v);
                return got >= 0;
            };
            const auto [a, b] = m.edge_vertices(t);
            bool good = take(a) && take(b);
            for (index_t s : {a, b})
                for (index_t f : m.vertex_faces(s))
                    for (index_t w : m.face_vertices(f)) good = good && take(w);
            ok += good;
            for (index_t v : held) locks.unlock(v, 1);
            held.clear();
            if (++i == r.size()) i = 0;
        }
        benchmark::DoNotOptimize(ok);
        st.SetItemsProcessed(st.iterations());
    } else {
        st.SkipWithError("this lock policy has no try_acquire");
    }
}

/// Pools of 32 edges grown breadth-first from a seed vertex.
regions pool_around(const mesh_t& m, index_t seed, std::size_t count) {
    regions out;
    std::vector<index_t> frontier{seed}, ring;
    std::vector<char> seen(m.vertex_slots(), 0);
    seen[seed] = 1;
    for (std::size_t k = 0; k < frontier.size() && out.size() < count; ++k) {
        const index_t v = frontier[k];
        for (index_t f : m.vertex_faces(v)) {
            for (std::uint8_t le = 0; le < 3 && out.size() < count; ++le) {
                const auto t = m.tuple_from_edge(f, le);
                const auto [a, b] = m.edge_vertices(t);
                if (a == v && b > v) out.add(m, t); // each edge once, from its smaller end
            }
        }
        ring.clear();
        m.one_ring_vertices(v, ring);
        for (index_t w : ring)
            if (!seen[w]) seen[w] = 1, frontier.push_back(w);
    }
    return out;
}

struct contention_pools {
    regions overlapping;
    std::vector<regions> disjoint; // one per thread, up to 4
    // 64-byte lines of vertex_try_lock's owner words (16 vertices each) that two disjoint
    // pools both touch: false sharing the lock layout cannot avoid.
    std::size_t shared_lock_lines = 0;
};

const contention_pools& pools() {
    static const contention_pools p = [] {
        const auto& m = bunny();
        // Seeds far apart: vertices at quarter points of the Morton order.
        const auto part = partition::morton::assign(m, 4);
        contention_pools out;
        std::vector<index_t> seed(4, invalid_index);
        for (index_t v = 0; v < m.vertex_slots(); ++v)
            if (m.vertex_alive(v) && seed[part[v]] == invalid_index &&
                std::ranges::distance(m.vertex_faces(v)) >= 5 && !m.is_boundary_vertex(v))
                seed[part[v]] = v;
        out.overlapping = pool_around(m, seed[0], 32);
        std::vector<int> owner(m.vertex_slots(), -1);
        for (int k = 0; k < 4; ++k) {
            out.disjoint.push_back(pool_around(m, seed[k], 32));
            for (index_t v : out.disjoint.back().verts) {
                if (owner[v] != -1 && owner[v] != k) {
                    std::fprintf(stderr, "bench_policies: disjoint pools share vertex %u\n", v);
                    std::exit(1);
                }
                owner[v] = k;
            }
        }
        std::map<index_t, std::uint32_t> line_pools; // cache line -> bit set of pools
        for (int k = 0; k < 4; ++k)
            for (index_t v : out.disjoint[std::size_t(k)].verts) line_pools[v / 16] |= 1u << k;
        for (const auto& [line, bits] : line_pools)
            out.shared_lock_lines += std::popcount(bits) > 1;
        return out;
    }();
    return p;
}

template <bool Overlapping>
void BM_lock_contended(benchmark::State& st) {
    static lock::vertex_try_lock locks(bunny().vertex_slots());
    const auto& p = pools();
    const regions& pool = Overlapping ? p.overlapping : p.disjoint[std::size_t(st.thread_index())];
    // Each thread visits its pool in its own fixed random order.
    std::vector<std::size_t> order(pool.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), std::mt19937(100u + unsigned(st.thread_index())));
    const auto me = static_cast<std::uint32_t>(st.thread_index() + 1);
    std::size_t i = 0, ok = 0, checksum = 0;
    for (auto _ : st) {
        ok += claim_region(locks, pool, order[i], me, checksum);
        if (++i == order.size()) i = 0;
    }
    benchmark::DoNotOptimize(checksum);
    st.SetItemsProcessed(st.iterations());
    st.counters["success"] =
        benchmark::Counter(double(ok) / double(st.iterations()), benchmark::Counter::kAvgThreads);
    if (!Overlapping)
        st.counters["shared_lines"] =
            benchmark::Counter(double(p.shared_lock_lines), benchmark::Counter::kAvgThreads);
}

// ------------------------------------------------------------------ queues ----

/// The recorded traffic: events[i] >= 0 pushes entries[events[i]]; -1 pops; -2 sweeps.
/// swept_in[id] is the sweep (0, 1, ...) that removed entry id, or -1. In `entries`,
/// tuple.vid holds the entry's id (the queues never look at vid).
struct queue_trace {
    std::vector<entry_t> entries;
    std::vector<std::int64_t> events;
    std::vector<std::int32_t> swept_in;
    std::int32_t sweeps = 0;
    std::size_t pops = 0;
};
queue_trace* recording = nullptr;

/// A queue policy that forwards to a binary heap and records the traffic in `recording`.
struct recording_queue {
    template <class E>
    class type {
    public:
        void push(const E& e) {
            const auto id = static_cast<std::uint32_t>(recording->entries.size());
            E x = e;
            x.tuple.vid = id;
            recording->entries.push_back(x);
            recording->swept_in.push_back(-1);
            recording->events.push_back(id);
            inner_.push({e, id});
        }
        bool pop(E& out) {
            tagged t;
            if (!inner_.pop(t)) return false;
            recording->events.push_back(-1);
            ++recording->pops;
            out = t.entry();
            return true;
        }
        std::size_t size() const noexcept { return inner_.size(); }
        void clear() noexcept { inner_.clear(); }
        void reserve(std::size_t n) { inner_.reserve(n); }
        template <class Pred>
        void erase_if(Pred&& stale) {
            recording->events.push_back(-2);
            const std::int32_t k = recording->sweeps++;
            inner_.erase_if([&](const tagged& t) {
                if (!stale(t.entry())) return false;
                recording->swept_in[t.id] = k;
                return true;
            });
        }

    private:
        // The inner heap orders by priority, tuple.fid and tuple.local_edge, as all heaps.
        struct tagged {
            tagged() = default;
            tagged(const E& e, std::uint32_t i)
                : priority(e.priority)
                , tuple(e.tuple)
                , kind(e.kind)
                , retries(e.retries)
                , id(i) {}
            E entry() const { return {priority, tuple, kind, retries}; }
            double priority = 0;
            decltype(E::tuple) tuple;
            std::uint8_t kind = 0, retries = 0;
            std::uint32_t id = 0;
        };
        typename queue::binary_heap::template type<tagged> inner_;
    };
};
static_assert(queue_policy<recording_queue, entry_t>);

/// The traffic of one serial run of `Algorithm` (shortest edge collapse or QSlim) on
/// armadillo x4 to 10%, recorded once per algorithm.
template <class Algorithm, class Spec>
const queue_trace& decimation_trace() {
    static const queue_trace tr = [] {
        queue_trace t;
        recording = &t;
        auto m = armadillo_x4();
        Spec spec;
        spec.target_faces = std::int64_t(m.n_faces() / 10);
        Algorithm::run(m, spec);
        recording = nullptr;
        return t;
    }();
    return tr;
}
using sec_recorded = shortest_edge_collapse<true, mesh_t, lock::vertex_try_lock, recording_queue>;
using qslim_recorded = qslim<mesh_t, lock::vertex_try_lock, recording_queue>;

template <class Q, class Algorithm, class Spec>
void BM_queue_replay(benchmark::State& st) {
    const auto& tr = decimation_trace<Algorithm, Spec>();
    std::size_t pops = 0;
    double sweep_seconds = 0; // wall time of the sweeps alone
    for (auto _ : st) {
        typename Q::template type<entry_t> q;
        q.reserve(3 * armadillo_x4().face_slots()); // as the executor does
        std::int32_t sweep = 0;
        entry_t e;
        for (const std::int64_t ev : tr.events) {
            if (ev >= 0) {
                q.push(tr.entries[std::size_t(ev)]);
            } else if (ev == -1) {
                pops += q.pop(e);
            } else {
                const std::int32_t k = sweep++;
                const auto t0 = std::chrono::steady_clock::now();
                q.erase_if([&](const entry_t& x) { return tr.swept_in[x.tuple.vid] == k; });
                sweep_seconds +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            }
        }
        benchmark::DoNotOptimize(e);
    }
    st.SetItemsProcessed(std::int64_t(tr.events.size()) * st.iterations());
    st.counters["events"] = double(tr.events.size());
    st.counters["pushes"] = double(tr.entries.size());
    st.counters["pops"] = double(tr.pops);
    st.counters["sweeps"] = double(tr.sweeps);
    st.counters["sweep_ms"] = 1e3 * sweep_seconds / double(st.iterations());
}

// -------------------------------------------------------------- partitions ----

struct partition_quality {
    double cut = 0, boundary = 0, cross_region = 0, imbalance = 0;
};

partition_quality quality_of(const mesh_t& m, const std::vector<std::uint32_t>& part,
                             unsigned parts) {
    partition_quality q;
    std::size_t edges = 0, cut = 0, cross = 0;
    std::vector<index_t> r;
    m.for_each_edge([&](const tuple_t& t) {
        const auto [a, b] = m.edge_vertices(t);
        ++edges;
        cut += part[a] != part[b];
        region_of(m, t, r);
        cross += std::any_of(r.begin(), r.end(), [&](index_t v) { return part[v] != part[a]; });
    });
    std::size_t vertices = 0, boundary = 0;
    std::vector<std::size_t> size(parts, 0);
    std::vector<index_t> ring;
    m.for_each_vertex([&](const tuple_t& t) {
        ++vertices, ++size[part[t.vid]];
        ring.clear();
        m.one_ring_vertices(t.vid, ring);
        boundary += std::any_of(ring.begin(), ring.end(),
                                [&](index_t w) { return part[w] != part[t.vid]; });
    });
    q.cut = double(cut) / double(edges);
    q.cross_region = double(cross) / double(edges);
    q.boundary = double(boundary) / double(vertices);
    q.imbalance = double(*std::max_element(size.begin(), size.end())) * parts / double(vertices);
    return q;
}

template <class P>
void BM_partition_assign(benchmark::State& st) {
    const auto& m = armadillo_x4();
    const auto parts = static_cast<unsigned>(st.range(0));
    std::vector<std::uint32_t> part;
    for (auto _ : st) {
        part = P::assign(m, parts);
        benchmark::DoNotOptimize(part.data());
    }
    const auto q = quality_of(m, part, parts);
    st.counters["cut"] = q.cut;
    st.counters["boundary"] = q.boundary;
    st.counters["cross_region"] = q.cross_region;
    st.counters["imbalance"] = q.imbalance;
    st.SetItemsProcessed(std::int64_t(m.n_vertices()) * st.iterations());
}

/// armadillo x4 decimated to 10% without consolidating: 90% of the vertex slots are dead,
/// as in the phases of a remeshing iteration that follow its collapse phase.
const mesh_t& armadillo_x4_decimated() {
    static const mesh_t m = [] {
        auto d = armadillo_x4();
        shortest_edge_collapse_spec<> spec;
        spec.target_faces = std::int64_t(d.n_faces() / 10);
        shortest_edge_collapse<>::run(d, spec);
        return d;
    }();
    return m;
}

template <class P>
void BM_partition_assign_sparse(benchmark::State& st) {
    const auto& m = armadillo_x4_decimated();
    const auto parts = static_cast<unsigned>(st.range(0));
    std::vector<std::uint32_t> part;
    for (auto _ : st) {
        part = P::assign(m, parts);
        benchmark::DoNotOptimize(part.data());
    }
    const auto q = quality_of(m, part, parts);
    st.counters["cut"] = q.cut;
    st.counters["cross_region"] = q.cross_region;
    st.counters["imbalance"] = q.imbalance;
    st.counters["live_vertices"] = double(m.n_vertices());
    st.counters["vertex_slots"] = double(m.vertex_slots());
}

// ------------------------------------------------------------- whole runs ----

/// CPU time of the whole process (every thread): on a loaded machine a steadier measure
/// of the work done than wall time.
double process_cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

void report_counters(benchmark::State& st, const run_report& r) {
    st.counters["faces"] = double(r.faces);
    st.counters["succeeded"] = double(r.succeeded);
    st.counters["popped"] = double(r.popped);
    st.counters["stale"] = double(r.stale);
    st.counters["purged"] = double(r.purged);
    st.counters["lock_failures"] = double(r.lock_failures);
    st.counters["stolen"] = double(r.stolen);
    st.counters["deferred_to_serial"] = double(r.deferred_to_serial);
}

template <class Algorithm, class Spec>
void run_decimation(benchmark::State& st, unsigned threads) {
    run_report r;
    double cpu = 0;
    for (auto _ : st) {
        st.PauseTiming();
        auto m = armadillo_x4();
        Spec spec;
        spec.target_faces = std::int64_t(m.n_faces() / 10);
        st.ResumeTiming();
        const double cpu0 = process_cpu_seconds();
        r = Algorithm::run(m, spec, {.threads = threads});
        cpu = process_cpu_seconds() - cpu0;
        st.SetIterationTime(r.seconds);
    }
    report_counters(st, r);
    st.counters["cpu_s"] = cpu;
}

template <class Queue>
void BM_run_sec_serial(benchmark::State& st) {
    run_decimation<shortest_edge_collapse<true, mesh_t, lock::vertex_try_lock, Queue>,
                   shortest_edge_collapse_spec<>>(st, 1);
}
template <class Queue>
void BM_run_qslim_serial(benchmark::State& st) {
    run_decimation<qslim<mesh_t, lock::vertex_try_lock, Queue>, qslim_spec>(st, 1);
}
template <class Partition>
void BM_run_sec_2t(benchmark::State& st) {
    run_decimation<
        shortest_edge_collapse<true, mesh_t, lock::vertex_try_lock, queue::dary_heap<4>, Partition>,
        shortest_edge_collapse_spec<>>(st, 2);
}

// Set-up steps isotropic_remeshing::run may or may not have (the smoothing pass stamp),
// detected so this copy of its loop follows the header it is built with.
template <class State>
void add_smoothing_stamp(State& s, mesh_t& m) {
    if constexpr (requires { s.smoothed = m.add_vertex_attribute<std::uint32_t>("", 0); })
        s.smoothed = m.add_vertex_attribute<std::uint32_t>("remesh_smoothed", 0);
}
template <class State>
void next_smoothing_pass(State& s) {
    if constexpr (requires { ++s.pass; }) ++s.pass;
}

/// One remeshing iteration as isotropic_remeshing::run does it (closed input: no boundary,
/// no features, so nothing is frozen), keeping each phase's run_report, which run() does
/// not return.
template <class Partition>
run_report remesh_once(mesh_t& m, unsigned threads, double (&phase_seconds)[4]) {
    using Lock = lock::vertex_try_lock;
    using Queue = queue::dary_heap<4>;
    remeshing_state s;
    {
        const auto [V, F] = m.to_arrays();
        const triangle_aabb_tree tree(V, F);
        s.L = 0.01 * tree.diagonal();
        s.input = std::make_shared<const triangle_aabb_tree>(V, F);
    }
    s.frozen = m.add_vertex_attribute<std::uint8_t>("remesh_frozen", 0);
    s.feature = m.add_vertex_attribute<std::uint8_t>("remesh_feature", 0);
    s.boundary = m.add_vertex_attribute<std::uint8_t>("remesh_boundary", 0);
    add_smoothing_stamp(s, m);
    remesh_split_spec<> split{{}, s};
    remesh_collapse_spec<> collapse{{}, s};
    remesh_swap_spec<> swap{{}, s};
    remesh_smooth_spec<> smooth{{}, s, true};
    const exec_options o{.threads = threads};
    run_report phase[4];
    phase[0] = executor<remesh_split_spec<>, mesh_t, Lock, Queue, Partition>::run(m, split, o);
    phase[1] =
        executor<remesh_collapse_spec<>, mesh_t, Lock, Queue, Partition>::run(m, collapse, o);
    phase[2] = executor<remesh_swap_spec<>, mesh_t, Lock, queue::fifo, Partition>::run(m, swap, o);
    next_smoothing_pass(s);
    phase[3] =
        executor<remesh_smooth_spec<>, mesh_t, Lock, queue::fifo, Partition>::run(m, smooth, o);
    for (int k = 0; k < 4; ++k) phase_seconds[k] = phase[k].seconds;
    run_report sum;
    for (const auto& r : phase) {
        sum.popped += r.popped, sum.stale += r.stale, sum.purged += r.purged;
        sum.succeeded += r.succeeded, sum.lock_failures += r.lock_failures;
        sum.stolen += r.stolen, sum.deferred_to_serial += r.deferred_to_serial;
        sum.seconds += r.seconds;
    }
    sum.faces = std::int64_t(m.n_faces());
    return sum;
}

template <class Partition>
void BM_run_remesh_2t(benchmark::State& st) {
    run_report r;
    double phase[4] = {0, 0, 0, 0}, cpu = 0;
    for (auto _ : st) {
        st.PauseTiming();
        auto m = armadillo_x4();
        st.ResumeTiming();
        const double cpu0 = process_cpu_seconds();
        r = remesh_once<Partition>(m, 2, phase);
        cpu = process_cpu_seconds() - cpu0;
        st.SetIterationTime(r.seconds);
    }
    report_counters(st, r);
    st.counters["cpu_s"] = cpu;
    const char* names[4] = {"split_s", "collapse_s", "swap_s", "smooth_s"};
    for (int k = 0; k < 4; ++k) st.counters[names[k]] = phase[k];
}

} // namespace

// Registration order = output order; run_policies.sh reads names, not positions.
BENCHMARK(BM_lock_region<lock::none>)->Name("lock/region/none");
BENCHMARK(BM_lock_region<lock::vertex_try_lock>)->Name("lock/region/vertex_try_lock");
BENCHMARK(BM_lock_walk<lock::none>)->Name("lock/walk/none");
BENCHMARK(BM_lock_walk<lock::vertex_try_lock>)->Name("lock/walk/vertex_try_lock");
BENCHMARK(BM_lock_walk_acquire<lock::vertex_try_lock>)
    ->Name("lock/walk/vertex_try_lock+try_acquire");
BENCHMARK(BM_lock_contended<true>)
    ->Name("lock/contended/overlapping")
    ->Threads(1)
    ->Threads(2)
    ->Threads(4)
    ->UseRealTime();
BENCHMARK(BM_lock_contended<false>)
    ->Name("lock/contended/disjoint")
    ->Threads(1)
    ->Threads(2)
    ->Threads(4)
    ->UseRealTime();

BENCHMARK(BM_queue_replay<queue::binary_heap, sec_recorded, shortest_edge_collapse_spec<>>)
    ->Name("queue/replay_sec/binary_heap")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_queue_replay<queue::dary_heap<4>, sec_recorded, shortest_edge_collapse_spec<>>)
    ->Name("queue/replay_sec/dary_heap<4>")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_queue_replay<queue::bucket_heap<>, sec_recorded, shortest_edge_collapse_spec<>>)
    ->Name("queue/replay_sec/bucket_heap<16>")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_queue_replay<queue::fifo, sec_recorded, shortest_edge_collapse_spec<>>)
    ->Name("queue/replay_sec/fifo")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_queue_replay<queue::binary_heap, qslim_recorded, qslim_spec>)
    ->Name("queue/replay_qslim/binary_heap")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_queue_replay<queue::dary_heap<4>, qslim_recorded, qslim_spec>)
    ->Name("queue/replay_qslim/dary_heap<4>")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_queue_replay<queue::bucket_heap<>, qslim_recorded, qslim_spec>)
    ->Name("queue/replay_qslim/bucket_heap<16>")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_queue_replay<queue::fifo, qslim_recorded, qslim_spec>)
    ->Name("queue/replay_qslim/fifo")
    ->Unit(benchmark::kMillisecond);

BENCHMARK(BM_partition_assign<partition::morton>)
    ->Name("partition/assign/morton")
    ->ArgName("parts")
    ->Arg(2)
    ->Arg(4)
    ->Arg(8)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_partition_assign<partition::metis>)
    ->Name("partition/assign/metis")
    ->ArgName("parts")
    ->Arg(2)
    ->Arg(4)
    ->Arg(8)
    ->Unit(benchmark::kMillisecond);

BENCHMARK(BM_partition_assign_sparse<partition::morton>)
    ->Name("partition/assign_sparse/morton")
    ->ArgName("parts")
    ->Arg(2)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_partition_assign_sparse<partition::metis>)
    ->Name("partition/assign_sparse/metis")
    ->ArgName("parts")
    ->Arg(2)
    ->Unit(benchmark::kMillisecond);

BENCHMARK(BM_run_sec_serial<queue::binary_heap>)
    ->Name("run/sec_serial/binary_heap")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_sec_serial<queue::dary_heap<4>>)
    ->Name("run/sec_serial/dary_heap<4>")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_sec_serial<queue::bucket_heap<>>)
    ->Name("run/sec_serial/bucket_heap<16>")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_sec_serial<queue::fifo>)
    ->Name("run/sec_serial/fifo")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_qslim_serial<queue::binary_heap>)
    ->Name("run/qslim_serial/binary_heap")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_qslim_serial<queue::dary_heap<4>>)
    ->Name("run/qslim_serial/dary_heap<4>")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_qslim_serial<queue::bucket_heap<>>)
    ->Name("run/qslim_serial/bucket_heap<16>")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_qslim_serial<queue::fifo>)
    ->Name("run/qslim_serial/fifo")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_sec_2t<partition::morton>)
    ->Name("run/sec_2t/morton")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_sec_2t<partition::metis>)
    ->Name("run/sec_2t/metis")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_remesh_2t<partition::morton>)
    ->Name("run/remesh_2t/morton")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_run_remesh_2t<partition::metis>)
    ->Name("run/remesh_2t/metis")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
