// The envelope invariant: every triangle an operation creates must lie inside the
// eps-envelope of the input surface, checked exactly (Wang, Ferguson, Schneider, Zorin,
// Panozzo 2020, "Exact and efficient polyhedral envelope containment check", as
// implemented by CGAL::Polyhedral_envelope).
//
// The envelope is the union of one prism per (non-degenerate) input triangle: the
// triangle thickened by eps/sqrt(3) along its normal and bevelled at its edges and
// corners. It lies inside the true eps-offset, so an accepted triangle is within eps of
// the input everywhere; the containment test itself uses exact predicates (and exact
// constructions where needed), so rounding never lets a triangle through.
//
// CGAL's check costs 50-300 us per triangle on remeshing-sized triangles, so a filter
// decides most triangles first, without changing any answer (both of its verdicts are
// proven, with margins for rounding):
// * inside, first stage (`covered`, ~90% of remeshing's checks): projected along a
//   coordinate axis, the input triangles under the query, found by walking the input's
//   edge adjacency from the last query's, cover the query's projection (checked with
//   exact orientations: a closed patch of consistently oriented triangles), and the part
//   of the query above each of them is within eps/sqrt(3) of it (its clipped corners
//   decide, the distance to a triangle being convex); see `covered_along`. Where the part
//   above a few of them fails that check, only those parts go to the second stage;
// * inside, otherwise: a prism contains every point within eps/sqrt(3) of its triangle T (each of
//   its bounding planes is at least that far from T). The distance to T is convex, so a
//   query triangle whose three corners are within r < eps/sqrt(3) of one input triangle
//   lies inside that prism. The query is split 4-to-1 (up to 8 levels, 256 pieces) until every
//   piece passes this test against some nearby input triangle (closest-point queries on an
//   idas::triangle_aabb_tree);
// * outside: every prism point is within eps of its triangle and within eps/sqrt(3) of
//   its plane, so a corner or piece centroid farther than eps from the input, or outside
//   the slabs of all the input triangles within eps, is outside the envelope.
// Whatever the filter cannot decide goes to CGAL, whose structure is built on the first
// such question (a user of the filter alone never builds it). `contains_exact` skips the
// filter.
// The filter keeps the input triangles it found near recent queries (a per-thread cache
// in the invariant hook, kept across operations), rejects most of them for a point with
// a bounding-sphere test before the exact point-triangle distance, tries the one that
// held the last piece first, and starts tree queries from the newest one. A piece that
// crosses an input edge is also tested against the two triangles of that edge, cut in
// two by a plane through the edge (remeshing blub: a third of the filter's time and half
// of the triangles it left to CGAL).
// Needle input triangles (height below 1e-6 of their longest edge) have rounded normals
// too inaccurate for these bounds: they never prove containment, and no outside verdict
// is given near one.
//
// Needs CGAL (5.4 or later; header-only, with GMP and MPFR): link CGAL::CGAL. Not part of
// the idas/idas.hpp umbrella.
//
// Thread safety: an envelope is immutable once built (CGAL's structure is made once, under
// std::call_once, by the first thread that needs it), and CGAL's const queries on it are
// safe to run concurrently (see the note at the end of this file), so one envelope object,
// and its copies (which share the CGAL structure), may be used by any number of threads.
//
// Usage: list it among a spec's invariants,
//     auto invariants() const { return idas::invariant_set{idas::no_normal_flip{}, env}; }
// where env = idas::envelope_from(input_mesh) (eps relative to the bounding-box diagonal)
// or idas::envelope(V, F, eps) (absolute). A default-constructed envelope is disabled and
// accepts everything, so a spec can always list it and switch it on at run time.
#pragma once

#include <idas/core/aabb_tree.hpp>
#include <idas/core/types.hpp>
#include <idas/mesh/tri_mesh.hpp>
#include <idas/ops/operation.hpp>
#include <idas/predicates/orient.hpp>

// GCC 12 reports false -Wmaybe-uninitialized positives inside CGAL's envelope code once
// inlined (at -O1 with sanitizers); they are CGAL's lines, so silence them there only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polyhedral_envelope.h>
#include <CGAL/version.h>
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

static_assert(CGAL_VERSION_NR >= 1050400000,
              "idas::envelope needs CGAL 5.4 or later (thread-safe Epeck, Polyhedral_envelope)");

#if !defined(CGAL_HAS_THREADS) && !defined(IDAS_ENVELOPE_SINGLE_THREADED)
#error                                                                                             \
    "CGAL is configured without thread support (CGAL_HAS_NO_THREADS), so its exact objects are not \
safe to share between threads and idas::envelope could not be used by parallel executors. \
Define IDAS_ENVELOPE_SINGLE_THREADED to use it from one thread only."
#endif

namespace idas {

/// Which stage decided each containment check, counted per thread when
/// IDAS_ENVELOPE_STATS is defined (in every translation unit); all zero otherwise.
struct envelope_stats {
    std::uint64_t checks = 0;         ///< triangles checked (filtered contains)
    std::uint64_t covered = 0;        ///< proven inside by the covering test (at the top)
    std::uint64_t filter_inside = 0;  ///< proven inside by the filter (covering included)
    std::uint64_t filter_outside = 0; ///< proven outside by the filter
    std::uint64_t exact = 0;          ///< left to CGAL
    std::uint64_t exact_inside = 0;   ///< of which CGAL found inside
    std::uint64_t seed_queries = 0;   ///< tree queries for the covering test's start
};

/// The calling thread's counters.
inline envelope_stats& envelope_counters() noexcept {
    thread_local envelope_stats s;
    return s;
}

#if defined(IDAS_ENVELOPE_STATS)
#define IDAS_DETAIL_ENV_COUNT(field) (++::idas::envelope_counters().field)
#else
#define IDAS_DETAIL_ENV_COUNT(field) ((void)0)
#endif

class envelope {
public:
    using kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
    using cgal_envelope = CGAL::Polyhedral_envelope<kernel>;

    static constexpr double default_relative_eps = 1e-3;

    /// Per-operation state of the invariant: none.
    struct state {};

    /// A disabled envelope: contains everything, costs nothing.
    envelope() = default;

    /// The envelope at absolute distance eps (> 0) of surface (V, F). Degenerate (zero-area)
    /// triangles are skipped, as CGAL does for meshes: they are covered by their neighbours'
    /// prisms. Throws input_error for a bad eps, out-of-range indices or non-finite
    /// coordinates.
    envelope(const std::vector<vec3>& V, const std::vector<tri_indices>& F, double eps) {
        if (!(eps > 0) || !std::isfinite(eps))
            throw input_error("envelope: eps must be positive and finite, got " +
                              std::to_string(eps));
        std::vector<kernel::Point_3> points;
        points.reserve(V.size());
        for (std::size_t i = 0; i < V.size(); ++i) {
            if (!is_finite(V[i]))
                throw input_error("envelope: vertex " + std::to_string(i) +
                                  " has a non-finite coordinate");
            points.emplace_back(V[i].x, V[i].y, V[i].z);
        }
        std::vector<std::array<int, 3>> triangles;
        triangles.reserve(F.size());
        std::size_t skipped = 0;
        for (std::size_t f = 0; f < F.size(); ++f) {
            for (index_t v : F[f])
                if (v >= V.size() || v > static_cast<index_t>(std::numeric_limits<int>::max()))
                    throw input_error("envelope: face " + std::to_string(f) + " has vertex index " +
                                      std::to_string(v) + " beyond the " +
                                      std::to_string(V.size()) + " vertices");
            // Exact test: CGAL's prism of a collinear triangle would have no normal.
            if (CGAL::collinear(points[F[f][0]], points[F[f][1]], points[F[f][2]])) {
                ++skipped;
                continue;
            }
            triangles.push_back({int(F[f][0]), int(F[f][1]), int(F[f][2])});
        }
        auto d = std::make_shared<data>(std::move(points), triangles, eps);
        d->faces = triangles.size(), d->skipped = skipped;
        build_filter(*d, V, triangles);
        data_ = std::move(d);
    }

    /// The envelope at distance relative_eps times the diagonal of the bounding box of
    /// the surface's (referenced) vertices.
    static envelope relative(const std::vector<vec3>& V, const std::vector<tri_indices>& F,
                             double relative_eps = default_relative_eps) {
        return envelope(V, F, relative_eps * bounding_diagonal(V, F));
    }

    /// False for a default-constructed (disabled) envelope.
    bool enabled() const noexcept { return data_ != nullptr; }
    /// The absolute distance (0 when disabled).
    double eps() const noexcept { return data_ ? data_->eps : 0.0; }
    /// Input triangles with a prism, and degenerate ones that were skipped.
    std::size_t n_prisms() const noexcept { return data_ ? data_->faces : 0; }
    std::size_t n_skipped_degenerate() const noexcept { return data_ ? data_->skipped : 0; }
    /// Whether CGAL's structure has been built (by a question the filter left open, by
    /// `contains_exact` or by `cgal()`). For tests and measurements.
    bool exact_built() const noexcept { return data_ && data_->built(); }
    /// Builds CGAL's structure now (it is otherwise built on the first question the filter
    /// leaves open): for a user that will ask exact questions from parallel operations,
    /// where a failure of the construction would surface inside an operation.
    void prepare_exact() const {
        if (data_) data_->exact();
    }
    /// The underlying CGAL object (null when disabled), built on the first call if no
    /// question has built it yet (see `data::exact`).
    const cgal_envelope* cgal() const { return data_ ? &data_->exact() : nullptr; }

    /// Exact: is triangle (a, b, c) inside the envelope? Collinear triangles are tested
    /// as segments, coincident corners as points. True when disabled.
    bool contains(const vec3& a, const vec3& b, const vec3& c) const {
        filter_cache cache;
        return contains(a, b, c, cache);
    }
    /// The same answer from CGAL alone (no filter): for tests and measurements.
    bool contains_exact(const vec3& a, const vec3& b, const vec3& c) const {
        if (!data_) return true;
        return data_->exact()(point(a), point(b), point(c));
    }
    /// Exact: is point p inside the envelope? True when disabled.
    bool contains(const vec3& p) const {
        if (!data_) return true;
        return data_->exact()(point(p));
    }

    enum class verdict : std::uint8_t { outside, inside, unknown };

    /// Input triangles the filter found near recent queries. Checking adjacent triangles
    /// (the new faces of one operation) with one cache saves most closest-point queries.
    /// Belongs to one thread.
    class filter_cache {
        friend class envelope;
        struct candidate {
            index_t face;
            std::array<vec3, 3> t;
            // Bounding sphere of t: a point farther than the radius plus r from the centre
            // is farther than r from t, which saves most exact point-triangle distances.
            vec3 centre;
            double reach_in2, reach_out2;
        };
        std::array<candidate, 16> cand;
        int n = 0;
        std::uint64_t owner = 0;      // the envelope (data id) the candidates belong to
        index_t seed = invalid_index; // where the last covering test started (see covered)
    };

    /// The covering test alone (the filter's first stage, see `covered`): true only if the
    /// triangle is inside; false says nothing. For tests and measurements.
    bool covers(const vec3& a, const vec3& b, const vec3& c) const {
        filter_cache cache;
        return !data_ || covered(*data_, a, b, c, cache);
    }

    /// The filter alone: inside or outside when it can prove it, else unknown (see the
    /// file comment). Never contradicts contains_exact.
    verdict fast_verdict(const vec3& a, const vec3& b, const vec3& c) const {
        filter_cache cache;
        return fast_verdict(a, b, c, cache);
    }

    verdict fast_verdict(const vec3& a, const vec3& b, const vec3& c, filter_cache& cache) const {
        if (!data_) return verdict::inside;
        const data& d = *data_;
        if (d.tree.empty()) return verdict::unknown;
        if (cache.owner != d.id) cache.n = 0, cache.owner = d.id, cache.seed = invalid_index;
        uncovered_parts parts;
        if (covered(d, a, b, c, cache, &parts)) {
            IDAS_DETAIL_ENV_COUNT(covered);
            return verdict::inside;
        }
        auto& cand = cache.cand;
        int& n_cand = cache.n;
        // Adds face f to the candidates; true if it is new there (and may prove containment).
        auto remember = [&](index_t f) {
            if (!d.usable[f]) return false;
            for (int i = 0; i < n_cand; ++i)
                if (cand[i].face == f) return false;
            if (n_cand == int(cand.size())) { // forget the oldest
                std::move(cand.begin() + 1, cand.end(), cand.begin());
                --n_cand;
            }
            auto& c = cand[n_cand++];
            c.face = f, c.t = d.tree.triangle(f);
            c.centre = (c.t[0] + c.t[1] + c.t[2]) / 3.0;
            // Rounding only makes the sphere test reject less (radius grown by 1e-9).
            const double radius = std::sqrt(std::max({squared_norm(c.t[0] - c.centre),
                                                      squared_norm(c.t[1] - c.centre),
                                                      squared_norm(c.t[2] - c.centre)})) *
                                  (1 + 1e-9);
            const double r_in = d.inside_r2 > 0 ? std::sqrt(d.inside_r2) : 0;
            c.reach_in2 = (radius + r_in) * (radius + r_in) * (1 + 1e-9);
            c.reach_out2 = (radius + d.outside_r) * (radius + d.outside_r) * (1 + 1e-9);
            return true;
        };
        using candidate = filter_cache::candidate;
        auto dist2 = [](const candidate& c, const vec3& p) {
            const auto& T = c.t;
            return squared_norm(p - closest_point_on_triangle(p, T[0], T[1], T[2]));
        };
        auto within = [&](const candidate& c, const vec3& p) {
            return squared_norm(p - c.centre) <= c.reach_in2 && dist2(c, p) <= d.inside_r2;
        };
        // Looks for the input triangle nearest to p within eps (bounded queries prune from the
        // start, the newest candidate's distance bounds them further): none means p, and so
        // the query triangle, is outside. Sets `added` if that triangle became a new candidate.
        auto near_input = [&](const vec3& p, bool& added) {
            const auto r = d.tree.closest_point(p, d.outside_r2,
                                                n_cand ? cand[n_cand - 1].face : invalid_index);
            if (!r) return false;
            added = remember(r.face);
            return true;
        };
        // Outside proofs need every prism that CGAL may consult to lie within eps of its
        // triangle; needle triangles' prisms may not (see build_filter).
        const verdict outside = d.needle_boxes.empty() || !near_needle(d, a, b, c)
                                    ? verdict::outside
                                    : verdict::unknown;
        for (const vec3* p : {&a, &b, &c}) {
            bool near = false;
            for (int i = n_cand - 1; i >= 0 && !near; --i)
                near = squared_norm(*p - cand[i].centre) <= cand[i].reach_out2 &&
                       dist2(cand[i], *p) <= d.outside_r2;
            bool added = false;
            if (!near && !near_input(*p, added)) return outside;
        }
        struct piece {
            vec3 a, b, c;
            int level;
        };
        auto holds = [&](const piece& p, const candidate& c) {
            return within(c, p.a) && within(c, p.b) && within(c, p.c);
        };
        // A piece no single candidate holds may lie in the union of two adjacent candidates'
        // prisms: cut it by a plane through their shared edge and test each part against
        // its own triangle (the parts are convex: their corners decide). Cut points
        // anywhere on the piece's edges give two parts that tile the piece, so the plane
        // is only a guess; the cut points' rounding (an ulp off the edges) is within the
        // margin of inside_r2. Saves subdividing pieces along every input edge they cross.
        auto held_by_two = [&](const piece& p) {
            const vec3 P[3] = {p.a, p.b, p.c};
            int near[16], mask[16], n_near = 0;
            for (int i = 0; i < n_cand; ++i) {
                const int k = int(within(cand[i], p.a)) | int(within(cand[i], p.b)) << 1 |
                              int(within(cand[i], p.c)) << 2;
                if (k) mask[n_near] = k, near[n_near++] = i;
            }
            for (int x = 0; x < n_near; ++x)
                for (int y = x + 1; y < n_near; ++y) {
                    if ((mask[x] | mask[y]) != 7) continue;
                    const candidate &ci = cand[near[x]], &cj = cand[near[y]];
                    int shared[2], k = 0; // corners of ci also in cj
                    for (int a = 0; a < 3; ++a)
                        if (ci.t[a] == cj.t[0] || ci.t[a] == cj.t[1] || ci.t[a] == cj.t[2])
                            shared[k < 2 ? k : 1] = a, ++k;
                    if (k != 2) continue;
                    const vec3 u = ci.t[shared[0]], v = ci.t[shared[1]];
                    const vec3 w = ci.t[3 - shared[0] - shared[1]];
                    vec3 n = cross(v - u, d.normals[ci.face] + d.normals[cj.face]);
                    if (dot(n, w - u) < 0) n = -n; // ci's side is the positive one
                    const double side[3] = {dot(n, P[0] - u), dot(n, P[1] - u), dot(n, P[2] - u)};
                    vec3 part_i[4], part_j[4];
                    int ni = 0, nj = 0;
                    for (int q = 0; q < 3; ++q) {
                        const int r = (q + 1) % 3;
                        (side[q] >= 0 ? part_i[ni++] : part_j[nj++]) = P[q];
                        if ((side[q] >= 0) != (side[r] >= 0)) {
                            const double t = std::clamp(side[q] / (side[q] - side[r]), 0.0, 1.0);
                            part_i[ni++] = part_j[nj++] = P[q] + (P[r] - P[q]) * t;
                        }
                    }
                    if (ni == 0 || nj == 0) continue; // one side only: `holds` failed it
                    bool good = true;
                    for (int q = 0; q < ni && good; ++q) good = within(ci, part_i[q]);
                    for (int q = 0; q < nj && good; ++q) good = within(cj, part_j[q]);
                    if (good) return true;
                }
            return false;
        };
        // Splits `root` until a candidate holds each piece (inside), a piece's centroid is
        // beyond every prism (outside) or the budget runs out (unknown).
        int pieces = 0;
        auto prove = [&](const piece& root) {
            piece stack[3 * max_level + 2];
            int top = 0;
            bool undecided = false;
            stack[top++] = root;
            while (top > 0) {
                if (++pieces > max_pieces) return verdict::unknown;
                const piece p = stack[--top];
                bool ok = false;
                for (int i = n_cand - 1; i >= 0 && !ok; --i)
                    if (holds(p, cand[i])) {
                        ok = true;
                        // Neighbouring pieces come next: try this candidate first for them.
                        if (i != n_cand - 1) std::swap(cand[i], cand[n_cand - 1]);
                    }
                if (!ok) {
                    bool added = false;
                    if (!near_input((p.a + p.b + p.c) / 3.0, added)) return outside;
                    if (added) ok = holds(p, cand[n_cand - 1]); // the others failed already
                }
                if (ok || held_by_two(p)) continue;
                if (p.level == max_level) {
                    // Unresolved piece: it may still prove the triangle outside if its centroid
                    // is outside every prism; otherwise CGAL decides the whole triangle, unless
                    // another piece proves it outside first.
                    if (outside == verdict::outside &&
                        outside_all_prisms(d, (p.a + p.b + p.c) / 3.0))
                        return outside;
                    undecided = true;
                    continue;
                }
                const vec3 ab = (p.a + p.b) * 0.5, bc = (p.b + p.c) * 0.5, ca = (p.c + p.a) * 0.5;
                stack[top++] = {ab, bc, ca, p.level + 1};
                stack[top++] = {ca, bc, p.c, p.level + 1};
                stack[top++] = {ab, p.b, bc, p.level + 1};
                stack[top++] = {p.a, ab, ca, p.level + 1};
            }
            return undecided ? verdict::unknown : verdict::inside;
        };
        // The parts the covering test left (most of the query proven by it): each part
        // apart, fanned into pieces. Failing that, the whole query.
        if (parts.beyond && outside == verdict::outside) return outside;
        if (parts.n > 0) {
            // A query that leaves the envelope is most often shown out, before any part is
            // split, by a part's failed corner: one beyond the inner radius of every input
            // triangle may be outside every prism.
            for (int k = 0; k < parts.n && outside == verdict::outside; ++k)
                if (parts.probe[k] >= 0 && outside_all_prisms(d, parts.corner(k, parts.probe[k])))
                    return outside;
            verdict v = verdict::inside;
            for (int k = 0; k < parts.n && v == verdict::inside; ++k)
                for (int m = 1; m + 1 < parts.count[k] && v == verdict::inside; ++m)
                    v = prove({parts.corner(k, 0), parts.corner(k, m), parts.corner(k, m + 1), 0});
            if (v != verdict::unknown) return v;
            pieces = 0;
        }
        return prove({a, b, c, 0});
    }

    /// contains(a, b, c) reusing a filter cache (see filter_cache).
    bool contains(const vec3& a, const vec3& b, const vec3& c, filter_cache& cache) const {
        if (!data_) return true;
        IDAS_DETAIL_ENV_COUNT(checks);
        const verdict v = fast_verdict(a, b, c, cache);
        if (v == verdict::inside) IDAS_DETAIL_ENV_COUNT(filter_inside);
        if (v == verdict::outside) IDAS_DETAIL_ENV_COUNT(filter_outside);
        if (v != verdict::unknown) return v == verdict::inside;
        IDAS_DETAIL_ENV_COUNT(exact);
        const bool in = data_->exact()(point(a), point(b), point(c));
        if (in) IDAS_DETAIL_ENV_COUNT(exact_inside);
        return in;
    }

    /// Invariant hook: every new or changed face of the operation lies inside.
    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh& m, const Result& r, state&) const {
        if (!data_) return true;
        // One cache per thread, kept across operations: successive operations are often
        // neighbours and find their input triangles among the last ones' candidates.
        thread_local filter_cache cache;
        for (const auto& t : r.cells) {
            const auto& fv = m.face_vertices(t.fid);
            if (!contains(m.position(fv[0]), m.position(fv[1]), m.position(fv[2]), cache))
                return false;
        }
        return true;
    }

    static double bounding_diagonal(const std::vector<vec3>& V, const std::vector<tri_indices>& F) {
        constexpr double inf = std::numeric_limits<double>::infinity();
        vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
        for (const auto& f : F)
            for (index_t v : f) {
                if (v >= V.size()) continue; // reported by the constructor
                for (int k = 0; k < 3; ++k)
                    lo[k] = std::min(lo[k], V[v][k]), hi[k] = std::max(hi[k], V[v][k]);
            }
        return F.empty() ? 0.0 : norm(hi - lo);
    }

private:
    // Pieces are split down to 1/256 of the query: a piece around an input vertex where
    // three or more triangles meet (a grid's vertex at an open border or a box's edge) is
    // held by any of them only once it is within eps/sqrt(3) of the vertex, which queries
    // of 100 eps need (bench/RESULTS.md, session 53). The budget bounds the pieces that a
    // thin region beyond the prisms' inner radius keeps splitting: past it, CGAL decides.
    static constexpr int max_level = 8;
    static constexpr int max_pieces = 256;
    static constexpr std::size_t max_needles = 256;
    static constexpr int max_cover = 48; // input triangles one covering test may use
    static constexpr int max_walk = 12;  // steps of a walk towards a point
    static constexpr int max_parts = 24; // parts a covering test may leave to the pieces

    /// What a covering test proved all of but a few parts: the query above those input
    /// triangles whose offset and distance checks failed (each clipped by the triangle's
    /// projection, a convex polygon on the query), for the piece test to decide. Left
    /// uninitialised but for the count: one is made for every query.
    struct uncovered_parts {
        int n = 0;
        bool beyond = false; // a point of the query is farther than eps from the input
        int count[max_parts];
        int probe[max_parts]; // a corner farther than the inner radius from the input, or -1
        double xyz[max_parts][9][3];

        vec3 corner(int k, int m) const noexcept {
            return {xyz[k][m][0], xyz[k][m][1], xyz[k][m][2]};
        }
        void add(const vec3* P, int np, int far_corner) noexcept {
            for (int m = 0; m < np; ++m)
                for (int i = 0; i < 3; ++i) xyz[n][m][i] = P[m][i];
            probe[n] = far_corner;
            count[n++] = np;
        }
    };

    struct data;
    struct cover_face {
        std::array<vec3, 3> t;
        vec3 n;                          // unit normal (rounded)
        std::array<index_t, 3> nbr;      // across edge (t[e], t[e+1]); invalid_index: none
        std::array<std::int8_t, 3> sign; // exact sign of the normal's x, y, z component
        bool usable;                     // not a needle (see build_filter)
    };
    using point2 = std::array<double, 2>;

    // The part of convex polygon `in` (n corners) where `side`, affine along its edges, is
    // not negative: corners kept, crossings interpolated. Returns the corner count of `out`.
    static int clip(const vec3* in, int n, const double* side, vec3* out) {
        int nn = 0;
        for (int m = 0; m < n; ++m) {
            const int q = m + 1 < n ? m + 1 : 0;
            if (side[m] >= 0) out[nn++] = in[m];
            if ((side[m] >= 0) != (side[q] >= 0)) {
                const double w = std::clamp(side[m] / (side[m] - side[q]), 0.0, 1.0);
                out[nn++] = in[m] + (in[q] - in[m]) * w;
            }
        }
        return nn;
    }

    // 2D cross product (b - a) x (c - a), floating point.
    static double cross2(const point2& a, const point2& b, const point2& c) {
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    }

    // Walks from face f over input edges towards the face whose projection (along axis k)
    // contains q, exactly; invalid_index if the walk leaves the sheet of f's orientation,
    // meets a border or takes too long.
    static index_t walk(const data& d, index_t f, const point2& q, int k, int steps) {
        const int i = (k + 1) % 3, j = (k + 2) % 3;
        const int sigma = d.cover[f].sign[k];
        if (sigma == 0) return invalid_index;
        for (int s = 0; s < steps; ++s) {
            const cover_face& F = d.cover[f];
            if (F.sign[k] != sigma) return invalid_index;
            const point2 T[3] = {
                {F.t[0][i], F.t[0][j]}, {F.t[1][i], F.t[1][j]}, {F.t[2][i], F.t[2][j]}};
            int out = -1;
            double worst = 0;
            for (int e = 0; e < 3; ++e) {
                const double side = sigma * cross2(T[e], T[(e + 1) % 3], q);
                if (side < worst) worst = side, out = e;
            }
            if (out < 0) // inside up to rounding: decide exactly
                for (int e = 0; e < 3 && out < 0; ++e)
                    if (sigma * orient2d(T[e], T[(e + 1) % 3], q) < 0) out = e;
            if (out < 0) return f;
            f = F.nbr[out];
            if (f == invalid_index) return invalid_index;
        }
        return invalid_index;
    }

    // Sufficient test: is triangle (a, b, c) inside the envelope? Projects along the axis
    // k closest to the triangle's normal and finds, by adjacency from the input triangle
    // under corner a, the input triangles S whose projections cover the triangle's:
    //   * every triangle of S projects with the same orientation (exact signs), and for
    //     every edge of a triangle of S whose projection may meet the query's, the input
    //     triangle across it (the edge is manifold) is in S. Then the projections of S
    //     cover the query's: leaving their union inside the query's projection would cross
    //     an edge (the next triangle is on its other side) or a vertex (its whole fan is in
    //     S and winds around it);
    //   * for each T of S, the part of the query above T (the query's projection clipped
    //     by T's, a convex polygon) is within cover_r of T along axis k: the offset from
    //     T's plane along k is affine there, so its largest value is at a corner, and a
    //     point at that offset above a point of T is at most that far from T.
    // So every point of the query is within the inner radius of some prism's triangle,
    // hence inside that prism. The edge test may only err towards "meets" and the clip
    // only towards larger polygons (tolerance cover_tol); cover_r leaves room for the
    // rounding of the normals, offsets and clipped corners. False says nothing.
    // With `parts`, a triangle of S whose clipped part fails the second check does not end
    // the test: the part is listed (up to max_parts of them), and false with parts listed
    // says that the rest of the query is inside. A query over a bumpy scan often passes
    // everywhere but above one or two triangles, so the pieces need prove only those parts
    // (bunny's pre-simplification: half its time went to queries the covering test failed
    // and the pieces then proved whole).
    // Also with `parts`, an edge the query's projection may meet without a triangle of the
    // same orientation across it (a border, or a crease that folds under the query) does
    // not end the test if the query lies on T's side of the edge's line but for the
    // tolerance: the sliver of the query beyond the line (clipped with the line moved
    // towards T by the tolerance) is listed as a part. The projections of S together with
    // these slivers still cover the query's: a straight path inside the query's projection
    // that leaves the union of S crosses such an edge, or passes a vertex between two such
    // edges (less than a turn apart, so that it goes beyond one of their lines), and from
    // there on it stays beyond that line, in its sliver. A mesh's creases (37989_sf, CAD
    // parts, open borders of soups) stopped most covering tests there before.
    static bool covered(const data& d, const vec3& a, const vec3& b, const vec3& c,
                        filter_cache& cache, uncovered_parts* parts = nullptr) {
        if (!(d.cover_r > 0)) return false;
        for (const vec3* p : {&a, &b, &c})
            if (!(std::max({std::abs(p->x), std::abs(p->y), std::abs(p->z)}) <= 2 * d.coord))
                return false; // far away (or not finite): the tolerances assume this scale
        // The axis closest to the query's normal first; the next one too if not much
        // farther (cells along a skewed axis may assign a point to a farther triangle).
        const vec3 nq = cross(b - a, c - a);
        const double m[3] = {std::abs(nq.x), std::abs(nq.y), std::abs(nq.z)};
        int k1 = 0, k2 = 1;
        if (m[k2] > m[k1]) std::swap(k1, k2);
        if (m[2] > m[k1])
            k2 = k1, k1 = 2;
        else if (m[2] > m[k2])
            k2 = 2;
        if (covered_along(d, a, b, c, k1, cache, parts)) return true;
        if (!(m[k2] >= 0.5 * m[k1]) || (parts && parts->beyond)) return false;
        if (!parts || parts->n == 0) return covered_along(d, a, b, c, k2, cache, parts);
        // k1 left parts: k2 may prove the whole query, else k1's parts stand.
        return covered_along(d, a, b, c, k2, cache, nullptr);
    }

    static bool covered_along(const data& d, const vec3& a, const vec3& b, const vec3& c, int k,
                              filter_cache& cache, uncovered_parts* parts = nullptr) {
        // Structural failures void the parts listed so far (the cover is not complete).
        auto fail = [parts] {
            if (parts) parts->n = 0;
            return false;
        };
        const int i = (k + 1) % 3, j = (k + 2) % 3;
        const point2 Q[3] = {{a[i], a[j]}, {b[i], b[j]}, {c[i], c[j]}};
        const int sq = orient2d(Q[0], Q[1], Q[2]);
        if (sq == 0) return false;
        // The input triangle under a: walk from the last one, else from a's closest one.
        index_t f =
            cache.seed < d.cover.size() ? walk(d, cache.seed, Q[0], k, max_walk) : invalid_index;
        if (f == invalid_index) {
            IDAS_DETAIL_ENV_COUNT(seed_queries);
            const auto r = d.tree.closest_point(a, d.outside_r2, cache.seed);
            if (!r) return false;
            f = walk(d, r.face, Q[0], k, 4);
            if (f == invalid_index) return false;
        }
        cache.seed = f;
        const int sigma = d.cover[f].sign[k];
        const double tol = d.cover_tol, r = d.cover_r, r2 = r * r;
        auto l1 = [](const point2& u, const point2& v) {
            return std::abs(v[0] - u[0]) + std::abs(v[1] - u[1]);
        };
        // May the projected edge (u, v) meet the query's projection? Only a separating line
        // (the edge's or one of the query's) with room for rounding says no.
        auto meets = [&](const point2& u, const point2& v) {
            const double t = tol * l1(u, v);
            const double s0 = cross2(u, v, Q[0]), s1 = cross2(u, v, Q[1]), s2 = cross2(u, v, Q[2]);
            if ((s0 > t && s1 > t && s2 > t) || (s0 < -t && s1 < -t && s2 < -t)) return false;
            for (int m = 0; m < 3; ++m) {
                const point2 &p = Q[m], &q = Q[(m + 1) % 3];
                const double tq = tol * l1(p, q);
                if (sq * cross2(p, q, u) < -tq && sq * cross2(p, q, v) < -tq) return false;
            }
            return true;
        };
        // The query's plane over the projection, unless the query is a needle (its rounded
        // normal would be inaccurate): offsets of input corners from it bound the offsets
        // of the query's part above that input triangle.
        const vec3 nq = cross(b - a, c - a);
        const double lq = std::max({squared_norm(b - a), squared_norm(c - b), squared_norm(a - c)});
        const double inv_q = squared_norm(nq) >= 1e-6 * lq * lq ? 1.0 / nq[k] : 0.0;
        index_t S[max_cover];
        int n = 0;
        S[n++] = f;
        for (int s = 0; s < n; ++s) {
            const cover_face& F = d.cover[S[s]];
            // Steep triangles magnify offsets along k (and their rounding).
            if (!F.usable) return fail();
            const point2 T[3] = {
                {F.t[0][i], F.t[0][j]}, {F.t[1][i], F.t[1][j]}, {F.t[2][i], F.t[2][j]}};
            for (int e = 0; e < 3; ++e) {
                if (!meets(T[e], T[(e + 1) % 3])) continue;
                const index_t g = F.nbr[e];
                if (g == invalid_index || d.cover[g].sign[k] != sigma) {
                    // No cover across: the query may only touch this edge (all of it on F's
                    // side but for the tolerance), and its sliver beyond the edge's line
                    // goes to the pieces (see `covered`).
                    const point2 &u = T[e], &v = T[(e + 1) % 3];
                    const double t = tol * l1(u, v);
                    double side[3];
                    bool inner = true;
                    for (int m = 0; m < 3; ++m) {
                        side[m] = t - sigma * cross2(u, v, Q[m]); // >= 0: beyond, expanded by t
                        inner = inner && side[m] <= 2 * t;
                    }
                    if (!inner || !parts || parts->n == max_parts) return fail();
                    const vec3 C[3] = {a, b, c};
                    vec3 B[4];
                    const int nb = clip(C, 3, side, B);
                    if (nb >= 3)
                        parts->add(B, nb, -1);
                    else if (nb > 0)
                        return fail();
                    continue;
                }
                if (std::find(S, S + n, g) == S + n) {
                    if (n == max_cover) return fail();
                    S[n++] = g;
                }
            }
            // The part of the query above F is within |offset along k| of F. The offset is
            // affine there, so its extremes over the query's corners, or over F's corners
            // (offsets of F's corners from the query's plane), bound it. Offsets from F's
            // plane are used only when F is not steep (it magnifies them and their rounding).
            const bool flat = std::abs(F.n[k]) >= 0.1;
            const double inv = flat ? 1.0 / F.n[k] : 0.0;
            auto offset_ok = [&](const vec3& p) {
                return flat && std::abs(dot(F.n, p - F.t[0]) * inv) <= r;
            };
            if (offset_ok(a) && offset_ok(b) && offset_ok(c)) continue;
            auto below_ok = [&](const vec3& t) { return std::abs(dot(nq, t - a) * inv_q) <= r; };
            if (inv_q != 0 && below_ok(F.t[0]) && below_ok(F.t[1]) && below_ok(F.t[2])) continue;
            // Clip the query by F's prism along k (F's edges moved out by the tolerance);
            // the polygon's corners, on the query, decide: by offset, else by distance.
            vec3 P[9] = {a, b, c}, P2[9];
            int np = 3;
            for (int e = 0; e < 3 && np > 0; ++e) {
                const point2 &u = T[e], &v = T[(e + 1) % 3];
                const double t = tol * l1(u, v);
                double side[9];
                for (int m = 0; m < np; ++m)
                    side[m] = sigma * cross2(u, v, point2{P[m][i], P[m][j]}) + t;
                np = clip(P, np, side, P2);
                std::copy(P2, P2 + np, P);
            }
            int failed = -1;
            for (int m = 0; m < np && failed < 0; ++m)
                if (!offset_ok(P[m]) &&
                    !(squared_norm(P[m] -
                                   closest_point_on_triangle(P[m], F.t[0], F.t[1], F.t[2])) <= r2))
                    failed = m;
            if (failed < 0) continue;
            // Parts above most of S (three in four so far, or half in the end): the pieces
            // would split nearly the whole query anyway, and splitting it whole costs less
            // than a tree query per part (a coarse sphere's queries, about one input
            // triangle wide, fail above nearly every one).
            if (np < 3 || !parts || parts->n == max_parts ||
                (parts->n >= 4 && 4 * parts->n > 3 * s))
                return fail();
            // The corner that failed is where the query is most likely to leave the
            // envelope: a query that does is told so at once.
            const auto near = d.tree.closest_point(P[failed], d.outside_r2, S[s]);
            if (!near) {
                parts->beyond = true;
                return fail();
            }
            parts->add(P, np, near.squared_distance > d.inside_r2 ? failed : -1);
        }
        if (parts && 2 * parts->n > n) return fail();
        return !parts || parts->n == 0;
    }

    struct data {
        data(std::vector<kernel::Point_3> points, std::vector<std::array<int, 3>> triangles,
             double e)
            : eps(e)
            , points_(std::move(points))
            , triangles_(std::move(triangles)) {}
        /// CGAL's envelope, made on the first question the filter leaves open: a user of
        /// the filter alone (the soup simplification asks only `fast_verdict`) never pays
        /// for it, and its construction was the tet mesher's first envelope's 10 of 11 ms
        /// on a 760-triangle sphere (bench/RESULTS.md, "Session 48, later"). Thread-safe: a
        /// worker that asks while another builds it waits for that one.
        const cgal_envelope& exact() const {
            std::call_once(once_, [this] {
                env_.emplace(points_, triangles_, eps);
                points_ = {}, triangles_ = {};
                built_.store(true, std::memory_order_release);
            });
            return *env_;
        }
        bool built() const noexcept { return built_.load(std::memory_order_acquire); }
        double eps;
        std::size_t faces = 0, skipped = 0;
        // The filter: the prismed triangles (same order as given to CGAL), which of them
        // may prove containment, and the squared radii of its two tests.
        triangle_aabb_tree tree;
        std::vector<char> usable;
        std::vector<vec3> normals; // unit normals of the prismed triangles
        double inside_r2 = 0, outside_r2 = 0, outside_r = 0, slab = 0;
        // Distinguishes envelopes in filter caches (an address may be reused).
        std::uint64_t id = next_id();
        // Boxes (min, max) around the needle triangles' prisms, as far as CGAL consults them.
        std::vector<std::pair<vec3, vec3>> needle_boxes;
        // The covering test (see covered): per prismed triangle, and its bound on the
        // distance along an axis (negative: off) and positional tolerance.
        std::vector<cover_face> cover;
        double cover_r = -1, cover_tol = 0, coord = 0;

    private:
        mutable std::once_flag once_;
        mutable std::atomic<bool> built_{false};
        mutable std::optional<cgal_envelope> env_;
        // The construction's input, until exact() has used it.
        mutable std::vector<kernel::Point_3> points_;
        mutable std::vector<std::array<int, 3>> triangles_;
    };

    // True if the bounding box of (a, b, c) meets a needle triangle's box.
    static bool near_needle(const data& d, const vec3& a, const vec3& b, const vec3& c) {
        const vec3 lo{std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}),
                      std::min({a.z, b.z, c.z})};
        const vec3 hi{std::max({a.x, b.x, c.x}), std::max({a.y, b.y, c.y}),
                      std::max({a.z, b.z, c.z})};
        for (const auto& [blo, bhi] : d.needle_boxes)
            if (!(hi.x < blo.x || hi.y < blo.y || hi.z < blo.z || lo.x > bhi.x || lo.y > bhi.y ||
                  lo.z > bhi.z))
                return true;
        return false;
    }

    // True if p is provably outside every prism: each prismed triangle within eps of p has
    // p outside its slab (a prism lies within eps/sqrt(3) of its triangle's plane).
    static bool outside_all_prisms(const data& d, const vec3& p) {
        return d.tree.for_each_face_within(p, d.outside_r2, [&](index_t f, double) {
            if (!d.usable[f]) return false; // its normal is not trusted
            const vec3 a = d.tree.triangle(f)[0];
            return std::abs(dot(p - a, d.normals[f])) > d.slab;
        });
    }

    static void build_filter(data& d, const std::vector<vec3>& V,
                             const std::vector<std::array<int, 3>>& T) {
        std::vector<tri_indices> F(T.size());
        d.usable.resize(T.size());
        d.normals.resize(T.size());
        double coord = 0; // largest coordinate magnitude: scale of CGAL's rounding errors
        for (std::size_t i = 0; i < T.size(); ++i) {
            const vec3 &a = V[T[i][0]], &b = V[T[i][1]], &c = V[T[i][2]];
            F[i] = {index_t(T[i][0]), index_t(T[i][1]), index_t(T[i][2])};
            for (const vec3* p : {&a, &b, &c})
                coord = std::max({coord, std::abs(p->x), std::abs(p->y), std::abs(p->z)});
            // CGAL offsets a triangle along its rounded unit normal: trust it only when the
            // triangle is not a needle (its normal is then accurate to ~1e-10).
            const double longest =
                std::max({squared_norm(b - a), squared_norm(c - b), squared_norm(a - c)});
            const vec3 n = cross(b - a, c - a);
            d.usable[i] = norm(n) >= 1e-6 * longest;
            d.normals[i] = n / norm(n);
        }
        d.tree = triangle_aabb_tree(V, F);
        build_cover(d, V, T);
        // A needle's rounded normal may be far off, so its prism (all CGAL consults of it is
        // within its bounding box grown by eps(1 + 1e-6)) may reach beyond eps of it:
        // no outside proof near one. Past a few hundred needles, no outside proofs at all.
        const double grow = d.eps * (1 + 1e-5) + 1e-8 * coord;
        std::size_t needles = 0;
        for (std::size_t i = 0; i < T.size(); ++i) {
            if (d.usable[i]) continue;
            if (++needles > max_needles) continue;
            const vec3 &a = V[T[i][0]], &b = V[T[i][1]], &c = V[T[i][2]];
            const vec3 lo{std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}),
                          std::min({a.z, b.z, c.z})};
            const vec3 hi{std::max({a.x, b.x, c.x}), std::max({a.y, b.y, c.y}),
                          std::max({a.z, b.z, c.z})};
            d.needle_boxes.push_back({lo - vec3{grow, grow, grow}, hi + vec3{grow, grow, grow}});
        }
        if (needles > max_needles) {
            // One box around everything disables outside proofs.
            const double big = std::numeric_limits<double>::max();
            d.needle_boxes.assign(1, {vec3{-big, -big, -big}, vec3{big, big, big}});
        }
        // Margins: 0.1% of the prism half-thickness, plus rounding of the prism planes'
        // points (CGAL computes them in doubles) magnified by up to 1e6 for thin triangles.
        const double rounding = 1e-8 * coord;
        const double half = d.eps / std::sqrt(3.0);
        const double r_in = half * 0.999 - rounding;
        d.inside_r2 = r_in > 0 ? r_in * r_in : -1.0; // -1: never proves containment
        const double r_out = d.eps * (1 + 1e-6) + rounding;
        d.outside_r2 = r_out * r_out;
        d.outside_r = r_out;
        d.slab = half * (1 + 1e-6) + rounding;
        // The covering test's offsets carry the normals' rounding (below 4e-10 of the
        // distance, up to 6 coord, for triangles that are not needles) magnified up to 10
        // times by steepness, and the clip tolerance: below 3e-8 coord in all.
        d.coord = coord;
        d.cover_tol = 1e-10 * coord;
        d.cover_r = r_in > 0 ? r_in - 1e-7 * coord : -1.0;
        for (std::size_t i = 0; i < T.size(); ++i) d.cover[i].usable = d.usable[i] != 0;
    }

    // Corners, normals, exact projected orientations and manifold neighbours of the
    // prismed triangles, for the covering test.
    static void build_cover(data& d, const std::vector<vec3>& V,
                            const std::vector<std::array<int, 3>>& T) {
        d.cover.resize(T.size());
        struct half {
            int lo, hi; // vertex indices, sorted
            index_t face;
            int edge;
            bool forward; // the face runs lo -> hi
        };
        std::vector<half> halves;
        halves.reserve(3 * T.size());
        for (std::size_t f = 0; f < T.size(); ++f) {
            cover_face& c = d.cover[f];
            for (int e = 0; e < 3; ++e) {
                c.t[e] = V[T[f][e]];
                c.nbr[e] = invalid_index;
                const int u = T[f][e], v = T[f][(e + 1) % 3];
                halves.push_back({std::min(u, v), std::max(u, v), index_t(f), e, u < v});
            }
            const vec3 n = cross(c.t[1] - c.t[0], c.t[2] - c.t[0]);
            c.n = n / norm(n);
            for (int k = 0; k < 3; ++k) {
                const int i = (k + 1) % 3, j = (k + 2) % 3;
                c.sign[k] =
                    std::int8_t(orient2d(point2{c.t[0][i], c.t[0][j]}, point2{c.t[1][i], c.t[1][j]},
                                         point2{c.t[2][i], c.t[2][j]}));
            }
        }
        std::sort(halves.begin(), halves.end(), [](const half& x, const half& y) {
            return x.lo != y.lo ? x.lo < y.lo : x.hi < y.hi;
        });
        // An edge with exactly two faces running it in opposite directions is manifold.
        for (std::size_t s = 0; s < halves.size();) {
            std::size_t e = s + 1;
            while (e < halves.size() && halves[e].lo == halves[s].lo &&
                   halves[e].hi == halves[s].hi)
                ++e;
            if (e - s == 2 && halves[s].forward != halves[s + 1].forward &&
                halves[s].face != halves[s + 1].face) {
                d.cover[halves[s].face].nbr[halves[s].edge] = halves[s + 1].face;
                d.cover[halves[s + 1].face].nbr[halves[s + 1].edge] = halves[s].face;
            }
            s = e;
        }
    }

    static kernel::Point_3 point(const vec3& p) { return {p.x, p.y, p.z}; }
    static std::uint64_t next_id() {
        static std::atomic<std::uint64_t> counter{0};
        return ++counter;
    }

    std::shared_ptr<const data> data_;
};

static_assert(invariant<envelope>);

/// The envelope of a mesh's current surface at relative_eps times its bounding-box
/// diagonal (build it from the input, before editing).
template <class Backend>
envelope envelope_from(const tri_mesh<Backend>& m,
                       double relative_eps = envelope::default_relative_eps) {
    const auto [V, F] = m.to_arrays();
    return envelope::relative(V, F, relative_eps);
}

// Why concurrent queries are safe (CGAL 5.5, checked in its source):
// * Polyhedral_envelope's queries are const and it has no mutable members; each query
//   builds its own local vectors. Its AABB tree is built eagerly by the constructor (and
//   CGAL's AABB_tree guards any lazy rebuild of a const tree with a mutex when
//   CGAL_HAS_THREADS is defined).
// * The prisms' planes are Epeck (lazy exact) objects shared by all queries. Since CGAL
//   5.4 (PR #5402, "Epeck thread safety") a lazy object computes its exact value under
//   std::call_once and publishes it atomically, and reference counts are atomic, provided
//   CGAL_HAS_THREADS (defined whenever Boost sees threads; checked above) and the exact
//   rational type is mpq_class, Boost.Multiprecision's mpq_rational (what Debian's CGAL
//   5.5 picks) or Quotient<MP_Float>.
// * Interval filters change the FPU rounding mode, which is per thread.
// * idas' filter only reads the (const) triangle_aabb_tree and works on the stack.
// tests/test_envelope.cpp checks that several threads on one object agree with a serial pass.

} // namespace idas
