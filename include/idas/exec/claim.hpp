// The region an operation claims before it runs in parallel: which vertices, in which
// order, and how a stale tuple is recognised under the claim. How a vertex is taken (a
// lock word, a read of the part map) is the lock policy's business: `take(v)` says.
#pragma once

#include <idas/exec/contract.hpp>
#include <idas/mesh/cells.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>

#include <cstddef>
#include <type_traits>
#include <utility>

namespace idas {

enum class claim_result { ok, busy, stale };

/// The vertices a worker holds, released together.
using held_vertices = boost::container::small_vector<index_t, 64>;

namespace detail {
/// The vertices of the simplex Op acts on, the tuple's first; returns how many.
template <operation_kind Op, class Mesh>
std::size_t seed_vertices(const Mesh& m, const typename Mesh::tuple& t, index_t (&seeds)[4]) {
    seeds[0] = seeds[1] = seeds[2] = seeds[3] = t.vid;
    std::size_t n_seeds = 1;
    if constexpr (Op::acts_on == simplex_kind::edge) {
        seeds[1] = m.edge_vertices(t).second, n_seeds = 2;
    } else if constexpr (Op::acts_on == simplex_kind::face) {
        if constexpr (detail::has_tets<Mesh>) { // the tuple's vertex is the face's first
            const auto fv = m.face_vertices(t);
            seeds[1] = fv[1], seeds[2] = fv[2], n_seeds = 3;
        } else {
            const auto& fv = m.face_vertices(t.fid);
            seeds[1] = fv[0], seeds[2] = fv[1], seeds[3] = fv[2], n_seeds = 4;
        }
    } else if constexpr (Op::acts_on == simplex_kind::tet) {
        const auto tv = cells::vertices(m, cells::of(m, t));
        for (std::size_t i = 0; i < 4; ++i) seeds[i] = tv[i];
        n_seeds = 4;
    }
    return n_seeds;
}
} // namespace detail

/// The default region of an operation: the vertices of the simplex it acts on (the
/// tuple's first), then every vertex of their stars. A spec's `lock_region` may call it
/// for the meshes where its own smaller region does not hold.
template <operation_kind Op, class Mesh, class Take>
bool closed_star_region(const Mesh& m, const typename Mesh::tuple& t, Take&& take) {
    index_t seeds[4];
    const std::size_t n_seeds = detail::seed_vertices<Op>(m, t, seeds);
    for (std::size_t i = 0; i < n_seeds; ++i)
        if (!take(seeds[i])) return false;
    for (std::size_t i = 0; i < n_seeds; ++i)
        for (index_t c : cells::around(m, seeds[i]))
            for (index_t w : cells::vertices(m, c))
                if (!take(w)) return false;
    return true;
}

namespace detail {
/// Whether the backend stores face links between tets (so writing a tet writes its
/// neighbours' links).
template <class Mesh>
concept links_faces = requires(const Mesh& m, index_t t, std::uint8_t lf) {
    m.connectivity().opposite_face(t, lf);
};
} // namespace detail

/// The smallest region of an operation that replaces the tets around an edge or the two
/// of a face (a 3-2, 4-4 or 2-3 swap, an edge removal, an edge split): the vertices of
/// those tets. The executor holds the tuple's vertex and has checked the tuple, so its tet
/// is frozen; every writer of a tet holds all its vertices, so holding a vertex freezes its
/// star. Such an operation reads and writes only the tets it replaces, looks edges and
/// faces up in the stars of their vertices (find_edge, find_face and opposite_tet start at
/// a held vertex), and its new tets have only those vertices and, for a split, a new vertex
/// no other worker knows. So this region is enough: 5 to 10 vertices, against the hundreds
/// of claims of the closed stars. Backends that link tets across faces rewrite the links of
/// the neighbours across the outer faces too, tets whose fourth vertex is not held: they
/// keep the closed stars.
template <operation_kind Op, class Mesh, class Take>
bool replaced_tets_region(const Mesh& m, const typename Mesh::tuple& t, Take&& take) {
    static_assert(Op::acts_on == simplex_kind::edge || Op::acts_on == simplex_kind::face,
                  "idas: replaced_tets_region is the region of an operation on an edge or a face");
    if constexpr (detail::links_faces<Mesh>) {
        return closed_star_region<Op>(m, t, take);
    } else {
        for (index_t x : m.tet_vertices(t.tid))
            if (!take(x)) return false;
        if constexpr (Op::acts_on == simplex_kind::face) {
            const index_t t2 = m.connectivity().opposite_tet(t.tid, t.local_face);
            if (t2 != invalid_index)
                for (index_t x : m.tet_vertices(t2))
                    if (!take(x)) return false;
        } else {
            const auto [a, b] = m.edge_vertices(t);
            for (index_t g : m.vertex_tets(a)) {
                const auto& gv = m.tet_vertices(g);
                if (std::find(gv.begin(), gv.end(), b) == gv.end()) continue;
                for (index_t x : gv)
                    if (!take(x)) return false;
            }
        }
        return true;
    }
}

namespace detail {
/// The tuple's vertex, and the tuple checked under it (or re-anchored, for a vertex
/// entry).
template <operation_kind Op, class Mesh, class Take>
claim_result claim_tuple(const Mesh& m, typename Mesh::tuple& t, Take& take) {
    if (t.vid >= m.vertex_slots() || !take(t.vid)) return claim_result::busy;
    // Holding the vertex freezes its star, so a vertex entry can be re-anchored in it
    // (to a cell of that star). Other tuples must name a cell of the held star before
    // their version is read.
    if constexpr (Op::acts_on == simplex_kind::vertex) {
        if (!m.vertex_alive(t.vid)) return claim_result::stale;
        t = m.tuple_from_vertex(t.vid);
    } else {
        bool in_star = false;
        for (index_t c : cells::around(m, t.vid)) in_star |= c == cells::of(m, t);
        if (!in_star) return claim_result::stale;
    }
    if (!m.is_valid(t)) return claim_result::stale;
    return claim_result::ok;
}
} // namespace detail

/// The first stage of a two-stage claim: the tuple's vertex (the tuple checked under it),
/// then the other vertices of the simplex the operation acts on. Holding them freezes
/// their stars, which is all that a spec with `decides_holding_seeds` reads to decide
/// whether to process an entry (see exec/run.hpp: step).
template <operation_kind Op, class Mesh, class Take>
claim_result claim_seeds(const Mesh& m, typename Mesh::tuple& t, Take& take) {
    const claim_result c = detail::claim_tuple<Op>(m, t, take);
    if (c != claim_result::ok) return c;
    index_t seeds[4];
    const std::size_t n_seeds = detail::seed_vertices<Op>(m, t, seeds);
    for (std::size_t i = 1; i < n_seeds; ++i)
        if (!take(seeds[i])) return claim_result::busy;
    return claim_result::ok;
}

/// Claims the vertices an operation reads or writes: the simplex it acts on first (so
/// the tuple can be validated under the claim), then every vertex of their stars.
/// Writers of a cell hold all of its vertices, so holding a vertex freezes its star. A
/// spec's `lock_region` replaces the stars.
template <operation_kind Op, class Spec, class Mesh, class Take>
claim_result claim_footprint(Spec& spec, const Mesh& m, typename Mesh::tuple& t, Take& take) {
    const claim_result c = detail::claim_tuple<Op>(m, t, take);
    if (c != claim_result::ok) return c;
    bool held = false;
    if constexpr (detail::lock_region_hook<Spec, Mesh, Op>)
        held = spec.lock_region(Op{}, m, t, take);
    else
        held = closed_star_region<Op>(m, t, take);
    // An invariant that reads beyond the star (a spatial index) claims that space too,
    // once the star is held and its geometry cannot change.
    using set = std::remove_cvref_t<decltype(detail::spec_invariants(spec))>;
    if constexpr (set::claims_space)
        held = held && detail::spec_invariants(spec).template claim<Op>(m, std::as_const(t), take);
    return held ? claim_result::ok : claim_result::busy;
}

} // namespace idas
