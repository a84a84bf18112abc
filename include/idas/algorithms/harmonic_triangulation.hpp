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
//   S         flips until no flip improves; complete mode then alternates smoothing
//             passes and flips for `rounds` rounds
#pragma once

#include <idas/exec/executor.hpp>
#include <idas/invariants/positive_orientation.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/ops/tet_ops.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

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

/// Number of tets around edge ab (tets of a holding b).
template <class Mesh>
std::size_t edge_valence(const Mesh& m, index_t a, index_t b) {
    std::size_t n = 0;
    for (index_t g : m.vertex_tets(a)) n += tet_local::contains(m.tet_vertices(g), b) ? 1 : 0;
    return n;
}

} // namespace detail

/// The flip phase. Mode is a template argument, so the reduced spec's operation list holds
/// the 3-2 swap alone and its schedule compiles without the others.
template <harmonic_mode Mode>
struct harmonic_flip_spec {
    using operations =
        std::conditional_t<Mode == harmonic_mode::reduced, op_list<op::edge_swap_32>,
                           op_list<op::edge_swap_32, op::edge_swap_44, op::face_swap_23>>;
    static constexpr bool complete = Mode == harmonic_mode::complete;

    bool keep_max = true; // also refuse flips that raise the local maximum energy

    auto invariants() const { return invariant_set<positive_orientation>{}; }

    // ---- the energy tests, on the old mesh ----
    // Used twice: when an entry is pushed (so the queue holds only flips that improve at
    // that moment) and in `before` (the mesh may have changed since). Any change to a
    // tet of a candidate renews the candidate from the new tets, so filtering at push
    // time loses nothing.

    /// 3-2 of edge ab: the ring x0 x1 x2 becomes (x0 x1 x2 b) and (x0 x2 x1 a).
    template <class Mesh>
    bool improves_32(const Mesh& m, index_t a, index_t b) const {
        idas::detail::edge_ring r;
        if (!idas::detail::closed_edge_ring(m, a, b, r) || r.tets.size() != 3) return false;
        detail::energy_sum old_e, new_e;
        for (index_t g : r.tets) old_e.add(harmonic_energy(m, m.tet_vertices(g)));
        new_e.add(harmonic_energy(m, {r.verts[0], r.verts[1], r.verts[2], b}));
        new_e.add(harmonic_energy(m, {r.verts[0], r.verts[2], r.verts[1], a}));
        return detail::improves(old_e, new_e, keep_max);
    }

    /// 4-4 of edge ab with ring x0..x3: the new diagonal x_i x_{i+2} for i = 0 or 1.
    /// Returns the ring vertex x_i of the better improving diagonal, or invalid_index.
    template <class Mesh>
    index_t best_44(const Mesh& m, index_t a, index_t b) const {
        idas::detail::edge_ring r;
        if (!idas::detail::closed_edge_ring(m, a, b, r) || r.tets.size() != 4) return invalid_index;
        detail::energy_sum old_e;
        for (index_t g : r.tets) old_e.add(harmonic_energy(m, m.tet_vertices(g)));
        index_t best = invalid_index;
        detail::energy_sum best_e = old_e;
        for (std::size_t i = 0; i < 2; ++i) {
            const index_t x0 = r.verts[i], x1 = r.verts[i + 1], x2 = r.verts[i + 2],
                          x3 = r.verts[(i + 3) % 4];
            detail::energy_sum e;
            e.add(harmonic_energy(m, {x0, x1, x2, b}));
            e.add(harmonic_energy(m, {x0, x2, x1, a}));
            e.add(harmonic_energy(m, {x0, x2, x3, b}));
            e.add(harmonic_energy(m, {x0, x3, x2, a}));
            if (detail::improves(best_e, e, keep_max)) best = x0, best_e = e;
        }
        return best;
    }

    /// Whether the tuple's 4-4 swap (diagonal from the tuple face's third vertex, as
    /// edge_swap_44 does it) is the better improving one.
    template <class Mesh>
    bool improves_44(const Mesh& m, const tet_tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const index_t c = best_44(m, a, b);
        if (c == invalid_index) return false;
        const index_t third = m.face_vertices(t)[2];
        if (third == c) return true;
        // The same diagonal seen from its other end x_{i+2}.
        idas::detail::edge_ring r;
        idas::detail::closed_edge_ring(m, a, b, r);
        for (std::size_t i = 0; i < 4; ++i)
            if (r.verts[i] == c) return r.verts[(i + 2) % 4] == third;
        return false;
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
        old_e.add(harmonic_energy(m, tv));
        old_e.add(harmonic_energy(m, m.tet_vertices(t2)));
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
        return improves_32(m, a, b);
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

    // ---- schedule ----

    /// Candidates among a set of edges and faces, each pushed only if its flip improves
    /// now: edges of valence 3 (3-2) and, in complete mode, of valence 4 (4-4, the better
    /// of the two diagonals) and interior faces (2-3).
    template <class Mesh, class Push>
    void push_edge(const Mesh& m, index_t g, index_t a, index_t b, std::size_t valence,
                   Push& push) const {
        if (valence == 3) {
            if (improves_32(m, a, b)) push(op::edge_swap_32{}, m.tuple_at(g, a, b));
        } else if constexpr (complete) {
            if (valence != 4) return;
            // The tuple must name the chosen diagonal's end c: a tet of the edge with c
            // whose face abc the tuple is on.
            const index_t c = best_44(m, a, b);
            if (c == invalid_index) return;
            for (index_t h : m.vertex_tets(a)) {
                const auto& hv = m.tet_vertices(h);
                if (!tet_local::contains(hv, b) || !tet_local::contains(hv, c)) continue;
                tet_tuple t = m.tuple_at(h, a, b);
                if (m.face_vertices(t)[2] != c) t = m.switch_face(t);
                push(op::edge_swap_44{}, t);
                return;
            }
        }
    }

    /// The initial candidates found at vertex a, from its star (no global edge or face ids
    /// needed): edges ab and faces abc whose smallest vertex is a.
    template <class Mesh, class Push>
    void initial_at(const Mesh& m, index_t a, Push&& push) const {
        boost::container::small_vector<std::pair<index_t, index_t>, 64> count; // (b, tets)
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
        {
            for (index_t g : m.vertex_tets(a)) {
                const auto& tv = m.tet_vertices(g);
                for (index_t b : tv) {
                    if (b <= a) continue;
                    auto it = std::find_if(count.begin(), count.end(),
                                           [&](const auto& x) { return x.first == b; });
                    if (it == count.end())
                        count.push_back({b, 1});
                    else
                        ++it->second;
                }
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
            for (const auto& [b, n] : count) {
                if (n != 3 && !(complete && n == 4)) continue;
                for (index_t g : m.vertex_tets(a))
                    if (tet_local::contains(m.tet_vertices(g), b)) {
                        push_edge(m, g, a, b, n, push);
                        break;
                    }
            }
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
    }

    /// After a flip: the candidates among the new tets' edges and faces.
    template <class Op, class Mesh, class Push>
    void renew(Op, const Mesh& m, const op_result<tet_tuple>& r, Push&& push) const {
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
                push_edge(m, c.tid, key.first, key.second,
                          detail::edge_valence(m, key.first, key.second), push);
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
        return {0, complete ? std::max<index_t>(4096, m.tet_slots() / 4) : 0};
    }
};

/// The smoothing phase (complete mode): each interior vertex once, moved down the gradient
/// of its star's energy.
struct harmonic_smooth_spec {
    using operations = op_list<op::smooth_vertex>;
    bool keep_max = true;
    unsigned steps = 2; // gradient steps per vertex

    auto invariants() const { return invariant_set<positive_orientation>{}; }

    /// E of one star tet as a function of the moving vertex p, with its gradient. (p, q1,
    /// q2, q3) is positively oriented. With n = (q2-q1)x(q3-q1): 6V = (q1-p).n, so
    /// grad(6V) = -n; for a face (p, x, y), grad |(x-p)x(y-p)|^2 = 2 (x-y) x ((x-p)x(y-p)).
    static double energy_and_gradient(const vec3& p, const vec3& q1, const vec3& q2, const vec3& q3,
                                      vec3& grad) noexcept {
        const vec3 n = cross(q2 - q1, q3 - q1);
        const double D = dot(q1 - p, n);
        if (!(D > 0)) return std::numeric_limits<double>::infinity();
        const vec3 c1 = cross(q1 - p, q2 - p), c2 = cross(q2 - p, q3 - p),
                   c3 = cross(q3 - p, q1 - p);
        const double S = squared_norm(n) + squared_norm(c1) + squared_norm(c2) + squared_norm(c3);
        const vec3 gS = (cross(q1 - q2, c1) + cross(q2 - q3, c2) + cross(q3 - q1, c3)) * 2.0;
        // E = S / (6 D); grad D = -n.
        grad = (gS * D + n * S) / (6.0 * D * D);
        return S / (6.0 * D);
    }

    /// The other three vertices of each star tet, ordered so that (v, q1, q2, q3) is an
    /// even permutation of the stored order (so positively oriented).
    using star = boost::container::small_vector<std::array<index_t, 3>, 48>;
    template <class Mesh>
    static void gather(const Mesh& m, index_t v, star& s) {
        static constexpr std::uint8_t perm[4][3] = {{1, 2, 3}, {0, 3, 2}, {3, 0, 1}, {2, 1, 0}};
        s.clear();
        for (index_t g : m.vertex_tets(v)) {
            const auto& tv = m.tet_vertices(g);
            const std::uint8_t i = tet_local::index_of(tv, v);
            s.push_back({tv[perm[i][0]], tv[perm[i][1]], tv[perm[i][2]]});
        }
    }

    template <class Mesh>
    static detail::energy_sum star_energy(const Mesh& m, const star& s, const vec3& p) {
        detail::energy_sum e;
        const auto pos = m.positions();
        for (const auto& q : s) e.add(harmonic_energy(p, pos[q[0]], pos[q[1]], pos[q[2]]));
        return e;
    }

    template <class Mesh>
    std::optional<vec3> before(op::smooth_vertex, const Mesh& m, const tet_tuple& t) const {
        const index_t v = t.vid;
        star s;
        gather(m, v, s);
        const auto pos = m.positions();
        vec3 p = pos[v];
        const detail::energy_sum start = star_energy(m, s, p);
        detail::energy_sum current = start;
        double shortest = std::numeric_limits<double>::infinity();
        for (const auto& q : s) shortest = std::min(shortest, squared_norm(pos[q[0]] - p));
        shortest = std::sqrt(shortest);
        for (unsigned step = 0; step < steps; ++step) {
            vec3 g{};
            for (const auto& q : s) {
                vec3 gi;
                energy_and_gradient(p, pos[q[0]], pos[q[1]], pos[q[2]], gi);
                g += gi;
            }
            const double gn = norm(g);
            if (!(gn > 0)) break;
            // First try a move of a fifth of the shortest edge at p; halve until it helps.
            double len = 0.2 * shortest;
            bool moved = false;
            for (int k = 0; k < 5 && !moved; ++k, len *= 0.5) {
                const vec3 q = p - g * (len / gn);
                const detail::energy_sum e = star_energy(m, s, q);
                if (detail::improves(current, e, keep_max)) p = q, current = e, moved = true;
            }
            if (!moved) break;
        }
        if (!detail::improves(start, current, keep_max)) return std::nullopt;
        return p;
    }

    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<tet_tuple>& r, vec3& p) const {
        m.positions().set(r.anchor.vid, p);
        return true;
    }
};

struct harmonic_options {
    harmonic_mode mode = harmonic_mode::complete;
    unsigned rounds = 2; // complete mode: smoothing pass + flips, this many times
    bool keep_max = true;
    exec_options exec{};
};

struct harmonic_report {
    std::uint64_t flips = 0, smoothed = 0, attempted = 0;
    std::uint64_t lock_failures = 0, deferred_to_serial = 0;
    double seconds = 0, flip_seconds = 0, smooth_seconds = 0;
};

/// The whole algorithm on one mesh type and lock policy: flips, then (complete mode)
/// rounds of smoothing and flips.
template <class Mesh = tet_mesh<>, lock_policy Lock = lock::vertex_try_lock,
          class Partition = partition::morton>
struct harmonic_triangulation {
    template <harmonic_mode M>
    using flips = executor<harmonic_flip_spec<M>, Mesh, Lock, queue::fifo, Partition>;
    using smooth = executor<harmonic_smooth_spec, Mesh, Lock, queue::fifo, Partition>;

    static harmonic_report run(Mesh& m, const harmonic_options& o = {}) {
        const auto start = std::chrono::steady_clock::now();
        harmonic_report rep;
        auto add = [&](const run_report& r, std::uint64_t& counter) {
            counter += r.succeeded, rep.attempted += r.attempted;
            (&counter == &rep.flips ? rep.flip_seconds : rep.smooth_seconds) += r.seconds;
            rep.lock_failures += r.lock_failures, rep.deferred_to_serial += r.deferred_to_serial;
        };
        if (o.mode == harmonic_mode::reduced) {
            harmonic_flip_spec<harmonic_mode::reduced> spec{o.keep_max};
            add(flips<harmonic_mode::reduced>::run(m, spec, o.exec), rep.flips);
        } else {
            harmonic_flip_spec<harmonic_mode::complete> spec{o.keep_max};
            add(flips<harmonic_mode::complete>::run(m, spec, o.exec), rep.flips);
            for (unsigned round = 0; round < o.rounds; ++round) {
                harmonic_smooth_spec smoothing;
                smoothing.keep_max = o.keep_max;
                const run_report sr = smooth::run(m, smoothing, o.exec);
                add(sr, rep.smoothed);
                const run_report fr = flips<harmonic_mode::complete>::run(m, spec, o.exec);
                add(fr, rep.flips);
                if (sr.succeeded == 0 && fr.succeeded == 0) break;
            }
        }
        rep.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return rep;
    }
};

static_assert(schedule_spec<harmonic_flip_spec<harmonic_mode::complete>, tet_mesh<>>);
static_assert(schedule_spec<harmonic_smooth_spec, tet_mesh<>>);
static_assert(tet_mesh_like<tet_mesh<>>);

} // namespace idas::algorithms
