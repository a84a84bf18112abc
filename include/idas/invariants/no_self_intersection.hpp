// No self-intersection: every face an operation creates or moves must meet no other face
// of the surface except at the vertices and edges they share, decided exactly
// (predicates/triangle_intersection.hpp). Local invariants (link condition, no normal
// flip) cannot see a face of another sheet of the surface: decimation to 1% folded faces
// through each other on thin parts and flat regions (issue 16: 2 to 44 intersecting pairs
// in 14 of 120 outputs).
//
// A spatial index finds the faces near the new ones (self_intersection_index.hpp): a
// uniform grid whose cells list the faces whose bounding box they overlap, each with that
// box (quantized to 16 bits per axis, rounded outwards: the scan reads 16-byte entries). The index
// must describe the mesh as it is: it is built from the mesh when the invariant is made, and the
// invariant keeps it up to date: when it accepts an operation, it moves the faces the operation
// changed. So it must be the last invariant of its set (checked at compile time), and the mesh may
// change only through operations that list it while the index is in use.
//
// In parallel, an operation reads faces outside its star and writes grid cells. So it
// claims space as well as vertices: every lock cell (a grid cell) its reach overlaps,
// where the reach is its star's bounding box grown by half its size; its new faces must
// stay within the reach (else it is refused, at any thread count). Whoever changes a face
// holds the lock cells of its old and new boxes, so faces in held cells do not change
// under the reader, and two operations whose new faces could meet exclude each other.
//
// Usage:
//     idas::self_intersection_index index(mesh);          // before the run; outlives it
//     spec.self_intersections = idas::no_self_intersection(index);
// and in the spec: invariant_set{no_normal_flip{}, ..., self_intersections} (last), and,
// where the faces grow (decimation), `void quiescent(Mesh& m, const progress& p) {
// self_intersections.refit(m, p.faces); }`.
// A default-constructed invariant is disabled and accepts everything.
#pragma once

#include <idas/core/types.hpp>
#include <idas/invariants/self_intersection_index.hpp>
#include <idas/ops/operation.hpp>
#include <idas/predicates/triangle_intersection.hpp>

#include <boost/container/small_vector.hpp>
#include <boost/container/static_vector.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace idas {

namespace detail::self_intersection {

/// The vertices whose stars an operation of kind Op at t rewrites (its claim's seeds).
template <class Op, class Mesh>
boost::container::static_vector<index_t, 3> seeds(const Mesh& m, const typename Mesh::tuple& t) {
    boost::container::static_vector<index_t, 3> s;
    if constexpr (Op::acts_on == simplex_kind::vertex) {
        s.push_back(t.vid);
    } else if constexpr (Op::acts_on == simplex_kind::edge) {
        const auto [a, b] = m.edge_vertices(t);
        s.push_back(a), s.push_back(b);
    } else {
        for (index_t v : m.face_vertices(t.fid)) s.push_back(v);
    }
    return s;
}

/// A face's corners, vertex ids and plane, read once for all its tests.
using triangle = face_geometry;
template <class Mesh>
triangle triangle_of(const Mesh& m, index_t f) {
    const auto& fv = m.face_vertices(f);
    return {{m.position(fv[0]), m.position(fv[1]), m.position(fv[2])}, fv};
}
inline bool meet(const triangle& a, const triangle& b) {
    return faces_meet(a, b);
}

/// The new faces' boxes, axis by axis in blocks of eight (empty boxes pad the last), so
/// that testing one entry against all of them is a few vector compares (SSE2; a plain loop
/// elsewhere).
struct box_block {
    static constexpr std::size_t lanes = 8, max_faces = 32;
    std::size_t blocks = 0;
    // Coordinates with the sign bit flipped: SSE2 compares 16-bit lanes as signed.
    alignas(16) std::int16_t lo[max_faces / lanes][3][lanes], hi[max_faces / lanes][3][lanes];

    static std::int16_t flipped(std::uint16_t x) noexcept { return std::int16_t(x ^ 0x8000u); }

    template <class Entries>
    explicit box_block(const Entries& made) noexcept {
        const std::size_t n = std::min(made.size(), max_faces);
        blocks = (n + lanes - 1) / lanes;
        for (std::size_t b = 0; b < blocks; ++b)
            for (int i = 0; i < 3; ++i)
                for (std::size_t k = 0; k < lanes; ++k) {
                    const std::size_t at = b * lanes + k;
                    lo[b][i][k] = flipped(at < n ? made[at].lo[i] : std::uint16_t(0xffff));
                    hi[b][i][k] = flipped(at < n ? made[at].hi[i] : std::uint16_t(0));
                }
    }
    /// Bit k: the entry's box overlaps new face k's (the first max_faces of them).
    std::uint32_t overlapping(const self_intersection_index::entry& g) const noexcept {
        std::uint32_t bits = 0;
        for (std::size_t b = 0; b < blocks; ++b) {
#if defined(__SSE2__)
            __m128i apart = _mm_setzero_si128();
            for (int i = 0; i < 3; ++i) {
                const __m128i glo = _mm_set1_epi16(flipped(g.lo[i]));
                const __m128i ghi = _mm_set1_epi16(flipped(g.hi[i]));
                const __m128i l = _mm_load_si128(reinterpret_cast<const __m128i*>(lo[b][i]));
                const __m128i h = _mm_load_si128(reinterpret_cast<const __m128i*>(hi[b][i]));
                apart = _mm_or_si128(
                    apart, _mm_or_si128(_mm_cmplt_epi16(ghi, l), _mm_cmplt_epi16(h, glo)));
            }
            const auto block = std::uint32_t(
                ~_mm_movemask_epi8(_mm_packs_epi16(apart, _mm_setzero_si128())) & 0xffu);
#else
            std::uint32_t block = 0;
            for (std::size_t k = 0; k < lanes; ++k) {
                bool apart = false;
                for (int i = 0; i < 3; ++i)
                    apart =
                        apart || flipped(g.hi[i]) < lo[b][i][k] || hi[b][i][k] < flipped(g.lo[i]);
                block |= std::uint32_t(!apart) << k;
            }
#endif
            bits |= block << (b * lanes);
        }
        return bits;
    }
};

/// The scan's first question to every entry of a cell: does its box overlap `around` (all
/// the new faces' box), and does it start in this cell (`from`: the cell's first quantum on
/// each axis where the cell is not on the scan's low side), so that a face met in several
/// cells is taken once. Six compares of 16-bit lanes at once (SSE2; plain compares
/// elsewhere): an entry is its box's six coordinates, then its face.
struct entry_filter {
    using entry = self_intersection_index::entry;
    static_assert(sizeof(entry) == 16 && offsetof(entry, hi) == 6 && offsetof(entry, face) == 12);
#if defined(__SSE2__)
    __m128i upper, lower; // entry - upper and lower - entry (saturated) are 0 where kept
    entry_filter(const entry& around, const std::array<std::uint16_t, 3>& from) noexcept {
        auto lane = [](std::uint16_t x) { return std::int16_t(x); };
        upper = _mm_setr_epi16(lane(around.hi[0]), lane(around.hi[1]), lane(around.hi[2]), -1, -1,
                               -1, -1, -1);
        lower = _mm_setr_epi16(lane(from[0]), lane(from[1]), lane(from[2]), lane(around.lo[0]),
                               lane(around.lo[1]), lane(around.lo[2]), 0, 0);
    }
    bool keeps(const entry& g) const noexcept {
        const __m128i e = _mm_loadu_si128(reinterpret_cast<const __m128i*>(&g));
        const __m128i out = _mm_or_si128(_mm_subs_epu16(e, upper), _mm_subs_epu16(lower, e));
        return _mm_movemask_epi8(_mm_cmpeq_epi16(out, _mm_setzero_si128())) == 0xffff;
    }
#else
    entry around;
    std::array<std::uint16_t, 3> from;
    entry_filter(const entry& a, const std::array<std::uint16_t, 3>& f) noexcept
        : around(a)
        , from(f) {}
    bool keeps(const entry& g) const noexcept {
        return g.lo[0] >= from[0] && g.lo[1] >= from[1] && g.lo[2] >= from[2] &&
               self_intersection_index::overlap(around, g);
    }
#endif
};

/// Whether the star of vertex a (the faces `faces`, all of them) is embedded: no two of
/// its faces meet except along the edges and at the vertex they share. Shown at once:
/// seen along the mean normal every face turns the same way (exact orientations) and
/// together they turn around a once (less than once if a is on the boundary). Then the
/// view maps the star one-to-one, so no two of its faces can meet elsewhere. Most stars
/// pass; for the others the caller tests faces pair by pair.
template <class Mesh, class Faces>
bool star_embeds(const Mesh& m, index_t a, const Faces& faces) {
    const std::size_t k = std::size(faces);
    boost::container::small_vector<std::pair<index_t, index_t>, 24> sides; // corners after a
    for (index_t f : faces) {
        const auto& fv = m.face_vertices(f);
        const int i = fv[0] == a ? 0 : fv[1] == a ? 1 : fv[2] == a ? 2 : -1;
        if (i < 0) return false;
        sides.push_back({fv[(i + 1) % 3], fv[(i + 2) % 3]});
    }
    if (k == 0) return false;
    // The rim in order: x0, x1, ... (each face goes from one rim vertex to the next).
    const bool open = m.is_boundary_vertex(a);
    std::size_t first = 0;
    if (open)
        while (first < k && std::any_of(sides.begin(), sides.end(), [&](const auto& e) {
                   return e.second == sides[first].first;
               }))
            ++first;
    if (first == k) return false;
    boost::container::small_vector<index_t, 25> rim{sides[first].first};
    for (std::size_t step = 0; step < k; ++step) {
        const index_t x = rim.back();
        const auto it =
            std::find_if(sides.begin(), sides.end(), [&](const auto& e) { return e.first == x; });
        if (it == sides.end()) return false;
        rim.push_back(it->second);
    }
    if (!open && rim.back() != rim.front()) return false;
    const vec3 pa = m.position(a);
    vec3 normal{0, 0, 0};
    double reach = 0;
    for (std::size_t i = 0; i < k; ++i) {
        const vec3 u = m.position(rim[i]) - pa, v = m.position(rim[i + 1]) - pa;
        normal += cross(u, v);
        reach = std::max(reach, norm(u));
    }
    const double length = norm(normal);
    if (!(length > 0) || !(reach > 0) || !std::isfinite(length * reach)) return false;
    const vec3 eye = pa + normal * (reach / length);
    const vec3 up = eye - pa; // the direction the orientations below are exact for
    for (std::size_t i = 0; i < k; ++i)
        if (orient3d(pa, m.position(rim[i]), m.position(rim[i + 1]), eye) <= 0) return false;
    // Each turn from one spoke to the next is counter-clockwise and below half a turn; the
    // fan goes around once if no turn but the last passes the first spoke's direction.
    const vec3 r0 = m.position(rim[0]) - pa;
    const std::size_t last = open ? k : k - 1;
    for (std::size_t i = 1; i < last; ++i) {
        const vec3 u = m.position(rim[i]) - pa, v = m.position(rim[i + 1]) - pa;
        const double tol = 1e-9 * norm(r0) * norm(up) * std::max(norm(u), norm(v));
        if (!(dot(cross(u, r0), up) < -tol || dot(cross(r0, v), up) < -tol)) return false;
    }
    return true;
}

/// The faces an operation of kind Op at t may change or remove.
template <class Op, class Mesh, class Fn>
void changed_faces(const Mesh& m, const typename Mesh::tuple& t, Fn&& fn) {
    if constexpr (std::is_same_v<Op, op::split_edge> || std::is_same_v<Op, op::swap_edge>) {
        fn(t.fid); // rewritten in place; the new faces come from the pool
        if (const auto g = m.switch_face(t)) fn(g->fid);
    } else {
        // Every face of the seeds' stars (a collapse rewrites both, a move renews one).
        const auto s = seeds<Op>(m, t);
        for (std::size_t i = 0; i < s.size(); ++i)
            for (index_t f : m.vertex_faces(s[i])) {
                bool seen = false;
                for (std::size_t j = 0; j < i && !seen; ++j) {
                    const auto& fv = m.face_vertices(f);
                    seen = fv[0] == s[j] || fv[1] == s[j] || fv[2] == s[j];
                }
                if (!seen) fn(f);
            }
    }
}

} // namespace detail::self_intersection

/// The invariant (see the top of this file).
class no_self_intersection {
public:
    static constexpr bool commits_on_accept = true;
    static constexpr bool claims_space = true;

    struct state {
        cell_range reach; // lock cells the operation may touch
        boost::container::small_vector<std::pair<index_t, cell_range>, 24> changed;
    };

    /// Disabled: accepts everything, claims nothing.
    no_self_intersection() = default;
    explicit no_self_intersection(self_intersection_index& index) noexcept
        : index_(&index) {}

    bool enabled() const noexcept { return index_ != nullptr; }

    /// Rebuilds the index once the live faces are a quarter of those it was built with
    /// (their edges about twice as long). Decimation grows the faces: with the grid of
    /// the input, a face of the 1% output spans some 3 x 3 x 2 cells, so each scan and
    /// each move visits many cells (bench/RESULTS.md). The answers stay exact at any cell
    /// size. Only where no operation runs (a spec's `quiescent` hook).
    template <class Mesh>
    void refit(const Mesh& m, std::int64_t live_faces) {
        if (index_ && live_faces >= 0 && 4 * std::size_t(live_faces) <= index_->faces_indexed())
            index_->rebuild(m);
    }

    template <class Mesh>
    std::size_t extra_lock_words(const Mesh&) const noexcept {
        return index_ ? index_->lock_cells() : 0;
    }

    /// Where lock word k (past the vertices) lies: the centre of its cell. A deterministic
    /// run gives each word to the group of the vertices around it (exec/deterministic.hpp).
    vec3 lock_cell_centre(std::size_t k) const noexcept {
        return index_ ? index_->lock_cell_centre(k) : vec3{0, 0, 0};
    }

    /// Takes the lock cells of the operation's reach (its star held already).
    template <class Op, class Mesh, class Take>
    bool claim(Op, const Mesh& m, const typename Mesh::tuple& t, Take& take,
               std::size_t first_word) const {
        if (!index_) return true;
        const cell_range l = reach<Op>(m, t);
        for (std::int32_t z = l.lo[2]; z <= l.hi[2]; ++z)
            for (std::int32_t y = l.lo[1]; y <= l.hi[1]; ++y)
                for (std::int32_t x = l.lo[0]; x <= l.hi[0]; ++x)
                    if (!take(index_t(first_word + index_->lock_word(x, y, z)))) return false;
        return true;
    }

    template <class Op, class Mesh>
    bool before(Op, const Mesh& m, const typename Mesh::tuple& t, state& s) const {
        if (!index_) return true;
        s.reach = reach<Op>(m, t);
        detail::self_intersection::changed_faces<Op>(m, t, [&](index_t f) {
            s.changed.push_back({f, index_->range_of(index_->entry_of(m, f))});
        });
        return true;
    }

    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh& m, const Result& r, state& s) const {
        if (!index_ || r.cells.empty()) return true;
        namespace si = detail::self_intersection;
        using entry = self_intersection_index::entry;
        const std::size_t n = r.cells.size();
        boost::container::small_vector<entry, 24> made;
        boost::container::small_vector<cell_range, 24> ranges;
        boost::container::small_vector<si::triangle, 24> shape;
        entry around{}; // all new faces' box
        for (std::size_t k = 0; k < n; ++k) {
            const index_t f = r.cells[k].fid;
            made.push_back(index_->entry_of(m, f));
            ranges.push_back(index_->range_of(made.back()));
            shape.push_back(si::triangle_of(m, f));
            if (!s.reach.contains(self_intersection_index::locks_of(ranges.back()))) return false;
            if (k == 0) around = made[0];
            for (int i = 0; i < 3; ++i)
                around.lo[i] = std::min(around.lo[i], made[k].lo[i]),
                around.hi[i] = std::max(around.hi[i], made[k].hi[i]);
        }
        // Memory first, work while it arrives: ask for the grid cells the new faces overlap,
        // test the new faces against each other, then ask for the cells' entries (every
        // line of them), build the box block, and only then scan.
        const cell_range all = index_->range_of(around);
        self_intersection_index::for_each_cell(all,
                                               [&](std::uint64_t key) { index_->prefetch(key); });
        // The new faces against each other: at once where they are the anchor's whole star
        // (a split's, a collapse's or a move's), else pair by pair.
        boost::container::small_vector<index_t, 24> ids;
        for (const auto& c : r.cells) ids.push_back(c.fid);
        const index_t anchor = r.anchor.vid;
        const bool whole_star = std::size_t(std::ranges::distance(m.vertex_faces(anchor))) == n &&
                                std::ranges::all_of(m.vertex_faces(anchor),
                                                    [&](index_t f) { return is_among(made, f); });
        if (!whole_star || !si::star_embeds(m, anchor, ids))
            for (std::size_t k = 0; k < n; ++k)
                for (std::size_t l = k + 1; l < n; ++l)
                    if (overlap(made[k], made[l]) && si::meet(shape[k], shape[l])) return false;
        // Each candidate is taken once: from the cell of `all` that holds the lowest corner
        // of its box within `all`, that is, where its box starts at or after the cell's
        // first quantum on each axis where that cell is not on `all`'s low side.
        struct cell_at {
            const self_intersection_index::cell* entries;
            std::array<std::uint16_t, 3> from;
        };
        boost::container::small_vector<cell_at, 32> cells;
        self_intersection_index::for_each_cell(all, [&](std::uint64_t key) {
            const auto* c = index_->find(key);
            if (!c || c->empty()) return;
            const auto* bytes = reinterpret_cast<const char*>(c->data());
            for (std::size_t at = 0; at < c->size() * sizeof(entry); at += 64)
                __builtin_prefetch(bytes + at);
            const auto where = self_intersection_index::coordinates(key);
            cell_at cell{c, {}};
            for (int i = 0; i < 3; ++i)
                cell.from[i] = where[i] == all.lo[i] ? 0 : index_->first_quantum(where[i]);
            cells.push_back(cell);
        });
        // The candidates first, then their corners, then the tests: each step asks for
        // the memory the next one reads (a candidate's face, then its vertices' positions),
        // so that the cache misses of all candidates overlap instead of following each
        // other (they were half of this check's time).
        const si::box_block boxes(made);
        struct candidate {
            entry g;
            std::uint32_t near; // bit k: new face k's box overlaps (the first 32 of them)
            bool beyond;        // a new face past the first 32 overlaps
        };
        // The new faces' ids, hashed to one bit each: most entries are ruled out by it
        // before the list is searched (a rewritten face's entry still has its old box).
        std::uint64_t made_bits = 0;
        for (const entry& e : made) made_bits |= std::uint64_t(1) << (e.face & 63u);
        boost::container::small_vector<candidate, 64> found;
        for (const auto& [entries, from] : cells) {
            const si::entry_filter first(around, from);
            for (const entry& g : *entries) {
                if (!first.keeps(g)) continue;
                const std::uint32_t near = boxes.overlapping(g);
                bool beyond = false;
                for (std::size_t k = si::box_block::max_faces; k < n && !beyond; ++k)
                    beyond = overlap(made[k], g);
                if ((near == 0 && !beyond) ||
                    ((made_bits >> (g.face & 63u) & 1u) && is_among(made, g.face)))
                    continue;
                __builtin_prefetch(&m.face_vertices(g.face));
                found.push_back({g, near, beyond});
            }
        }
        for (const candidate& c : found)
            if (m.face_alive(c.g.face))
                for (index_t v : m.face_vertices(c.g.face)) __builtin_prefetch(&m.position(v));
        si::triangle other; // out of the loop: made once, not zeroed per candidate
        for (const candidate& c : found) {
            if (!m.face_alive(c.g.face)) continue;
            // The candidate's plane only when a new face's plane cannot part them.
            const auto& gv = m.face_vertices(c.g.face);
            const std::array<vec3, 3> gp{m.position(gv[0]), m.position(gv[1]), m.position(gv[2])};
            bool built = false;
            auto meets = [&](std::size_t k) {
                if (plane_separates(shape[k], gp, gv)) return false;
                if (!built) other = si::triangle(gp, gv), built = true;
                return faces_meet(shape[k], other, true);
            };
            for (std::uint32_t near = c.near; near != 0; near &= near - 1)
                if (meets(std::size_t(std::countr_zero(near)))) return false;
            if (c.beyond)
                for (std::size_t k = si::box_block::max_faces; k < n; ++k)
                    if (overlap(made[k], c.g) && meets(k)) return false;
        }
        return commit(s, made, ranges);
    }

private:
    /// The lock cells an operation may touch: its star's box grown by half its size.
    template <class Op, class Mesh>
    cell_range reach(const Mesh& m, const typename Mesh::tuple& t) const {
        vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
        for (index_t v : detail::self_intersection::seeds<Op>(m, t))
            for (index_t f : m.vertex_faces(v))
                for (index_t w : m.face_vertices(f)) {
                    const vec3& p = m.position(w);
                    for (int i = 0; i < 3; ++i)
                        lo[i] = std::min(lo[i], p[i]), hi[i] = std::max(hi[i], p[i]);
                }
        const double grow = 0.5 * std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
        const vec3 g{grow, grow, grow};
        return self_intersection_index::locks_of(index_->range_of(index_->box_of(lo - g, hi + g)));
    }

    static bool overlap(const self_intersection_index::entry& a,
                        const self_intersection_index::entry& b) noexcept {
        return self_intersection_index::overlap(a, b);
    }
    template <class Entries>
    static bool is_among(const Entries& made, index_t f) noexcept {
        for (const auto& e : made)
            if (e.face == f) return true;
        return false;
    }

    /// Moves the changed faces in the index: out of their old cells, into their new ones.
    template <class Made, class Ranges>
    bool commit(const state& s, const Made& made, const Ranges& ranges) const {
        using entry = self_intersection_index::entry;
        const std::size_t n = made.size();
        boost::container::small_vector<bool, 24> placed(n, false);
        for (const auto& [f, old] : s.changed) {
            std::size_t k = 0;
            while (k < n && made[k].face != f) ++k;
            const bool same_cells = k < n && ranges[k] == old;
            self_intersection_index::for_each_cell(old, [&](std::uint64_t key) {
                auto& cell = index_->find_or_add(key);
                auto it = std::find_if(cell.begin(), cell.end(),
                                       [&](const entry& e) { return e.face == f; });
                if (it == cell.end()) return;
                if (same_cells) {
                    *it = made[k]; // same cells, new box
                } else {
                    *it = cell.back();
                    cell.pop_back();
                }
            });
            if (same_cells) placed[k] = true;
        }
        for (std::size_t k = 0; k < n; ++k) {
            if (placed[k]) continue;
            self_intersection_index::for_each_cell(ranges[k], [&](std::uint64_t key) {
                index_->push(index_->find_or_add(key), made[k]);
            });
        }
        return true;
    }

    self_intersection_index* index_ = nullptr;
};

static_assert(invariant<no_self_intersection>);

/// Pairs of faces of m that meet anywhere but at shared vertices and edges (exact). For
/// tests and reports: builds its own index.
template <class Mesh>
std::size_t count_self_intersections(const Mesh& m) {
    namespace si = detail::self_intersection;
    const self_intersection_index index(m);
    using entry = self_intersection_index::entry;
    std::size_t pairs = 0;
    for (index_t f = 0; f < m.face_slots(); ++f) {
        if (!m.face_alive(f)) continue;
        const entry e = index.entry_of(m, f);
        const cell_range r = index.range_of(e);
        const si::triangle t = si::triangle_of(m, f);
        self_intersection_index::for_each_cell(r, [&](std::uint64_t key) {
            const auto* cell = index.find(key);
            if (!cell) return;
            const auto here = self_intersection_index::coordinates(key);
            for (const entry& g : *cell) {
                if (g.face <= f || !self_intersection_index::overlap(e, g)) continue;
                const cell_range gr = index.range_of(g);
                if (std::max(gr.lo[0], r.lo[0]) != here[0] ||
                    std::max(gr.lo[1], r.lo[1]) != here[1] ||
                    std::max(gr.lo[2], r.lo[2]) != here[2])
                    continue;
                pairs += si::meet(t, si::triangle_of(m, g.face));
            }
        });
    }
    return pairs;
}

} // namespace idas
