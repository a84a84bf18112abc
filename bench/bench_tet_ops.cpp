// Benchmarks of the tetrahedral core: ns per local operation (committed, and rolled back
// because the spec's after() refuses) on a jittered subdivided cube, and the memory the
// indexed_tet backend needs per tet. orient3d (filtered and exact paths) is measured by
// bench_predicates; see bench/RESULTS.md.
//
// Method
// ------
// * Mesh: the unit cube cut into 24^3 cells of 6 tets each (82,944 tets, 15,625 vertices),
//   interior vertices jittered by up to 0.15 cell sizes (seed 1). For edge_swap_32 the
//   mesh first gets an independent set of 2-3 swaps, which creates the valence-3 edges a
//   3-2 swap needs (the plain cube has none).
// * Spec (the same for every operation): midpoint split, collapse to the midpoint (or to
//   the boundary endpoint), Laplacian smoothing (vertex to its one-ring centroid), and the
//   positive_orientation invariant (exact orient3d on every new tet). No attributes.
// * An "independent set" per operation: candidates (every edge, interior face or vertex)
//   are visited in a fixed random order and one is kept if the vertices of the tets
//   around its key vertices (edge: both ends; face: its three corners; vertex: itself) are
//   disjoint from those of every kept candidate, and the operation succeeds on a working
//   copy. Kept operations neither read nor write anything another one touches, so on any
//   fresh copy of the mesh each of them is valid and succeeds (the "ok" counter checks it).
// * commit: one iteration is one operation. The pristine mesh is copied with timing paused
//   (capacity reserved, so slot growth does not reallocate), then the set is applied in
//   order; when it is used up the mesh is copied again.
// * rollback: the spec's after() returns false, so the whole operation runs (connectivity
//   change, after(), no invariant) and its journal is rolled back. The mesh is left
//   unchanged (checked after the loop with idas::identical, "unchanged" counter), so this
//   cycles in place over the same set.
// * mem/indexed_tet: backend memory_bytes() / tets, and position bytes per tet.
// * pair/*: a 2-3 swap of an interior face immediately undone by a 3-2 swap of the new
//   edge (the only flips idas and CGAL both have), in place, over the face_swap_23 set
//   (idas) or over an independent set of flippable facets of CGAL's Delaunay
//   triangulation of the same points (CGAL::Triangulation_3::flip(Cell_handle, int) then
//   flip(Edge); Epick kernel; compiled only when CGAL is found). Both check orientations
//   exactly (filtered) and that the new edge does not exist yet; idas also checks the
//   3-2's face and runs its journal and invariant protocol. time/op is per flip.
// * commit/split_edge/cgal: CGAL::Triangulation_3::insert_in_edge at the edge midpoint
//   (the Delaunay triangulation's base class, so no Delaunay repair), over an independent
//   set of finite edges of the same triangulation (vertex-disjoint neighbourhoods, so every
//   edge handle stays valid while the others are split), on a fresh copy per pass with
//   container capacity reserved, as for idas' commit rows. CGAL only rewires cells here; idas'
//   split also checks orientations exactly and journals. No other CGAL 5.5 Triangulation_3
//   operation matches an idas one: it has no 4-4 flip, no n-to-(2n-4) edge removal, no edge
//   collapse and no smoothing (those live inside Tetrahedral_remeshing, not as public triangulation
//   operations).
// * mem/cgal: bytes per finite tet of CGAL's triangulation data structure: capacity of the
//   cell and vertex containers times sizeof(Cell) and sizeof(Vertex) (the vertex holds
//   its point), divided by the finite cells (infinite cells are CGAL's own overhead).
#include <idas/invariants/positive_orientation.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/ops/tet_ops.hpp>

#include <benchmark/benchmark.h>
#include <boost/container/small_vector.hpp>

#if IDAS_BENCH_WITH_CGAL
#include <idas/algorithms/harmonic_triangulation.hpp>
#include <idas/cgal/delaunay.hpp>
#include <idas/io/points.hpp>

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cstdlib>
#include <iterator>
#include <map>
#include <set>
#endif

#include <algorithm>
#include <cstddef>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace {

using namespace idas;
using indexed_mesh = tet_mesh<backend::indexed_tet>;
using adjacency_mesh = tet_mesh<backend::adjacency_tet>;

constexpr int cube_cells = 24;
constexpr double cube_jitter = 0.15;

/// The jittered Kuhn cube (6 tets per cell around the cell's main diagonal).
template <class Mesh>
Mesh make_cube(int n, double jitter, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> shake(-jitter, jitter);
    const double h = 1.0 / n;
    auto id = [&](int i, int j, int k) { return index_t((k * (n + 1) + j) * (n + 1) + i); };
    std::vector<vec3> V;
    for (int k = 0; k <= n; ++k)
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) {
                vec3 p{i * h, j * h, k * h};
                if (i > 0 && j > 0 && k > 0 && i < n && j < n && k < n)
                    p += vec3{shake(rng), shake(rng), shake(rng)} * h;
                V.push_back(p);
            }
    std::vector<tet_indices> T;
    const int axes[6][2] = {{1, 2}, {1, 4}, {2, 1}, {2, 4}, {4, 1}, {4, 2}};
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                auto c = [&](int bits) {
                    return id(i + (bits & 1), j + (bits >> 1 & 1), k + (bits >> 2 & 1));
                };
                for (const auto& ax : axes) {
                    tet_indices t{c(0), c(ax[0]), c(ax[0] | ax[1]), c(7)};
                    if (orient3d(V[t[0]], V[t[1]], V[t[2]], V[t[3]]) < 0) std::swap(t[2], t[3]);
                    T.push_back(t);
                }
            }
    return {V, T};
}

struct bench_spec {
    bool fail = false;

    template <class Mesh>
    std::optional<vec3> before(op::split_edge, const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Mesh>
    std::optional<vec3> before(op::collapse_edge, const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const bool ba = m.is_boundary_vertex(a), bb = m.is_boundary_vertex(b);
        if (ba != bb) return ba ? m.position(a) : m.position(b);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Op, class Mesh>
    requires(std::is_same_v<Op, op::split_edge> ||
             std::is_same_v<Op, op::collapse_edge>) bool after(Op, Mesh& m,
                                                               const op_result<tet_tuple>& r,
                                                               vec3& p) const {
        m.positions(r).set(r.anchor.vid, p);
        return !fail;
    }
    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<tet_tuple>& r) const {
        boost::container::small_vector<index_t, 64> ring;
        m.one_ring_vertices(r.anchor.vid, ring);
        vec3 c{};
        for (index_t w : ring) c += m.position(w);
        m.positions(r).set(r.anchor.vid, c / double(ring.size()));
        return !fail;
    }
    template <class Op, class Mesh>
    requires(std::is_same_v<Op, op::face_swap_23> || std::is_same_v<Op, op::edge_swap_32> ||
             std::is_same_v<Op, op::edge_swap_44> ||
             std::is_same_v<Op, op::edge_removal>) bool after(Op, Mesh&,
                                                              const op_result<tet_tuple>&) const {
        return !fail;
    }
    auto invariants() const { return invariant_set<positive_orientation>{}; }
};

enum class kind { split, collapse, smooth, swap23, swap32, swap44, removal };
constexpr const char* kind_names[] = {"split_edge",   "collapse_edge", "smooth_vertex",
                                      "face_swap_23", "edge_swap_32",  "edge_swap_44",
                                      "edge_removal"};

template <class Mesh>
bool run_op(kind k, Mesh& m, const tet_tuple& t, bench_spec& s) {
    switch (k) {
    case kind::split:
        return split_edge(m, t, s).has_value();
    case kind::collapse:
        return collapse_edge(m, t, s).has_value();
    case kind::smooth:
        return smooth_vertex(m, t, s).has_value();
    case kind::swap23:
        return face_swap_23(m, t, s).has_value();
    case kind::swap32:
        return edge_swap_32(m, t, s).has_value();
    case kind::swap44:
        return edge_swap_44(m, t, s).has_value();
    case kind::removal:
        return edge_removal(m, t, s).has_value();
    }
    return false;
}

/// The vertices whose incidences or positions the operation on t may read or write.
template <class Mesh>
void neighbourhood(const Mesh& m, kind k, const tet_tuple& t, std::vector<index_t>& out) {
    out.clear();
    boost::container::small_vector<index_t, 3> keys;
    if (k == kind::smooth) {
        keys.push_back(t.vid);
    } else if (k == kind::swap23) {
        for (index_t v : m.face_vertices(t)) keys.push_back(v);
    } else {
        const auto [a, b] = m.edge_vertices(t);
        keys.push_back(a), keys.push_back(b);
    }
    for (index_t v : keys)
        for (index_t g : m.vertex_tets(v))
            for (index_t x : m.tet_vertices(g)) out.push_back(x);
}

template <class Mesh>
struct prepared {
    Mesh base;
    std::vector<tet_tuple> set;
    index_t reserve_vertices = 0, reserve_tets = 0;
    double mean_ring = 0; // edge ops: mean number of tets around the edge
};

template <class Mesh>
prepared<Mesh> independent_set(const Mesh& base, kind k) {
    prepared<Mesh> p{base, {}, 0, 0, 0};
    std::vector<tet_tuple> cands;
    if (k == kind::smooth)
        cands = base.get_vertices();
    else if (k == kind::swap23)
        for (const auto& f : base.get_faces()) {
            if (!base.is_boundary_face(f)) cands.push_back(f);
        }
    else
        cands = base.get_edges();
    std::mt19937 rng(42);
    std::shuffle(cands.begin(), cands.end(), rng);
    Mesh work = base;
    std::vector<char> used(base.vertex_slots(), 0);
    std::vector<index_t> hood;
    bench_spec spec;
    std::size_t ring_sum = 0;
    std::vector<index_t> ring;
    for (const auto& c : cands) {
        neighbourhood(base, k, c, hood);
        if (std::any_of(hood.begin(), hood.end(), [&](index_t v) { return used[v] != 0; }))
            continue;
        ring.clear();
        if (k != kind::smooth && k != kind::swap23) base.edge_tets(c, ring);
        if (!run_op(k, work, c, spec)) continue;
        for (index_t v : hood) used[v] = 1;
        p.set.push_back(c);
        ring_sum += ring.size();
    }
    if (!p.set.empty()) p.mean_ring = double(ring_sum) / double(p.set.size());
    p.reserve_vertices = base.vertex_slots() + index_t(p.set.size());
    p.reserve_tets = base.tet_slots() + index_t(max_edge_ring * p.set.size());
    return p;
}

template <class Mesh = indexed_mesh>
const Mesh& cube_mesh() {
    static const Mesh m = make_cube<Mesh>(cube_cells, cube_jitter, 1);
    return m;
}

template <class Mesh>
const prepared<Mesh>& fixture(kind k) {
    static std::optional<prepared<Mesh>> cache[7];
    auto& slot = cache[int(k)];
    if (!slot) {
        if (k == kind::swap32) {
            // Apply an independent set of 2-3 swaps: each leaves a valence-3 edge.
            const prepared<Mesh>& p23 = fixture<Mesh>(kind::swap23);
            Mesh m = p23.base;
            bench_spec spec;
            for (const auto& t : p23.set) run_op(kind::swap23, m, t, spec);
            slot = independent_set(m, k);
        } else {
            slot = independent_set(cube_mesh<Mesh>(), k);
        }
    }
    return *slot;
}

template <class Mesh>
void bm_commit(benchmark::State& st, kind k) {
    const prepared<Mesh>& p = fixture<Mesh>(k);
    if (p.set.empty()) {
        st.SkipWithError("no candidate");
        return;
    }
    Mesh m;
    bench_spec spec;
    std::size_t i = p.set.size(), ok = 0, ops = 0, copies = 0;
    for (auto _ : st) {
        if (i == p.set.size()) {
            st.PauseTiming();
            m = p.base;
            m.reserve(p.reserve_vertices, p.reserve_tets);
            i = 0;
            ++copies;
            st.ResumeTiming();
        }
        ok += run_op(k, m, p.set[i++], spec);
        ++ops;
    }
    st.counters["ok"] = double(ok) / double(ops);
    st.counters["set"] = double(p.set.size());
    if (p.mean_ring > 0) st.counters["ring"] = p.mean_ring;
}

template <class Mesh>
void bm_rollback(benchmark::State& st, kind k) {
    const prepared<Mesh>& p = fixture<Mesh>(k);
    if (p.set.empty()) {
        st.SkipWithError("no candidate");
        return;
    }
    Mesh m = p.base;
    m.reserve(p.reserve_vertices, p.reserve_tets);
    bench_spec spec;
    spec.fail = true;
    for (const auto& t : p.set) run_op(k, m, t, spec); // warm the buffers
    std::size_t i = 0, refused = 0, ops = 0;
    for (auto _ : st) {
        refused += !run_op(k, m, p.set[i], spec);
        if (++i == p.set.size()) i = 0;
        ++ops;
    }
    st.counters["refused"] = double(refused) / double(ops);
    st.counters["unchanged"] = identical(m, p.base) ? 1 : 0;
}

template <class Mesh>
void bm_pair_idas(benchmark::State& st) {
    const prepared<Mesh>& p = fixture<Mesh>(kind::swap23);
    Mesh m = p.base;
    bench_spec spec;
    std::vector<tet_tuple> faces = p.set;
    std::size_t i = 0, ok = 0, ops = 0;
    for (auto _ : st) {
        const auto r23 = face_swap_23(m, faces[i], spec);
        bool good = false;
        if (r23) {
            const index_t e = m.edge_vertices(r23->anchor).second; // the new edge de
            const auto r32 = edge_swap_32(m, r23->anchor, spec);
            if (r32) {
                const index_t g = r32->anchor.tid;
                faces[i] = m.tuple_from_face(g, tet_local::index_of(m.tet_vertices(g), e));
                good = true;
            }
        }
        ok += good;
        if (++i == faces.size()) i = 0;
        ++ops;
    }
    st.counters["ok"] = double(ok) / double(ops);
    st.counters["set"] = double(faces.size());
    st.counters["time/op"] = benchmark::Counter(double(2 * ops), benchmark::Counter::kIsRate |
                                                                     benchmark::Counter::kInvert);
}

#if IDAS_BENCH_WITH_CGAL
using cgal_kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using cgal_dt = CGAL::Delaunay_triangulation_3<cgal_kernel>;
using cgal_tr = cgal_dt::Tr_Base; // its Triangulation_3 base, where flip() lives

const cgal_dt& cgal_cube() {
    static const cgal_dt dt = [] {
        const auto& m = cube_mesh();
        std::vector<cgal_kernel::Point_3> pts;
        for (index_t v = 0; v < m.vertex_slots(); ++v) {
            const vec3& q = m.position(v);
            pts.emplace_back(q[0], q[1], q[2]);
        }
        return cgal_dt(pts.begin(), pts.end());
    }();
    return dt;
}

void bm_pair_cgal(benchmark::State& st) {
    static cgal_dt dt = cgal_cube(); // a copy: the flips below edit it in place
    cgal_tr& tr = dt;
    using vh = cgal_dt::Vertex_handle;
    struct cand {
        vh u, v; // the flipped facet is opposite u in u->cell(), v across it
    };
    static std::vector<cand> set = [&] {
        std::vector<cgal_dt::Facet> facets(dt.finite_facets_begin(), dt.finite_facets_end());
        std::mt19937 rng(42);
        std::shuffle(facets.begin(), facets.end(), rng);
        std::vector<cand> out;
        std::set<vh> used;
        std::vector<cgal_dt::Cell_handle> cells;
        std::vector<vh> hood;
        for (auto [c, i] : facets) {
            hood.clear();
            for (int k = 1; k < 4; ++k) {
                cells.clear();
                dt.incident_cells(c->vertex((i + k) & 3), std::back_inserter(cells));
                for (auto cc : cells)
                    for (int j = 0; j < 4; ++j) hood.push_back(cc->vertex(j));
            }
            if (std::any_of(hood.begin(), hood.end(),
                            [&](vh x) { return dt.is_infinite(x) || used.count(x); }))
                continue;
            const vh u = c->vertex(i), v = dt.mirror_vertex(c, i);
            if (!tr.flip(c, i)) continue;
            // c now holds u and v (CGAL reuses it); undo with the 3-2 flip of uv.
            if (!tr.flip(cgal_dt::Edge(c, c->index(u), c->index(v)))) std::abort();
            for (vh x : hood) used.insert(x);
            out.push_back({u, v});
        }
        return out;
    }();
    std::size_t i = 0, ok = 0, ops = 0;
    for (auto _ : st) {
        const cand& k = set[i];
        auto c = k.u->cell();
        bool good = false;
        if (tr.flip(c, c->index(k.u)))
            good = tr.flip(cgal_dt::Edge(c, c->index(k.u), c->index(k.v)));
        ok += good;
        if (++i == set.size()) i = 0;
        ++ops;
    }
    st.counters["ok"] = double(ok) / double(ops);
    st.counters["set"] = double(set.size());
    st.counters["tets"] = double(dt.number_of_finite_cells());
    st.counters["time/op"] = benchmark::Counter(double(2 * ops), benchmark::Counter::kIsRate |
                                                                     benchmark::Counter::kInvert);
}

void bm_split_cgal(benchmark::State& st) {
    const cgal_dt& base = cgal_cube();
    using vh = cgal_dt::Vertex_handle;
    using point = cgal_kernel::Point_3;
    // The set as point pairs, found again by coordinates in every fresh copy.
    static const std::vector<std::pair<point, point>> set = [&] {
        std::vector<cgal_dt::Edge> edges(base.finite_edges_begin(), base.finite_edges_end());
        std::mt19937 rng(42);
        std::shuffle(edges.begin(), edges.end(), rng);
        std::vector<std::pair<point, point>> out;
        std::set<vh> used;
        std::vector<cgal_dt::Cell_handle> cells;
        std::vector<vh> hood;
        for (const cgal_dt::Edge& e : edges) {
            const auto c = e.first;
            const int i = e.second, j = e.third;
            hood.clear();
            for (int end : {i, j}) {
                cells.clear();
                base.incident_cells(c->vertex(end), std::back_inserter(cells));
                for (auto cc : cells)
                    for (int k = 0; k < 4; ++k) hood.push_back(cc->vertex(k));
            }
            if (std::any_of(hood.begin(), hood.end(),
                            [&](vh x) { return base.is_infinite(x) || used.count(x); }))
                continue;
            for (vh x : hood) used.insert(x);
            out.emplace_back(c->vertex(i)->point(), c->vertex(j)->point());
        }
        return out;
    }();
    cgal_dt dt;
    std::vector<cgal_dt::Edge> todo;
    std::size_t i = set.size(), ok = 0, ops = 0, ring_sum = 0;
    for (auto _ : st) {
        if (i == set.size()) {
            st.PauseTiming();
            dt = base;
            // Capacity for the whole pass, as idas' commit rows reserve() theirs: a split
            // replaces the ring's cells by twice as many and adds one vertex.
            auto& cells = dt.tds().cells();
            cells.reserve(cells.size() + 16 * set.size());
            dt.tds().vertices().reserve(dt.tds().vertices().size() + set.size());
            std::map<point, vh> by_point;
            for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v)
                by_point.emplace(v->point(), v);
            todo.clear();
            ring_sum = 0;
            for (const auto& [p, q] : set) {
                cgal_dt::Cell_handle c;
                int a = 0, b = 0;
                if (!dt.is_edge(by_point.at(p), by_point.at(q), c, a, b)) std::abort();
                todo.emplace_back(c, a, b);
                auto circ = dt.incident_cells(todo.back()), done = circ;
                do ++ring_sum;
                while (++circ != done);
            }
            i = 0;
            st.ResumeTiming();
        }
        const cgal_dt::Edge& e = todo[i++];
        const auto c = e.first;
        const point mid = CGAL::midpoint(c->vertex(e.second)->point(), c->vertex(e.third)->point());
        const vh v = static_cast<cgal_tr&>(dt).insert_in_edge(mid, c, e.second, e.third);
        ok += v != vh();
        ++ops;
    }
    st.counters["ok"] = double(ok) / double(ops);
    st.counters["set"] = double(set.size());
    st.counters["ring"] = double(ring_sum) / double(set.size());
}

void bm_memory_cgal(benchmark::State& st) {
    const cgal_dt& dt = cgal_cube();
    std::size_t bytes = 0;
    for (auto _ : st) {
        bytes = dt.tds().cells().capacity() * sizeof(cgal_dt::Cell) +
                dt.tds().vertices().capacity() * sizeof(cgal_dt::Vertex);
        benchmark::DoNotOptimize(bytes);
    }
    const double tets = double(dt.number_of_finite_cells());
    st.counters["tets"] = tets;
    st.counters["vertices"] = double(dt.number_of_vertices());
    st.counters["bytes/tet"] = double(bytes) / tets;
    st.counters["sizeof_cell"] = double(sizeof(cgal_dt::Cell));
    st.counters["sizeof_vertex"] = double(sizeof(cgal_dt::Vertex));
    st.counters["cells/tet"] = double(dt.number_of_cells()) / tets;
}
#endif

template <class Mesh>
void bm_memory(benchmark::State& st) {
    const Mesh& m = cube_mesh<Mesh>();
    std::size_t bytes = 0;
    for (auto _ : st) {
        bytes = m.connectivity().memory_bytes();
        benchmark::DoNotOptimize(bytes);
    }
    const double tets = double(m.n_tets());
    st.counters["tets"] = tets;
    st.counters["vertices"] = double(m.n_vertices());
    st.counters["bytes/tet"] = double(bytes) / tets;
    st.counters["position_bytes/tet"] = double(m.vertex_slots() * sizeof(vec3)) / tets;
}

// ---- navigation: the same queries on both backends, over the whole cube ----

/// One tuple per (tet, local face), in slot order.
template <class Mesh>
const std::vector<tet_tuple>& face_tuples() {
    static const std::vector<tet_tuple> out = [] {
        const Mesh& m = cube_mesh<Mesh>();
        std::vector<tet_tuple> v;
        for (index_t t = 0; t < m.tet_slots(); ++t)
            for (std::uint8_t lf = 0; lf < 4; ++lf) v.push_back(m.tuple_from_face(t, lf));
        return v;
    }();
    return out;
}

/// switch_vertex, switch_edge, switch_face: local to the tet on both backends.
template <class Mesh>
void bm_nav_local(benchmark::State& st) {
    const Mesh& m = cube_mesh<Mesh>();
    const auto& tuples = face_tuples<Mesh>();
    std::size_t i = 0;
    for (auto _ : st) {
        const auto u = m.switch_face(m.switch_edge(m.switch_vertex(tuples[i])));
        benchmark::DoNotOptimize(u);
        if (++i == tuples.size()) i = 0;
    }
    st.counters["time/switch"] = benchmark::Counter(
        3 * double(st.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

/// switch_tetrahedron over every (tet, face): a star search (indexed) or one load
/// (adjacency).
template <class Mesh>
void bm_nav_switch_tetrahedron(benchmark::State& st) {
    const Mesh& m = cube_mesh<Mesh>();
    const auto& tuples = face_tuples<Mesh>();
    std::size_t i = 0, across = 0;
    for (auto _ : st) {
        const auto g = m.switch_tetrahedron(tuples[i]);
        across += g.has_value();
        benchmark::DoNotOptimize(g);
        if (++i == tuples.size()) i = 0;
    }
    st.counters["interior"] = double(across) / double(st.iterations());
}

/// Every tet of a vertex's star, over all vertices: a stored list (indexed) or a walk
/// from the anchor (adjacency). Time per vertex; "tets/vertex" is the mean star.
template <class Mesh>
void bm_nav_vertex_star(benchmark::State& st) {
    const Mesh& m = cube_mesh<Mesh>();
    index_t v = 0;
    std::size_t visited = 0;
    for (auto _ : st) {
        index_t sum = 0;
        for (index_t g : m.vertex_tets(v)) sum += g, ++visited;
        benchmark::DoNotOptimize(sum);
        if (++v == m.vertex_slots()) v = 0;
    }
    st.counters["tets/vertex"] = double(visited) / double(st.iterations());
    st.counters["time/tet"] = benchmark::Counter(double(visited), benchmark::Counter::kIsRate |
                                                                      benchmark::Counter::kInvert);
}

/// The tets around an edge (edge_tets), over one tuple per (tet, local edge).
template <class Mesh>
void bm_nav_edge_tets(benchmark::State& st) {
    const Mesh& m = cube_mesh<Mesh>();
    std::size_t i = 0, n = 0;
    boost::container::small_vector<index_t, 32> around;
    for (auto _ : st) {
        around.clear();
        m.edge_tets(m.tuple_from_edge(index_t(i / 6), std::uint8_t(i % 6)), around);
        n += around.size();
        benchmark::DoNotOptimize(around.data());
        if (++i == 6 * std::size_t(m.tet_slots())) i = 0;
    }
    st.counters["tets/edge"] = double(n) / double(st.iterations());
}

/// Edge and face ids (what edge and face attributes are indexed by).
template <class Mesh>
void bm_nav_ids(benchmark::State& st) {
    const Mesh& m = cube_mesh<Mesh>();
    const auto& tuples = face_tuples<Mesh>();
    std::size_t i = 0;
    for (auto _ : st) {
        benchmark::DoNotOptimize(m.eid(tuples[i]) + m.fid(tuples[i]));
        if (++i == tuples.size()) i = 0;
    }
}

#if IDAS_BENCH_WITH_CGAL
/// Serial reduced-mode harmonic triangulation (3-2 swaps) of the Delaunay tetrahedrization
/// of data/gaussian_points_100k.ply; the Delaunay mesh is built outside the timed region.
template <class Mesh>
void bm_harmonic_reduced(benchmark::State& st) {
    static const auto dt = cgal::delaunay_tetrahedralization(
        io::read_points(std::string(IDAS_DATA_DIR) + "/gaussian_points_100k.ply"));
    algorithms::harmonic_options o;
    o.mode = algorithms::harmonic_mode::reduced;
    o.exec.threads = 1;
    std::size_t flips = 0, tets = 0;
    double index = 0;
    for (auto _ : st) {
        st.PauseTiming();
        Mesh m(dt.vertices, dt.tets);
        st.ResumeTiming();
        flips = algorithms::harmonic_triangulation<Mesh>::run(m, o).flips;
        st.PauseTiming();
        tets = m.n_tets();
        index = algorithms::harmonic_statistics(m).mean_index;
        st.ResumeTiming();
    }
    st.counters["tets_before"] = double(dt.tets.size());
    st.counters["tets_after"] = double(tets);
    st.counters["flips"] = double(flips);
    st.counters["mean_index"] = index;
}
#endif

} // namespace

int main(int argc, char** argv) {
    // Rows without a backend suffix are indexed_tet (the default backend), as before;
    // "/adjacency" rows run the same on adjacency_tet.
    for (int k = 0; k < 7; ++k) {
        const std::string name = kind_names[k];
        benchmark::RegisterBenchmark(("commit/" + name).c_str(), bm_commit<indexed_mesh>, kind(k));
        benchmark::RegisterBenchmark(("commit/" + name + "/adjacency").c_str(),
                                     bm_commit<adjacency_mesh>, kind(k));
        benchmark::RegisterBenchmark(("rollback/" + name).c_str(), bm_rollback<indexed_mesh>,
                                     kind(k));
        benchmark::RegisterBenchmark(("rollback/" + name + "/adjacency").c_str(),
                                     bm_rollback<adjacency_mesh>, kind(k));
    }
    benchmark::RegisterBenchmark("pair/face_swap_23+edge_swap_32/idas", bm_pair_idas<indexed_mesh>);
    benchmark::RegisterBenchmark("pair/face_swap_23+edge_swap_32/idas/adjacency",
                                 bm_pair_idas<adjacency_mesh>);
    benchmark::RegisterBenchmark("nav/switch_vertex+edge+face", bm_nav_local<indexed_mesh>);
    benchmark::RegisterBenchmark("nav/switch_vertex+edge+face/adjacency",
                                 bm_nav_local<adjacency_mesh>);
    benchmark::RegisterBenchmark("nav/switch_tetrahedron", bm_nav_switch_tetrahedron<indexed_mesh>);
    benchmark::RegisterBenchmark("nav/switch_tetrahedron/adjacency",
                                 bm_nav_switch_tetrahedron<adjacency_mesh>);
    benchmark::RegisterBenchmark("nav/vertex_star", bm_nav_vertex_star<indexed_mesh>);
    benchmark::RegisterBenchmark("nav/vertex_star/adjacency", bm_nav_vertex_star<adjacency_mesh>);
    benchmark::RegisterBenchmark("nav/edge_tets", bm_nav_edge_tets<indexed_mesh>);
    benchmark::RegisterBenchmark("nav/edge_tets/adjacency", bm_nav_edge_tets<adjacency_mesh>);
    benchmark::RegisterBenchmark("nav/eid+fid", bm_nav_ids<indexed_mesh>);
    benchmark::RegisterBenchmark("nav/eid+fid/adjacency", bm_nav_ids<adjacency_mesh>);
#if IDAS_BENCH_WITH_CGAL
    benchmark::RegisterBenchmark("harmonic/reduced_100k", bm_harmonic_reduced<indexed_mesh>)
        ->Unit(benchmark::kMillisecond)
        ->Iterations(3);
    benchmark::RegisterBenchmark("harmonic/reduced_100k/adjacency",
                                 bm_harmonic_reduced<adjacency_mesh>)
        ->Unit(benchmark::kMillisecond)
        ->Iterations(3);
#endif
#if IDAS_BENCH_WITH_CGAL
    benchmark::RegisterBenchmark("pair/flip23+flip32/cgal", bm_pair_cgal);
    benchmark::RegisterBenchmark("commit/split_edge/cgal", bm_split_cgal);
    benchmark::RegisterBenchmark("mem/cgal", bm_memory_cgal);
#endif
    benchmark::RegisterBenchmark("mem/indexed_tet", bm_memory<indexed_mesh>);
    benchmark::RegisterBenchmark("mem/adjacency_tet", bm_memory<adjacency_mesh>);
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
