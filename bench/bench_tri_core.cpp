// Benchmarks of the triangle core on the Stanford bunny (data/bunny.obj, 69k faces):
// tuple navigation, the four local operations (committed and rolled back), the memory
// the connectivity needs per face, and heap allocations per operation; each for both
// connectivity backends (indexed_tri: per-vertex face lists; corner_table_tri: opposite
// corners per face, one corner per vertex).
//
// Method
// ------
// * Every benchmark is a member of core<Mesh>, instantiated once per backend and
//   registered as "<name>/indexed" and "<name>/corner_table" one right after the other
//   (so both see the same machine load). Both work on identical inputs: the same tuples,
//   edge sets and visiting orders (the two backends number slots and edges alike).
// * The bunny is loaded once per backend (fixture()); every benchmark works on its own copy.
// * nav/*: each iteration sweeps a precomputed array of tuples (or the whole mesh);
//   items_per_second is navigation steps per second. Results are folded into a checksum
//   so nothing is optimised away.
// * op/*: one iteration is one operation, so "Time" is ns per operation (the time/op
//   counter says the same and is also right for the two-operation pair/* rows). Edges
//   and vertices are visited in a fixed random order.
//   - commit, split/collapse/swap: an operation changes the mesh, so these run in
//     batches. The pristine bunny is copied (timing paused, capacity reserved so slot
//     growth does not reallocate), then one operation is applied to each edge of an
//     "independent set": edges whose endpoints are at least three rings apart, so no
//     operation modifies a face or incidence list another one will read, and every
//     precomputed tuple stays valid. When the set is used up the mesh is copied again.
//     One PauseTiming/ResumeTiming pair is paid per ~2000 operations. Each copy starts
//     cold, so incidence lists that outgrow their inline capacity allocate (allocs/op).
//   - commit, smooth_vertex: connectivity never changes, so it cycles in place over all
//     vertices (Laplacian: the vertex moves to its one-ring centroid).
//   - rollback_after: the spec's after() returns false, so the whole operation runs and
//     its journal is rolled back. rollback_invariant: an invariant's after() refuses the
//     new cells (same work, reached through the invariant set). Either way the mesh is
//     left bit-for-bit unchanged (checked after the loop with idas::identical), so these
//     cycle in place over every eligible edge/vertex, on a mesh warmed by one full pass
//     (steady state: every buffer already at its working size).
//   - op_in_mesh_order/*: two of the above visiting the mesh in file order rather than
//     in random order; the gap is what cache misses cost.
//   - commit+no_normal_flip: as commit, with the no_normal_flip invariant in the spec;
//     the "ok" counter is the fraction of operations it let through.
// * pair/*: steady state without any pause: split an edge then collapse the new edge
//   back (the mesh regains its exact geometry; slots grow, capacity reserved up front),
//   or swap an edge and swap it back (nothing grows at all).
// * nav/vertex_faces: iterating vertex_faces(v) (a stored list against a circulation);
//   nav/is_boundary_vertex: one query per vertex.
// * mem/connectivity: backend memory_bytes() / faces, plus attribute bytes per face.
// * allocs/op: a counting global operator new (this translation unit) counts heap
//   allocations inside the timed region only, divided by the operations run.
#include <idas/idas.hpp>
#include <idas/io/io.hpp>

#include <benchmark/benchmark.h>
#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <new>
#include <optional>
#include <random>
#include <string>
#include <vector>

// ---- counting allocator -------------------------------------------------------------

namespace {
std::atomic<std::uint64_t> g_allocations{0};

void* counted_alloc(std::size_t n) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void* counted_alloc_aligned(std::size_t n, std::align_val_t al) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    const auto a = static_cast<std::size_t>(al);
    const std::size_t rounded = (std::max<std::size_t>(n, 1) + a - 1) / a * a;
    if (void* p = std::aligned_alloc(a, rounded)) return p;
    throw std::bad_alloc();
}
} // namespace

void* operator new(std::size_t n) {
    return counted_alloc(n);
}
void* operator new[](std::size_t n) {
    return counted_alloc(n);
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
    try {
        return counted_alloc(n);
    } catch (...) {
        return nullptr;
    }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
    try {
        return counted_alloc(n);
    } catch (...) {
        return nullptr;
    }
}
void* operator new(std::size_t n, std::align_val_t al) {
    return counted_alloc_aligned(n, al);
}
void* operator new[](std::size_t n, std::align_val_t al) {
    return counted_alloc_aligned(n, al);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
    std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
    std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
    std::free(p);
}

namespace {

using idas::index_t;
using idas::vec3;
namespace op = idas::op;
/// Heap allocations made while the meter runs (start/stop bracket the timed parts).
class alloc_meter {
public:
    void start() { mark_ = g_allocations.load(std::memory_order_relaxed); }
    void stop() { counted_ += g_allocations.load(std::memory_order_relaxed) - mark_; }
    std::uint64_t count() const { return counted_; }

private:
    std::uint64_t mark_ = 0, counted_ = 0;
};

enum class mode { commit, commit_nnf, rollback_after, rollback_invariant };

/// An invariant that refuses every result: forces the rollback path through the
/// invariant set rather than through the spec's after().
struct refuse_all {
    struct state {};
    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh&, const Result&, state&) const {
        return false;
    }
};

void report_ops(benchmark::State& st, double ops_per_iteration, std::uint64_t allocs,
                std::uint64_t ok) {
    const double ops = ops_per_iteration * static_cast<double>(st.iterations());
    st.counters["time/op"] =
        benchmark::Counter(ops_per_iteration, benchmark::Counter::kIsIterationInvariantRate |
                                                  benchmark::Counter::kInvert);
    st.counters["allocs/op"] = ops > 0 ? static_cast<double>(allocs) / ops : 0.0;
    st.counters["ok"] = ops > 0 ? static_cast<double>(ok) / ops : 0.0;
    st.SetItemsProcessed(static_cast<std::int64_t>(ops));
}

struct memory_figures {
    double connectivity_per_face, connectivity_per_vertex, attributes_per_face;
};

/// Every benchmark of one backend: instantiated once per connectivity backend, and
/// registered side by side (see register_all).
template <class Mesh>
struct core {
    using mesh_t = Mesh;
    using tuple = typename Mesh::tuple;
    using ctx_t = idas::op_context<mesh_t>;
    using result_t = idas::op_result<tuple>;

    // ---- the bunny and the tuple sets every benchmark draws from ------------------------

    static std::vector<index_t> one_ring(const mesh_t& m, index_t v) {
        std::vector<index_t> r;
        m.one_ring_vertices(v, r);
        return r;
    }

    static bool swappable(const mesh_t& m, const tuple& t) {
        const auto g = m.switch_face(t);
        if (!g) return false;
        const index_t c = m.opposite_vertex(t), d = m.opposite_vertex(*g);
        if (c == d) return false;
        const auto ring = one_ring(m, c);
        return std::find(ring.begin(), ring.end(), d) == ring.end();
    }

    /// Greedy independent set, in the order given: an edge is taken only if both its
    /// endpoints are at distance >= 3 from every endpoint taken before. Then an operation on
    /// one edge touches faces and incidence lists within distance 1 of its endpoints, and
    /// what another one reads (its endpoints' stars and their neighbours' incidence lists)
    /// is never among them.
    static std::vector<tuple> independent_set(const mesh_t& m,
                                              const std::vector<tuple>& candidates) {
        std::vector<char> blocked(m.vertex_slots(), 0);
        std::vector<tuple> out;
        for (const tuple& t : candidates) {
            const auto [a, b] = m.edge_vertices(t);
            if (blocked[a] || blocked[b]) continue;
            out.push_back(t);
            std::vector<index_t> ring1 = one_ring(m, a);
            m.one_ring_vertices(b, ring1);
            ring1.push_back(a), ring1.push_back(b);
            for (index_t v : ring1) {
                blocked[v] = 1;
                for (index_t w : one_ring(m, v)) blocked[w] = 1;
            }
        }
        return out;
    }

    struct fixture_t {
        mesh_t mesh;
        std::size_t n_vertices = 0, n_faces = 0, n_edges = 0, n_boundary_edges = 0;

        // navigation
        std::vector<tuple> half_edges;          // all 3F tuples, face order
        std::vector<tuple> interior_half_edges; // those with a face across, face order
        std::vector<tuple> interior_shuffled;   // same, random order
        std::vector<tuple> interior_vertices;   // one tuple per interior vertex
        std::vector<index_t> vertices;          // every vertex with a face

        // operations (random order)
        std::vector<tuple> edges;          // one tuple per edge: split
        std::vector<tuple> edges_in_order; // the same in mesh (face) order
        std::vector<tuple> collapsible;    // link condition holds
        std::vector<tuple> swappable;      // interior, c != d, cd not an edge yet
        std::vector<index_t> smoothable;   // every vertex with a face

        // independent sets for batched commits
        std::vector<tuple> split_set, collapse_set, swap_set, pair_set;
    };

    static fixture_t build_fixture() {
        const auto s = idas::io::read_surface(std::string(IDAS_DATA_DIR) + "/bunny.obj");
        fixture_t fx;
        fx.mesh = mesh_t(s.vertices, s.faces);
        const mesh_t& m = fx.mesh;
        std::mt19937 rng(20240611);

        fx.n_vertices = m.n_vertices();
        fx.n_faces = m.n_faces();
        m.for_each_face([&](const tuple& f) {
            for (std::uint8_t le = 0; le < 3; ++le) {
                const tuple t = m.tuple_from_edge(f.fid, le);
                fx.half_edges.push_back(t);
                if (m.switch_face(t)) fx.interior_half_edges.push_back(t);
            }
        });
        fx.interior_shuffled = fx.interior_half_edges;
        std::shuffle(fx.interior_shuffled.begin(), fx.interior_shuffled.end(), rng);
        m.for_each_vertex([&](const tuple& t) {
            fx.vertices.push_back(t.vid);
            fx.smoothable.push_back(t.vid);
            if (!m.is_boundary_vertex(t.vid)) fx.interior_vertices.push_back(t);
        });
        std::shuffle(fx.smoothable.begin(), fx.smoothable.end(), rng);

        fx.edges = m.get_edges();
        fx.edges_in_order = fx.edges;
        fx.n_edges = fx.edges.size();
        std::shuffle(fx.edges.begin(), fx.edges.end(), rng);
        std::vector<tuple> interior_edges;
        for (const tuple& t : fx.edges) {
            if (m.is_boundary_edge(t))
                ++fx.n_boundary_edges;
            else
                interior_edges.push_back(t);
            if (idas::link_condition_holds(m, t)) fx.collapsible.push_back(t);
            if (swappable(m, t)) fx.swappable.push_back(t);
        }
        fx.split_set = independent_set(m, fx.edges);
        fx.collapse_set = independent_set(m, fx.collapsible);
        fx.swap_set = independent_set(m, fx.swappable);
        fx.pair_set = independent_set(m, interior_edges);
        return fx;
    }

    static const fixture_t& fixture() {
        static const fixture_t fx = build_fixture();
        return fx;
    }

    // ---- specs ---------------------------------------------------------------------------

    template <mode M>
    struct spec_base {
        static constexpr bool keep = M != mode::rollback_after;
        auto invariants() const {
            if constexpr (M == mode::commit_nnf)
                return idas::invariant_set{idas::no_normal_flip{}};
            else if constexpr (M == mode::rollback_invariant)
                return idas::invariant_set{refuse_all{}};
            else
                return idas::invariant_set<>{};
        }
    };

    static vec3 midpoint(const mesh_t& m, const tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        return 0.5 * (m.position(a) + m.position(b));
    }

    /// Midpoint split: before() caches the midpoint, after() gives it to the new vertex.
    template <mode M>
    struct split_spec : spec_base<M> {
        std::optional<vec3> before(op::split_edge, const mesh_t& m, const tuple& t) const {
            return midpoint(m, t);
        }
        bool after(op::split_edge, mesh_t& m, const result_t& r, vec3& mid) const {
            m.positions(r).set(r.anchor.vid, mid);
            return this->keep;
        }
    };

    /// Collapse to the midpoint: the surviving vertex moves there.
    template <mode M>
    struct collapse_spec : spec_base<M> {
        std::optional<vec3> before(op::collapse_edge, const mesh_t& m, const tuple& t) const {
            return midpoint(m, t);
        }
        bool after(op::collapse_edge, mesh_t& m, const result_t& r, vec3& mid) const {
            m.positions(r).set(r.anchor.vid, mid);
            return this->keep;
        }
    };

    template <mode M>
    struct swap_spec : spec_base<M> {
        bool after(op::swap_edge, mesh_t&, const result_t&) const { return this->keep; }
    };

    /// Laplacian smoothing: the vertex moves to the centroid of its one-ring.
    template <mode M>
    struct smooth_spec : spec_base<M> {
        std::optional<vec3> before(op::smooth_vertex, const mesh_t& m, const tuple& t) const {
            boost::container::small_vector<index_t, 24> ring;
            m.one_ring_vertices(t.vid, ring);
            vec3 c{};
            for (index_t w : ring) c += m.position(w);
            return c / static_cast<double>(ring.size());
        }
        bool after(op::smooth_vertex, mesh_t& m, const result_t& r, vec3& c) const {
            m.positions(r).set(r.anchor.vid, c);
            return this->keep;
        }
    };

    struct split_op {
        template <mode M>
        static bool run(mesh_t& m, const tuple& t, ctx_t& ctx) {
            split_spec<M> s;
            return idas::split_edge(m, t, s, ctx).has_value();
        }
    };
    struct collapse_op {
        template <mode M>
        static bool run(mesh_t& m, const tuple& t, ctx_t& ctx) {
            collapse_spec<M> s;
            return idas::collapse_edge(m, t, s, ctx).has_value();
        }
    };
    struct swap_op {
        template <mode M>
        static bool run(mesh_t& m, const tuple& t, ctx_t& ctx) {
            swap_spec<M> s;
            return idas::swap_edge(m, t, s, ctx).has_value();
        }
    };
    /// Smoothing takes a vertex id: a committed smooth renews every face of its star, so
    /// tuples held for neighbouring vertices go stale; the tuple is made when needed.
    struct smooth_op {
        template <mode M>
        static bool run(mesh_t& m, index_t v, ctx_t& ctx) {
            smooth_spec<M> s;
            return idas::smooth_vertex(m, m.tuple_from_vertex(v), s, ctx).has_value();
        }
    };

    // ---- runners -------------------------------------------------------------------------

    /// A copy of the bunny and an operation context that have seen one full pass of the
    /// operations a benchmark runs: journals, scratch buffers, attribute columns and any
    /// incidence list that outgrows its inline capacity are at their working size.
    struct warm_mesh {
        mesh_t m;
        ctx_t ctx;
    };

    template <class T, class Run>
    static std::unique_ptr<warm_mesh> make_warm(const std::vector<T>& list, Run run) {
        auto w = std::make_unique<warm_mesh>();
        w->m = fixture().mesh;
        for (const T& x : list) run(w->m, x, w->ctx);
        return w;
    }

    /// Runs `run(mesh, item, ctx)` on each item of `list` in turn on a warmed copy of the
    /// bunny that is never reset (steady state). For rollbacks, after which the mesh must be
    /// bit-for-bit the bunny again, and for smoothing.
    template <class T, class Run>
    static void run_in_place(benchmark::State& st, warm_mesh& w, const std::vector<T>& list,
                             Run run, bool expect_unchanged) {
        const fixture_t& fx = fixture();
        mesh_t& m = w.m;
        ctx_t& ctx = w.ctx;
        alloc_meter meter;
        std::uint64_t ok = 0;
        std::size_t i = 0;
        meter.start();
        for (auto _ : st) {
            ok += run(m, list[i], ctx) ? 1 : 0;
            if (++i == list.size()) i = 0;
        }
        meter.stop();
        report_ops(st, 1, meter.count(), ok);
        if (expect_unchanged && !idas::identical(m, fx.mesh))
            st.SkipWithError("rollback did not restore the mesh bit for bit");
    }

    /// Runs `run` once per tuple of an independent set, on a fresh copy of the bunny per
    /// pass over the set (copying is not timed and not counted as allocations).
    template <class Run>
    static void run_batched(benchmark::State& st, const std::vector<tuple>& set, Run run) {
        const fixture_t& fx = fixture();
        mesh_t m;
        ctx_t ctx;
        auto reset = [&] {
            m = fx.mesh;
            m.reserve(m.vertex_slots() + static_cast<index_t>(set.size()),
                      m.face_slots() + 2 * static_cast<index_t>(set.size()));
        };
        reset();
        for (std::size_t i = 0; i < std::min<std::size_t>(set.size(), 64); ++i) run(m, set[i], ctx);

        alloc_meter meter;
        std::uint64_t ok = 0;
        std::size_t i = set.size(); // forces a fresh copy first
        meter.start();
        for (auto _ : st) {
            if (i == set.size()) {
                meter.stop();
                st.PauseTiming();
                reset();
                i = 0;
                st.ResumeTiming();
                meter.start();
            }
            ok += run(m, set[i++], ctx) ? 1 : 0;
        }
        meter.stop();
        report_ops(st, 1, meter.count(), ok);
    }

    template <class Op, mode M>
    static void bm_edge_op(benchmark::State& st, const std::vector<tuple>& all,
                           const std::vector<tuple>& set) {
        if constexpr (M == mode::rollback_after || M == mode::rollback_invariant) {
            static const auto warm = make_warm(all, Op::template run<M>); // once per process
            run_in_place(st, *warm, all, Op::template run<M>, true);
        } else {
            run_batched(st, set, Op::template run<M>);
        }
    }

    template <mode M>
    static void bm_smooth(benchmark::State& st) {
        constexpr bool rollback = M == mode::rollback_after || M == mode::rollback_invariant;
        static const auto warm = make_warm(fixture().smoothable, smooth_op::template run<M>);
        run_in_place(st, *warm, fixture().smoothable, smooth_op::template run<M>, rollback);
    }

    // The same work visiting the mesh in its own (file) order instead of a random one: the
    // difference is the cost of cache misses.
    static void bm_smooth_in_order(benchmark::State& st) {
        static const auto warm =
            make_warm(fixture().vertices, smooth_op::template run<mode::commit>);
        run_in_place(st, *warm, fixture().vertices, smooth_op::template run<mode::commit>, false);
    }
    static void bm_split_rollback_in_order(benchmark::State& st) {
        const auto& list = fixture().edges_in_order;
        static const auto warm = make_warm(list, split_op::template run<mode::rollback_after>);
        run_in_place(st, *warm, list, split_op::template run<mode::rollback_after>, true);
    }

    /// Split an edge, then collapse the new edge back into the old endpoint: the mesh gets
    /// the same triangles back (face f' takes over from f with the same corner order).
    static void bm_pair_split_collapse(benchmark::State& st) {
        const fixture_t& fx = fixture();
        mesh_t m = fx.mesh;
        std::vector<tuple> list = fx.pair_set;
        // Each pair leaves 1 dead vertex slot and 2 dead face slots; reserve them so the
        // measurement sees no amortised vector growth (skipped for absurd iteration counts).
        const auto n = static_cast<std::size_t>(st.max_iterations) + 512;
        if (n < 20'000'000)
            m.reserve(static_cast<index_t>(m.vertex_slots() + n),
                      static_cast<index_t>(m.face_slots() + 2 * n));
        ctx_t ctx;
        auto pair = [&](std::size_t i) {
            const tuple t = list[i];
            const auto s = idas::split_edge(m, t, split_spec<mode::commit>{}, ctx);
            if (!s) return false;
            const index_t f_new = s->cells[1].fid; // the face (nv, b, c) split off f
            const tuple back = m.switch_vertex(s->anchor);
            if (!idas::collapse_edge(m, back, idas::no_spec{}, ctx)) return false;
            list[i] = tuple{t.vid, f_new, t.local_edge, m.connectivity().face_version(f_new)};
            return true;
        };
        for (std::size_t i = 0; i < std::min<std::size_t>(list.size(), 256); ++i) pair(i);

        alloc_meter meter;
        std::uint64_t ok = 0;
        std::size_t i = 0;
        meter.start();
        for (auto _ : st) {
            ok += pair(i) ? 2 : 0;
            if (++i == list.size()) i = 0;
        }
        meter.stop();
        report_ops(st, 2, meter.count(), ok);
    }

    /// Swap an edge and swap it back: the same triangles, nothing grows.
    static void bm_pair_swap_back(benchmark::State& st) {
        const fixture_t& fx = fixture();
        mesh_t m = fx.mesh;
        std::vector<tuple> list = fx.swap_set;
        ctx_t ctx;
        auto pair = [&](std::size_t i) {
            const auto s1 = idas::swap_edge(m, list[i], idas::no_spec{}, ctx);
            if (!s1) return false;
            const tuple there = s1->anchor;
            const auto s2 = idas::swap_edge(m, there, idas::no_spec{}, ctx);
            if (!s2) return false;
            list[i] = s2->anchor; // on the original edge again
            return true;
        };
        for (std::size_t i = 0; i < std::min<std::size_t>(list.size(), 256); ++i) pair(i);

        alloc_meter meter;
        std::uint64_t ok = 0;
        std::size_t i = 0;
        meter.start();
        for (auto _ : st) {
            ok += pair(i) ? 2 : 0;
            if (++i == list.size()) i = 0;
        }
        meter.stop();
        report_ops(st, 2, meter.count(), ok);
    }

    // ---- navigation ----------------------------------------------------------------------

    /// Sweeps `list` once per iteration through `step`, which returns a number to fold into
    /// the checksum. items_per_second = calls of `step` per second.
    template <class Step>
    static void sweep(benchmark::State& st, const std::vector<tuple>& list, Step step) {
        alloc_meter meter;
        meter.start();
        for (auto _ : st) {
            std::uint64_t acc = 0;
            for (const tuple& t : list) acc += step(t);
            benchmark::DoNotOptimize(acc);
        }
        meter.stop();
        const auto items = static_cast<double>(st.iterations()) * static_cast<double>(list.size());
        st.SetItemsProcessed(static_cast<std::int64_t>(items));
        st.counters["allocs/op"] = static_cast<double>(meter.count()) / items;
    }

    static void bm_switch_vertex(benchmark::State& st) {
        const mesh_t& m = fixture().mesh;
        sweep(st, fixture().half_edges, [&](const tuple& t) { return m.switch_vertex(t).vid; });
    }
    static void bm_switch_edge(benchmark::State& st) {
        const mesh_t& m = fixture().mesh;
        sweep(st, fixture().half_edges,
              [&](const tuple& t) { return m.switch_edge(t).local_edge; });
    }
    static void bm_switch_face(benchmark::State& st, const std::vector<tuple>* list) {
        const mesh_t& m = fixture().mesh;
        sweep(st, *list, [&](const tuple& t) {
            const auto g = m.switch_face(t);
            return g ? g->fid : index_t{1};
        });
    }
    static void bm_is_valid(benchmark::State& st) {
        const mesh_t& m = fixture().mesh;
        sweep(st, fixture().half_edges, [&](const tuple& t) { return m.is_valid(t) ? 1u : 0u; });
    }
    static void bm_eid(benchmark::State& st) {
        const mesh_t& m = fixture().mesh;
        sweep(st, fixture().half_edges, [&](const tuple& t) { return m.eid(t); });
    }

    /// Walks around every interior vertex with switch_edge + switch_face (a dependent chain:
    /// each step needs the previous one). Items are single switches.
    static void bm_vertex_circulation(benchmark::State& st) {
        const fixture_t& fx = fixture();
        const mesh_t& m = fx.mesh;
        std::uint64_t switches = 0;
        alloc_meter meter;
        meter.start();
        for (auto _ : st) {
            std::uint64_t acc = 0, n = 0;
            for (const tuple& start : fx.interior_vertices) {
                tuple t = start;
                do {
                    t = *m.switch_face(m.switch_edge(t));
                    acc += t.fid, n += 2;
                } while (t.fid != start.fid);
            }
            benchmark::DoNotOptimize(acc);
            switches = n;
        }
        meter.stop();
        const auto items = static_cast<double>(st.iterations()) * static_cast<double>(switches);
        st.SetItemsProcessed(static_cast<std::int64_t>(items));
        st.counters["allocs/op"] = static_cast<double>(meter.count()) / items;
    }

    /// one_ring_vertices for every vertex into a reused small_vector. Items are vertices.
    static void bm_one_ring(benchmark::State& st) {
        const fixture_t& fx = fixture();
        const mesh_t& m = fx.mesh;
        boost::container::small_vector<index_t, 24> ring;
        std::uint64_t neighbours = 0;
        alloc_meter meter;
        meter.start();
        for (auto _ : st) {
            std::uint64_t acc = 0;
            for (index_t v : fx.vertices) {
                ring.clear();
                m.one_ring_vertices(v, ring);
                for (index_t w : ring) acc += w;
                neighbours += ring.size();
            }
            benchmark::DoNotOptimize(acc);
        }
        meter.stop();
        const auto items =
            static_cast<double>(st.iterations()) * static_cast<double>(fx.vertices.size());
        st.SetItemsProcessed(static_cast<std::int64_t>(items));
        st.counters["neighbours/s"] =
            benchmark::Counter(static_cast<double>(neighbours), benchmark::Counter::kIsRate);
        st.counters["allocs/op"] = static_cast<double>(meter.count()) / items;
    }

    /// for_each_edge over the whole mesh. Items are edges visited.
    static void bm_for_each_edge(benchmark::State& st) {
        const fixture_t& fx = fixture();
        const mesh_t& m = fx.mesh;
        alloc_meter meter;
        meter.start();
        for (auto _ : st) {
            std::uint64_t acc = 0;
            m.for_each_edge([&](const tuple& t) { acc += t.fid + t.local_edge; });
            benchmark::DoNotOptimize(acc);
        }
        meter.stop();
        const auto items = static_cast<double>(st.iterations()) * static_cast<double>(fx.n_edges);
        st.SetItemsProcessed(static_cast<std::int64_t>(items));
        st.counters["allocs/op"] = static_cast<double>(meter.count()) / items;
    }

    /// Iterates vertex_faces(v) of every vertex: a stored list (indexed_tri) against a
    /// circulation through the opposite table (corner_table_tri). Items are faces visited.
    static void bm_vertex_faces(benchmark::State& st) {
        const fixture_t& fx = fixture();
        const mesh_t& m = fx.mesh;
        std::uint64_t faces = 0;
        alloc_meter meter;
        meter.start();
        for (auto _ : st) {
            std::uint64_t acc = 0, n = 0;
            for (index_t v : fx.vertices)
                for (index_t f : m.vertex_faces(v)) acc += f, ++n;
            benchmark::DoNotOptimize(acc);
            faces = n;
        }
        meter.stop();
        const auto items = static_cast<double>(st.iterations()) * static_cast<double>(faces);
        st.SetItemsProcessed(static_cast<std::int64_t>(items));
        st.counters["allocs/op"] = static_cast<double>(meter.count()) / items;
    }

    /// is_boundary_vertex for every vertex. Items are vertices.
    static void bm_is_boundary_vertex(benchmark::State& st) {
        const fixture_t& fx = fixture();
        const mesh_t& m = fx.mesh;
        alloc_meter meter;
        meter.start();
        for (auto _ : st) {
            std::uint64_t acc = 0;
            for (index_t v : fx.vertices) acc += m.is_boundary_vertex(v) ? 1 : 0;
            benchmark::DoNotOptimize(acc);
        }
        meter.stop();
        const auto items =
            static_cast<double>(st.iterations()) * static_cast<double>(fx.vertices.size());
        st.SetItemsProcessed(static_cast<std::int64_t>(items));
        st.counters["allocs/op"] = static_cast<double>(meter.count()) / items;
    }

    // ---- memory ----------------------------------------------------------------------------

    static memory_figures memory_of(const mesh_t& m, std::size_t faces, std::size_t vertices) {
        std::size_t attr = 0;
        for (const auto& c : m.attributes().columns()) attr += c->count * c->stride;
        const auto conn = static_cast<double>(m.connectivity().memory_bytes());
        return {conn / static_cast<double>(faces), conn / static_cast<double>(vertices),
                static_cast<double>(attr) / static_cast<double>(faces)};
    }

    static void bm_memory(benchmark::State& st) {
        const fixture_t& fx = fixture();
        for (auto _ : st) benchmark::DoNotOptimize(fx.mesh.connectivity().memory_bytes());
        const auto mf = memory_of(fx.mesh, fx.n_faces, fx.n_vertices);
        st.counters["bytes/face"] = mf.connectivity_per_face;
        st.counters["bytes/vertex"] = mf.connectivity_per_vertex;
        st.counters["attr_bytes/face"] = mf.attributes_per_face;
    }
};

// ---- registration ----------------------------------------------------------------------

using indexed = core<idas::tri_mesh<idas::backend::indexed_tri>>;
using corner_table = core<idas::tri_mesh<idas::backend::corner_table_tri>>;

/// Registers `add(Core, backend name)` for each backend in turn, so the two rows of a
/// benchmark run next to each other (and see the same machine load).
template <class Add>
void for_each_backend(Add&& add) {
    add(indexed{}, "indexed");
    add(corner_table{}, "corner_table");
}

/// A benchmark's name is "<kind>/<what>[/<variant>]/<backend>".
std::string name_of(const std::string& what, const char* backend) {
    return what + "/" + backend;
}

template <class Core, class Op>
void register_edge_op(const std::string& name, const char* backend,
                      const std::vector<typename Core::tuple>& all,
                      const std::vector<typename Core::tuple>& set) {
    const auto add = [&](const char* suffix, auto fn) {
        benchmark::RegisterBenchmark(name_of("op/" + name + "/" + suffix, backend).c_str(),
                                     [fn, &all, &set](benchmark::State& st) { fn(st, all, set); });
    };
    add("commit", Core::template bm_edge_op<Op, mode::commit>);
    add("commit+no_normal_flip", Core::template bm_edge_op<Op, mode::commit_nnf>);
    add("rollback_after", Core::template bm_edge_op<Op, mode::rollback_after>);
    add("rollback_invariant", Core::template bm_edge_op<Op, mode::rollback_invariant>);
}

void register_all() {
    using benchmark::RegisterBenchmark;
    const auto us = benchmark::kMicrosecond;
    // Registers the same benchmark for both backends: reg("name", &Core::fn, args...).
    const auto both = [&](const char* what, auto select) {
        for_each_backend([&](auto c, const char* backend) {
            using C = decltype(c);
            select(C{}, name_of(what, backend));
        });
    };
    both("nav/switch_vertex", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_switch_vertex)->Unit(us);
    });
    both("nav/switch_edge", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_switch_edge)->Unit(us);
    });
    both("nav/switch_face/interior", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_switch_face, &C::fixture().interior_half_edges)
            ->Unit(us);
    });
    both("nav/switch_face/interior_random", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_switch_face, &C::fixture().interior_shuffled)->Unit(us);
    });
    both("nav/switch_face/mixed", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_switch_face, &C::fixture().half_edges)->Unit(us);
    });
    both("nav/vertex_circulation", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_vertex_circulation)->Unit(us);
    });
    both("nav/vertex_faces", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_vertex_faces)->Unit(us);
    });
    both("nav/is_boundary_vertex", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_is_boundary_vertex)->Unit(us);
    });
    both("nav/is_valid", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_is_valid)->Unit(us);
    });
    both("nav/eid", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_eid)->Unit(us);
    });
    both("nav/one_ring_vertices", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_one_ring)->Unit(us);
    });
    both("nav/for_each_edge", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_for_each_edge)->Unit(us);
    });

    for_each_backend([&]<class C>(C, const char* b) {
        const auto& fx = C::fixture();
        register_edge_op<C, typename C::split_op>("split_edge", b, fx.edges, fx.split_set);
    });
    for_each_backend([&]<class C>(C, const char* b) {
        const auto& fx = C::fixture();
        register_edge_op<C, typename C::collapse_op>("collapse_edge", b, fx.collapsible,
                                                     fx.collapse_set);
    });
    for_each_backend([&]<class C>(C, const char* b) {
        const auto& fx = C::fixture();
        register_edge_op<C, typename C::swap_op>("swap_edge", b, fx.swappable, fx.swap_set);
    });
    for_each_backend([&]<class C>(C, const char* b) {
        RegisterBenchmark(name_of("op/smooth_vertex/commit", b).c_str(),
                          C::template bm_smooth<mode::commit>);
        RegisterBenchmark(name_of("op/smooth_vertex/commit+no_normal_flip", b).c_str(),
                          C::template bm_smooth<mode::commit_nnf>);
        RegisterBenchmark(name_of("op/smooth_vertex/rollback_after", b).c_str(),
                          C::template bm_smooth<mode::rollback_after>);
        RegisterBenchmark(name_of("op/smooth_vertex/rollback_invariant", b).c_str(),
                          C::template bm_smooth<mode::rollback_invariant>);
    });
    both("op_in_mesh_order/split_edge/rollback_after", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_split_rollback_in_order);
    });
    both("op_in_mesh_order/smooth_vertex/commit", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_smooth_in_order);
    });
    both("pair/split+collapse_back", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_pair_split_collapse);
    });
    both("pair/swap+swap_back", [&]<class C>(C, const std::string& n) {
        RegisterBenchmark(n.c_str(), C::bm_pair_swap_back);
    });
    both("mem/connectivity",
         [&]<class C>(C, const std::string& n) { RegisterBenchmark(n.c_str(), C::bm_memory); });
}

} // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    try {
        const auto& fx = indexed::fixture();
        std::printf("bunny.obj: %zu vertices, %zu faces, %zu edges (%zu on the boundary)\n",
                    fx.n_vertices, fx.n_faces, fx.n_edges, fx.n_boundary_edges);
        std::printf("independent sets (ops per mesh copy): split %zu, collapse %zu, swap %zu, "
                    "split+collapse %zu\n",
                    fx.split_set.size(), fx.collapse_set.size(), fx.swap_set.size(),
                    fx.pair_set.size());
        for_each_backend([&]<class C>(C, const char* b) {
            const auto& f = C::fixture();
            const auto mf = C::memory_of(f.mesh, f.n_faces, f.n_vertices);
            std::printf("connectivity (%s): %.1f bytes/face, %.1f bytes/vertex; "
                        "attributes (position): %.1f bytes/face\n",
                        b, mf.connectivity_per_face, mf.connectivity_per_vertex,
                        mf.attributes_per_face);
        });
        std::printf("\n");
        std::fflush(stdout);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "cannot load the bunny: %s\n", e.what());
        return 1;
    }
    register_all();
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
