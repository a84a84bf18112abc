// fTetWild's pre-simplification of the input (Hu et al. 2020, section 3.1) as an IDAS
// spec: before tetrahedral meshing, collapse the soup's edges, shortest first, while the
// surface stays inside a slightly thinner envelope of the input. Every input triangle
// becomes tracked faces of the tet mesh and every tracked vertex a surface vertex the
// optimization must carry, so a scan's dense triangles cost time in every later stage
// (blub: 14,208 faces, of which the envelope lets 60% go).
//
//   I  link condition (the operation's), no normal flip, the envelope
//   D  priority: edge length, shortest first
//   A  the survivor keeps one endpoint's position (so it stays on the input); frozen
//      vertices (open borders and the cuts below) never move
//   S  every edge; after a success, the edges of the new star
//
// A soup is not a mesh: its non-manifold and inconsistently oriented edges are cut
// first (`cut_to_manifold`), each fan of faces around a vertex getting its own copy. The
// copies are frozen and keep their positions, and the caller welds them back by position
// afterwards.
#pragma once

#include <idas/algorithms/decimation_common.hpp>
#include <idas/exec/executor.hpp>
#include <idas/invariants/no_normal_flip.hpp>
#include <idas/mesh/temporary_attribute.hpp>
#include <idas/mesh/topology_report.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <optional>
#include <utility>
#include <vector>

namespace idas::algorithms {

/// A triangle soup cut into a consistently oriented 2-manifold with boundary: an edge
/// stays shared only where exactly two faces use it in opposite directions, and every
/// vertex gets one copy per fan of faces joined across such edges.
struct manifold_cut {
    std::vector<vec3> vertices;
    std::vector<tri_indices> faces;  ///< the soup's faces, in order, on the copies
    std::vector<std::uint8_t> split; ///< per copy: its soup vertex has other copies
    std::vector<index_t> origin;     ///< per copy: its soup vertex
};

inline manifold_cut cut_to_manifold(const std::vector<vec3>& V, const std::vector<tri_indices>& F) {
    // Half-edges sorted by their undirected edge; corner 3f + i is vertex F[f][i].
    struct half {
        index_t lo, hi, face;
        std::uint8_t from; // local index of the half-edge's first vertex
    };
    std::vector<half> h;
    h.reserve(3 * F.size());
    for (std::size_t f = 0; f < F.size(); ++f)
        for (std::uint8_t i = 0; i < 3; ++i) {
            const auto [lo, hi] = std::minmax(F[f][i], F[f][(i + 1) % 3]);
            h.push_back({lo, hi, index_t(f), i});
        }
    std::sort(h.begin(), h.end(), [](const half& x, const half& y) {
        return std::tie(x.lo, x.hi, x.face) < std::tie(y.lo, y.hi, y.face);
    });
    idas::detail::union_find corners(3 * F.size());
    for (std::size_t i = 0; i < h.size();) {
        std::size_t j = i + 1;
        while (j < h.size() && h[j].lo == h[i].lo && h[j].hi == h[i].hi) ++j;
        if (j - i == 2) {
            const half &x = h[i], &y = h[i + 1];
            const index_t x_from = F[x.face][x.from], y_from = F[y.face][y.from];
            if (x_from != y_from) { // opposite directions: the two faces agree
                // x runs a -> b, y runs b -> a: join a's corners and b's corners.
                const std::size_t xa = 3 * x.face + x.from, xb = 3 * x.face + (x.from + 1) % 3;
                const std::size_t ya = 3 * y.face + (y.from + 1) % 3, yb = 3 * y.face + y.from;
                corners.unite(index_t(xa), index_t(ya));
                corners.unite(index_t(xb), index_t(yb));
            }
        }
        i = j;
    }
    manifold_cut out;
    out.faces.resize(F.size());
    std::vector<index_t> copy_of(3 * F.size(), invalid_index), source;
    std::vector<std::uint32_t> copies(V.size(), 0);
    for (std::size_t c = 0; c < 3 * F.size(); ++c) {
        const index_t root = corners.find(index_t(c));
        const index_t v = F[c / 3][c % 3];
        if (copy_of[root] == invalid_index) {
            copy_of[root] = index_t(out.vertices.size());
            out.vertices.push_back(V[v]);
            source.push_back(v);
            ++copies[v];
        }
        out.faces[c / 3][c % 3] = copy_of[root];
    }
    out.split.resize(out.vertices.size());
    for (std::size_t i = 0; i < source.size(); ++i) out.split[i] = copies[source[i]] > 1;
    out.origin = std::move(source);
    return out;
}

/// An envelope whose filter proves containment of most triangles without exact
/// arithmetic (idas::envelope).
template <class E>
concept filtered_envelope = requires(const E& e, const vec3& p, typename E::filter_cache& c) {
    { e.fast_verdict(p, p, p, c) == E::verdict::inside } -> std::convertible_to<bool>;
};

/// Invariant: every new face is proven inside the envelope by its filter alone. What the
/// filter cannot decide is refused: the exact test of a large flat triangle costs
/// milliseconds (hour_glass: 3.5 s for 512 faces), and a simplification may miss a few
/// collapses.
template <filtered_envelope Envelope>
struct proven_in_envelope {
    const Envelope* envelope = nullptr;
    /// What the filter proves depends on where its cache's candidates and walks start, so
    /// a cache kept from operation to operation (faster: the last operation was nearby)
    /// makes a verdict depend on what ran before on the same thread. A deterministic run
    /// starts each operation with an empty cache.
    bool fresh_cache_per_operation = false;
    struct state {};
    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh& m, const Result& r, state&) const {
        if (fresh_cache_per_operation) {
            typename Envelope::filter_cache cache;
            return all_proven(m, r, cache);
        }
        thread_local typename Envelope::filter_cache cache;
        return all_proven(m, r, cache);
    }

private:
    template <class Mesh, class Result>
    bool all_proven(const Mesh& m, const Result& r, typename Envelope::filter_cache& cache) const {
        for (const auto& t : r.cells) {
            const auto& fv = m.face_vertices(t.fid);
            if (envelope->fast_verdict(m.position(fv[0]), m.position(fv[1]), m.position(fv[2]),
                                       cache) != Envelope::verdict::inside)
                return false;
        }
        return true;
    }
};

/// Shortest-edge collapse inside an envelope of the input.
template <filtered_envelope Envelope>
struct soup_simplification_spec {
    using operations = op_list<op::collapse_edge>;
    const Envelope* envelope = nullptr;
    vertex_attribute<std::uint8_t> frozen; ///< on a border of the cut: never moves
    vertex_attribute<index_t> origin;      ///< the soup vertex a copy stands for
    bool deterministic = false;            ///< verdicts independent of the thread's history

    auto invariants() const {
        return invariant_set<no_normal_flip, proven_in_envelope<Envelope>>(
            no_normal_flip{}, proven_in_envelope<Envelope>{envelope, deterministic});
    }

    /// A push that drops edges with both ends frozen (nothing could collapse them).
    template <class Mesh, class Push>
    auto movable_only(const Mesh& m, Push& push) const {
        return [&m, &push, this](op::collapse_edge o, const typename Mesh::tuple& t) {
            const auto [a, b] = m.edge_vertices(t);
            const auto fr = m.attribute(frozen);
            if (!(fr[a] && fr[b])) push(o, t);
        };
    }
    template <class Mesh, class Push>
    void initial(const Mesh& m, Push& push) const {
        auto filtered = movable_only(m, push);
        push_all_edges<op::collapse_edge>(m, filtered);
    }
    template <class Mesh>
    double priority(op::collapse_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return squared_norm(m.position(a) - m.position(b));
    }

    /// The endpoint the survivor stands for: the frozen one if there is one.
    struct cache {
        vec3 position;
        std::uint8_t frozen;
        index_t origin;
    };
    template <class Mesh>
    std::optional<cache> before(op::collapse_edge, const Mesh& m,
                                const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const auto fr = m.attribute(frozen);
        if (fr[a] && fr[b]) return std::nullopt;
        const index_t kept = fr[b] ? b : a;
        return cache{m.position(kept), std::uint8_t(fr[a] | fr[b]), m.attribute(origin)[kept]};
    }
    template <class Mesh>
    bool after(op::collapse_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const cache& c) const {
        // The survivor is the tuple's vertex a; when b was the frozen end, a takes b's
        // place, the soup vertex it stands for included.
        m.positions(r).set(r.anchor.vid, c.position);
        m.attribute(frozen, r).set(r.anchor.vid, c.frozen);
        m.attribute(origin, r).set(r.anchor.vid, c.origin);
        // Once the copies are welded back, a new face must not repeat a face: one of
        // another sheet on three cut vertices, or one of this sheet through another copy
        // of a cut vertex. Only a face with a frozen corner can (the other vertices have
        // one copy each), but the survivor need not be that corner: collapsing an inner
        // edge next to a cut made 7 of 37989_sf's faces repeat others, which opened 6
        // edges once the repeats were dropped.
        const auto fr = m.attribute(frozen);
        const auto src = m.attribute(origin);
        auto welded = [&](index_t f) {
            const auto& fv = m.face_vertices(f);
            std::array<index_t, 3> k{src[fv[0]], src[fv[1]], src[fv[2]]};
            std::sort(k.begin(), k.end());
            return k;
        };
        for (const auto& t : r.cells) {
            const auto& fv = m.face_vertices(t.fid);
            const int frozen_corners = fr[fv[0]] + fr[fv[1]] + fr[fv[2]];
            if (frozen_corners == 0) continue;
            if (frozen_corners == 3) return false;
            const auto k = welded(t.fid);
            for (index_t x : fv)
                for (index_t g : m.vertex_faces(x))
                    if (g != t.fid && welded(g) == k) return false;
        }
        return true;
    }
    template <class Mesh, class Push>
    void renew(op::collapse_edge, const Mesh& m, const op_result<typename Mesh::tuple>& r,
               Push& push) const {
        auto filtered = movable_only(m, push);
        push_star_edges<op::collapse_edge>(m, r, filtered);
    }
};

/// The soup, simplified inside `envelope`; its cut copies are welded back by the caller.
/// Returns the soup unchanged if its cut is not an editable mesh. `Lock`: the executor's
/// lock policy (lock::deterministic_rounds for the same result at any thread count).
template <class Lock = lock::vertex_try_lock, filtered_envelope Envelope>
std::pair<std::vector<vec3>, std::vector<tri_indices>>
simplify_soup(const std::vector<vec3>& V, const std::vector<tri_indices>& F,
              const Envelope& envelope, const exec_options& exec) {
    manifold_cut cut = cut_to_manifold(V, F);
    if (!diagnose_topology(cut.vertices.size(), cut.faces).editable()) return {V, F};
    tri_mesh<> m(cut.vertices, cut.faces);
    const temporary_attribute frozen(m, m.template add_vertex_attribute<std::uint8_t>("frozen", 0));
    const temporary_attribute origin(
        m, m.template add_vertex_attribute<index_t>("origin", invalid_index));
    {
        auto src = m.attribute(origin.handle);
        for (std::size_t v = 0; v < cut.origin.size(); ++v) src.raw(index_t(v)) = cut.origin[v];
        auto fr = m.attribute(frozen.handle);
        // Borders stay, and so do the copies of a cut vertex (a fan closed around a
        // non-manifold vertex has no border), so that they weld back.
        m.for_each_vertex([&](const tri_mesh<>::tuple& t) {
            if (m.is_boundary_vertex(t.vid) || cut.split[t.vid]) fr.raw(t.vid) = 1;
        });
    }
    soup_simplification_spec<Envelope> spec{&envelope, frozen.handle, origin.handle,
                                            deterministic_policy<Lock>};
    executor<soup_simplification_spec<Envelope>, tri_mesh<>, Lock, queue::dary_heap<4>>::run(
        m, spec, exec);
    return m.to_arrays();
}

} // namespace idas::algorithms
