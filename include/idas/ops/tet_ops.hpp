// Local operations on tetrahedral meshes, with the triangle core's protocol: the tuple's
// validity and the operation's own topological preconditions; the invariants' `before`
// and the spec's `before` (old mesh); the connectivity change; the spec's `after` (new
// mesh, writes new simplices' attributes); the invariants' `after` on the new tets. Any
// failure restores connectivity and every attribute exactly (journal rollback).
//
// Boundary policy. No operation ever changes the topology of the mesh or of its boundary
// (collapses check the link condition on the mesh closed by a virtual vertex). Beyond
// that, operations that would change the boundary surface are refused unless the spec
// has a member `allow_boundary_change` that is true (static constexpr or not):
//   - collapse_edge removing a boundary vertex, smooth_vertex moving one;
//   - the swaps never touch the boundary: they need an interior face or edge.
// split_edge refines boundary edges freely: it keeps the boundary as a point set as long
// as the spec puts the new vertex on the edge.
#pragma once

#include <idas/mesh/tet_mesh.hpp>
#include <idas/mesh/tet_quality.hpp>
#include <idas/ops/operation.hpp>
#include <idas/ops/tet_op_kinds.hpp>
#include <idas/ops/tri_ops.hpp>
#include <idas/predicates/orient.hpp>

#include <boost/container/small_vector.hpp>
#include <boost/container/static_vector.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <utility>
#include <vector>

namespace idas {

template <class Mesh>
double tet_quality(const Mesh& m, const tet_indices& t) {
    const auto p = m.positions();
    return tet_quality(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
}

namespace detail {

template <class Spec>
bool allows_boundary_change(const Spec& spec) {
    if constexpr (requires {
                      { spec.allow_boundary_change } -> std::convertible_to<bool>;
                  })
        return static_cast<bool>(spec.allow_boundary_change);
    else
        return false;
}

/// Records tet g as a result cell (tuple at v), coming from `origin`.
template <class Mesh>
void emit_tet(const Mesh& m, op_context<Mesh>& ctx, index_t v, index_t g, index_t origin) {
    ctx.cells.push_back(m.tuple_in_tet(v, g));
    ctx.origins.push_back(origin);
}

inline tet_indices replaced(tet_indices t, index_t from, index_t to) noexcept {
    for (auto& v : t)
        if (v == from) v = to;
    return t;
}

/// The other two vertices (x, y) of a tet holding edge ab, ordered so that (a, b, x, y)
/// is an even permutation of the stored (positive) order.
inline std::pair<index_t, index_t> oriented_opposite(const tet_indices& tv, index_t a,
                                                     index_t b) noexcept {
    const std::uint8_t i = tet_local::index_of(tv, a), j = tet_local::index_of(tv, b);
    const auto rest = tet_local::edge_complement(tet_local::edge_of[i][j]);
    const std::array<std::uint8_t, 4> perm = {i, j, rest[0], rest[1]};
    int inversions = 0;
    for (int p = 0; p < 4; ++p)
        for (int q = p + 1; q < 4; ++q) inversions += perm[p] > perm[q];
    if (inversions % 2 == 0) return {tv[rest[0]], tv[rest[1]]};
    return {tv[rest[1]], tv[rest[0]]};
}

/// The tets around an interior edge ab in cyclic order: tet i holds a, b, verts[i] and
/// verts[i+1], and (a, b, verts[i], verts[i+1]) is positively oriented.
struct edge_ring {
    boost::container::static_vector<index_t, max_edge_ring> tets, verts;
};

/// Fills `r` and returns true iff the tets of edge ab form a single closed ring of at
/// most max_edge_ring tets (so ab is interior and manifold). `hint`, a tet holding ab,
/// lets a backend with face links walk around the edge instead of searching a's star.
template <class Mesh>
bool closed_edge_ring(const Mesh& m, index_t a, index_t b, edge_ring& r,
                      index_t hint = invalid_index) {
    if constexpr (requires { requires Mesh::face_links; }) {
        if (hint != invalid_index) {
            r.tets.clear(), r.verts.clear();
            index_t g = hint;
            for (;;) {
                if (r.tets.size() == r.tets.capacity()) return false;
                const auto& tv = m.tet_vertices(g);
                const index_t x = oriented_opposite(tv, a, b).first;
                r.tets.push_back(g), r.verts.push_back(x);
                // (a, b, x, y) is positive: the next tet holds a, b, y and the next ring vertex.
                g = m.connectivity().opposite_tet(g, tet_local::index_of(tv, x));
                if (g == invalid_index) return false; // open: ab is on the boundary
                if (g == hint) return r.tets.size() >= 3;
            }
        }
    }
    struct item {
        index_t tet, x, y;
    };
    boost::container::static_vector<item, max_edge_ring> items;
    for (index_t g : m.vertex_tets(a)) {
        const auto& tv = m.tet_vertices(g);
        if (!tet_local::contains(tv, b)) continue;
        if (items.size() == items.capacity()) return false;
        const auto [x, y] = oriented_opposite(tv, a, b);
        items.push_back({g, x, y});
    }
    r.tets.clear(), r.verts.clear();
    if (items.size() < 3) return false;
    std::uint32_t used = 1;
    r.tets.push_back(items[0].tet), r.verts.push_back(items[0].x);
    index_t next = items[0].y;
    while (next != items[0].x) {
        std::size_t k = 0;
        while (k < items.size() && ((used >> k) & 1u || items[k].x != next)) ++k;
        if (k == items.size()) return false; // open (boundary) or broken ring
        used |= 1u << k;
        r.tets.push_back(items[k].tet), r.verts.push_back(items[k].x);
        next = items[k].y;
    }
    return r.tets.size() == items.size();
}

// ---- the link condition in 3D ----
//
// Collapsing ab keeps a 3-manifold (with the same boundary topology) iff
// lk(a) ∩ lk(b) = lk(ab), evaluated on the mesh closed by coning its boundary to a
// virtual vertex ω (Dey et al. 1999). Both vertex links must also be 2-spheres there,
// which refuses vertices that are non-manifold in the input.

/// Counts of 64-bit keys (link edges, link vertices): open addressing, emptied in O(1) by
/// moving to a new stamp. The link condition asked every collapse to sort its links' edges
/// and vertices (a tenth of a tet optimization's run); counting them here takes one probe
/// each, and the links are compared by looking one up in the other.
class key_counts {
public:
    key_counts() { reset(); }
    /// Empties the set.
    void reset() {
        if (slots_.empty() || ++stamp_ == 0) {
            slots_.assign(std::max<std::size_t>(slots_.size(), 64), slot{});
            stamp_ = 1;
            set_room(slots_.size());
        }
        size_ = 0;
    }
    /// Counts one more `key`; returns its count now.
    std::uint32_t add(std::uint64_t key) {
        for (std::size_t i = home(key);; i = (i + 1) & mask_) {
            slot& s = slots_[i];
            if (s.stamp != stamp_) {
                s = {key, 1, stamp_};
                if (2 * ++size_ > slots_.size()) grow();
                return 1;
            }
            if (s.key == key) return ++s.count;
        }
    }
    std::uint32_t count(std::uint64_t key) const noexcept {
        for (std::size_t i = home(key);; i = (i + 1) & mask_) {
            const slot& s = slots_[i];
            if (s.stamp != stamp_) return 0;
            if (s.key == key) return s.count;
        }
    }

private:
    struct slot {
        std::uint64_t key = 0;
        std::uint32_t count = 0, stamp = 0;
    };
    std::size_t home(std::uint64_t key) const noexcept {
        return std::size_t((key * 0x9E3779B97F4A7C15ull) >> shift_);
    }
    void set_room(std::size_t room) noexcept {
        shift_ = 64 - std::countr_zero(room);
        mask_ = room - 1;
    }
    /// Twice the room, the live keys moved over (a star larger than any before).
    void grow() {
        std::vector<slot> old(2 * slots_.size());
        old.swap(slots_);
        set_room(slots_.size());
        for (const slot& s : old)
            if (s.stamp == stamp_)
                for (std::size_t i = home(s.key);; i = (i + 1) & mask_)
                    if (slots_[i].stamp != stamp_) {
                        slots_[i] = s;
                        break;
                    }
    }
    std::vector<slot> slots_;
    std::uint32_t stamp_ = 0;
    std::size_t size_ = 0, mask_ = 0;
    int shift_ = 64;
};

/// A vertex's link, closed by ω: its triangles (the faces opposite it, each sorted), its
/// real vertices and edges (each once, an edge as `edge_key`, counted in `vertex_count`
/// and `edge_count`: 1 for an open edge, 2 for an inner one), its open edges (in one
/// triangle: coned to ω) and the rim (their vertices, each once, whose edges to ω close it;
/// in `rim_count`). ω's own elements are implied by `open`.
struct link_buffers {
    std::vector<tri_indices> tris;
    std::vector<index_t> verts;
    std::vector<std::uint64_t> edges;
    std::vector<std::uint64_t> open;
    std::vector<index_t> rim;
    key_counts vertex_count, edge_count, rim_count;
};

/// An edge (x < y) as one word: one integer compare where a pair needs two.
constexpr std::uint64_t edge_key(index_t x, index_t y) noexcept {
    static_assert(sizeof(index_t) <= 4, "two vertex indices must fit in one 64-bit key");
    return std::uint64_t(x) << 32 | y;
}

/// A face's vertices in ascending order: the key of a face whatever its orientation.
inline tri_indices sorted_triple(index_t a, index_t b, index_t c) noexcept {
    if (a > b) std::swap(a, b);
    if (b > c) std::swap(b, c);
    if (a > b) std::swap(a, b);
    return {a, b, c};
}

inline link_buffers& thread_link_buffers(int which) {
    thread_local link_buffers buffers[2];
    return buffers[which];
}

/// The link of v closed by ω. Returns false unless it is a 2-sphere: every edge in two
/// triangles (an open edge's second is its cone xyω; an edge xω is in the cones of the
/// two open edges at x) and Euler characteristic 2.
template <class Mesh>
bool closed_vertex_link(const Mesh& m, index_t v, link_buffers& l) {
    l.tris.clear(), l.verts.clear(), l.edges.clear(), l.open.clear(), l.rim.clear();
    l.vertex_count.reset(), l.edge_count.reset();
    for (index_t g : m.vertex_tets(v)) {
        tri_indices opposite{};
        std::size_t k = 0;
        for (index_t x : m.tet_vertices(g))
            if (x != v) opposite[k++] = x;
        const tri_indices f = sorted_triple(opposite[0], opposite[1], opposite[2]);
        l.tris.push_back(f);
        for (index_t x : f)
            if (l.vertex_count.add(x) == 1) l.verts.push_back(x);
        for (const std::uint64_t e :
             {edge_key(f[0], f[1]), edge_key(f[0], f[2]), edge_key(f[1], f[2])}) {
            const std::uint32_t n = l.edge_count.add(e);
            if (n == 1) l.edges.push_back(e);
            if (n > 2) return false;
        }
    }
    for (const std::uint64_t e : l.edges)
        if (l.edge_count.count(e) == 1) l.open.push_back(e);
    l.rim_count.reset();
    for (const std::uint64_t e : l.open)
        for (const index_t x : {index_t(e >> 32), index_t(e)})
            if (l.rim_count.add(x) == 1) l.rim.push_back(x);
    for (const index_t x : l.rim)
        if (l.rim_count.count(x) != 2) return false;
    const long omega = l.open.empty() ? 0 : 1;
    const long chi = long(l.verts.size()) + omega - long(l.edges.size() + l.rim.size()) +
                     long(l.tris.size() + l.open.size());
    return chi == 2;
}

/// Whether the two links share a triangle with three real vertices. Such a triangle has
/// its vertices among `common` (sorted), which few of either link's triangles do.
inline bool share_real_triangle(const link_buffers& la, const link_buffers& lb,
                                std::span<const index_t> common) {
    auto in_common = [&](const tri_indices& f) {
        return std::ranges::binary_search(common, f[0]) &&
               std::ranges::binary_search(common, f[1]) && std::ranges::binary_search(common, f[2]);
    };
    boost::container::small_vector<tri_indices, 8> from_a;
    for (const auto& f : la.tris)
        if (in_common(f)) from_a.push_back(f);
    if (from_a.empty()) return false;
    for (const auto& f : lb.tris)
        if (in_common(f) && std::ranges::find(from_a, f) != from_a.end()) return true;
    return false;
}

} // namespace detail

/// True iff collapsing edge ab keeps the mesh a 3-manifold with the same topology and
/// the same boundary topology.
template <class Mesh>
bool link_condition_3d_holds(const Mesh& m, index_t a, index_t b) {
    auto& la = detail::thread_link_buffers(0);
    auto& lb = detail::thread_link_buffers(1);
    if (!detail::closed_vertex_link(m, a, la) || !detail::closed_vertex_link(m, b, lb))
        return false;
    // lk(ab): an edge (x, y) per tet abxy, an edge (x, ω) per boundary face abx.
    boost::container::small_vector<index_t, 64> ring;
    std::size_t tets = 0;
    for (index_t g : m.vertex_tets(a)) {
        const auto& tv = m.tet_vertices(g);
        if (!tet_local::contains(tv, b)) continue;
        ++tets;
        for (index_t x : tv)
            if (x != a && x != b) ring.push_back(x);
    }
    std::sort(ring.begin(), ring.end());
    std::size_t ring_verts = 0, boundary_faces = 0;
    for (std::size_t i = 0; i < ring.size();) {
        std::size_t j = i + 1;
        while (j < ring.size() && ring[j] == ring[i]) ++j;
        ++ring_verts;
        boundary_faces += j - i == 1 ? 1 : 0;
        i = j;
    }
    const std::size_t link_verts = ring_verts + (boundary_faces > 0 ? 1 : 0);
    const std::size_t link_edges = tets + boundary_faces;
    // lk(ab) ⊆ lk(a) ∩ lk(b) always, so equality is a matter of counts. ω is a common
    // vertex iff both links are open, xω a common edge iff x is on both rims, and xyω a
    // common triangle iff xy is open in both.
    boost::container::small_vector<index_t, 64> common;
    for (const index_t x : lb.verts)
        if (la.vertex_count.count(x) != 0) common.push_back(x);
    const std::size_t omega = !la.open.empty() && !lb.open.empty() ? 1 : 0;
    if (common.size() + omega != link_verts) return false;
    std::size_t common_edges = 0;
    for (const std::uint64_t e : lb.edges) common_edges += la.edge_count.count(e) != 0;
    for (const index_t x : lb.rim) common_edges += la.rim_count.count(x) != 0;
    if (common_edges != link_edges) return false;
    for (const std::uint64_t e : lb.open) // open in both: a common triangle xyω
        if (la.edge_count.count(e) == 1) return false;
    std::sort(common.begin(), common.end());
    return !detail::share_real_triangle(la, lb, {common.data(), common.size()});
}

namespace detail {

/// Quality of a candidate new tet: the spec's `tet_quality(mesh, tet)` if it has one,
/// else idas::tet_quality; -infinity unless exactly positively oriented.
template <class Mesh, class Spec>
double candidate_quality(const Mesh& m, Spec& spec, const tet_indices& t) {
    constexpr double reject = -std::numeric_limits<double>::infinity();
    const auto p = m.positions();
    if (orient3d(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) <= 0) return reject;
    double q;
    if constexpr (requires {
                      { spec.tet_quality(m, t) } -> std::convertible_to<double>;
                  })
        q = spec.tet_quality(m, t);
    else
        q = tet_quality(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
    return q == q ? q : reject; // NaN never wins
}

/// Triangles (indices into the ring) of a triangulation of the ring polygon.
using ring_triangulation =
    boost::container::static_vector<std::array<std::uint8_t, 3>, max_edge_ring - 2>;

/// Replaces the ring's tets around ab by two tets per ring triangle (p, q, r):
/// (p, q, r, b) and (p, r, q, a). Reuses the old slots first.
template <class Mesh>
void replace_edge_ring(Mesh& m, op_context<Mesh>& ctx, index_t a, index_t b, const edge_ring& r,
                       const ring_triangulation& tris) {
    std::size_t next = 0;
    const std::size_t n_old = r.tets.size();
    auto place = [&](const tet_indices& nt) {
        index_t slot;
        index_t origin = r.tets[next % n_old];
        if (next < n_old) {
            slot = r.tets[next];
            m.set_tet(slot, nt, ctx.conn);
        } else {
            slot = m.add_tet(nt, ctx.conn, ctx.attrs);
        }
        ++next;
        emit_tet(m, ctx, nt[0], slot, origin);
    };
    for (const auto& tri : tris) {
        const index_t p = r.verts[tri[0]], q = r.verts[tri[1]], s = r.verts[tri[2]];
        place({p, q, s, b});
        place({p, s, q, a});
    }
    for (; next < n_old; ++next) m.remove_tet(r.tets[next], ctx.conn);
    ctx.pending_faces =
        static_cast<std::int64_t>(2 * tris.size()) - static_cast<std::int64_t>(n_old);
}

/// True iff the ring polygon's chord (i, k) may become an edge: it is a side of the
/// polygon, or it does not exist yet (an existing one would pinch the mesh).
template <class Mesh>
bool chord_free(const Mesh& m, const edge_ring& r, std::size_t i, std::size_t k) {
    const std::size_t n = r.verts.size();
    if (k == i + 1 || (i == 0 && k == n - 1)) return true;
    return !m.find_edge(r.verts[i], r.verts[k]);
}

/// For a 3-ring the new face must not exist already.
template <class Mesh>
bool triangle_face_free(const Mesh& m, const edge_ring& r) {
    return r.verts.size() != 3 || !m.find_face(r.verts[0], r.verts[1], r.verts[2]);
}

} // namespace detail

namespace detail {
/// The edge split, under operation kind Op (split_edge or split_tet_edge).
template <class Op, class B, class Spec>
std::optional<op_result<tet_tuple>> split_tet_edge_as(tet_mesh<B>& m, const tet_tuple& t,
                                                      Spec& spec, op_context<tet_mesh<B>>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    return run_tri_operation<Op>(m, t, spec, ctx, [&] {
        const auto [a, b] = m.edge_vertices(t);
        auto& tets = ctx.scratch;
        tets.clear();
        m.edge_tets(t, tets);
        const index_t nv = m.add_vertex(ctx.conn, ctx.attrs);
        // Live-count changes, for executors that track mesh size.
        ctx.pending_faces = static_cast<std::int64_t>(tets.size()), ctx.pending_vertices = 1;
        for (index_t g : tets) {
            const tet_indices old = m.tet_vertices(g);
            m.set_tet(g, replaced(old, b, nv), ctx.conn);
            const index_t h = m.add_tet(replaced(old, a, nv), ctx.conn, ctx.attrs);
            emit_tet(m, ctx, nv, g, g);
            emit_tet(m, ctx, nv, h, g);
        }
        return m.tuple_at(tets.front(), nv, a);
    });
}
} // namespace detail

/// Splits the tuple's edge ab at a new vertex m: every tet abxy becomes amxy and mbxy.
/// New tets: the 2n tets around m. Anchor: m, on the edge (m, a). `after` must set m's
/// position. Allowed on boundary edges (it refines the boundary).
template <class B, class Spec = no_spec>
std::optional<op_result<tet_tuple>> split_edge(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec,
                                               op_context<tet_mesh<B>>& ctx) {
    return detail::split_tet_edge_as<op::split_edge>(m, t, spec, ctx);
}

/// Collapses the tuple's edge ab into a (the tuple's vertex survives, b is removed).
/// Refused unless the 3D link condition holds, and, without allow_boundary_change, if b
/// is on the boundary. New tets: the whole new star of a. Anchor: a. `after` sets a's
/// new position (and other attributes).
template <class B, class Spec = no_spec>
std::optional<op_result<tet_tuple>> collapse_edge(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec,
                                                  op_context<tet_mesh<B>>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    const auto [a, b] = m.edge_vertices(t);
    if (!detail::allows_boundary_change(spec) && m.is_boundary_vertex(b)) return std::nullopt;
    // Something must survive: a tet of a or b that does not hold the edge.
    bool survivor = false;
    for (index_t g : m.vertex_tets(a)) survivor |= !tet_local::contains(m.tet_vertices(g), b);
    for (index_t g : m.vertex_tets(b)) survivor |= !tet_local::contains(m.tet_vertices(g), a);
    if (!survivor || !link_condition_3d_holds(m, a, b)) return std::nullopt;
    return detail::run_tri_operation<op::collapse_edge>(m, t, spec, ctx, [&] {
        auto& tets_b = ctx.scratch;
        const auto star_b = m.vertex_tets(b); // may be a range computed by value
        tets_b.assign(star_b.begin(), star_b.end());
        for (index_t g : tets_b) {
            const auto& tv = m.tet_vertices(g);
            if (tet_local::contains(tv, a))
                m.remove_tet(g, ctx.conn), --ctx.pending_faces;
            else
                m.set_tet(g, detail::replaced(tv, b, a), ctx.conn);
        }
        m.remove_vertex(b, ctx.conn);
        ctx.pending_vertices = -1;
        // a moves, so its whole new star changes; moved-in tets were bumped already.
        for (index_t g : m.vertex_tets(a)) {
            if (std::find(tets_b.begin(), tets_b.end(), g) == tets_b.end())
                m.touch_tet(g, ctx.conn);
            detail::emit_tet(m, ctx, a, g, g);
        }
        return m.tuple_in_tet(a, ctx.cells.front().tid);
    });
}

/// Moves the tuple's vertex: `after` writes its new position. Connectivity is unchanged
/// but every tet of its star is renewed (new version). Refused for boundary vertices
/// without allow_boundary_change. Anchor: the vertex.
template <class B, class Spec = no_spec>
std::optional<op_result<tet_tuple>> smooth_vertex(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec,
                                                  op_context<tet_mesh<B>>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    if (!detail::allows_boundary_change(spec) && m.is_boundary_vertex(t.vid)) return std::nullopt;
    return detail::run_tri_operation<op::smooth_vertex>(m, t, spec, ctx, [&] {
        const index_t v = t.vid;
        for (index_t g : m.vertex_tets(v)) {
            m.touch_tet(g, ctx.conn);
            detail::emit_tet(m, ctx, v, g, g);
        }
        return m.tuple_in_tet(v, t.tid);
    });
}

/// 2-3 swap of the tuple's face abc, shared by tets abcd and cbae: they become the three
/// tets around the new edge de. Refused on boundary faces or if de exists. New tets:
/// the three around de. Anchor: d, on edge de.
template <class B, class Spec = no_spec>
std::optional<op_result<tet_tuple>> face_swap_23(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec,
                                                 op_context<tet_mesh<B>>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    const index_t t1 = t.tid;
    const index_t t2 = m.connectivity().opposite_tet(t1, t.local_face);
    if (t2 == invalid_index) return std::nullopt;
    const auto out = m.face_vertices_outward(t);
    const index_t d = m.opposite_vertex(t);
    index_t e = invalid_index;
    for (index_t x : m.tet_vertices(t2))
        if (x != out[0] && x != out[1] && x != out[2]) e = x;
    if (m.find_edge(d, e)) return std::nullopt;
    return detail::run_tri_operation<op::face_swap_23>(m, t, spec, ctx, [&] {
        // (a, b, c) seen from d counter-clockwise, i.e. the outward face reversed.
        const index_t a = out[0], b = out[2], c = out[1];
        m.set_tet(t1, {a, b, e, d}, ctx.conn);
        m.set_tet(t2, {b, c, e, d}, ctx.conn);
        const index_t t3 = m.add_tet({c, a, e, d}, ctx.conn, ctx.attrs);
        ctx.pending_faces = 1;
        detail::emit_tet(m, ctx, d, t1, t1);
        detail::emit_tet(m, ctx, d, t2, t2);
        detail::emit_tet(m, ctx, d, t3, t1);
        return m.tuple_at(t1, d, e);
    });
}

/// 3-2 swap of the tuple's edge ab, interior with exactly three tets abx0x1, abx1x2,
/// abx2x0: they become x0x1x2b and x0x2x1a. Refused if face x0x1x2 exists. New tets: those
/// two. Anchor: x0, in the first new tet.
template <class B, class Spec = no_spec>
std::optional<op_result<tet_tuple>> edge_swap_32(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec,
                                                 op_context<tet_mesh<B>>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    const auto [a, b] = m.edge_vertices(t);
    detail::edge_ring r;
    if (!detail::closed_edge_ring(m, a, b, r, t.tid) || r.tets.size() != 3 ||
        !detail::triangle_face_free(m, r))
        return std::nullopt;
    return detail::run_tri_operation<op::edge_swap_32>(m, t, spec, ctx, [&] {
        detail::replace_edge_ring(m, ctx, a, b, r, {{0, 1, 2}});
        return m.tuple_at(ctx.cells.front().tid, r.verts[0], r.verts[1]);
    });
}

/// 4-4 swap of the tuple's edge ab, interior with exactly four tets around the ring
/// x0 x1 x2 x3. The new diagonal runs from the third vertex c of the tuple's face to the
/// ring vertex opposite c (so switch_face picks the other diagonal). Refused if that
/// diagonal exists. New tets: the four around it. Anchor: c, on the new diagonal.
template <class B, class Spec = no_spec>
std::optional<op_result<tet_tuple>> edge_swap_44(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec,
                                                 op_context<tet_mesh<B>>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    const auto [a, b] = m.edge_vertices(t);
    detail::edge_ring r;
    if (!detail::closed_edge_ring(m, a, b, r, t.tid) || r.tets.size() != 4) return std::nullopt;
    const index_t c = m.face_vertices(t)[2];
    std::uint8_t i = 0;
    while (i < 4 && r.verts[i] != c) ++i;
    if (i == 4) return std::nullopt;
    const auto i1 = static_cast<std::uint8_t>((i + 1) % 4),
               i2 = static_cast<std::uint8_t>((i + 2) % 4),
               i3 = static_cast<std::uint8_t>((i + 3) % 4);
    if (m.find_edge(c, r.verts[i2])) return std::nullopt;
    return detail::run_tri_operation<op::edge_swap_44>(m, t, spec, ctx, [&] {
        detail::replace_edge_ring(m, ctx, a, b, r, {{i, i1, i2}, {i, i2, i3}});
        return m.tuple_at(ctx.cells.front().tid, c, r.verts[i2]);
    });
}

/// Removes the tuple's interior edge ab: its n tets (3 <= n <= max_edge_ring) become the
/// 2n - 4 tets that cone the best triangulation of the ring polygon to a and b. "Best"
/// maximises the minimum quality of the new tets (dynamic programming over the polygon;
/// quality from the spec's `tet_quality(mesh, tet_indices)` if it has one, else
/// idas::tet_quality), among triangulations whose tets are all positively oriented
/// (exact) and whose diagonals do not exist yet. Refused if there is none. New tets: the
/// 2n - 4. Anchor: in the first new tet.
template <class B, class Spec = no_spec>
std::optional<op_result<tet_tuple>> edge_removal(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec,
                                                 op_context<tet_mesh<B>>& ctx) {
    if (!m.is_valid(t)) return std::nullopt;
    const auto [a, b] = m.edge_vertices(t);
    detail::edge_ring r;
    if (!detail::closed_edge_ring(m, a, b, r, t.tid) || !detail::triangle_face_free(m, r))
        return std::nullopt;
    const std::size_t n = r.verts.size();
    constexpr double reject = -std::numeric_limits<double>::infinity();
    // best[i][k]: the best min-quality of triangulating the sub-polygon i..k.
    std::array<std::array<double, max_edge_ring>, max_edge_ring> best;
    std::array<std::array<std::uint8_t, max_edge_ring>, max_edge_ring> split;
    std::array<std::array<bool, max_edge_ring>, max_edge_ring> chord_ok;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t k = i + 1; k < n; ++k) chord_ok[i][k] = detail::chord_free(m, r, i, k);
    for (std::size_t i = 0; i + 1 < n; ++i)
        best[i][i + 1] = std::numeric_limits<double>::infinity();
    for (std::size_t len = 2; len < n; ++len)
        for (std::size_t i = 0; i + len < n; ++i) {
            const std::size_t k = i + len;
            double top = reject;
            std::uint8_t arg = 0;
            if (chord_ok[i][k])
                for (std::size_t j = i + 1; j < k; ++j) {
                    double q = std::min(best[i][j], best[j][k]);
                    if (!(q > top)) continue;
                    const index_t p = r.verts[i], x = r.verts[j], y = r.verts[k];
                    q = std::min(q, detail::candidate_quality(m, spec, {p, x, y, b}));
                    if (!(q > top)) continue;
                    q = std::min(q, detail::candidate_quality(m, spec, {p, y, x, a}));
                    if (q > top) top = q, arg = static_cast<std::uint8_t>(j);
                }
            best[i][k] = top, split[i][k] = arg;
        }
    if (!(best[0][n - 1] > reject)) return std::nullopt;
    detail::ring_triangulation tris;
    boost::container::static_vector<std::pair<std::uint8_t, std::uint8_t>, max_edge_ring> todo;
    todo.push_back({0, static_cast<std::uint8_t>(n - 1)});
    while (!todo.empty()) {
        const auto [i, k] = todo.back();
        todo.pop_back();
        if (k - i < 2) continue;
        const std::uint8_t j = split[i][k];
        tris.push_back({i, j, k});
        todo.push_back({j, k}), todo.push_back({i, j});
    }
    return detail::run_tri_operation<op::edge_removal>(m, t, spec, ctx, [&] {
        detail::replace_edge_ring(m, ctx, a, b, r, tris);
        const auto& first = m.tet_vertices(ctx.cells.front().tid);
        return m.tuple_at(ctx.cells.front().tid, first[0], first[1]);
    });
}

// The tet-only kinds map to their functions by overload, as the triangle core's kinds do
// (ops/tri_ops.hpp), so the executor dispatches on the kind type at compile time.
template <class B, class Spec>
std::optional<op_result<tet_tuple>> apply(op::split_tet_edge, tet_mesh<B>& m, const tet_tuple& t,
                                          Spec& s, op_context<tet_mesh<B>>& c) {
    if (!m.is_valid(t)) return std::nullopt;
    const auto [a, b] = m.edge_vertices(t);
    std::size_t n = 0;
    for (index_t g : m.vertex_tets(a)) n += tet_local::contains(m.tet_vertices(g), b) ? 1 : 0;
    if (n > max_split_ring) return std::nullopt; // more new tets than the kind has room for
    return detail::split_tet_edge_as<op::split_tet_edge>(m, t, s, c);
}
template <class B, class Spec>
auto apply(op::face_swap_23, tet_mesh<B>& m, const tet_tuple& t, Spec& s,
           op_context<tet_mesh<B>>& c) {
    return face_swap_23(m, t, s, c);
}
template <class B, class Spec>
auto apply(op::edge_swap_32, tet_mesh<B>& m, const tet_tuple& t, Spec& s,
           op_context<tet_mesh<B>>& c) {
    return edge_swap_32(m, t, s, c);
}
template <class B, class Spec>
auto apply(op::edge_swap_44, tet_mesh<B>& m, const tet_tuple& t, Spec& s,
           op_context<tet_mesh<B>>& c) {
    return edge_swap_44(m, t, s, c);
}
template <class B, class Spec>
auto apply(op::edge_removal, tet_mesh<B>& m, const tet_tuple& t, Spec& s,
           op_context<tet_mesh<B>>& c) {
    return edge_removal(m, t, s, c);
}

// Convenience overloads that use the calling thread's default context.
template <class B, class Spec = no_spec>
auto split_edge(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec = {}) {
    return split_edge(m, t, spec, thread_context<tet_mesh<B>>());
}
template <class B, class Spec = no_spec>
auto collapse_edge(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec = {}) {
    return collapse_edge(m, t, spec, thread_context<tet_mesh<B>>());
}
template <class B, class Spec = no_spec>
auto smooth_vertex(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec = {}) {
    return smooth_vertex(m, t, spec, thread_context<tet_mesh<B>>());
}
template <class B, class Spec = no_spec>
auto face_swap_23(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec = {}) {
    return face_swap_23(m, t, spec, thread_context<tet_mesh<B>>());
}
template <class B, class Spec = no_spec>
auto edge_swap_32(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec = {}) {
    return edge_swap_32(m, t, spec, thread_context<tet_mesh<B>>());
}
template <class B, class Spec = no_spec>
auto edge_swap_44(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec = {}) {
    return edge_swap_44(m, t, spec, thread_context<tet_mesh<B>>());
}
template <class B, class Spec = no_spec>
auto edge_removal(tet_mesh<B>& m, const tet_tuple& t, Spec&& spec = {}) {
    return edge_removal(m, t, spec, thread_context<tet_mesh<B>>());
}

} // namespace idas
