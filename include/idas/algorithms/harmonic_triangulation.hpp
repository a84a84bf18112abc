// Harmonic triangulations (Alexa, "Harmonic Triangulations", SIGGRAPH 2019) as IDAS specs.
//
// Energy. For a tet T with face areas A_0..A_3 and volume V, the trace of its cotan
// Laplacian (the Dirichlet energy summed over the coordinate functions, up to a constant)
// is
//     E(T) = (A_0^2 + A_1^2 + A_2^2 + A_3^2) / (9 V)
// (each barycentric gradient has length A_i / (3 V), and |grad phi_i|^2 V summed over i).
// A triangulation's harmonic energy is the sum over its tets; a flip is harmonic iff it
// lowers the sum over the tets it replaces. The *harmonic index* of a tet reported in the
// paper's figures (and by the Wildmeshing Toolkit, whose stats multiply its per-tet
// sum(A^2)/(6V) by 6) is
//     h(T) = (A_0^2 + A_1^2 + A_2^2 + A_3^2) / V = 9 E(T),
// and the *mean harmonic index* is the plain mean of h over the tets. h has the dimension
// of a length: for a regular tet of edge l, h = 9 l / sqrt(2) (E = l / sqrt(2)), so means
// are only comparable on the same point distribution (standard normal, as in the paper).
//
// Specs (the paper's listing, one executor each):
//
//   flips     reduced:  3-2 edge swaps only (as the authors' code)
//             complete: 2-3 face swaps, 3-2 and 4-4 edge swaps
//             accepted iff the sum of E over the new tets is lower than over the old ones
//             and (keep_max) their maximum is not higher; queue: FIFO, renewed with the
//             edges and faces of the new tets; until no flip improves
//   smooth    complete only: each interior vertex moves down the gradient of the energy of
//             its star (backtracking line search), accepted under the same rule
//   I         every new tet positively oriented (exact orient3d); flips never touch the
//             boundary (the convex hull) and smoothing never moves boundary vertices, so
//             the vertex set and the hull are preserved
//   S         both modes: 3-2 swaps until none improves. Complete mode then runs `rounds`
//             times a smoothing pass and all three flips seeded from the tets whose energy
//             is above `seed_above` times the mean (a full scan of every face and edge
//             costs as much as a smoothing pass and finds few more improving flips).
#pragma once

#include <idas/exec/executor.hpp>
#include <idas/exec/schedule.hpp>
#include <idas/invariants/positive_orientation.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/ops/tet_ops.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

namespace idas::algorithms {

/// E(T) = sum of squared face areas / (9 V); +infinity unless (a, b, c, d) has positive
/// (floating-point) volume. Scale: a regular tet of edge l has E = l / sqrt(2).
inline double harmonic_energy(const vec3& a, const vec3& b, const vec3& c, const vec3& d) noexcept {
    const vec3 u = b - a, v = c - a, w = d - a;
    const vec3 nd = cross(u, v), nc = cross(w, u), nb = cross(v, w), na = cross(c - b, d - b);
    const double six_volume = dot(nb, u);
    if (!(six_volume > 0)) return std::numeric_limits<double>::infinity();
    // |n| = 2 A, 6 V = six_volume: sum(A^2) / (9 V) = sum(|n|^2) / (6 six_volume).
    const double sum_n2 = squared_norm(na) + squared_norm(nb) + squared_norm(nc) + squared_norm(nd);
    return sum_n2 / (6.0 * six_volume);
}

/// The paper's harmonic index of a tet: sum of squared face areas / V = 9 E.
inline double harmonic_index(const vec3& a, const vec3& b, const vec3& c, const vec3& d) noexcept {
    return 9.0 * harmonic_energy(a, b, c, d);
}

template <class Mesh>
double harmonic_energy(const Mesh& m, const tet_indices& t) {
    const auto p = m.positions();
    return harmonic_energy(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
}

struct harmonic_stats {
    std::size_t tets = 0;
    double total_energy = 0, max_energy = 0, mean_index = 0;
};

/// Sum and maximum of E, and the mean harmonic index, over the live tets.
template <class Mesh>
harmonic_stats harmonic_statistics(const Mesh& m) {
    harmonic_stats s;
    const auto p = m.positions();
    for (index_t t = 0; t < m.tet_slots(); ++t) {
        if (!m.tet_alive(t)) continue;
        const auto& tv = m.tet_vertices(t);
        const double e = harmonic_energy(p[tv[0]], p[tv[1]], p[tv[2]], p[tv[3]]);
        s.total_energy += e, s.max_energy = std::max(s.max_energy, e), ++s.tets;
    }
    s.mean_index = s.tets ? 9.0 * s.total_energy / double(s.tets) : 0.0;
    return s;
}

enum class harmonic_mode { reduced, complete };

namespace detail {

/// Sum and max of E over a few tets.
struct energy_sum {
    double sum = 0, max = 0;
    void add(double e) noexcept { sum += e, max = std::max(max, e); }
};

/// The acceptance rule shared by flips and smoothing: strictly lower sum (by a relative
/// margin, so rounding cannot make two configurations alternate) and, with keep_max, no
/// higher maximum.
inline bool improves(const energy_sum& before, const energy_sum& after, bool keep_max) noexcept {
    if (!(after.sum < before.sum * (1.0 - 1e-12))) return false;
    return !keep_max || after.max <= before.max;
}

/// Per-thread marks on vertices, for counting distinct neighbours in a star without a
/// search: a vertex is marked in the current round iff stamp == now (a linear search of
/// the star's vertices cost as much as everything else done with them).
struct vertex_marks {
    std::vector<std::uint32_t> stamp;
    std::vector<std::uint8_t> count;
    std::uint32_t now = 0;

    /// Starts a round on a mesh of n vertex slots: nothing marked.
    void start(std::size_t n) {
        if (stamp.size() < n) stamp.assign(n, 0), count.assign(n, 0), now = 0;
        if (++now == 0) std::fill(stamp.begin(), stamp.end(), 0), now = 1;
    }
    /// Marks v (count 1) and returns true the first time in this round; else counts it.
    bool mark(index_t v) noexcept {
        if (stamp[v] == now) {
            ++count[v];
            return false;
        }
        stamp[v] = now, count[v] = 1;
        return true;
    }
    static vertex_marks& local() {
        thread_local vertex_marks marks;
        return marks;
    }
};

/// The ring of edge ab (as detail::closed_edge_ring) if it is closed and has at most
/// `max_tets` tets; else false. Scans the smaller of the two stars and gives up as soon as
/// the edge has too many tets, so testing the edges of new tets for 3-2 and 4-4 swaps
/// costs little more than one star scan each.
template <class Mesh>
bool short_edge_ring(const Mesh& m, index_t a, index_t b, std::size_t max_tets,
                     idas::detail::edge_ring& r) {
    struct item {
        index_t tet, x, y;
    };
    std::array<item, 4> items;
    std::size_t n = 0;
    const auto sa = m.vertex_tets(a), sb = m.vertex_tets(b);
    const bool from_b = sb.size() < sa.size();
    const index_t other = from_b ? a : b;
    for (index_t g : from_b ? sb : sa) {
        if (!tet_local::contains(m.tet_vertices(g), other)) continue;
        if (n == max_tets || n == items.size()) return false;
        items[n++].tet = g;
    }
    if (n < 3) return false;
    for (std::size_t k = 0; k < n; ++k) {
        const auto [x, y] = idas::detail::oriented_opposite(m.tet_vertices(items[k].tet), a, b);
        items[k].x = x, items[k].y = y;
    }
    r.tets.clear(), r.verts.clear();
    std::uint32_t used = 1;
    r.tets.push_back(items[0].tet), r.verts.push_back(items[0].x);
    index_t next = items[0].y;
    while (next != items[0].x) {
        std::size_t k = 0;
        while (k < n && ((used >> k) & 1u || items[k].x != next)) ++k;
        if (k == n) return false; // open (boundary) or broken ring
        used |= 1u << k;
        r.tets.push_back(items[k].tet), r.verts.push_back(items[k].x);
        next = items[k].y;
    }
    return r.tets.size() == n;
}

} // namespace detail

/// The flip phase. Mode is a template argument, so the reduced spec's operation list holds
/// the 3-2 swap alone and its schedule compiles without the others.
///
/// Energies of the current tets are cached per tet slot (filled by `prepare`, updated by
/// `renew` for every new tet), so testing a flip computes only the energies of the tets it
/// would create, and stops as soon as their partial sum reaches the old one. In parallel a
/// slot's entry is written by the worker that created the tet, which holds all its
/// vertices, and read only by workers holding one of them.
template <harmonic_mode Mode>
struct harmonic_flip_rules {
    using operations =
        std::conditional_t<Mode == harmonic_mode::reduced, op_list<op::edge_swap_32>,
                           op_list<op::edge_swap_32, op::edge_swap_44, op::face_swap_23>>;
    static constexpr bool complete = Mode == harmonic_mode::complete;

    bool keep_max = true; // also refuse flips that raise the local maximum energy

    /// E per tet slot; slots past the end (tets added serially beyond the headroom) are
    /// computed on demand.
    std::vector<double> energies{};

    auto invariants() const { return invariant_set<positive_orientation>{}; }

    template <class Mesh>
    void prepare(const Mesh& m, const exec_options& o = {}) {
        // Headroom for the tets 2-3 swaps add in parallel (see parallel_growth).
        const std::size_t slots = m.tet_slots();
        energies.assign(slots + growth(slots), std::numeric_limits<double>::infinity());
        const auto p = m.positions();
        // Blocks of slots shared by the threads (on 6.8M tets, 0.13 s on one thread), with
        // each block's sum and count for the mean. A fixed number of blocks, summed in
        // order: the mean, and so the seeds, do not depend on the thread count.
        const unsigned T = std::max(1u, prepare_threads ? prepare_threads : o.threads);
        constexpr unsigned blocks = 64;
        std::vector<std::pair<double, std::size_t>> block(blocks, {0.0, 0});
        idas::detail::run_workers(T, blocks, [&](unsigned w) {
            const std::size_t end = slots * (w + 1) / blocks;
            auto& [sum, count] = block[w];
            for (std::size_t t = slots * w / blocks; t < end; ++t)
                if (m.tet_alive(index_t(t))) {
                    const auto& tv = m.tet_vertices(index_t(t));
                    energies[t] = harmonic_energy(p[tv[0]], p[tv[1]], p[tv[2]], p[tv[3]]);
                    sum += energies[t], ++count;
                }
        });
        total_energy = 0, live_tets = 0;
        for (const auto& [sum, count] : block) total_energy += sum, live_tets += count;
    }
    double total_energy = 0; // over the live tets, when prepared
    std::size_t live_tets = 0;
    unsigned prepare_threads = 0; // threads to compute the energies on (0: the executor's)
    /// Slots set aside for the tets that 2-3 swaps add in parallel.
    static std::size_t growth(std::size_t slots) noexcept {
        return complete ? std::max<std::size_t>(4096, slots / 4) : 0;
    }

    template <class Mesh>
    double energy(const Mesh& m, index_t t) const {
        return t < energies.size() ? energies[t] : harmonic_energy(m, m.tet_vertices(t));
    }

    // ---- the energy tests, on the old mesh ----
    // Used twice: when an entry is pushed (so the queue holds only flips that improve at
    // that moment) and in `before` (the mesh may have changed since). Any change to a
    // tet of a candidate renews the candidate from the new tets, so filtering at push
    // time loses nothing.

    /// 3-2 of edge ab with ring x0 x1 x2: it becomes (x0 x1 x2 b) and (x0 x2 x1 a).
    template <class Mesh>
    bool improves_32(const Mesh& m, index_t a, index_t b, const idas::detail::edge_ring& r) const {
        detail::energy_sum old_e, new_e;
        for (index_t g : r.tets) old_e.add(energy(m, g));
        new_e.add(harmonic_energy(m, {r.verts[0], r.verts[1], r.verts[2], b}));
        if (!(new_e.sum < old_e.sum)) return false;
        new_e.add(harmonic_energy(m, {r.verts[0], r.verts[2], r.verts[1], a}));
        return detail::improves(old_e, new_e, keep_max);
    }

    /// 4-4 of edge ab with ring x0..x3: the new diagonal x_i x_{i+2} for i = 0 or 1.
    /// Returns i of the better improving diagonal, or -1.
    template <class Mesh>
    int best_44(const Mesh& m, index_t a, index_t b, const idas::detail::edge_ring& r) const {
        detail::energy_sum old_e;
        for (index_t g : r.tets) old_e.add(energy(m, g));
        int best = -1;
        detail::energy_sum best_e = old_e;
        for (std::size_t i = 0; i < 2; ++i) {
            const index_t x0 = r.verts[i], x1 = r.verts[i + 1], x2 = r.verts[i + 2],
                          x3 = r.verts[(i + 3) % 4];
            const tet_indices nt[4] = {
                {x0, x1, x2, b}, {x0, x2, x1, a}, {x0, x2, x3, b}, {x0, x3, x2, a}};
            detail::energy_sum e;
            std::size_t k = 0;
            for (; k < 4 && e.sum < best_e.sum; ++k) e.add(harmonic_energy(m, nt[k]));
            if (k == 4 && detail::improves(best_e, e, keep_max)) best = int(i), best_e = e;
        }
        return best;
    }

    /// Whether the tuple's 4-4 swap (diagonal from the tuple face's third vertex, as
    /// edge_swap_44 does it) is the better improving one.
    template <class Mesh>
    bool improves_44(const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        idas::detail::edge_ring r;
        if (!detail::short_edge_ring(m, a, b, 4, r) || r.tets.size() != 4) return false;
        const int i = best_44(m, a, b, r);
        if (i < 0) return false;
        const index_t third = m.face_vertices(t)[2];
        return third == r.verts[i] || third == r.verts[i + 2];
    }

    /// 2-3 of the face (local face lf of tet t1, t2 across it): tets abcd and cbae become
    /// (a b e d), (b c e d), (c a e d), where (a, b, c) is the face seen counter-clockwise
    /// from d (face_swap_23's convention).
    template <class Mesh>
    bool improves_23(const Mesh& m, index_t t1, std::uint8_t lf, index_t t2) const {
        const auto& tv = m.tet_vertices(t1);
        const auto fv = tet_local::face_vertices[lf];
        const index_t a = tv[fv[0]], b = tv[fv[2]], c = tv[fv[1]], d = tv[lf];
        index_t e = invalid_index;
        for (index_t x : m.tet_vertices(t2))
            if (x != a && x != b && x != c) e = x;
        detail::energy_sum old_e, new_e;
        old_e.add(energy(m, t1));
        old_e.add(energy(m, t2));
        new_e.add(harmonic_energy(m, {a, b, e, d}));
        if (!(new_e.sum < old_e.sum)) return false; // most faces stop here
        new_e.add(harmonic_energy(m, {b, c, e, d}));
        if (!(new_e.sum < old_e.sum)) return false;
        new_e.add(harmonic_energy(m, {c, a, e, d}));
        return detail::improves(old_e, new_e, keep_max);
    }

    template <class Mesh>
    bool before(op::edge_swap_32, const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        idas::detail::edge_ring r;
        return detail::short_edge_ring(m, a, b, 3, r) && improves_32(m, a, b, r);
    }
    template <class Mesh>
    bool before(op::edge_swap_44, const Mesh& m, const tet_tuple& t) const {
        return improves_44(m, t);
    }
    template <class Mesh>
    bool before(op::face_swap_23, const Mesh& m, const tet_tuple& t) const {
        const index_t t2 = m.connectivity().opposite_tet(t.tid, t.local_face);
        return t2 != invalid_index && improves_23(m, t.tid, t.local_face, t2);
    }

    // ---- parallel: the smallest region each flip needs (the vertices of its tets) ----
    template <class Op, class Mesh, class Claim>
    bool lock_region(Op, const Mesh& m, const tet_tuple& t, Claim&& claim) const {
        return replaced_tets_region<Op>(m, t, claim);
    }

    // ---- schedule ----

    /// The candidate on edge ab, pushed only if its flip improves now: a 3-2 swap if ab
    /// has three tets, in complete mode a 4-4 swap (the better diagonal) if it has four.
    template <class Mesh, class Push>
    void push_edge(const Mesh& m, index_t a, index_t b, Push& push) const {
        idas::detail::edge_ring r;
        if (!detail::short_edge_ring(m, a, b, complete ? 4 : 3, r)) return;
        if (r.tets.size() == 3) {
            if (improves_32(m, a, b, r)) push(op::edge_swap_32{}, m.tuple_at(r.tets[0], a, b));
        } else if constexpr (complete) {
            if (r.tets.size() != 4) return;
            const int i = best_44(m, a, b, r);
            if (i < 0) return;
            // The tuple must name the chosen diagonal's end c = x_i: tet i holds a, b, x_i.
            const index_t c = r.verts[i];
            tet_tuple t = m.tuple_at(r.tets[i], a, b);
            if (m.face_vertices(t)[2] != c) t = m.switch_face(t);
            push(op::edge_swap_44{}, t);
        }
    }

    /// The initial candidates found at vertex a, from its star (no global edge or face ids
    /// needed): edges ab and faces abc whose smallest vertex is a.
    template <class Mesh, class Push>
    void candidates_at(const Mesh& m, index_t a, Push&& push) const {
        // The b > a of edges ab, and (in the marks) how many tets each edge has.
        auto& marks = detail::vertex_marks::local();
        marks.start(m.vertex_slots());
        boost::container::small_vector<index_t, 32> ends;
        // A face (x, y) with smallest vertex a, and the tet and local face it was seen from.
        struct face_seen {
            std::pair<index_t, index_t> key;
            index_t tet;
            std::uint8_t lf;
            bool operator<(const face_seen& o) const noexcept {
                return key != o.key ? key < o.key : tet < o.tet;
            }
        };
        boost::container::small_vector<face_seen, 128> faces;
        for (index_t g : m.vertex_tets(a)) {
            const auto& tv = m.tet_vertices(g);
            for (index_t b : tv)
                if (b > a && marks.mark(b)) ends.push_back(b);
            if constexpr (complete) {
                const std::uint8_t i = tet_local::index_of(tv, a);
                for (std::uint8_t lf = 0; lf < 4; ++lf) {
                    if (lf == i) continue;
                    index_t x = invalid_index, y = invalid_index;
                    for (std::uint8_t k = 0; k < 4; ++k)
                        if (k != lf && k != i) (x == invalid_index ? x : y) = tv[k];
                    if (x < a || y < a) continue;
                    faces.push_back({std::pair<index_t, index_t>(std::minmax(x, y)), g, lf});
                }
            }
        }
        // In vertex order, not the star's (which differs between backends), so every
        // backend runs the same serial schedule.
        std::sort(ends.begin(), ends.end());
        for (index_t b : ends)
            if (marks.count[b] == 3 || (complete && marks.count[b] == 4)) push_edge(m, a, b, push);
        if constexpr (complete) {
            // A face seen from two tets of a's star is interior.
            std::sort(faces.begin(), faces.end());
            for (std::size_t k = 0; k + 1 < faces.size(); ++k)
                if (faces[k].key == faces[k + 1].key) {
                    if (improves_23(m, faces[k].tet, faces[k].lf, faces[k + 1].tet))
                        push(op::face_swap_23{}, m.tuple_from_face(faces[k].tet, faces[k].lf));
                    ++k;
                }
        }
    }

    /// After a flip: cache the new tets' energies, then the candidates among their edges
    /// and faces.
    template <class Op, class Mesh, class Push>
    void renew(Op, const Mesh& m, const op_result<tet_tuple>& r, Push&& push) {
        for (const tet_tuple& c : r.cells)
            if (c.tid < energies.size())
                energies[c.tid] = harmonic_energy(m, m.tet_vertices(c.tid));
        boost::container::small_vector<std::pair<index_t, index_t>, 24> seen_edges;
        boost::container::small_vector<tri_indices, 24> seen_faces;
        for (const tet_tuple& c : r.cells) {
            const auto& tv = m.tet_vertices(c.tid);
            for (std::uint8_t le = 0; le < 6; ++le) {
                const auto ev = tet_local::edge_vertices[le];
                const std::pair<index_t, index_t> key = std::minmax(tv[ev[0]], tv[ev[1]]);
                if (std::find(seen_edges.begin(), seen_edges.end(), key) != seen_edges.end())
                    continue;
                seen_edges.push_back(key);
                push_edge(m, key.first, key.second, push);
            }
            if constexpr (complete) {
                for (std::uint8_t lf = 0; lf < 4; ++lf) {
                    const auto fv = tet_local::face_vertices[lf];
                    tri_indices key = {tv[fv[0]], tv[fv[1]], tv[fv[2]]};
                    std::sort(key.begin(), key.end());
                    if (std::find_if(seen_faces.begin(), seen_faces.end(),
                                     [&](const tri_indices& f) {
                                         return f[0] == key[0] && f[1] == key[1] && f[2] == key[2];
                                     }) != seen_faces.end())
                        continue;
                    seen_faces.push_back(key);
                    const index_t t2 = m.connectivity().opposite_tet(c.tid, lf);
                    if (t2 != invalid_index && improves_23(m, c.tid, lf, t2))
                        push(op::face_swap_23{}, m.tuple_from_face(c.tid, lf));
                }
            }
        }
    }

    /// Room for the tets 2-3 swaps add while workers run (3-2 swaps free slots, but
    /// recycling is off in parallel).
    template <class Mesh>
    std::pair<index_t, index_t> parallel_growth(const Mesh& m) const {
        return {0, static_cast<index_t>(growth(m.tet_slots()))};
    }
};

/// The flip phase as a spec: candidates found at every vertex (by each worker in its part).
template <harmonic_mode Mode>
struct harmonic_flip_spec : harmonic_flip_rules<Mode> {
    template <class Mesh, class Push>
    void initial_at(const Mesh& m, index_t a, Push& push) const {
        this->candidates_at(m, a, push);
    }
};

/// Complete-mode flips (2-3, 3-2, 4-4) seeded from the worst tets only: the edges and faces
/// of tets whose energy exceeds `above` times the mean, instead of every edge and face
/// (a scan that costs as much as a smoothing pass). Improvements then spread through
/// `renew` as usual.
struct harmonic_seeded_flip_spec : harmonic_flip_rules<harmonic_mode::complete> {
    double above = 8;

    double bar = 0;            // seeds: tets with E above this (set by prepare)
    std::size_t seed_tets = 0; // how many

    template <class Mesh>
    void prepare(const Mesh& m, const exec_options& o = {}) {
        harmonic_flip_rules<harmonic_mode::complete>::prepare(m, o);
        bar = live_tets ? above * total_energy / double(live_tets) : 0.0;
        seed_tets = 0;
        for (index_t t = 0; t < m.tet_slots(); ++t)
            seed_tets += m.tet_alive(t) && energies[t] > bar;
    }
    /// The seeds' flips add a few tets each (2-3 swaps, then those their renewals find),
    /// not a quarter of the mesh: setting aside less saves growing the arrays (0.15 s on
    /// 6M tets). An operation that finds no room waits for the serial pass.
    template <class Mesh>
    std::pair<index_t, index_t> parallel_growth(const Mesh&) const {
        return {0, static_cast<index_t>(std::max<std::size_t>(4096, 16 * seed_tets))};
    }

    template <class Mesh, class Push>
    void initial(const Mesh& m, Push&& push) const {
        for (index_t t = 0; t < m.tet_slots(); ++t) {
            if (!m.tet_alive(t) || !(energies[t] > bar)) continue;
            const auto& tv = m.tet_vertices(t);
            for (std::uint8_t le = 0; le < 6; ++le) {
                const auto ev = tet_local::edge_vertices[le];
                push_edge(m, tv[ev[0]], tv[ev[1]], push);
            }
            for (std::uint8_t lf = 0; lf < 4; ++lf) {
                const index_t t2 = m.connectivity().opposite_tet(t, lf);
                if (t2 != invalid_index && improves_23(m, t, lf, t2))
                    push(op::face_swap_23{}, m.tuple_from_face(t, lf));
            }
        }
    }
};

/// The smoothing phase (complete mode): each interior vertex once, moved down the gradient
/// of its star's energy.
struct harmonic_smooth_spec {
    using operations = op_list<op::smooth_vertex>;
    bool keep_max = true;
    unsigned steps = 2; // gradient steps per vertex
    unsigned tries = 1; // step lengths tried per step, halving from a fifth of the shortest edge
    // smooth_vertex would test is_boundary_vertex (a sort of the link's edges) itself;
    // `before` refuses boundary vertices from the star it gathers anyway (interior_star).
    static constexpr bool allow_boundary_change = true;

    auto invariants() const { return invariant_set<positive_orientation>{}; }

    /// Every vertex with tets, found by each worker in its own part.
    template <class Mesh, class Push>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        if (!std::ranges::empty(m.vertex_tets(v)))
            push(op::smooth_vertex{}, m.tuple_from_vertex(v));
    }

    /// A star tet (p, q1, q2, q3), positively oriented, with what does not depend on the
    /// moving vertex p: n = (q2-q1)x(q3-q1) (so 6V = q1.n - p.n) and |n|^2 (twice the
    /// opposite face's area, squared).
    struct star_tet {
        vec3 q1, q2, q3, n;
        double nn, q1n;
    };

    /// E of a star tet with the moving vertex at p (+infinity unless positive volume).
    static double energy(const vec3& p, const star_tet& t) noexcept {
        const double D = t.q1n - dot(p, t.n);
        if (!(D > 0)) return std::numeric_limits<double>::infinity();
        const vec3 a = t.q1 - p, b = t.q2 - p, c = t.q3 - p;
        return (t.nn + squared_norm(cross(a, b)) + squared_norm(cross(b, c)) +
                squared_norm(cross(c, a))) /
               (6.0 * D);
    }

    /// E and its gradient in p. For a face (p, x, y), grad |(x-p)x(y-p)|^2 = 2 (x-y) x
    /// ((x-p)x(y-p)); grad(6V) = -n.
    static double energy_and_gradient(const vec3& p, const star_tet& t, vec3& grad) noexcept {
        const double D = t.q1n - dot(p, t.n);
        if (!(D > 0)) return std::numeric_limits<double>::infinity();
        const vec3 a = t.q1 - p, b = t.q2 - p, c = t.q3 - p;
        const vec3 c1 = cross(a, b), c2 = cross(b, c), c3 = cross(c, a);
        const double S = t.nn + squared_norm(c1) + squared_norm(c2) + squared_norm(c3);
        const vec3 gS =
            (cross(t.q1 - t.q2, c1) + cross(t.q2 - t.q3, c2) + cross(t.q3 - t.q1, c3)) * 2.0;
        // E = S / (6 D); grad D = -n.
        grad = (gS * D + t.n * S) / (6.0 * D * D);
        return S / (6.0 * D);
    }

    static star_tet make_star_tet(const vec3& q1, const vec3& q2, const vec3& q3) noexcept {
        const vec3 n = cross(q2 - q1, q3 - q1);
        return {q1, q2, q3, n, squared_norm(n), dot(q1, n)};
    }

    /// E of the tet (p, q1, q2, q3) with its gradient in p (tests use this form).
    static double energy_and_gradient(const vec3& p, const vec3& q1, const vec3& q2, const vec3& q3,
                                      vec3& grad) noexcept {
        return energy_and_gradient(p, make_star_tet(q1, q2, q3), grad);
    }

    /// The star of v: per tet the other three vertices' positions, ordered so that (v, q1,
    /// q2, q3) is an even permutation of the stored order (so positively oriented).
    /// Returns false for a boundary vertex: its link, a triangulated sphere (T triangles,
    /// V = 2 + T / 2 vertices by Euler) for an interior vertex, is a disk with b >= 3
    /// boundary edges (V = 1 + (T + b) / 2) on the hull, so counting the distinct link
    /// vertices tells them apart.
    using star = boost::container::small_vector<star_tet, 48>;
    template <class Mesh>
    static bool gather_interior(const Mesh& m, index_t v, star& s) {
        static constexpr std::uint8_t perm[4][3] = {{1, 2, 3}, {0, 3, 2}, {3, 0, 1}, {2, 1, 0}};
        // Distinct link vertices.
        auto& marks = detail::vertex_marks::local();
        marks.start(m.vertex_slots());
        std::size_t link = 0;
        for (index_t g : m.vertex_tets(v))
            for (index_t x : m.tet_vertices(g)) link += x != v && marks.mark(x) ? 1 : 0;
        if (2 * link != m.vertex_tets(v).size() + 4) return false;
        const auto pos = m.positions();
        s.clear();
        for (index_t g : m.vertex_tets(v)) {
            const auto& tv = m.tet_vertices(g);
            const std::uint8_t i = tet_local::index_of(tv, v);
            s.push_back(
                make_star_tet(pos[tv[perm[i][0]]], pos[tv[perm[i][1]]], pos[tv[perm[i][2]]]));
        }
        return true;
    }

    /// The star's energy with the vertex at q if that improves on `current`; else nullopt,
    /// as soon as the partial sum or (keep_max) one tet shows it cannot.
    std::optional<detail::energy_sum> trial(const star& s, const vec3& q,
                                            const detail::energy_sum& current) const {
        detail::energy_sum e;
        const double limit = current.sum * (1.0 - 1e-12);
        for (const auto& t : s) {
            e.add(energy(q, t));
            if (!(e.sum < limit) || (keep_max && e.max > current.max)) return std::nullopt;
        }
        return e;
    }

    template <class Mesh>
    std::optional<vec3> before(op::smooth_vertex, const Mesh& m, const tet_tuple& t) const {
        star s;
        if (!gather_interior(m, t.vid, s)) return std::nullopt; // the hull stays put
        vec3 p = m.positions()[t.vid];
        double shortest = std::numeric_limits<double>::infinity();
        for (const auto& x : s) shortest = std::min(shortest, squared_norm(x.q1 - p));
        shortest = std::sqrt(shortest);
        detail::energy_sum start, current;
        for (unsigned step = 0; step < steps; ++step) {
            // The gradient, and (first step) the star's energy, in one pass.
            vec3 g{};
            detail::energy_sum here;
            for (const auto& x : s) {
                vec3 gi;
                here.add(energy_and_gradient(p, x, gi));
                g += gi;
            }
            if (step == 0) start = current = here;
            const double gn = norm(g);
            if (!(gn > 0) || !(start.sum < std::numeric_limits<double>::infinity())) break;
            double len = 0.2 * shortest;
            bool moved = false;
            for (unsigned k = 0; k < tries && !moved; ++k, len *= 0.5) {
                const vec3 q = p - g * (len / gn);
                if (const auto e = trial(s, q, current)) p = q, current = *e, moved = true;
            }
            if (!moved) break;
        }
        if (!detail::improves(start, current, keep_max)) return std::nullopt;
        return p;
    }

    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<tet_tuple>& r, vec3& p) const {
        m.positions(r).set(r.anchor.vid, p);
        return true;
    }
};

struct harmonic_options {
    harmonic_mode mode = harmonic_mode::complete;
    unsigned rounds = 1;   // complete mode: smoothing pass + seeded flips, this many times
    double seed_above = 8; // complete mode: flips seeded from tets with E above this x mean
    bool keep_max = true;
    exec_options exec{};
};

struct harmonic_report {
    std::uint64_t flips = 0, smoothed = 0, attempted = 0;
    std::uint64_t lock_failures = 0, deferred_to_serial = 0, crossed_parts = 0;
    double seconds = 0, flip_seconds = 0, smooth_seconds = 0;
    double owner_seconds = 0;                   // lock-free phases of own_part_first
    double setup_seconds = 0, tail_seconds = 0; // on one thread, summed over the phases
};

/// The schedules: both modes start with 3-2 swaps to convergence (they are the cheapest
/// flips: the candidates are the valence-3 edges, and they do most of the work). Complete
/// mode then alternates smoothing passes, which lower the energy most, with all three flips
/// seeded from the tets still far above the mean, until a round does nothing. The seeds
/// give a few thousand flips: on one thread, as starting workers (partition, slot pools)
/// costs more than they save.
using harmonic_reduced_schedule =
    schedule::sequence<schedule::phase<harmonic_flip_spec<harmonic_mode::reduced>>>;
using harmonic_complete_schedule =
    schedule::sequence<schedule::phase<harmonic_flip_spec<harmonic_mode::reduced>>,
                       schedule::repeat_while_busy<
                           schedule::phase<harmonic_smooth_spec>,
                           schedule::phase<harmonic_seeded_flip_spec, schedule::default_queue, 1>>>;

/// The whole algorithm on one mesh type and lock policy. Its phases run until their queues
/// are empty, in no particular order, so each part's own operations can all go first:
/// own_part_first.
template <class Mesh = tet_mesh<>, lock_policy Lock = lock::own_part_first,
          class Partition = partition::morton>
struct harmonic_triangulation {
    static harmonic_report run(Mesh& m, const harmonic_options& o = {}) {
        return run_observed(m, o, schedule::no_observer{});
    }

    /// The same, telling `observer(phase, round, run_report)` after every phase (0: the
    /// 3-2 flips; complete mode: 1 smoothing, 2 seeded flips).
    template <class Observer>
    static harmonic_report run_observed(Mesh& m, const harmonic_options& o, Observer&& observer) {
        harmonic_flip_spec<harmonic_mode::reduced> reduced{{o.keep_max}};
        harmonic_report rep;
        auto add = [&](const run_report& r, std::uint64_t& counter, double& seconds) {
            counter += r.succeeded, rep.attempted += r.attempted, seconds += r.seconds;
            rep.lock_failures += r.lock_failures, rep.deferred_to_serial += r.deferred_to_serial;
            rep.crossed_parts += r.crossed_parts, rep.owner_seconds += r.owner_seconds;
            rep.setup_seconds += r.setup_seconds, rep.tail_seconds += r.tail_seconds;
        };
        if (o.mode == harmonic_mode::reduced) {
            using driver =
                schedule::driver<harmonic_reduced_schedule, Mesh, Lock, queue::fifo, Partition>;
            const auto r = driver::run(m, o.exec, 1, observer, reduced);
            add(r.phases[0], rep.flips, rep.flip_seconds);
            rep.seconds = r.seconds;
            return rep;
        }
        harmonic_smooth_spec smoothing;
        smoothing.keep_max = o.keep_max;
        harmonic_seeded_flip_spec seeds;
        seeds.keep_max = o.keep_max, seeds.above = o.seed_above;
        seeds.prepare_threads = o.exec.threads; // its energies: on every thread
        using driver =
            schedule::driver<harmonic_complete_schedule, Mesh, Lock, queue::fifo, Partition>;
        const auto r = driver::run(m, o.exec, o.rounds, observer, reduced, smoothing, seeds);
        add(r.phases[0], rep.flips, rep.flip_seconds);
        add(r.phases[1], rep.smoothed, rep.smooth_seconds);
        add(r.phases[2], rep.flips, rep.flip_seconds);
        rep.seconds = r.seconds;
        return rep;
    }
};

static_assert(spec_for<harmonic_flip_spec<harmonic_mode::complete>, tet_mesh<>>);
static_assert(spec_for<harmonic_smooth_spec, tet_mesh<>>);
static_assert(tet_mesh_like<tet_mesh<>>);
static_assert(!idas::detail::links_faces<tet_mesh<>>); // so the flips' minimal lock regions apply

} // namespace idas::algorithms
