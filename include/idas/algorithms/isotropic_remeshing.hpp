// Isotropic remeshing (Botsch and Kobbelt 2004) as four IDAS specs run in turn, one
// executor each, for a number of iterations:
//
//   split     edges longer than 4/3 L at their midpoints, longest first
//   collapse  edges shorter than 4/5 L, shortest first, into one of their endpoints, unless
//             a new edge would be longer than 4/3 L
//   swap      edges whose flip brings the four vertices' valences towards 6 (4 on the
//             boundary), the flips giving the best-shaped triangles first
//   smooth    every vertex towards the area-weighted centroid of its faces, within its tangent
//             plane, then back onto the input surface (closest point, AABB tree)
//
//   I  link condition (always), no normal flip, plus any extra invariants (e.g. envelope)
//   A  positions; per-vertex `frozen` flag: boundary vertices (on request) and vertices on
//      sharp features (dihedral angle above a threshold), which never move nor vanish
//   S  as above; stop after N iterations or when an iteration changes no connectivity
#pragma once

#include <idas/algorithms/decimation_common.hpp>
#include <idas/core/aabb_tree.hpp>
#include <idas/core/geometry.hpp>
#include <idas/exec/schedule.hpp>
#include <idas/invariants/link_condition.hpp>
#include <idas/invariants/no_normal_flip.hpp>
#include <idas/mesh/temporary_attribute.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <system_error>
#include <thread>
#include <tuple>
#include <utility>

namespace idas::algorithms {

struct remeshing_options {
    double target_length = 0; // absolute edge length L
    unsigned iterations = 5;
    bool preserve_boundary = true; // boundary vertices stay where they are
    double feature_angle_deg = -1; // dihedral angle above which an edge is sharp; <0: none
    bool project = true;           // project smoothed vertices back onto the input
    /// A: the file's attributes carried through every operation (none when null); its
    /// constrained vertices (seams, tag borders) are kept like features.
    const attribute_transfer* transfer = nullptr;
};

namespace detail {
/// A job on its own thread, joined by wait() or at the latest by the destructor; wait()
/// rethrows what the job threw.
class background_task {
public:
    /// Starts the job; if no thread can be had, runs it here and now.
    template <class Job>
    void start(Job job) {
        auto shared = std::make_shared<Job>(std::move(job));
        try {
            thread_ = std::thread([this, shared] { run(*shared); });
        } catch (const std::system_error&) {
            run(*shared);
        }
    }
    void wait() {
        if (thread_.joinable()) thread_.join();
        if (failure_) std::rethrow_exception(std::exchange(failure_, nullptr));
    }
    ~background_task() {
        if (thread_.joinable()) thread_.join();
    }

private:
    template <class Job>
    void run(Job& job) {
        try {
            job();
        } catch (...) {
            failure_ = std::current_exception();
        }
    }

    std::thread thread_;
    std::exception_ptr failure_;
};
} // namespace detail

/// What the four phase specs share: L, the frozen flags, the input surface for projection.
/// The attribute columns are the run's own: removed when it returns.
struct remeshing_state {
    double L = 0;
    vertex_attribute<std::uint8_t> frozen;
    vertex_attribute<std::uint8_t> feature;
    // Kept up to date by the phases (a split boundary edge's midpoint is on the boundary;
    // a collapse's survivor is if either end was), so valences are O(1) to get.
    vertex_attribute<std::uint8_t> boundary;
    std::shared_ptr<const triangle_aabb_tree> input;
    detail::background_task input_build; // builds `input` beside the first phases
    // Smoothing pass stamp: a vertex whose `smoothed` equals `pass` was moved in this pass
    // (so each vertex moves at most once per pass).
    vertex_attribute<std::uint32_t> smoothed;
    std::uint32_t pass = 0;
    const attribute_transfer* transfer = nullptr; // the file's attributes, if carried
};

namespace detail {

/// How far v's valence is from ideal (6 inside, 4 on the boundary) after `change`. A
/// manifold vertex has as many neighbours as faces, one more on the boundary.
template <class Mesh>
double valence_deviation(const Mesh& m, const remeshing_state& s, index_t v, int change) {
    const bool boundary = m.attribute(s.boundary)[v] != 0;
    const double valence = double(std::ranges::distance(m.vertex_faces(v))) + (boundary ? 1 : 0);
    const double x = valence + change - (boundary ? 4.0 : 6.0);
    return x * x;
}

template <class Mesh>
double min_angle(const Mesh& m, index_t a, index_t b, index_t c) {
    const auto t = triangle_angles(m.position(a), m.position(b), m.position(c));
    return std::min({t[0], t[1], t[2]});
}

/// v's neighbour other than `not_this` across a boundary edge (one face holds both), or
/// invalid_index if there is none.
template <class Mesh>
index_t other_boundary_neighbour(const Mesh& m, index_t v, index_t not_this) {
    boost::container::small_vector<std::pair<index_t, int>, 16> seen; // neighbour, faces
    for (index_t f : m.vertex_faces(v))
        for (index_t w : m.face_vertices(f)) {
            if (w == v) continue;
            auto it =
                std::find_if(seen.begin(), seen.end(), [&](const auto& e) { return e.first == w; });
            if (it == seen.end())
                seen.push_back({w, 1});
            else
                ++it->second;
        }
    for (const auto& [w, faces] : seen)
        if (faces == 1 && w != not_this) return w;
    return invalid_index;
}

/// Squared distance from x to the faces that replace its star when x is collapsed into y
/// (x's faces without y, x moved to y): how far the collapse moves the surface at x.
/// Infinite if every face of x holds y (the collapse would remove x's surface outright).
template <class Mesh>
double surface_move_of_collapse(const Mesh& m, index_t x, index_t y) {
    const vec3 p = m.position(x);
    double nearest = std::numeric_limits<double>::infinity();
    for (index_t f : m.vertex_faces(x)) {
        const auto& fv = m.face_vertices(f);
        if (fv[0] == y || fv[1] == y || fv[2] == y) continue;
        auto moved = [&](int i) { return m.position(fv[i] == x ? y : fv[i]); };
        nearest = std::min(
            nearest, squared_norm(p - closest_point_on_triangle(p, moved(0), moved(1), moved(2))));
    }
    return nearest;
}

inline double squared_distance_to_segment(const vec3& q, const vec3& x, const vec3& y) {
    const vec3 d = y - x;
    const double l = squared_norm(d);
    const double u = l > 0 ? std::clamp(dot(q - x, d) / l, 0.0, 1.0) : 0.0;
    return squared_norm(q - (x + d * u));
}

/// Orients an edge tuple so that a frozen endpoint is the tuple's vertex: collapses keep
/// the tuple's vertex, so a frozen vertex is never the one removed.
template <class Mesh>
typename Mesh::tuple frozen_first(const Mesh& m, const remeshing_state& s, typename Mesh::tuple t) {
    const auto fr = m.attribute(s.frozen);
    const auto [a, b] = m.edge_vertices(t);
    return (!fr[a] && fr[b]) ? m.switch_vertex(t) : t;
}

/// Extra invariants (such as an envelope) join the phases' own no_normal_flip.
template <class... Extra>
struct with_invariants {
    std::tuple<Extra...> extra;
    auto invariants() const {
        return std::apply(
            [](const Extra&... e) {
                return invariant_set<no_normal_flip, Extra...>(no_normal_flip{}, e...);
            },
            extra);
    }
};
template <>
struct with_invariants<> {
    std::tuple<> extra;
    auto invariants() const { return invariant_set<no_normal_flip>{}; }
};

} // namespace detail

template <class... Extra>
struct remesh_split_spec : detail::with_invariants<Extra...> {
    using operations = op_list<op::split_edge>;
    remeshing_state& s;

    struct cache {
        vec3 position;
        bool frozen, feature, boundary;
    };

    template <class Mesh>
    bool too_long(const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const double hi = 4.0 / 3.0 * s.L;
        return squared_norm(m.position(a) - m.position(b)) > hi * hi;
    }
    // Only candidates enter the queue: most edges are already fine.
    template <class Push, class Mesh>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        for_each_edge_from(m, v, [&](const typename Mesh::tuple& t) {
            if (too_long(m, t)) push(op::split_edge{}, t);
        });
    }
    template <class Mesh>
    double priority(op::split_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return -squared_norm(m.position(a) - m.position(b)); // longest first
    }
    template <class Mesh>
    std::optional<cache> before(op::split_edge, const Mesh& m,
                                const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const double hi = 4.0 / 3.0 * s.L;
        if (!(squared_norm(m.position(a) - m.position(b)) > hi * hi)) return std::nullopt;
        const auto fe = m.attribute(s.feature), fr = m.attribute(s.frozen);
        // A split boundary edge keeps its new vertex on the boundary; one joining two
        // feature vertices is taken to lie on the feature line.
        const bool on_feature = fe[a] && fe[b];
        const bool boundary_edge = m.is_boundary_edge(t);
        const bool keep = boundary_edge && fr[a] && fr[b];
        return cache{(m.position(a) + m.position(b)) * 0.5, on_feature || keep, on_feature,
                     boundary_edge};
    }
    template <class Mesh>
    bool after(op::split_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const cache& c) const {
        const index_t v = r.anchor.vid;
        m.positions(r).set(v, c.position);
        m.attribute(s.frozen, r).set(v, c.frozen);
        m.attribute(s.feature, r).set(v, c.feature);
        m.attribute(s.boundary, r).set(v, c.boundary);
        if (s.transfer) s.transfer->split_after(m, r);
        return true;
    }
    template <class Mesh, class Push>
    void renew(op::split_edge, const Mesh& m, const op_result<typename Mesh::tuple>& r,
               Push& push) const {
        auto candidates = [&](op::split_edge o, const typename Mesh::tuple& t) {
            if (too_long(m, t)) push(o, t); // halves still too long are split again
        };
        push_star_edges<op::split_edge>(m, r, candidates);
    }
};

template <class... Extra>
struct remesh_collapse_spec : detail::with_invariants<Extra...> {
    using operations = op_list<op::collapse_edge>;
    remeshing_state& s;

    template <class Mesh>
    bool too_short(const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const double lo = 0.8 * s.L;
        return squared_norm(m.position(a) - m.position(b)) < lo * lo;
    }
    template <class Push, class Mesh>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        for_each_edge_from(m, v, [&](const typename Mesh::tuple& t) {
            if (too_short(m, t)) push(op::collapse_edge{}, detail::frozen_first(m, s, t));
        });
    }
    template <class Mesh>
    double priority(op::collapse_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return squared_norm(m.position(a) - m.position(b)); // shortest first
    }
    using collapse_cache = placed_values; // the position, and the file's attributes there
    template <class Mesh>
    std::optional<collapse_cache> before(op::collapse_edge, const Mesh& m,
                                         const typename Mesh::tuple& t) const {
        const auto p = survivor_position(m, t);
        if (!p) return std::nullopt;
        std::optional<collapse_cache> c(std::in_place);
        c->position = *p;
        if (s.transfer && !s.transfer->collapse_before(m, t, *p, c->carried)) c.reset();
        return c;
    }
    template <class Mesh>
    std::optional<vec3> survivor_position(const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const double lo = 0.8 * s.L, hi = 4.0 / 3.0 * s.L;
        if (!(squared_norm(m.position(a) - m.position(b)) < lo * lo)) return std::nullopt;
        const auto fr = m.attribute(s.frozen), bd = m.attribute(s.boundary);
        if (fr[b]) return std::nullopt; // a frozen vertex never vanishes
        // Where the survivor may go: an endpoint, so it stays on the input surface (a
        // midpoint would cut chords into curved regions: armadillo's farthest output point
        // 0.0025 -> 0.0021 of the diagonal from the input); a first, b if a may not. Not
        // off a frozen vertex, and an open boundary stays in place: a boundary end is kept
        // over an interior one.
        bool at_a = fr[a] || bd[a] || !bd[b], at_b = !fr[a] && !bd[a];
        // Along an open boundary, keep the end whose removal bends the boundary least:
        // boundary vertices are never smoothed, so a cut corner stays for good (bunny: the
        // output's farthest points from the input were such chords, 0.0017 of the diagonal,
        // all made by keeping a split midpoint and dropping the input vertex next to it).
        if (!fr[a] && m.is_boundary_edge(t)) {
            const index_t a2 = detail::other_boundary_neighbour(m, a, b),
                          b2 = detail::other_boundary_neighbour(m, b, a);
            if (a2 != invalid_index && b2 != invalid_index) {
                const bool keep_b = detail::squared_distance_to_segment(
                                        m.position(a), m.position(a2), m.position(b)) <
                                    detail::squared_distance_to_segment(
                                        m.position(b), m.position(a), m.position(b2));
                at_a = !keep_b, at_b = keep_b;
            }
        }
        // An end may stay if no edge of the merged vertex gets longer than 4/3 L and the
        // surface moves by at most L/5 where the other end was. Trying both ends lets more
        // short edges go (one end only: blub at 0.01 of the diagonal, 8 threads, mean edge
        // 0.90 L); the bound on the move keeps collapses from cutting creases, where the
        // farthest input points from the output were (bunny's cut-off bottom rim:
        // 0.0023 -> 0.0019 of the diagonal).
        const double reach = 0.2 * s.L;
        auto may_stay = [&](index_t kept, index_t removed) {
            for (index_t v : {a, b})
                for (index_t f : m.vertex_faces(v))
                    for (index_t w : m.face_vertices(f))
                        if (w != a && w != b &&
                            squared_norm(m.position(w) - m.position(kept)) > hi * hi)
                            return false;
            return detail::surface_move_of_collapse(m, removed, kept) <= reach * reach;
        };
        at_a = at_a && may_stay(a, b);
        at_b = at_b && !at_a && may_stay(b, a);
        if (!at_a && !at_b) return std::nullopt;
        return at_a ? m.position(a) : m.position(b);
    }
    template <class Mesh>
    bool after(op::collapse_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const collapse_cache& c) const {
        m.positions(r).set(r.anchor.vid, c.position);
        if (s.transfer && !s.transfer->collapse_after(m, r, c.carried)) return false;
        // The survivor took over b's faces: it is on the boundary if any of them is open.
        bool open = false;
        for (const auto& c : r.cells)
            open = open || m.is_boundary_edge(c) || m.is_boundary_edge(m.switch_edge(c));
        m.attribute(s.boundary, r).set(r.anchor.vid, open);
        return true;
    }
    template <class Mesh, class Push>
    void renew(op::collapse_edge, const Mesh& m, const op_result<typename Mesh::tuple>& r,
               Push& push) const {
        auto oriented = [&](op::collapse_edge o, const typename Mesh::tuple& t) {
            if (too_short(m, t)) push(o, detail::frozen_first(m, s, t));
        };
        push_star_edges<op::collapse_edge>(m, r, oriented);
    }
};

template <class... Extra>
struct remesh_swap_spec : detail::with_invariants<Extra...> {
    using operations = op_list<op::swap_edge>;
    remeshing_state& s;

    // Only candidates enter the queue: most edges are not worth flipping.
    template <class Push, class Mesh>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        for_each_edge_from(m, v, [&](const typename Mesh::tuple& t) {
            if (wanted(m, t)) push(op::swap_edge{}, t);
        });
    }
    /// The corner values of the quad's vertices (the file's attributes, if carried).
    using swap_cache = attribute_transfer::swap_values;
    template <class Mesh>
    std::optional<swap_cache> before(op::swap_edge, const Mesh& m,
                                     const typename Mesh::tuple& t) const {
        std::optional<swap_cache> c; // one return, so the cache is built in place
        if (wanted(m, t) && (!s.transfer || s.transfer->swap_allowed(m, t))) {
            c.emplace();
            if (s.transfer) s.transfer->swap_before(m, t, *c);
        }
        return c;
    }
    template <class Mesh>
    bool after(op::swap_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const swap_cache& c) const {
        return !s.transfer || s.transfer->swap_after(m, r, c);
    }
    template <class Mesh>
    bool wanted(const Mesh& m, const typename Mesh::tuple& t) const {
        if (m.is_boundary_edge(t)) return false;
        const auto [a, b] = m.edge_vertices(t);
        const auto fe = m.attribute(s.feature);
        if (fe[a] && fe[b]) return false; // keep feature lines
        const index_t c = m.opposite_vertex(t), d = m.opposite_vertex(*m.switch_face(t));
        auto dev = [&](index_t v, int change) {
            return detail::valence_deviation(m, s, v, change);
        };
        const double now = dev(a, 0) + dev(b, 0) + dev(c, 0) + dev(d, 0);
        const double then = dev(a, -1) + dev(b, -1) + dev(c, +1) + dev(d, +1);
        if (then > now) return false;
        const double old_min =
            std::min(detail::min_angle(m, a, b, c), detail::min_angle(m, b, a, d));
        const double new_min =
            std::min(detail::min_angle(m, c, d, a), detail::min_angle(m, d, c, b));
        // Better valences are not worth a sliver: the flip may not halve the quad's
        // smallest angle (a concave or nearly degenerate quad fails this). With equal
        // valences, flip only to open up a thin pair of triangles.
        if (then < now) {
            // Smoothing evens out a thinner pair later, except at frozen vertices, which
            // never move: there the flip may not make the quad's smallest angle smaller
            // (else a 9 degree triangle stayed on bunny's kept border).
            const auto fr = m.attribute(s.frozen);
            if (fr[a] || fr[b] || fr[c] || fr[d]) return new_min >= old_min;
            return new_min >= 0.5 * old_min;
        }
        return old_min < 0.35 && new_min > 1.5 * old_min; // 0.35 rad = 20 degrees
    }
    // Flips whose new triangles have the largest smallest angle run first. Right after the
    // splits, most vertices have valence 4 or 8 and neighbouring edges compete for the same
    // valence gains: in first-come order, flips into thin triangles took them and blocked
    // the flips that would have made the pattern regular (bunny, one iteration: 56% of the
    // interior vertices of valence 6 in fifo order, 89% in this order, CGAL 82%).
    template <class Mesh>
    double priority(op::swap_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        if (m.is_boundary_edge(t)) return 0;
        const auto [a, b] = m.edge_vertices(t);
        const index_t c = m.opposite_vertex(t), d = m.opposite_vertex(*m.switch_face(t));
        return -std::min(detail::min_angle(m, c, d, a), detail::min_angle(m, d, c, b));
    }
    // A flip renews its two faces, so the entries of the quad's four outer edges went
    // stale: enqueue them again. Terminates: a flip either lowers the valence deviation or
    // keeps it and replaces the quad's smallest angle by a larger one.
    template <class Mesh, class Push>
    void renew(op::swap_edge, const Mesh& m, const op_result<typename Mesh::tuple>& r,
               Push& push) const {
        if (r.cells.size() != 2) return;
        for (int i = 0; i < 2; ++i) {
            const auto& other = m.face_vertices(r.cells[1 - i].fid);
            auto in_other = [&](index_t v) {
                return other[0] == v || other[1] == v || other[2] == v;
            };
            for (std::uint8_t le = 0; le < 3; ++le) {
                const auto t = m.tuple_from_edge(r.cells[i].fid, le);
                const auto [x, y] = m.edge_vertices(t);
                if (!(in_other(x) && in_other(y))) push(op::swap_edge{}, t); // not the diagonal
            }
        }
    }
};

template <class... Extra>
struct remesh_smooth_spec : detail::with_invariants<Extra...> {
    using operations = op_list<op::smooth_vertex>;
    remeshing_state& s;
    bool project = true;

    /// A new pass: each vertex moves at most once in it; projection needs the input's tree.
    template <class Mesh>
    void prepare(Mesh&) {
        ++s.pass;
        s.input_build.wait();
    }

    template <class Mesh>
    bool movable(const Mesh& m, index_t v) const {
        return !m.attribute(s.frozen)[v] && !m.attribute(s.boundary)[v] &&
               m.attribute(s.smoothed)[v] != s.pass;
    }
    template <class Push, class Mesh>
    void initial_at(const Mesh& m, index_t v, Push& push) const {
        if (movable(m, v) && !std::ranges::empty(m.vertex_faces(v))) // not unreferenced
            push(op::smooth_vertex{}, m.tuple_from_vertex(v));
    }
    using smooth_cache = placed_values; // the position, and the file's attributes there
    template <class Mesh>
    std::optional<smooth_cache> before(op::smooth_vertex, const Mesh& m,
                                       const typename Mesh::tuple& t) const {
        const auto q = target(m, t.vid);
        if (!q || !keeps_angles(m, t.vid, *q)) return std::nullopt;
        std::optional<smooth_cache> c(std::in_place);
        c->position = *q;
        if (s.transfer && !s.transfer->smooth_before(m, t.vid, *q, c->carried)) c.reset();
        return c;
    }
    template <class Mesh>
    std::optional<vec3> target(const Mesh& m, index_t v) const {
        if (!movable(m, v)) return std::nullopt;
        vec3 c{};
        // Towards the area-weighted centroid of the incident faces: against the uniform
        // centroid of the ring, the symmetric Hausdorff distance to the input fell 8-25%
        // on bunny, armadillo and armadillo x4 (with 3-6% more faces), valences and
        // minimum angles about the same.
        // The same face normals, summed, give the area-weighted vertex normal.
        vec3 n{};
        double area_sum = 0;
        for (index_t f : m.vertex_faces(v)) {
            const auto& fv = m.face_vertices(f);
            const vec3 a = m.position(fv[0]), b = m.position(fv[1]), d = m.position(fv[2]);
            const vec3 normal = cross(b - a, d - a);
            const double area = norm(normal);
            c += (a + b + d) * (area / 3.0);
            area_sum += area;
            n += normal;
        }
        if (!(area_sum > 0)) return std::nullopt; // all faces degenerate: leave it
        c /= area_sum;
        if (const double l = norm(n); l > 0) n /= l;
        const vec3 p = m.position(v);
        vec3 q = p + (c - p) - n * dot(c - p, n); // tangential part of the move only
        if (project && s.input) q = s.input->closest_point(q).point;
        return q;
    }
    /// Projection onto a piecewise flat input pulls a vertex near one of its creases onto
    /// the crease, in line with the neighbours already there: a thin cap that each iteration
    /// made thinner (armadillo x16 on 8 and 16 threads: 13.8 -> 9.3 -> 7.5 degrees). A move
    /// may make the ring's smallest angle smaller only while it stays wide.
    /// Angles compared by their cosines (the law of cosines: no arc tangents on this path).
    template <class Mesh>
    static bool keeps_angles(const Mesh& m, index_t v, const vec3& q) {
        constexpr double cos_wide = 0.8660254037844387; // 30 degrees
        auto largest_cosine_with_v_at = [&](const vec3& at) {
            double largest = -1;
            for (index_t f : m.vertex_faces(v)) {
                const auto& fv = m.face_vertices(f);
                auto p = [&](index_t w) { return w == v ? at : m.position(w); };
                const vec3 a = p(fv[0]), b = p(fv[1]), c = p(fv[2]);
                const double ab = squared_norm(b - a), bc = squared_norm(c - b),
                             ca = squared_norm(a - c);
                for (const auto [x, y, opposite] :
                     {std::array{ab, ca, bc}, std::array{ab, bc, ca}, std::array{bc, ca, ab}}) {
                    const double d = 2 * std::sqrt(x * y);
                    largest = std::max(largest, d > 0 ? (x + y - opposite) / d : 1.0);
                }
            }
            return largest;
        };
        const double then = largest_cosine_with_v_at(q);
        return then <= cos_wide || then <= largest_cosine_with_v_at(m.position(v));
    }
    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const smooth_cache& c) const {
        m.positions(r).set(r.anchor.vid, c.position);
        m.attribute(s.smoothed, r).set(r.anchor.vid, s.pass);
        return !s.transfer || s.transfer->smooth_after(m, r, c.carried);
    }
};

struct remeshing_report {
    unsigned iterations = 0;
    std::uint64_t splits = 0, collapses = 0, swaps = 0, smooths = 0;
    double seconds = 0;
    /// Split, collapse, swap and smooth, each summed over the iterations (wall time, setup
    /// and serial tail per kind: where a parallel run loses its speedup).
    std::array<run_report, 4> phases{};
    /// On one thread: marking frozen vertices and (serial runs) building the projection
    /// tree, plus every phase's setup and serial tail.
    double setup_seconds = 0, tail_seconds = 0;
};

/// The remeshing schedule: split, collapse, swap, smooth, repeated until an iteration
/// changes no connectivity (or the iteration count is reached).
template <class... Extra>
using remeshing_schedule =
    schedule::repeat<schedule::phase<remesh_split_spec<Extra...>>,
                     schedule::phase<remesh_collapse_spec<Extra...>>,
                     schedule::phase<remesh_swap_spec<Extra...>>,
                     schedule::phase<remesh_smooth_spec<Extra...>, queue::fifo>>;

/// The whole algorithm: policies as template arguments, extra invariants as `Extra...`
/// (constructed by the caller, e.g. an envelope of the input).
template <class Mesh = tri_mesh<>, class Lock = lock::vertex_try_lock,
          class Queue = queue::dary_heap<4>, class Partition = partition::morton, class... Extra>
struct isotropic_remeshing {
    using schedule_type = remeshing_schedule<Extra...>;
    using driver = schedule::driver<schedule_type, Mesh, Lock, Queue, Partition>;

    static remeshing_report run(Mesh& m, const remeshing_options& o, const exec_options& exec = {},
                                Extra... extra) {
        return run_observed(m, o, exec, schedule::no_observer{}, extra...);
    }

    /// The same, telling `observer(phase, iteration, run_report)` after every phase (phases
    /// 0-3: split, collapse, swap, smooth).
    template <class Observer>
    static remeshing_report run_observed(Mesh& m, const remeshing_options& o,
                                         const exec_options& exec, Observer&& observer,
                                         Extra... extra) {
        const idas::detail::stopwatch preparing;
        remeshing_state s;
        s.L = o.target_length;
        const temporary_attribute frozen(
            m, m.template add_vertex_attribute<std::uint8_t>("remesh_frozen", 0));
        const temporary_attribute feature(
            m, m.template add_vertex_attribute<std::uint8_t>("remesh_feature", 0));
        const temporary_attribute boundary(
            m, m.template add_vertex_attribute<std::uint8_t>("remesh_boundary", 0));
        const temporary_attribute smoothed(
            m, m.template add_vertex_attribute<std::uint32_t>("remesh_smoothed", 0));
        s.frozen = frozen.handle, s.feature = feature.handle, s.boundary = boundary.handle;
        s.smoothed = smoothed.handle;
        s.transfer = o.transfer;
        // Only smoothing projects onto the input, so with several threads its tree is
        // built beside the first split and collapse phases instead of before them (on
        // armadillo x4 the build is 0.35 s, a tenth of a serial remesh).
        if (o.project) {
            auto build = [&s, arrays = m.to_arrays()] {
                s.input = std::make_shared<const triangle_aabb_tree>(arrays.first, arrays.second);
            };
            if (exec.threads > 1)
                s.input_build.start(std::move(build));
            else
                build();
        }
        mark_frozen(m, s, o);

        const double prepared = preparing.seconds();
        remesh_split_spec<Extra...> split{{std::tuple<Extra...>(extra...)}, s};
        remesh_collapse_spec<Extra...> collapse{{std::tuple<Extra...>(extra...)}, s};
        remesh_swap_spec<Extra...> swap{{std::tuple<Extra...>(extra...)}, s};
        remesh_smooth_spec<Extra...> smooth{{std::tuple<Extra...>(extra...)}, s, o.project};

        const auto r = driver::run(m, exec, o.iterations, observer, split, collapse, swap, smooth);
        s.input_build.wait(); // joined before the state goes, even if no smoothing ran
        remeshing_report report;
        report.iterations = r.iterations;
        report.splits = r.phases[0].succeeded, report.collapses = r.phases[1].succeeded;
        report.swaps = r.phases[2].succeeded, report.smooths = r.phases[3].succeeded;
        report.seconds = r.seconds + prepared;
        report.phases = r.phases;
        report.setup_seconds = prepared;
        for (const run_report& p : r.phases)
            report.setup_seconds += p.setup_seconds, report.tail_seconds += p.tail_seconds;
        return report;
    }

private:
    static void mark_frozen(Mesh& m, remeshing_state& s, const remeshing_options& o) {
        auto fr = m.attribute(s.frozen);
        auto fe = m.attribute(s.feature);
        auto bd = m.attribute(s.boundary);
        // Seams and tag borders are kept like features.
        if (o.transfer)
            m.for_each_vertex([&](const typename Mesh::tuple& t) {
                if (o.transfer->constrained(m, t.vid)) fr.raw(t.vid) = fe.raw(t.vid) = 1;
            });
        m.for_each_vertex([&](const typename Mesh::tuple& t) {
            if (m.is_boundary_vertex(t.vid)) bd.raw(t.vid) = 1, fr.raw(t.vid) = o.preserve_boundary;
        });
        if (o.feature_angle_deg >= 0) {
            const double cos_limit = std::cos(o.feature_angle_deg * std::numbers::pi / 180.0);
            m.for_each_edge([&](const typename Mesh::tuple& t) {
                const auto g = m.switch_face(t);
                if (!g) return;
                vec3 n1 = face_normal_unnormalised(m, t.fid),
                     n2 = face_normal_unnormalised(m, g->fid);
                const double l = norm(n1) * norm(n2);
                if (l > 0 && dot(n1, n2) / l < cos_limit) {
                    const auto [a, b] = m.edge_vertices(t);
                    fr.raw(a) = fr.raw(b) = fe.raw(a) = fe.raw(b) = 1;
                }
            });
        }
    }
};

static_assert(spec_for<remesh_split_spec<>, tri_mesh<>> &&
              spec_for<remesh_collapse_spec<>, tri_mesh<>> &&
              spec_for<remesh_swap_spec<>, tri_mesh<>> &&
              spec_for<remesh_smooth_spec<>, tri_mesh<>>);

} // namespace idas::algorithms
