// TetWild's mesh improvement (Hu et al. 2018, 2020) as four IDAS specs run in turn, one
// executor each, until the worst tet is good enough:
//
//   split     edges longer than 4/3 of the local target length, at their midpoints,
//             longest first
//   collapse  edges shorter than 4/5 of it, shortest first, into one end, unless the
//             largest AMIPS energy of the changed tets would rise above both its old value
//             and 0.6 of the stop energy (a surface vertex may go into any vertex: the
//             envelope decides, as in fTetWild); a vertex still rational goes into a
//             neighbour whatever the length
//   swap      edge removal (3-2, 4-4 and n-(2n-4) swaps, the best triangulation of the
//             ring) and 2-3 face swaps around the tets whose energy is above a bar, when
//             they lower the largest energy of the tets they replace, worst tets first
//   smooth    each vertex one Newton step on the AMIPS energy of its star (line search),
//             accepted when the star's sum falls and its maximum does not rise; surface
//             vertices are projected back onto the input, open-border vertices onto the
//             borders
//
//   I  every tet positively oriented (exact orient3d; on the exact coordinates where a
//      vertex is still rational); every tracked face inside the input's envelope
//   A  per tet: which of its faces are tracked (cover the input); per vertex: its kind
//      (surface, feature, rational), the sizing field's length there and the adaptive
//      scale of it
//   S  a collapse and a smoothing pass first (the insertion leaves many short edges),
//      then rounds of the four; a round that leaves a few tets above the stop energy is
//      touched up by collapses, swaps and smoothing; after each round, rational vertices
//      are rounded where every tet stays positive, and where the energy stalled (or
//      crawled) the target length shrinks around the bad tets and grows back elsewhere
//      (fTetWild's adaptive sizing); stop when the largest energy is at most the stop
//      energy, or after the iteration limit; last, a pass of collapses at the full target
//      length (as loose about the energy as the first rounds), swaps and smoothing, up to
//      three times
//
// What must stay: the tracked surface (a tracked face is never swapped away, a surface
// vertex moves or vanishes only within the envelope, into any vertex, through the volume
// too; where surfaces cross, too, as in fTetWild), its open borders (feature vertices
// slide along them and vanish into other vertices while the border's edges stay within
// border_epsilon of the borders at the start, as in fTetWild's boundary envelope), and the
// bounding box (a vertex on a box plane stays on it: splits keep the coordinate, collapses
// need the survivor on every plane of the removed vertex, smoothing keeps it).
#pragma once

#include <idas/core/aabb_tree.hpp>
#include <idas/exec/executor.hpp>
#include <idas/exec/schedule.hpp>
#include <idas/exec/workers.hpp>
#include <idas/mesh/geometry_range.hpp>
#include <idas/mesh/sizing_field.hpp>
#include <idas/mesh/temporary_attribute.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/mesh/tet_quality.hpp>
#include <idas/ops/tet_ops.hpp>
#include <idas/predicates/rational.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <ranges>
#include <unordered_map>
#include <vector>

namespace idas::algorithms {

/// Bits of a vertex's kind during tet optimization.
namespace tet_vertex {
inline constexpr std::uint8_t surface = 1;  ///< on a tracked face
inline constexpr std::uint8_t feature = 2;  ///< on a tracked edge in an odd number of tracked
                                            ///< faces (an open border): moves along it
inline constexpr std::uint8_t rational = 4; ///< exact position only in the rational table,
                                            ///< the mesh holds its nearest double
inline constexpr std::uint8_t merged = 8;   ///< on a tracked face where a collapse merged
                                            ///< two (or on what splits and collapses made of
                                            ///< its edges): an odd edge at such a vertex
                                            ///< need not be a border
} // namespace tet_vertex

/// An envelope of the input surface: exact containment of triangles.
template <class E>
concept triangle_envelope = requires(const E& e, const vec3& p) {
    { e.contains(p, p, p) } -> std::convertible_to<bool>;
};

struct tet_optimization_options {
    double target_length = 0;     ///< absolute target edge length L (> 0), where no field is given
    double stop_energy = 10;      ///< stop when the largest AMIPS is at most this
    unsigned max_iterations = 80; ///< rounds of split, collapse, swap, smooth
    /// Stop once this many rounds in a row have lowered neither the largest AMIPS nor the
    /// number of tets above stop_energy below their best so far (0: never). A tet whose
    /// every neighbour is held (armadillo: a tet of 21.8 with three faces on the surface,
    /// from round 12) otherwise ran all 80 rounds; by then adaptive sizing has shrunk the
    /// target around it to its floor (min_scale: five halvings, one every other round).
    unsigned stall_rounds = 12;
    /// Swaps are tried around tets with AMIPS above this. fTetWild tries every edge; 5
    /// keeps most of what that gains (fewer tets, lower energies) at a fraction of the
    /// tries; bench/RESULTS.md, session 24.
    double swap_above = 5;
    /// A collapse may raise the largest AMIPS of its star up to this fraction of
    /// stop_energy (0: never raise it, fTetWild's rule), until the energy first stalls.
    /// With fTetWild's rule idas kept 1.0-1.4x its tets; bench/RESULTS.md, session 23.
    double collapse_up_to = 0.6;
    /// The same in the last pass, which undoes adaptive sizing. With fTetWild's rule there
    /// it collapsed 155 edges of a 320-shard soup's 117,000 tets (adaptive sizing had
    /// grown them from 30,000), whose output kept 1.4x fTetWild's tets; 0.6 and the
    /// repeated pass keep 0.95-1.09x of them, at a mean AMIPS up to 0.2 higher than the
    /// strict pass gave (bench/RESULTS.md, session 56).
    double last_pass_up_to = 0.6;
    /// The last pass runs again, up to this many times in all, while a pass removes at
    /// least 1% of the tets: its swaps and smoothing let through collapses it refused
    /// (on a 320-shard soup the second pass removed 7% of the inside tets, the third 3%).
    unsigned last_passes = 3;
    double min_length = 0;       ///< a sizing field's smaller values are raised to this
    double min_scale = 1.0 / 32; ///< adaptive sizing never shrinks the target below this fraction
    /// A round that leaves at most this many tets above stop_energy is followed by
    /// collapses, swaps and smoothing (no splits) before the energy is judged (0: never).
    /// The order the operations run in decides whether a round leaves a few flat tets,
    /// and a whole round more for them cost the sphere a third of its optimization. Swaps
    /// and smoothing alone cleared one or two; the 40 that the deterministic order leaves
    /// on the sphere need the collapses too, which then also remove what the round's
    /// collapses refused (bench/RESULTS.md, "Session 44").
    std::size_t touch_up_tets = 64;
    /// The touch-up's swaps and smoothing start on the vertices within this many rings of
    /// the tets above stop_energy (renewals then go where they go); 0: on every vertex.
    /// The bad tets sit in a few small clusters: smoothing every vertex again for them
    /// cost the sphere's 2-thread run as much as its round's smoothing. Its collapses
    /// start everywhere: started near the bad tets only, they left x.stl 5-11% more tets
    /// (bench/RESULTS.md, "Session 45").
    unsigned touch_up_rings = 2;
    /// A vertex on an open border (a curve of edges in an odd number of tracked faces)
    /// slides along the borders and may vanish into another vertex where the border's
    /// edges stay within this distance of the borders the insertion left (fTetWild's
    /// boundary envelope, at its epsilon); 0: it never moves, and vanishes only into a
    /// neighbour along its border where the border stays where it was. Kept where it was,
    /// the insertion's short border edges and the slivers at them could never go: a soup
    /// whose triangles share no vertex is all border.
    double border_epsilon = 0;
    /// The energy counts as stalled (and the sizing adapts) also when a round lowered the
    /// largest AMIPS, but so slowly that at that rate reaching stop_energy would take more
    /// than this many rounds, while the count of tets above it fell by less than a tenth
    /// (0: fTetWild's test alone). In such runs the largest energy never fell by less than
    /// the 0.5 fTetWild's test asks: a nearly flat tet with its four vertices on the surface halved
    /// its energy each round from 1e10 for 30 rounds, and 320 shards' border tets went from 4,030
    /// to 800 in eleven rounds with over a thousand tets above 10 (bench/RESULTS.md, session 58).
    unsigned slow_rounds = 8;
};

enum class tet_optimization_stop { energy_reached, iteration_limit, already_good, stalled };

/// The largest and the mean AMIPS of a mesh (over the tets whose energy is finite), and how
/// many tets are above the stop energy.
struct energy_summary {
    double max = 0, mean = 0;
    std::size_t above = 0;
};

/// Whether the round from `before` to `now` stalled the energy, so that the target length
/// shrinks around the bad tets: fTetWild's test (the largest energy fell by less than 0.5
/// and the mean by less than a tenth), or a fall too slow to reach `stop` within
/// `slow_rounds` more rounds like it while the tets above `stop` stay nearly as many
/// (tet_optimization_options::slow_rounds).
inline bool energy_stalled(const energy_summary& before, const energy_summary& now, double stop,
                           unsigned slow_rounds) {
    if (before.max - now.max < 0.5 && before.mean - now.mean < 0.1 * before.mean) return true;
    if (slow_rounds == 0 || !(now.max > stop) || !(before.max > now.max) ||
        !std::isfinite(before.max))
        return false;
    if (10 * (before.above - std::min(before.above, now.above)) >= before.above) return false;
    return std::log(now.max / stop) > double(slow_rounds) * std::log(before.max / now.max);
}

/// Counts the rounds in a row that improved on neither the best largest energy nor the
/// best count of tets above the stop energy (tet_optimization_options::stall_rounds).
class stall_watch {
public:
    explicit stall_watch(unsigned limit) noexcept
        : limit_(limit) {}
    /// After a round: whether the run has stalled for `limit` rounds in a row.
    bool stalled_after(double max_energy, std::size_t above) noexcept {
        const bool progress = max_energy < best_max_ || above < best_above_;
        best_max_ = std::min(best_max_, max_energy);
        best_above_ = std::min(best_above_, above);
        idle_ = progress ? 0 : idle_ + 1;
        return limit_ > 0 && idle_ >= limit_;
    }

private:
    unsigned limit_, idle_ = 0;
    double best_max_ = std::numeric_limits<double>::infinity();
    std::size_t best_above_ = std::numeric_limits<std::size_t>::max();
};

struct tet_optimization_report {
    unsigned iterations = 0;
    tet_optimization_stop stopped = tet_optimization_stop::iteration_limit;
    std::uint64_t splits = 0, collapses = 0, swaps = 0, smooths = 0, rounded = 0;
    std::uint64_t sizing_refinements = 0; ///< vertices whose target length was halved
    unsigned touch_ups = 0;               ///< rounds followed by swaps and smoothing alone
    unsigned last_passes = 0;             ///< passes of the last collapses, swaps and smoothing
    std::size_t rational_left = 0;
    double max_energy_before = 0, max_energy = 0;
    std::vector<double> max_energy_history;      ///< after each round
    std::vector<std::size_t> above_stop_history; ///< tets above stop_energy after each round
    std::array<run_report, 4> phases{};          ///< split, collapse, swap, smooth: summed
    double seconds = 0;
};

/// Hears nothing of the rounds (the default observer).
struct no_round_observer {
    void operator()(unsigned, double) const noexcept {}
};

/// Verdicts of recent containment checks, by the exact corner positions. The envelope is
/// fixed for a whole optimization, and a collapse the envelope refused is tried again, with
/// the same faces, in every round: on blub, 73% of the checks repeat an earlier one.
///
/// One table for all threads, direct-mapped (a newer triangle takes its slot). Each slot is
/// a sequence lock over atomic fields: a reader uses a slot only if its sequence number was
/// even and unchanged across the read, and a writer that finds the slot busy leaves it, so
/// a verdict is only ever reused for the very same triangle (the key is compared in full).
class containment_memo {
public:
    /// A table of at least `slots` entries (rounded up to a power of two, at least 2^12).
    explicit containment_memo(std::size_t slots)
        : bits_(std::max(12, int(std::bit_width(std::max<std::size_t>(slots, 1) - 1))))
        , table_(std::size_t(1) << bits_) {}

    /// env.contains(a, b, c), remembered. Containment does not depend on the corners'
    /// order, so they are sorted first.
    template <triangle_envelope Envelope>
    bool contains(const Envelope& env, vec3 a, vec3 b, vec3 c) {
        auto before = [](const vec3& x, const vec3& y) {
            return x.x != y.x ? x.x < y.x : x.y != y.y ? x.y < y.y : x.z < y.z;
        };
        if (before(b, a)) std::swap(a, b);
        if (before(c, b)) std::swap(b, c);
        if (before(b, a)) std::swap(a, b);
        const std::array<double, 9> key{a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z};
        std::uint64_t h = 0x9e3779b97f4a7c15ull;
        for (const double x : key) {
            std::uint64_t word;
            std::memcpy(&word, &x, sizeof word);
            h = (h ^ word) * 0xff51afd7ed558ccdull;
            h ^= h >> 29;
        }
        entry& e = table_[h >> (64 - bits_)];
        // Without fences (TSan does not model them): the fields are read with acquire, so
        // the second read of the sequence comes after them, and written with release, so a
        // reader that sees a new field also sees the odd sequence number before it.
        const std::uint64_t seq = e.seq.load(std::memory_order_acquire);
        if (!(seq & 1u)) {
            bool same = true;
            for (int k = 0; k < 9; ++k) same &= e.key[k].load(std::memory_order_acquire) == key[k];
            const std::uint8_t verdict = e.verdict.load(std::memory_order_acquire);
            if (same && verdict != unknown && e.seq.load(std::memory_order_relaxed) == seq)
                return verdict == inside;
        }
        const bool in = env.contains(a, b, c);
        std::uint64_t now = e.seq.load(std::memory_order_relaxed);
        if (!(now & 1u) && e.seq.compare_exchange_strong(now, now + 1, std::memory_order_acq_rel)) {
            for (int k = 0; k < 9; ++k) e.key[k].store(key[k], std::memory_order_release);
            e.verdict.store(in ? inside : outside, std::memory_order_release);
            e.seq.store(now + 2, std::memory_order_release);
        }
        return in;
    }

private:
    enum : std::uint8_t { unknown, outside, inside };
    struct entry {
        std::atomic<std::uint64_t> seq{0};
        std::array<std::atomic<double>, 9> key{};
        std::atomic<std::uint8_t> verdict{unknown};
    };
    int bits_;
    std::vector<entry> table_;
};

/// What the phase specs share. The attribute columns belong to the run.
struct tet_optimization_state {
    double swap_above = 4;
    double collapse_up_to = 0; ///< absolute AMIPS (tet_optimization_options::collapse_up_to)
    tet_attribute<std::uint8_t> tracked; ///< bit lf: local face lf is tracked
    vertex_attribute<std::uint8_t> kind; ///< tet_vertex bits
    vertex_attribute<double> length;     ///< the sizing field at the vertex (absolute)
    vertex_attribute<double> scale;      ///< local target length: `length` times this
    /// Exact positions of the vertices whose kind has tet_vertex::rational. Read-only
    /// while phases run.
    const std::unordered_map<index_t, rational_point>* exact = nullptr;
    const triangle_aabb_tree* input = nullptr; ///< the input surface, for projection
    /// The open borders at the start, one degenerate triangle (p, q, q) per edge, and how
    /// far a border edge may stray from them (tet_optimization_options::border_epsilon).
    triangle_aabb_tree border;
    double border_epsilon = 0;
    vec3 box_lo{}, box_hi{}; ///< the background's bounding box
    /// Remembered containment verdicts (see containment_memo).
    containment_memo* verdicts = nullptr;
    /// Where swaps and smoothing start: the vertices flagged here (a touch-up's), or every
    /// vertex if empty. Read-only while phases run.
    std::vector<std::uint8_t> focus;

    bool in_focus(index_t v) const noexcept {
        return focus.empty() || (v < focus.size() && focus[v] != 0);
    }

    /// Which box planes p lies on: bit 2k for the low plane of axis k, 2k+1 for the high.
    std::uint8_t box_planes(const vec3& p) const noexcept {
        std::uint8_t m = 0;
        for (int k = 0; k < 3; ++k) {
            if (p[k] == box_lo[k]) m |= std::uint8_t(1u << (2 * k));
            if (p[k] == box_hi[k]) m |= std::uint8_t(1u << (2 * k + 1));
        }
        return m;
    }
};

namespace detail {

using idas::detail::sorted_triple;

/// Tracked faces (sorted vertex triples) among the tets an operation replaces.
using tracked_faces = boost::container::small_vector<tri_indices, 24>;

inline bool has(const tri_indices& k, index_t v) noexcept {
    return k[0] == v || k[1] == v || k[2] == v;
}

inline bool holds(const tracked_faces& l, const tri_indices& k) noexcept {
    // Compared word by word: std::array's == became a call to memcmp per element here.
    return std::any_of(l.begin(), l.end(), [&](const tri_indices& x) {
        return x[0] == k[0] && x[1] == k[1] && x[2] == k[2];
    });
}

template <class Mesh>
void gather_tracked(const Mesh& m, const tet_optimization_state& s, index_t g, tracked_faces& out) {
    const std::uint8_t bits = m.attribute(s.tracked)[g];
    if (!bits) return;
    const auto& tv = m.tet_vertices(g);
    for (std::uint8_t lf = 0; lf < 4; ++lf)
        if (bits >> lf & 1u) {
            const auto f = tet_local::face_vertices[lf];
            const tri_indices k = sorted_triple(tv[f[0]], tv[f[1]], tv[f[2]]);
            if (!holds(out, k)) out.push_back(k);
        }
}

/// Sets the tracked bits of the operation's new tets: face lf is tracked iff
/// `tracked(sorted triple)` says so.
template <class Mesh, class Tracked>
void retrack(Mesh& m, const tet_optimization_state& s, const op_result<tet_tuple>& r,
             Tracked&& tracked) {
    auto col = m.attribute(s.tracked, r);
    for (const tet_tuple& c : r.cells) {
        const auto& tv = m.tet_vertices(c.tid);
        std::uint8_t bits = 0;
        for (std::uint8_t lf = 0; lf < 4; ++lf) {
            const auto f = tet_local::face_vertices[lf];
            if (tracked(c.tid, lf, sorted_triple(tv[f[0]], tv[f[1]], tv[f[2]])))
                bits |= std::uint8_t(1u << lf);
        }
        if (col[c.tid] != bits) col.set(c.tid, bits);
    }
}

/// Whether segment pq lies within r of the union of `border`'s segments. The distance to
/// one segment is convex along pq, so a piece whose two ends are within r of the same
/// segment lies within r of it; a piece that no one segment holds is halved, down to 1/64
/// of pq, then refused. Distances in doubles: what the output promises (the surface within
/// epsilon) the exact envelope checks; this keeps the open borders where they were.
inline bool near_border(const triangle_aabb_tree& border, double r, const vec3& p, const vec3& q,
                        int halvings = 6) {
    const double r2 = r * r;
    bool near_p = false, held = false;
    border.for_each_face_within(p, r2, [&](index_t f, double) {
        near_p = true;
        const auto t = border.triangle(f);
        held = squared_norm(q - closest_point_on_triangle(q, t[0], t[1], t[2])) <= r2;
        return !held;
    });
    if (held) return true;
    if (!near_p || halvings == 0 || !border.within_squared_distance(q, r2)) return false;
    const vec3 mid = (p + q) * 0.5;
    return near_border(border, r, p, mid, halvings - 1) &&
           near_border(border, r, mid, q, halvings - 1);
}

/// Whether an edge ab in an odd number of tracked faces, at a vertex whose kind is
/// `kind_a` (or the two ends' kinds and-ed, where both are known), is a border. Where a collapse
/// merged two sheets of the surface, their faces count once from then on, so the odd count may be
/// the merge's: there the edge must also lie within border_epsilon of the borders. Merges happen
/// where a soup's pieces nearly touch; counted as borders, such edges froze the feature vertices on
/// them (shard soups stalled at AMIPS 30). Only a's kind is read: a collapse decides holding a and
/// b alone.
template <class Mesh>
bool odd_edge_is_border(const Mesh& m, const tet_optimization_state& s, std::uint8_t kind_a,
                        index_t a, index_t b) {
    if (!(kind_a & tet_vertex::merged) || !(s.border_epsilon > 0)) return true;
    return near_border(s.border, s.border_epsilon, m.position(a), m.position(b));
}

/// The vertices joined to b by border edges: edges in an odd number of tracked faces (an
/// even number lies inside the surface, or across an intersection) that odd_edge_is_border
/// keeps. Where borders meet or end at b, more or fewer than two.
using border_ends = boost::container::small_vector<index_t, 4>;

template <class Mesh>
border_ends border_ends_of(const Mesh& m, const tet_optimization_state& s, index_t b) {
    tracked_faces faces;
    for (index_t g : m.vertex_tets(b)) gather_tracked(m, s, g, faces);
    boost::container::small_vector<std::pair<index_t, int>, 24> around; // neighbour, faces
    for (const auto& k : faces) {
        if (!has(k, b)) continue;
        for (index_t x : k) {
            if (x == b) continue;
            auto it = std::find_if(around.begin(), around.end(),
                                   [&](const auto& e) { return e.first == x; });
            if (it == around.end())
                around.push_back({x, 1});
            else
                ++it->second;
        }
    }
    const std::uint8_t kind_b = m.attribute(s.kind)[b];
    border_ends ends;
    for (const auto& [x, n] : around)
        if (n % 2 == 1 && odd_edge_is_border(m, s, kind_b, b, x)) ends.push_back(x);
    return ends;
}

/// Whether feature vertex b may vanish into a: where b lies on segment ac between its two
/// border neighbours a and c up to rounding (the border stays where it was), or where every
/// border edge of b, moved to end at a instead, stays within s.border_epsilon of the
/// borders the run started with (fTetWild's boundary envelope). The second holds also where
/// borders meet or end at b, and for an a off b's border: the insertion leaves such
/// vertices a sliver apart where a soup's pieces cross or nearly touch (a soup of loose
/// triangles is all border; kept, their slivers stayed above the stop energy).
template <class Mesh>
bool may_leave_border(const Mesh& m, const tet_optimization_state& s, index_t a, index_t b) {
    const border_ends ends = border_ends_of(m, s, b);
    const vec3 pa = m.position(a);
    if (ends.size() == 2 && (ends[0] == a || ends[1] == a)) {
        const vec3 pc = m.position(ends[0] == a ? ends[1] : ends[0]);
        const vec3 ac = pc - pa, ab = m.position(b) - pa;
        const double along = dot(ab, ac), ac2 = dot(ac, ac);
        if (along > 0 && along < ac2 && squared_norm(cross(ab, ac)) <= 1e-18 * ac2 * ac2)
            return true;
    }
    if (!(s.border_epsilon > 0)) return false;
    for (index_t x : ends)
        if (x != a && !near_border(s.border, s.border_epsilon, pa, m.position(x))) return false;
    return true;
}

template <class Mesh>
double amips(const Mesh& m, const tet_indices& t) {
    const auto p = m.positions();
    return tet_amips(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
}

/// Each edge (v, w) with w > v of v's star once, as a tuple at v.
template <class Mesh, class Fn>
void for_each_tet_edge_from(const Mesh& m, index_t v, Fn&& fn) {
    boost::container::small_vector<index_t, 32> seen;
    for (index_t g : m.vertex_tets(v))
        for (index_t w : m.tet_vertices(g))
            if (w > v && std::find(seen.begin(), seen.end(), w) == seen.end()) {
                seen.push_back(w);
                fn(m.tuple_at(g, v, w));
            }
}

/// Every edge of the tets `tets` (slots), each once, in the order first met. The edges
/// met are counted in a hash table (the link condition's, one per thread, emptied by a
/// stamp): a list searched from the start made this quadratic in the star, 7% of x.stl's
/// run, whose insertion leaves vertices with hundreds of tets (bench/RESULTS.md,
/// "Session 44"). `fn` must not call it again (it pushes renewals).
template <class Mesh, class Tets, class Fn>
void for_each_edge_of(const Mesh& m, const Tets& tets, Fn&& fn) {
    thread_local idas::detail::key_counts seen;
    seen.reset();
    for (index_t g : tets) {
        const auto& tv = m.tet_vertices(g);
        for (std::uint8_t le = 0; le < 6; ++le) {
            const auto ev = tet_local::edge_vertices[le];
            const auto [lo, hi] = std::minmax(tv[ev[0]], tv[ev[1]]);
            if (seen.add(idas::detail::edge_key(lo, hi)) == 1) fn(m.tuple_from_edge(g, le));
        }
    }
}

/// The edges of an operation's new tets, each once.
template <class Mesh, class Fn>
void for_each_new_edge(const Mesh& m, const op_result<tet_tuple>& r, Fn&& fn) {
    for_each_edge_of(m, r.cells | std::views::transform(&tet_tuple::tid), fn);
}

/// Squared local target length of edge ab.
template <class Mesh>
double target_squared(const Mesh& m, const tet_optimization_state& s, index_t a, index_t b) {
    const auto sc = m.attribute(s.scale);
    const auto len = m.attribute(s.length);
    const double l = 0.5 * (len[a] * sc[a] + len[b] * sc[b]);
    return l * l;
}

/// x moved by `steps` ulps (towards +infinity where positive).
inline double ulps_from(double x, int steps) noexcept {
    for (; steps > 0; --steps) x = std::nextafter(x, std::numeric_limits<double>::infinity());
    for (; steps < 0; ++steps) x = std::nextafter(x, -std::numeric_limits<double>::infinity());
    return x;
}

/// The offsets, in ulps per coordinate, that rounding tries beyond a rational vertex's
/// nearest doubles: every offset of at most three ulps a coordinate, nearest first.
inline constexpr auto ulp_steps = [] {
    constexpr int reach = 3, side = 2 * reach + 1;
    std::array<std::array<int, 3>, side * side * side - 1> steps{};
    std::size_t n = 0;
    for (int x = -reach; x <= reach; ++x)
        for (int y = -reach; y <= reach; ++y)
            for (int z = -reach; z <= reach; ++z)
                if (x || y || z) steps[n++] = {x, y, z};
    std::ranges::sort(steps, {}, [](const std::array<int, 3>& d) {
        return std::array{d[0] * d[0] + d[1] * d[1] + d[2] * d[2], d[0], d[1], d[2]};
    });
    return steps;
}();

/// Exact orient3d of tet tv on the exact positions: rational ones where a vertex's kind
/// says so, except `at_double`, taken at its double position (a rounding candidate).
template <class Mesh>
int exact_orient3d(const Mesh& m, const tet_optimization_state& s, const tet_indices& tv,
                   index_t at_double = invalid_index) {
    const auto p = m.positions();
    const auto kind = m.attribute(s.kind);
    auto rational = [&](index_t v) { return v != at_double && (kind[v] & tet_vertex::rational); };
    if (std::none_of(tv.begin(), tv.end(), rational))
        return orient3d(p[tv[0]], p[tv[1]], p[tv[2]], p[tv[3]]);
    // A rational vertex's position is the nearest double of its exact one: where that
    // rounding cannot change the sign, the doubles decide it (most tests; the rational
    // arithmetic below was a fifth of open_boxes_1's run).
    const auto radius = [&](index_t v) { return rational(v) ? rounding_radius(p[v]) : 0.0; };
    if (const int sign = orient3d_within(p[tv[0]], p[tv[1]], p[tv[2]], p[tv[3]], radius(tv[0]),
                                         radius(tv[1]), radius(tv[2]), radius(tv[3])))
        return sign;
    std::array<rational_point, 4> q;
    for (int i = 0; i < 4; ++i) q[i] = rational(tv[i]) ? s.exact->at(tv[i]) : to_rational(p[tv[i]]);
    return orient3d(q[0], q[1], q[2], q[3]);
}

} // namespace detail

/// Invariant: every new tet is positively oriented, by an exact orient3d on the exact
/// positions (rational ones where a vertex's kind says so).
struct exact_orientation {
    const tet_optimization_state* s = nullptr;
    struct state {};

    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh& m, const Result& r, state&) const {
        for (const auto& c : r.cells)
            if (detail::exact_orient3d(m, *s, m.tet_vertices(c.tid)) <= 0) return false;
        return true;
    }
};

/// Invariant: every tracked face of the new tets lies inside the envelope.
///
/// Only faces whose geometry is new are tested (the operation kind's `new_facets`): a
/// tracked face that an operation keeps (same corners, unmoved) was tested when it was
/// made. A split, a collapse and a smoothing make new faces only through their anchor; a
/// swap makes them only inside its ring, where no face is tracked (the specs refuse swaps
/// that would remove a tracked face). Any other operation has all its tracked faces tested.
template <triangle_envelope Envelope>
struct tracked_in_envelope {
    const Envelope* envelope = nullptr;
    const tet_optimization_state* s = nullptr;
    struct state {};

    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh& m, const Result& r, state&) const {
        if constexpr (where_new_facets<Op> == new_facets::inside_region) return true;
        const auto p = m.positions();
        const auto tracked = m.attribute(s->tracked);
        for (const auto& c : r.cells) {
            const std::uint8_t bits = tracked[c.tid];
            if (!bits) continue;
            const auto& tv = m.tet_vertices(c.tid);
            // The local face opposite the anchor is the one face of the tet without it.
            std::uint8_t unchanged = 4;
            if constexpr (where_new_facets<Op> == new_facets::through_anchor)
                unchanged = tet_local::index_of(tv, r.anchor.vid);
            for (std::uint8_t lf = 0; lf < 4; ++lf) {
                if (!(bits >> lf & 1u) || lf == unchanged) continue;
                // Each tracked face is in two new tets; test it from the one that holds it
                // with the smaller slot, or from the only one.
                const index_t other = m.connectivity().opposite_tet(c.tid, lf);
                if (other != invalid_index && other < c.tid &&
                    std::any_of(r.cells.begin(), r.cells.end(),
                                [&](const tet_tuple& x) { return x.tid == other; }))
                    continue;
                const auto f = tet_local::face_vertices[lf];
                if (!s->verdicts->contains(*envelope, p[tv[f[0]]], p[tv[f[1]]], p[tv[f[2]]]))
                    return false;
            }
        }
        return true;
    }
};

static_assert(invariant<exact_orientation>);

/// The two invariants every phase shares.
template <class Envelope>
struct tet_optimization_invariants {
    tet_optimization_state& s;
    const Envelope& envelope;
    static constexpr bool allow_boundary_change = true; // the box rules are the specs' own
    auto invariants() const {
        return invariant_set<exact_orientation, tracked_in_envelope<Envelope>>(
            exact_orientation{&s}, tracked_in_envelope<Envelope>{&envelope, &s});
    }
};

template <class Envelope>
struct tet_split_spec : tet_optimization_invariants<Envelope> {
    using operations = op_list<op::split_tet_edge>;
    using tet_optimization_invariants<Envelope>::s;

    struct cache {
        index_t a, b;
        vec3 position;
        std::uint8_t kind;
        double scale, length;
        detail::tracked_faces tracked;
    };

    template <class Mesh>
    bool too_long(const Mesh& m, index_t a, index_t b) const {
        return squared_norm(m.position(a) - m.position(b)) >
               16.0 / 9.0 * detail::target_squared(m, s, a, b);
    }
    template <class Mesh, class Push>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        detail::for_each_tet_edge_from(m, v, [&](const tet_tuple& t) {
            if (too_long(m, v, m.edge_vertices(t).second)) push(op::split_tet_edge{}, t);
        });
    }
    template <class Mesh>
    double priority(op::split_tet_edge, const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return -squared_norm(m.position(a) - m.position(b)); // longest first
    }
    template <class Mesh>
    std::optional<cache> before(op::split_tet_edge, const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        if (!too_long(m, a, b)) return std::nullopt;
        // Built in place: moving the small vector out of a local trips a false GCC warning.
        std::optional<cache> out(std::in_place, a, b, (m.position(a) + m.position(b)) * 0.5,
                                 std::uint8_t(0), 0.0, 0.0, detail::tracked_faces{});
        cache& c = *out;
        int faces_on_edge = 0;
        for (index_t g : m.vertex_tets(a)) {
            const auto& tv = m.tet_vertices(g);
            if (!tet_local::contains(tv, b)) continue;
            detail::gather_tracked(m, s, g, c.tracked);
        }
        for (const auto& k : c.tracked) faces_on_edge += detail::has(k, a) && detail::has(k, b);
        if (faces_on_edge > 0) c.kind |= tet_vertex::surface;
        // A border's midpoint stays on the border. An odd edge between vertices that are not
        // both on a border is no border, nor one between merged vertices away from the
        // borders: a collapse merged two tracked faces across a flat tet there (two sheets
        // of the surface became one), and feature vertices spread along it by splits would
        // be frozen where nothing needs them (open_boxes_2 of bench/make_soups.py stalled on
        // slivers between such vertices at AMIPS 1e9). The midpoint of an edge between
        // merged vertices is merged too, so the edge's halves are judged as it was.
        const auto kind = m.attribute(s.kind);
        const std::uint8_t both = kind[a] & kind[b];
        if (faces_on_edge % 2 == 1 && (both & tet_vertex::feature) &&
            detail::odd_edge_is_border(m, s, both, a, b))
            c.kind |= tet_vertex::feature;
        if (faces_on_edge > 0) c.kind |= both & tet_vertex::merged;
        const auto sc = m.attribute(s.scale);
        c.scale = 0.5 * (sc[a] + sc[b]);
        // The midpoint's length, linear along the edge until the round's end re-reads it.
        const auto len = m.attribute(s.length);
        c.length = 0.5 * (len[a] + len[b]);
        return out;
    }
    template <class Mesh>
    bool after(op::split_tet_edge, Mesh& m, const op_result<tet_tuple>& r, cache& c) const {
        const index_t v = r.anchor.vid;
        m.positions(r).set(v, c.position);
        m.attribute(s.kind, r).set(v, c.kind);
        m.attribute(s.scale, r).set(v, c.scale);
        m.attribute(s.length, r).set(v, c.length);
        // A face through v lies in the old face through edge ab if it holds a or b, and
        // inside an old tet (untracked) otherwise.
        detail::retrack(m, s, r, [&](index_t, std::uint8_t, const tri_indices& k) {
            if (!detail::has(k, v)) return detail::holds(c.tracked, k);
            index_t other = invalid_index;
            bool on_ab = false;
            for (index_t x : k) {
                if (x == c.a || x == c.b)
                    on_ab = true;
                else if (x != v)
                    other = x;
            }
            return on_ab && other != invalid_index &&
                   detail::holds(c.tracked, detail::sorted_triple(c.a, c.b, other));
        });
        return true;
    }
    template <class Mesh, class Push>
    void renew(op::split_tet_edge, const Mesh& m, const op_result<tet_tuple>& r, Push& push) const {
        detail::for_each_new_edge(m, r, [&](const tet_tuple& t) {
            const auto [a, b] = m.edge_vertices(t);
            if (too_long(m, a, b)) push(op::split_tet_edge{}, t);
        });
    }
    /// Room for the phase's new vertices and tets in parallel. An edge l long, with target
    /// length t, ends in about 3l / 4t pieces, and a new vertex brings about six tets; twice
    /// that covers the new edges that need splitting too. The executor's default (room to
    /// double) sent most of a small input's first splits to the serial pass, after the
    /// others and so out of their longest-first order (sphere, 2 threads: 14,464 splits
    /// against 9,761 on one thread, and a second round).
    /// Estimated from every eighth vertex's edges: the whole scan, on one thread before
    /// the workers start, cost bunny 0.4 s over its rounds.
    template <class Mesh>
    std::pair<index_t, index_t> parallel_growth(const Mesh& m) const {
        constexpr index_t sample = 8;
        double pieces = 0;
        for (index_t v = 0; v < m.vertex_slots(); v += sample) {
            if (!m.vertex_alive(v)) continue;
            detail::for_each_tet_edge_from(m, v, [&](const tet_tuple& t) {
                const auto [a, b] = m.edge_vertices(t);
                const double ratio = std::sqrt(squared_norm(m.position(a) - m.position(b)) /
                                               detail::target_squared(m, s, a, b));
                if (ratio > 4.0 / 3.0) pieces += 0.75 * ratio;
            });
        }
        // At most eight times the mesh: the slots are memory, and an absurd target length
        // is refused before this (at most 1/1000 of the diagonal).
        const double vertices = std::min(2 * sample * pieces, 8.0 * double(m.n_vertices())) + 4096;
        return {index_t(vertices), index_t(6 * vertices)};
    }
    /// In parallel, a split holds the vertices of the tets around its edge: it replaces
    /// only those, its new vertex is the worker's own, and its hooks read a and b, those
    /// tets and the new ones.
    template <class Mesh, class Claim>
    bool lock_region(op::split_tet_edge, const Mesh& m, const tet_tuple& t, Claim&& claim) const {
        return replaced_tets_region<op::split_tet_edge>(m, t, claim);
    }
};

template <class Envelope>
struct tet_collapse_spec : tet_optimization_invariants<Envelope> {
    using operations = op_list<op::collapse_edge>;
    using tet_optimization_invariants<Envelope>::s;
    /// should_process reads the stars of a and b, positions (no collapse moves a vertex)
    /// and the attributes of a and b: in parallel it is asked holding a and b alone.
    static constexpr bool decides_holding_seeds = true;

    struct cache {
        index_t b;
        std::uint8_t kind_b;
        detail::tracked_faces tracked;
        boost::container::small_vector<index_t, 6> merged; // of faces that merge
    };

    template <class Mesh>
    bool too_short(const Mesh& m, index_t a, index_t b) const {
        return squared_norm(m.position(a) - m.position(b)) <
               0.64 * detail::target_squared(m, s, a, b);
    }
    /// Whether b should vanish into a: ab is short, or b is still rational. A vertex that
    /// could not be rounded leaves tets that are flat in doubles (infinite energy), which
    /// no smoothing can move (no gradient) and no length rule would touch.
    template <class Mesh>
    bool wanted(const Mesh& m, index_t a, index_t b) const {
        return (m.attribute(s.kind)[b] & tet_vertex::rational) || too_short(m, a, b);
    }
    /// Both directions where wanted: the tuple's vertex survives.
    template <class Mesh, class Push>
    void push_both(const Mesh& m, const tet_tuple& t, Push& push) const {
        const auto [a, b] = m.edge_vertices(t);
        const auto kind = m.attribute(s.kind);
        const bool short_edge = too_short(m, a, b); // once for both directions
        if (short_edge || (kind[b] & tet_vertex::rational)) push(op::collapse_edge{}, t);
        if (short_edge || (kind[a] & tet_vertex::rational))
            push(op::collapse_edge{}, m.switch_vertex(t));
    }
    template <class Mesh, class Push>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        detail::for_each_tet_edge_from(m, v, [&](const tet_tuple& t) { push_both(m, t, push); });
    }
    template <class Mesh>
    double priority(op::collapse_edge, const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return squared_norm(m.position(a) - m.position(b)); // shortest first
    }

    /// The cheap refusals first, before the operation's link condition: b must be allowed
    /// to vanish into a (a feature vertex where its border edges stay near the borders, a
    /// on every box plane b is on), and the largest energy of the tets of b's star may not rise
    /// above the larger of its old value and collapse_up_to (fTetWild's rule alone, never rise,
    /// left 1.4x its tets on sphere). A surface vertex may go into a vertex off the surface, or
    /// into another surface vertex through the volume, as in fTetWild: the envelope invariant
    /// decides whether its faces may follow. (Collapses only along tracked edges left flat tets
    /// between surface vertices that nothing could remove: open_boxes_1 of bench/make_soups.py,
    /// deterministic, stalled at AMIPS 1.6e7, and spheres_2 kept 1.3x fTetWild's tets.)
    template <class Mesh>
    bool should_process(op::collapse_edge, const Mesh& m, const queue_entry<tet_tuple>& e) const {
        const tet_tuple& t = e.tuple;
        if (!m.is_valid(t)) return false;
        const auto [a, b] = m.edge_vertices(t);
        if (!wanted(m, a, b)) return false;
        const auto kind = m.attribute(s.kind);
        // A feature vertex vanishes only where the border stays: b all but on a, or its
        // border edges, moved to a, within border_epsilon of the borders.
        if ((kind[b] & tet_vertex::feature) &&
            !(squared_norm(m.position(a) - m.position(b)) <=
              1e-12 * detail::target_squared(m, s, a, b)) &&
            !detail::may_leave_border(m, s, a, b))
            return false;
        const std::uint8_t pb = s.box_planes(m.position(b));
        if ((pb & s.box_planes(m.position(a))) != pb) return false;
        const auto p = m.positions();
        // A surface vertex going into a vertex off the surface: the survivor must at least
        // be inside the envelope itself (one point test before the faces' tests).
        if ((kind[b] & tet_vertex::surface) && !(kind[a] & tet_vertex::surface) &&
            !s.verdicts->contains(this->envelope, p[a], p[a], p[a]))
            return false;
        // The old star's largest energy matters only once a new tet exceeds collapse_up_to,
        // which most accepted collapses never do. Energies are compared to the power 3/2
        // (no cube root; a bound at or below 0 stays one that no energy is under).
        const double up_to = s.collapse_up_to;
        double bound = up_to > 0 ? up_to * std::sqrt(up_to) : up_to;
        bool old_star_weighed = false;
        for (index_t g : m.vertex_tets(b)) {
            const auto& tv = m.tet_vertices(g);
            if (tet_local::contains(tv, a)) continue;
            const auto nt = idas::detail::replaced(tv, b, a);
            const double energy = tet_amips_three_halves(p[nt[0]], p[nt[1]], p[nt[2]], p[nt[3]]);
            if (energy <= bound) continue;
            if (!old_star_weighed) {
                old_star_weighed = true;
                for (index_t h : m.vertex_tets(b)) {
                    const auto& ov = m.tet_vertices(h);
                    bound = std::max(
                        bound, tet_amips_three_halves(p[ov[0]], p[ov[1]], p[ov[2]], p[ov[3]]));
                }
            }
            if (!(energy <= bound)) return false;
        }
        return true;
    }

    template <class Mesh>
    std::optional<cache> before(op::collapse_edge, const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        if (!wanted(m, a, b)) return std::nullopt;
        std::optional<cache> c(std::in_place, b, m.attribute(s.kind)[b], detail::tracked_faces{},
                               boost::container::small_vector<index_t, 6>{});
        const auto bits = m.attribute(s.tracked);
        for (index_t g : m.vertex_tets(b)) {
            detail::gather_tracked(m, s, g, c->tracked);
            // A tet on ab whose faces opposite a and b are both tracked: they become one.
            const auto& tv = m.tet_vertices(g);
            const std::uint8_t ia = tet_local::index_of(tv, a);
            if (ia == tet_local::none) continue;
            const std::uint8_t ib = tet_local::index_of(tv, b);
            if ((bits[g] >> ia & 1u) && (bits[g] >> ib & 1u))
                for (index_t x : tv)
                    if (x != b) c->merged.push_back(x);
        }
        return c;
    }
    template <class Mesh>
    bool after(op::collapse_edge, Mesh& m, const op_result<tet_tuple>& r, cache& c) const {
        const index_t a = r.anchor.vid;
        auto kind = m.attribute(s.kind, r);
        // b's surface is a's now, and so are b's border edges (a vertex off b's border takes
        // them where they stay within border_epsilon of the borders).
        const std::uint8_t inherited =
            c.kind_b & (tet_vertex::surface | tet_vertex::feature | tet_vertex::merged) & ~kind[a];
        if (inherited) kind.set(a, std::uint8_t(kind[a] | inherited));
        for (index_t x : c.merged)
            if (!(kind[x] & tet_vertex::merged))
                kind.set(x, std::uint8_t(kind[x] | tet_vertex::merged));
        // Tets keep their slots and local order, so a face keeps its bit; a face through a
        // is also tracked if it replaced a tracked face through b (or merged with one).
        const auto bits = m.attribute(s.tracked);
        detail::retrack(m, s, r, [&](index_t g, std::uint8_t lf, const tri_indices& k) {
            if (bits[g] >> lf & 1u) return true;
            if (!detail::has(k, a)) return false;
            tri_indices via_b = k;
            for (auto& x : via_b)
                if (x == a) x = c.b;
            return detail::holds(c.tracked, k) ||
                   detail::holds(c.tracked, detail::sorted_triple(via_b[0], via_b[1], via_b[2]));
        });
        return true;
    }
    /// Every edge of the merged vertex's star: those through it changed length, and the
    /// entries of the others went stale with their changed tets.
    template <class Mesh, class Push>
    void renew(op::collapse_edge, const Mesh& m, const op_result<tet_tuple>& r, Push& push) const {
        detail::for_each_edge_of(m, m.vertex_tets(r.anchor.vid),
                                 [&](const tet_tuple& t) { push_both(m, t, push); });
    }
};

template <class Envelope>
struct tet_swap_spec : tet_optimization_invariants<Envelope> {
    using operations = op_list<op::edge_removal, op::face_swap_23>;
    using tet_optimization_invariants<Envelope>::s;
    static constexpr std::size_t max_ring = 5; // 3-2, 4-4 and 5-6 swaps, as fTetWild

    struct cache {
        double old_max;
        detail::tracked_faces tracked;
    };

    /// Edge removal picks the triangulation of the ring whose worst tet is best.
    template <class Mesh>
    double tet_quality(const Mesh& m, const tet_indices& t) const {
        return -detail::amips(m, t);
    }

    template <class Mesh, class Push>
    void push_around(const Mesh& m, index_t g, Push& push) const {
        for (std::uint8_t le = 0; le < 6; ++le) push(op::edge_removal{}, m.tuple_from_edge(g, le));
        for (std::uint8_t lf = 0; lf < 4; ++lf)
            if (!(m.attribute(s.tracked)[g] >> lf & 1u) &&
                m.connectivity().opposite_tet(g, lf) != invalid_index)
                push(op::face_swap_23{}, m.tuple_from_face(g, lf));
    }
    /// The tets above the bar whose smallest vertex is v.
    template <class Mesh, class Push>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        if (!s.in_focus(v)) return;
        for (index_t g : m.vertex_tets(v)) {
            const auto& tv = m.tet_vertices(g);
            if (*std::min_element(tv.begin(), tv.end()) == v && detail::amips(m, tv) > s.swap_above)
                push_around(m, g, push);
        }
    }
    template <class Op, class Mesh>
    double priority(Op, const Mesh& m, const tet_tuple& t) const {
        return -detail::amips(m, m.tet_vertices(t.tid)); // worst tets first
    }

    /// Edge removal searches its best triangulation before `before` runs: the cheap
    /// refusals come first, here.
    template <class Mesh>
    bool should_process(op::edge_removal, const Mesh& m, const queue_entry<tet_tuple>& e) const {
        return m.is_valid(e.tuple) && gather_ring(m, e.tuple).has_value();
    }
    template <class Mesh>
    bool should_process(op::face_swap_23, const Mesh& m, const queue_entry<tet_tuple>& e) const {
        return m.is_valid(e.tuple);
    }
    /// The ring's largest energy and tracked faces, if ab has at most max_ring tets, one
    /// of them above the bar, and no tracked face (which would vanish).
    template <class Mesh>
    std::optional<cache> gather_ring(const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        std::optional<cache> c(std::in_place, 0.0, detail::tracked_faces{});
        std::size_t n = 0;
        for (index_t g : m.vertex_tets(a)) {
            const auto& tv = m.tet_vertices(g);
            if (!tet_local::contains(tv, b)) continue;
            if (++n > max_ring) return std::nullopt;
            c->old_max = std::max(c->old_max, detail::amips(m, tv));
            detail::gather_tracked(m, s, g, c->tracked);
        }
        if (!(c->old_max > s.swap_above)) return std::nullopt;
        for (const auto& k : c->tracked)
            if (detail::has(k, a) && detail::has(k, b)) return std::nullopt;
        return c;
    }
    template <class Mesh>
    std::optional<cache> before(op::edge_removal, const Mesh& m, const tet_tuple& t) const {
        return gather_ring(m, t);
    }
    template <class Mesh>
    std::optional<cache> before(op::face_swap_23, const Mesh& m, const tet_tuple& t) const {
        if (m.attribute(s.tracked)[t.tid] >> t.local_face & 1u) return std::nullopt;
        const index_t t2 = m.connectivity().opposite_tet(t.tid, t.local_face);
        if (t2 == invalid_index) return std::nullopt;
        std::optional<cache> c(
            std::in_place,
            std::max(detail::amips(m, m.tet_vertices(t.tid)), detail::amips(m, m.tet_vertices(t2))),
            detail::tracked_faces{});
        if (!(c->old_max > s.swap_above)) return std::nullopt;
        // The new tets, as face_swap_23 makes them: (a b e d), (b c e d), (c a e d).
        const auto out = m.face_vertices_outward(t);
        const index_t d = m.opposite_vertex(t);
        index_t e = invalid_index;
        for (index_t x : m.tet_vertices(t2))
            if (x != out[0] && x != out[1] && x != out[2]) e = x;
        const index_t fa = out[0], fb = out[2], fc = out[1];
        for (const tet_indices& nt :
             {tet_indices{fa, fb, e, d}, tet_indices{fb, fc, e, d}, tet_indices{fc, fa, e, d}})
            if (!(detail::amips(m, nt) < c->old_max)) return std::nullopt;
        detail::gather_tracked(m, s, t.tid, c->tracked);
        detail::gather_tracked(m, s, t2, c->tracked);
        return c;
    }
    template <class Op, class Mesh>
    bool after(Op, Mesh& m, const op_result<tet_tuple>& r, cache& c) const {
        // Edge removal chose its best triangulation; keep it only if it is better.
        for (const tet_tuple& x : r.cells)
            if (!(detail::amips(m, m.tet_vertices(x.tid)) < c.old_max)) return false;
        detail::retrack(m, s, r, [&](index_t, std::uint8_t, const tri_indices& k) {
            return detail::holds(c.tracked, k);
        });
        return true;
    }
    template <class Op, class Mesh, class Push>
    void renew(Op, const Mesh& m, const op_result<tet_tuple>& r, Push& push) const {
        for (const tet_tuple& x : r.cells)
            if (detail::amips(m, m.tet_vertices(x.tid)) > s.swap_above) push_around(m, x.tid, push);
    }
    /// In parallel, a swap holds the vertices of the tets it replaces, not the closed stars:
    /// its hooks read only those tets, their tracked bits and the new tets.
    template <class Op, class Mesh, class Claim>
    bool lock_region(Op, const Mesh& m, const tet_tuple& t, Claim&& claim) const {
        return replaced_tets_region<Op>(m, t, claim);
    }
};

template <class Envelope>
struct tet_smooth_spec : tet_optimization_invariants<Envelope> {
    using operations = op_list<op::smooth_vertex>;
    using tet_optimization_invariants<Envelope>::s;
    unsigned line_search_steps = 8;

    template <class Mesh>
    bool movable(const Mesh& m, index_t v) const {
        if ((m.attribute(s.kind)[v] & tet_vertex::feature) && !(s.border_epsilon > 0)) return false;
        const std::uint8_t planes = s.box_planes(m.position(v));
        // A vertex on two box planes (a box edge) or three (a corner) stays.
        return std::popcount(planes) < 2;
    }
    template <class Mesh, class Push>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        if (s.in_focus(v) && !std::ranges::empty(m.vertex_tets(v)) && movable(m, v))
            push(op::smooth_vertex{}, m.tuple_from_vertex(v));
    }

    /// The star as (v, q1, q2, q3) positively ordered.
    using star = boost::container::small_vector<std::array<vec3, 3>, 64>;
    template <class Mesh>
    static void gather(const Mesh& m, index_t v, star& out) {
        static constexpr std::uint8_t perm[4][3] = {{1, 2, 3}, {0, 3, 2}, {3, 0, 1}, {2, 1, 0}};
        const auto pos = m.positions();
        out.clear();
        for (index_t g : m.vertex_tets(v)) {
            const auto& tv = m.tet_vertices(g);
            const std::uint8_t i = tet_local::index_of(tv, v);
            out.push_back({pos[tv[perm[i][0]]], pos[tv[perm[i][1]]], pos[tv[perm[i][2]]]});
        }
    }
    struct star_energy {
        double sum = 0, max = 0;
    };
    static star_energy energy(const star& st, const vec3& p) noexcept {
        star_energy e;
        for (const auto& q : st) {
            const double x = tet_amips(p, q[0], q[1], q[2]);
            e.sum += x, e.max = std::max(e.max, x);
        }
        return e;
    }

    template <class Mesh>
    std::optional<vec3> before(op::smooth_vertex, const Mesh& m, const tet_tuple& t) const {
        const index_t v = t.vid;
        if (!movable(m, v)) return std::nullopt;
        star st;
        gather(m, v, st);
        const vec3 p = m.position(v);
        // A vertex on an open border slides along the borders, as in fTetWild: projected
        // onto them, each of its border edges within border_epsilon of them. So do vertices
        // where borders meet or end: where a soup's pieces nearly touch, the insertion leaves
        // them a sliver apart.
        const std::uint8_t kind = m.attribute(s.kind)[v];
        detail::border_ends ends;
        if (kind & tet_vertex::feature) ends = detail::border_ends_of(m, s, v);
        const bool on_border = !ends.empty();
        // Newton direction of the star's summed energy.
        vec3 grad{};
        std::array<double, 9> H{};
        star_energy now;
        for (const auto& q : st) {
            const auto d = tet_amips_derivatives(p, q[0], q[1], q[2]);
            now.sum += d.energy, now.max = std::max(now.max, d.energy);
            grad += d.gradient;
            for (int i = 0; i < 9; ++i) H[i] += d.hessian[i];
        }
        if (!std::isfinite(now.sum)) return std::nullopt; // flat in doubles: leave it
        // Box planes: that coordinate stays.
        const std::uint8_t planes = s.box_planes(p);
        for (int k = 0; k < 3; ++k)
            if (planes >> (2 * k) & 3u) {
                grad[k] = 0;
                for (int j = 0; j < 3; ++j) H[3 * k + j] = H[3 * j + k] = 0;
                H[4 * k] = 1;
            }
        vec3 dir = newton_direction(H, grad);
        if (!(squared_norm(dir) > 0)) return std::nullopt;
        for (unsigned k = 0; k < line_search_steps; ++k, dir *= 0.5) {
            vec3 q = p + dir;
            if (on_border)
                q = s.border.closest_point(q).point;
            else if ((kind & tet_vertex::surface) && s.input)
                q = s.input->closest_point(q).point;
            for (int a = 0; a < 3; ++a)
                if (planes >> (2 * a) & 3u) q[a] = p[a];
            if (q == p) continue;
            const star_energy e = energy(st, q);
            if (!(e.sum < now.sum * (1 - 1e-10) && e.max <= now.max)) continue;
            if (on_border && !std::ranges::all_of(ends, [&](index_t x) {
                    return detail::near_border(s.border, s.border_epsilon, q, m.position(x));
                }))
                continue;
            return q;
        }
        return std::nullopt;
    }
    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<tet_tuple>& r, vec3& q) const {
        const index_t v = r.anchor.vid;
        m.positions(r).set(v, q);
        auto kind = m.attribute(s.kind, r);
        if (kind[v] & tet_vertex::rational)
            kind.set(v, std::uint8_t(kind[v] & ~tet_vertex::rational)); // exactly q now
        return true;
    }

    /// -H^-1 g when H is positive definite (Cholesky), else the steepest descent step
    /// scaled like a Newton step of H's size.
    static vec3 newton_direction(const std::array<double, 9>& H, const vec3& g) noexcept {
        const double l00 = H[0];
        if (l00 > 0) {
            const double L00 = std::sqrt(l00), L10 = H[3] / L00, L20 = H[6] / L00;
            const double d1 = H[4] - L10 * L10;
            if (d1 > 0) {
                const double L11 = std::sqrt(d1), L21 = (H[7] - L20 * L10) / L11;
                const double d2 = H[8] - L20 * L20 - L21 * L21;
                if (d2 > 0) {
                    const double L22 = std::sqrt(d2);
                    // L y = -g, L^T x = y.
                    const double y0 = -g[0] / L00, y1 = (-g[1] - L10 * y0) / L11,
                                 y2 = (-g[2] - L20 * y0 - L21 * y1) / L22;
                    const double x2 = y2 / L22, x1 = (y1 - L21 * x2) / L11,
                                 x0 = (y0 - L10 * x1 - L20 * x2) / L00;
                    const vec3 x{x0, x1, x2};
                    if (std::isfinite(x0) && std::isfinite(x1) && std::isfinite(x2)) return x;
                }
            }
        }
        const double trace = H[0] + H[4] + H[8];
        return trace > 0 ? g * (-3.0 / trace) : vec3{};
    }
};

/// The optimization schedule: one round of the four phases (the driver repeats rounds
/// until the stop criterion).
template <class Envelope>
using tet_optimization_round =
    schedule::sequence<schedule::phase<tet_split_spec<Envelope>>,
                       schedule::phase<tet_collapse_spec<Envelope>>,
                       schedule::phase<tet_swap_spec<Envelope>>,
                       schedule::phase<tet_smooth_spec<Envelope>, queue::fifo>>;

/// Before the rounds, as fTetWild: the insertion leaves many short edges around the cut
/// tets; collapsing them and smoothing first keeps the first split from refining them.
template <class Envelope>
using tet_optimization_prologue =
    schedule::sequence<schedule::phase<tet_collapse_spec<Envelope>>,
                       schedule::phase<tet_smooth_spec<Envelope>, queue::fifo>>;

/// After a round that left a few bad tets: a round without its splits, which made them.
template <class Envelope>
using tet_optimization_touch_up =
    schedule::sequence<schedule::phase<tet_collapse_spec<Envelope>>,
                       schedule::phase<tet_swap_spec<Envelope>>,
                       schedule::phase<tet_smooth_spec<Envelope>, queue::fifo>>;

/// After the rounds: the adaptive sizing is undone and short edges collapsed where the
/// energy allows, so that refinement made for a bad tet long gone does not stay; swaps and
/// smoothing then even out what the collapses left (neither raises the largest energy).
/// The touch-up's schedule, with every vertex in play (no focus).
template <class Envelope>
using tet_optimization_epilogue = tet_optimization_touch_up<Envelope>;

/// The whole algorithm on a tet mesh whose tracked faces are marked in `tracked` and whose
/// rational vertices (exact positions in `exact`, approximated in the mesh) are listed.
template <triangle_envelope Envelope, class Mesh = tet_mesh<>, class Lock = lock::vertex_try_lock,
          class Queue = queue::dary_heap<4>, class Partition = partition::morton>
struct tet_optimization {
    template <class Schedule>
    using driver = schedule::driver<Schedule, Mesh, Lock, Queue, Partition>;

    /// `observer(round, max_energy)` after every round. The target length is
    /// `o.target_length` everywhere.
    template <class Observer>
    static tet_optimization_report run(Mesh& m, tet_attribute<std::uint8_t> tracked,
                                       const std::unordered_map<index_t, rational_point>& exact,
                                       const Envelope& envelope, const triangle_aabb_tree& input,
                                       const tet_optimization_options& o, const exec_options& exec,
                                       Observer&& observer) {
        if (!(o.target_length > 0) || !std::isfinite(o.target_length))
            throw input_error("tet optimization: the target edge length must be positive");
        return run(m, tracked, exact, envelope, input, o, exec, observer,
                   uniform_sizing{o.target_length});
    }

    /// The same with a sizing field: the target length at a vertex is the field's value
    /// there (read at the start and again after every round, as vertices move and appear)
    /// times the adaptive scale.
    template <class Observer, sizing_field Sizing>
    static tet_optimization_report run(Mesh& m, tet_attribute<std::uint8_t> tracked,
                                       const std::unordered_map<index_t, rational_point>& exact,
                                       const Envelope& envelope, const triangle_aabb_tree& input,
                                       const tet_optimization_options& o, const exec_options& exec,
                                       Observer&& observer, const Sizing& sizing) {
        const auto start = std::chrono::steady_clock::now();
        tet_optimization_state s;
        // Four slots per tracked face (counted from both of its tets), at most 2^20 slots
        // (92 MB) for very large inputs.
        std::size_t tracked_faces = 0;
        for (index_t g = 0; g < m.tet_slots(); ++g)
            if (m.tet_alive(g)) tracked_faces += std::popcount(m.attribute(tracked)[g]);
        containment_memo verdicts(std::min(2 * tracked_faces, std::size_t(1) << 20));
        s.verdicts = &verdicts;
        s.swap_above = o.swap_above;
        s.collapse_up_to = o.collapse_up_to * o.stop_energy;
        s.tracked = tracked, s.exact = &exact, s.input = &input;
        const temporary_attribute kind(
            m, m.template add_vertex_attribute<std::uint8_t>("tet_kind", 0));
        const temporary_attribute scale(m,
                                        m.template add_vertex_attribute<double>("tet_scale", 1.0));
        const temporary_attribute length(
            m, m.template add_vertex_attribute<double>("tet_length", 0.0));
        s.kind = kind.handle, s.scale = scale.handle, s.length = length.handle;
        s.border_epsilon = o.border_epsilon;
        mark_kinds(m, s, exact);
        read_sizing(m, s, sizing, o.min_length);

        tet_split_spec<Envelope> split{{s, envelope}};
        tet_collapse_spec<Envelope> collapse{{s, envelope}};
        tet_swap_spec<Envelope> swap{{s, envelope}};
        tet_smooth_spec<Envelope> smooth{{s, envelope}};

        tet_optimization_report rep;
        // A phase's report into the run's, by its kind (0 split, 1 collapse, 2 swap, 3 smooth).
        const auto count = [&rep](std::size_t kind, const run_report& r) {
            rep.phases[kind] += r;
            std::uint64_t* done[4] = {&rep.splits, &rep.collapses, &rep.swaps, &rep.smooths};
            *done[kind] += r.succeeded;
        };
        energy_summary now = energy_stats(m, exec.threads);
        bool just_refined = false;
        rep.max_energy_before = rep.max_energy = now.max;
        if (rep.max_energy <= o.stop_energy) {
            rep.stopped = tet_optimization_stop::already_good;
        } else {
            const auto pro = driver<tet_optimization_prologue<Envelope>>::run(
                m, exec, 1, schedule::no_observer{}, collapse, smooth);
            count(1, pro.phases[0]), count(3, pro.phases[1]);
            stall_watch stall(o.stall_rounds);
            for (unsigned it = 0; it < o.max_iterations; ++it) {
                const auto r = driver<tet_optimization_round<Envelope>>::run(
                    m, exec, 1, schedule::no_observer{}, split, collapse, swap, smooth);
                for (std::size_t k = 0; k < 4; ++k) count(k, r.phases[k]);
                rep.rounded += round_rational(m, s, envelope);
                read_sizing(m, s, sizing, o.min_length);
                const energy_summary before = now;
                now = energy_stats(m, exec.threads, o.stop_energy);
                if (now.above > 0 && now.above <= o.touch_up_tets) {
                    if (o.touch_up_rings > 0)
                        s.focus = around_bad_tets(m, o.stop_energy, o.touch_up_rings);
                    const auto t = driver<tet_optimization_touch_up<Envelope>>::run(
                        m, exec, 1, schedule::no_observer{}, collapse, swap, smooth);
                    s.focus.clear();
                    for (std::size_t k = 0; k < 3; ++k) count(k + 1, t.phases[k]);
                    ++rep.touch_ups;
                    now = energy_stats(m, exec.threads, o.stop_energy);
                }
                rep.max_energy = now.max;
                rep.max_energy_history.push_back(rep.max_energy);
                rep.above_stop_history.push_back(now.above);
                rep.iterations = it + 1;
                observer(it, rep.max_energy);
                if (rep.max_energy <= o.stop_energy) {
                    rep.stopped = tet_optimization_stop::energy_reached;
                    break;
                }
                if (stall.stalled_after(now.max, now.above)) {
                    rep.stopped = tet_optimization_stop::stalled;
                    break;
                }
                // fTetWild's trigger (the worst tet gained less than 0.5 and the mean
                // less than 10%) or a crawl, unless the last round just changed the sizing.
                if (just_refined) {
                    just_refined = false;
                } else if (energy_stalled(before, now, o.stop_energy, o.slow_rounds)) {
                    rep.sizing_refinements += refine_sizing(m, s, o, now.max);
                    just_refined = true;
                    // Stalled: from here on a collapse may not raise its star's largest
                    // energy at all (fTetWild's rule), which the stalled region needs.
                    s.collapse_up_to = 0;
                }
            }
        }
        if (rep.stopped != tet_optimization_stop::already_good) {
            auto sc = m.attribute(s.scale);
            for (index_t v = 0; v < m.vertex_slots(); ++v) sc.raw(v) = 1.0;
            // The rule of the rounds after a stall (never raise a star's largest energy)
            // would keep nearly all of the refinement. No new tet exceeds both its star's
            // old largest energy and this bound, so a run that reached the stop energy
            // keeps it.
            s.collapse_up_to = o.last_pass_up_to * o.stop_energy;
            for (unsigned pass = 0; pass < o.last_passes; ++pass) {
                const std::size_t tets_before = m.n_tets();
                const auto epi = driver<tet_optimization_epilogue<Envelope>>::run(
                    m, exec, 1, schedule::no_observer{}, collapse, swap, smooth);
                for (std::size_t k = 0; k < 3; ++k) count(k + 1, epi.phases[k]);
                ++rep.last_passes;
                const auto removed = std::ptrdiff_t(tets_before) - std::ptrdiff_t(m.n_tets());
                if (100 * removed < std::ptrdiff_t(tets_before)) break;
            }
            rep.max_energy = max_energy(m, exec.threads);
        }
        for (index_t v = 0; v < m.vertex_slots(); ++v)
            rep.rational_left += (m.attribute(s.kind)[v] & tet_vertex::rational) ? 1 : 0;
        rep.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return rep;
    }

    /// Flags for the vertices of the tets above `stop` and for those `rings` rings of
    /// tets further out, by vertex slot.
    static std::vector<std::uint8_t> around_bad_tets(const Mesh& m, double stop, unsigned rings) {
        std::vector<std::uint8_t> in(m.vertex_slots(), 0);
        std::vector<index_t> front;
        for (index_t g = 0; g < m.tet_slots(); ++g) {
            if (!m.tet_alive(g) || detail::amips(m, m.tet_vertices(g)) <= stop) continue;
            for (index_t v : m.tet_vertices(g))
                if (!std::exchange(in[v], 1)) front.push_back(v);
        }
        std::vector<index_t> next;
        for (unsigned r = 0; r < rings; ++r) {
            next.clear();
            for (index_t v : front)
                for (index_t g : m.vertex_tets(v))
                    for (index_t w : m.tet_vertices(g))
                        if (!std::exchange(in[w], 1)) next.push_back(w);
            front.swap(next);
        }
        return in;
    }

    /// The largest AMIPS over the live tets (+infinity if one is flat in doubles).
    static double max_energy(const Mesh& m, unsigned threads) {
        return energy_stats(m, threads).max;
    }

    /// The largest and the mean AMIPS (over the tets whose energy is finite). Summed in
    /// fixed blocks of slots, added in slot order, so that the mean (which decides when
    /// the sizing adapts) does not depend on the thread count.
    static energy_summary energy_stats(const Mesh& m, unsigned threads,
                                       double stop = std::numeric_limits<double>::infinity()) {
        struct block_stats {
            double max = 0, sum = 0;
            std::size_t finite = 0, above = 0;
        };
        constexpr std::size_t block_slots = 4096;
        const std::size_t slots = m.tet_slots();
        std::vector<block_stats> block((slots + block_slots - 1) / block_slots);
        std::atomic<std::size_t> next{0};
        const unsigned T =
            unsigned(std::clamp<std::size_t>(threads, 1, std::max<std::size_t>(block.size(), 1)));
        idas::detail::run_workers(T, T, [&](unsigned) {
            for (std::size_t k;
                 (k = next.fetch_add(1, std::memory_order_relaxed)) < block.size();) {
                block_stats b;
                for (std::size_t t = k * block_slots; t < std::min(slots, (k + 1) * block_slots);
                     ++t)
                    if (m.tet_alive(index_t(t))) {
                        const double e = detail::amips(m, m.tet_vertices(index_t(t)));
                        b.max = std::max(b.max, e);
                        if (std::isfinite(e)) b.sum += e, ++b.finite;
                        if (!(e <= stop)) ++b.above;
                    }
                block[k] = b;
            }
        });
        energy_summary out;
        double sum = 0;
        std::size_t finite = 0;
        for (const auto& b : block)
            out.max = std::max(out.max, b.max), sum += b.sum, finite += b.finite,
            out.above += b.above;
        out.mean = finite ? sum / double(finite) : 0.0;
        return out;
    }

private:
    /// Surface and feature vertices from the tracked faces; rational ones from `exact`.
    static void mark_kinds(Mesh& m, tet_optimization_state& s,
                           const std::unordered_map<index_t, rational_point>& exact) {
        auto kind = m.attribute(s.kind);
        const auto tracked = m.attribute(s.tracked);
        std::vector<std::pair<index_t, index_t>> edges; // of tracked faces, once per face
        vec3 lo = m.position(0), hi = lo;
        for (index_t v = 0; v < m.vertex_slots(); ++v)
            for (int k = 0; k < 3; ++k)
                lo[k] = std::min(lo[k], m.position(v)[k]),
                hi[k] = std::max(hi[k], m.position(v)[k]);
        s.box_lo = lo, s.box_hi = hi;
        for (index_t g = 0; g < m.tet_slots(); ++g) {
            if (!m.tet_alive(g) || !tracked[g]) continue;
            const auto& tv = m.tet_vertices(g);
            for (std::uint8_t lf = 0; lf < 4; ++lf) {
                if (!(tracked[g] >> lf & 1u)) continue;
                const index_t other = m.connectivity().opposite_tet(g, lf);
                const bool count_here = other == invalid_index || other > g;
                const auto f = tet_local::face_vertices[lf];
                for (int i = 0; i < 3; ++i) {
                    kind.raw(tv[f[i]]) |= tet_vertex::surface;
                    if (count_here) edges.push_back(std::minmax(tv[f[i]], tv[f[(i + 1) % 3]]));
                }
            }
        }
        // An edge in an odd number of tracked faces is on an open border (one face) or
        // where a border meets another surface (three); an even number above two is where
        // surfaces cross, whose vertices are surface vertices, as in fTetWild: frozen, the
        // insertion's short edges along the crossing and the slivers on them stayed (a soup
        // of overlapping spheres kept 500 tets above 10 and ten times fTetWild's tets).
        std::sort(edges.begin(), edges.end());
        std::vector<vec3> ends;
        std::vector<tri_indices> segments;
        for (std::size_t i = 0; i < edges.size();) {
            std::size_t j = i + 1;
            while (j < edges.size() && edges[j] == edges[i]) ++j;
            if ((j - i) % 2 == 1) {
                const auto [a, b] = edges[i];
                kind.raw(a) |= tet_vertex::feature, kind.raw(b) |= tet_vertex::feature;
                const index_t at = index_t(ends.size());
                ends.push_back(m.position(a)), ends.push_back(m.position(b));
                segments.push_back({at, at + 1, at + 1});
            }
            i = j;
        }
        if (s.border_epsilon > 0) s.border = triangle_aabb_tree(ends, segments); // else unused
        for (const auto& [v, q] : exact)
            if (v < m.vertex_slots()) kind.raw(v) |= tet_vertex::rational;
    }

    /// The field's length at every vertex; a value that is not a positive finite length is
    /// the field's error, reported with the point.
    template <sizing_field Sizing>
    static void read_sizing(Mesh& m, tet_optimization_state& s, const Sizing& sizing,
                            double min_length) {
        auto len = m.attribute(s.length);
        for (index_t v = 0; v < m.vertex_slots(); ++v) {
            if (!m.vertex_alive(v)) continue;
            const double l = sizing(m.position(v));
            if (!(l > 0) || !std::isfinite(l))
                throw input_error("tet optimization: the sizing field gives " +
                                  idas::detail::shortest(l) +
                                  " at a vertex; it must be a positive length");
            len.raw(v) = std::max(l, min_length);
        }
    }

    /// Rational vertices become double vertices where a double point keeps every tet of
    /// their star positive and their tracked faces inside the envelope: their nearest
    /// doubles, or else a point a few ulps from them. Returns how many.
    ///
    /// Why not only the nearest: two cut points of the insertion can round to the same
    /// doubles, and then the tets that hold both are flat at either one's nearest doubles
    /// while both stay rational, their stars too flat in doubles for smoothing to move
    /// them. The exact point lies inside the cone of positions that keep its star
    /// positive, and so do doubles a few ulps from it unless the cone is thinner than that.
    static std::size_t round_rational(Mesh& m, tet_optimization_state& s,
                                      const Envelope& envelope) {
        auto kind = m.attribute(s.kind);
        auto p = m.positions();
        std::size_t rounded = 0;
        const auto positive = [&](index_t v) {
            const auto star = m.vertex_tets(v);
            return std::all_of(star.begin(), star.end(), [&](index_t g) {
                return detail::exact_orient3d(m, s, m.tet_vertices(g), v) > 0;
            });
        };
        const auto tracked_inside = [&](index_t v) {
            detail::tracked_faces faces;
            for (index_t g : m.vertex_tets(v)) detail::gather_tracked(m, s, g, faces);
            return std::ranges::all_of(faces, [&](const tri_indices& k) {
                return !detail::has(k, v) ||
                       s.verdicts->contains(envelope, p[k[0]], p[k[1]], p[k[2]]);
            });
        };
        for (const auto& [v, q] : *s.exact) {
            if (v >= m.vertex_slots() || !(kind[v] & tet_vertex::rational)) continue;
            bool found = positive(v);
            const vec3 nearest = p[v];
            for (std::size_t k = 0; !found && k < detail::ulp_steps.size(); ++k) {
                const auto& d = detail::ulp_steps[k];
                p.raw(v) = {detail::ulps_from(nearest.x, d[0]), detail::ulps_from(nearest.y, d[1]),
                            detail::ulps_from(nearest.z, d[2])};
                found = positive(v) && tracked_inside(v);
            }
            if (found)
                kind.raw(v) &= std::uint8_t(~tet_vertex::rational), ++rounded;
            else
                p.raw(v) = nearest;
        }
        return rounded;
    }

    /// fTetWild's adaptive sizing, when the energy stalls: around the vertices of tets
    /// above a filter energy (a hundredth of the worst, within [0.8 stop energy, 100]) the
    /// target length shrinks, to half at the vertex and back to unchanged at a radius of
    /// 1.8 target lengths; everywhere else it grows back by half (to at most the field).
    /// Returns how many vertices got a smaller target.
    static std::uint64_t refine_sizing(Mesh& m, tet_optimization_state& s,
                                       const tet_optimization_options& o, double worst) {
        const double filter = std::clamp(worst / 100, 0.8 * o.stop_energy, 100.0);
        auto sc = m.attribute(s.scale);
        const std::size_t n = m.vertex_slots();
        std::vector<double> multiplier(n, 1.5);
        std::vector<index_t> seed(n, invalid_index); // the bad vertex nearest, as found
        std::vector<index_t> frontier;
        for (index_t g = 0; g < m.tet_slots(); ++g) {
            if (!m.tet_alive(g)) continue;
            const auto& tv = m.tet_vertices(g);
            if (!(detail::amips(m, tv) > filter)) continue;
            for (index_t v : tv)
                if (seed[v] == invalid_index)
                    seed[v] = v, multiplier[v] = 0.5, frontier.push_back(v);
        }
        // Spread outwards through the edges, each vertex measured from the seed that
        // reached it first, while within the seed's radius.
        std::vector<index_t> next;
        while (!frontier.empty()) {
            next.clear();
            for (index_t v : frontier)
                for (index_t g : m.vertex_tets(v))
                    for (index_t w : m.tet_vertices(g)) {
                        if (seed[w] != invalid_index) continue;
                        const index_t from = seed[v];
                        const double radius = 1.8 * m.attribute(s.length)[from] * sc[from];
                        const double d = norm(m.position(w) - m.position(from));
                        if (!(d < radius)) continue;
                        seed[w] = from;
                        multiplier[w] = std::min(multiplier[w], 0.5 + 0.5 * d / radius);
                        next.push_back(w);
                    }
            frontier.swap(next);
        }
        std::uint64_t refined = 0;
        for (index_t v = 0; v < n; ++v) {
            if (!m.vertex_alive(v)) continue;
            const double scaled = std::clamp(sc[v] * multiplier[v], o.min_scale, 1.0);
            refined += scaled < sc[v];
            sc.raw(v) = scaled;
        }
        return refined;
    }
};

} // namespace idas::algorithms
