// triangle_aabb_tree: closest-point queries on a fixed triangle soup (the input surface of
// remeshing's projection, the reference of distance checks).
//
// A bounding-volume hierarchy built with binned SAH splits (16 bins along the widest
// centroid axis; object medians below depth 48 or when centroids coincide), leaves of at
// most 4 triangles, stored as a flat array of 32-byte nodes in depth-first order (a left
// child follows its parent; float boxes, rounded outwards so they always contain their
// triangles). Triangles are copied into leaf order, so a leaf's triangles are contiguous.
// Queries descend the nearer child first and prune every box farther than the best
// distance found so far.
//
// Every query is const and touches no shared mutable state: any number of threads may
// query one tree concurrently.
//
// Distances are those of closest_point_on_triangle (below), so a brute-force loop over
// the faces with the same function finds the same squared distance.
#pragma once

#include <idas/core/types.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

namespace idas {

/// The point of triangle (a, b, c) closest to p (Ericson, Real-Time Collision Detection,
/// 5.1.5), by the Voronoi regions of the triangle's features. Always a finite point of the
/// triangle, degenerate triangles included (their closest segment point).
inline vec3 closest_point_on_triangle(const vec3& p, const vec3& a, const vec3& b, const vec3& c) {
    // Point of segment (s, s + d) closest to p, parameter clamped; a point segment is s.
    auto on_segment = [&p](const vec3& s, const vec3& d) {
        const double dd = dot(d, d);
        if (!(dd > 0)) return s;
        return s + d * std::clamp(dot(p - s, d) / dd, 0.0, 1.0);
    };
    const vec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const vec3 bp = p - b;
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0)
        return d1 - d3 > 0 ? a + ab * std::min(d1 / (d1 - d3), 1.0) : a;
    const vec3 cp = p - c;
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0)
        return d2 - d6 > 0 ? a + ac * std::min(d2 / (d2 - d6), 1.0) : a;
    const double va = d3 * d6 - d5 * d4;
    const double e4 = d4 - d3, e5 = d5 - d6;
    if (va <= 0 && e4 >= 0 && e5 >= 0)
        return e4 + e5 > 0 ? b + (c - b) * std::min(e4 / (e4 + e5), 1.0) : b;
    const double denom = va + vb + vc;
    if (denom > 0 && std::isfinite(denom)) {
        const double v = vb / denom, w = vc / denom;
        if (v >= 0 && w >= 0 && v + w <= 1) return a + ab * v + ac * w;
    }
    // Degenerate (or numerically ambiguous) triangle: the nearest of its three edges.
    const vec3 s[3] = {on_segment(a, ab), on_segment(a, ac), on_segment(b, c - b)};
    const double q[3] = {squared_norm(p - s[0]), squared_norm(p - s[1]), squared_norm(p - s[2])};
    return q[0] <= q[1] ? (q[0] <= q[2] ? s[0] : s[2]) : (q[1] <= q[2] ? s[1] : s[2]);
}

/// Answer of a closest-point query. `face` is an index into the faces the tree was built
/// from; invalid_index (and an infinite distance) when nothing was found: the tree is
/// empty, or no face is within the query's upper bound.
struct closest_point_result {
    vec3 point{};
    double squared_distance = std::numeric_limits<double>::infinity();
    index_t face = invalid_index;

    explicit operator bool() const noexcept { return face != invalid_index; }
};

class triangle_aabb_tree {
public:
    /// An empty tree: every query finds nothing.
    triangle_aabb_tree() = default;

    /// Builds the hierarchy over faces F of vertices V (copied; V and F may then change).
    /// Throws input_error for an out-of-range vertex index.
    triangle_aabb_tree(const std::vector<vec3>& V, const std::vector<tri_indices>& F) {
        build(V, F);
    }

    std::size_t n_faces() const noexcept { return tris_.size(); }
    bool empty() const noexcept { return tris_.empty(); }
    /// Bounding box of every triangle (min, max corners); both zero for an empty tree.
    std::pair<vec3, vec3> bounds() const noexcept { return {lo_, hi_}; }
    /// Length of the bounding box's diagonal.
    double diagonal() const noexcept { return norm(hi_ - lo_); }
    /// The triangle of input face f, as built.
    std::array<vec3, 3> triangle(index_t f) const noexcept {
        const tri& t = tris_[slot_of_face_[f]];
        return {t.a, t.b, t.c};
    }
    /// Nodes of the hierarchy (for statistics and tests).
    std::size_t n_nodes() const noexcept { return nodes_.size(); }
    std::size_t depth() const noexcept { return depth_; }

    /// The closest point of the surface to q.
    closest_point_result closest_point(const vec3& q) const {
        return search(q, std::numeric_limits<double>::infinity(), invalid_index);
    }

    /// The closest point among faces at squared distance at most `max_squared_distance`
    /// (a known upper bound prunes from the start); nothing if there is none.
    closest_point_result closest_point(const vec3& q, double max_squared_distance) const {
        return search(q, max_squared_distance, invalid_index);
    }

    /// The same, starting from the distance to `face_hint` (a face likely to be near q):
    /// the answer does not depend on the hint, only the speed.
    closest_point_result closest_point(const vec3& q, double max_squared_distance,
                                       index_t face_hint) const {
        return search(q, max_squared_distance, face_hint);
    }

    /// The closest point, starting from the distance to `face_hint` (for instance the face a
    /// moving vertex was last projected onto). The answer does not depend on the hint, only
    /// the speed; an out-of-range hint is ignored.
    closest_point_result closest_point_near(const vec3& q, index_t face_hint) const {
        return search(q, std::numeric_limits<double>::infinity(), face_hint);
    }

    /// Squared distance from q to the surface (infinite for an empty tree).
    double squared_distance(const vec3& q) const { return closest_point(q).squared_distance; }

    /// Calls fn(face, squared_distance) for every face at squared distance at most r2 from
    /// q, in no particular order; fn returns false to stop early. Returns false if stopped.
    template <class Fn>
    bool for_each_face_within(const vec3& q, double r2, Fn&& fn) const {
        if (nodes_.empty() || !(box_distance(nodes_[0], q) <= r2)) return true;
        std::uint32_t stack[max_stack];
        std::size_t top = 0;
        std::uint32_t n = 0;
        for (;;) {
            const node& nd = nodes_[n];
            if (nd.count > 0) {
                for (std::uint32_t i = nd.index, e = nd.index + nd.count; i < e; ++i) {
                    const tri& t = tris_[i];
                    const double d = squared_norm(q - closest_point_on_triangle(q, t.a, t.b, t.c));
                    if (d <= r2 && !fn(face_of_slot_[i], d)) return false;
                }
            } else {
                const std::uint32_t l = n + 1, r = nd.index;
                const bool gl = box_distance(nodes_[l], q) <= r2,
                           gr = box_distance(nodes_[r], q) <= r2;
                if (gl && gr) stack[top++] = r;
                if (gl || gr) {
                    n = gl ? l : r;
                    continue;
                }
            }
            if (top == 0) return true;
            n = stack[--top];
        }
    }

    /// True if some face is at squared distance at most r2 from q; stops at the first one.
    bool within_squared_distance(const vec3& q, double r2) const {
        if (nodes_.empty() || !(box_distance(nodes_[0], q) <= r2)) return false;
        std::uint32_t stack[max_stack];
        std::size_t top = 0;
        std::uint32_t n = 0;
        for (;;) {
            const node& nd = nodes_[n];
            if (nd.count > 0) {
                for (std::uint32_t i = nd.index, e = nd.index + nd.count; i < e; ++i) {
                    const tri& t = tris_[i];
                    if (squared_norm(q - closest_point_on_triangle(q, t.a, t.b, t.c)) <= r2)
                        return true;
                }
            } else {
                const std::uint32_t l = n + 1, r = nd.index;
                const double dl = box_distance(nodes_[l], q), dr = box_distance(nodes_[r], q);
                const bool gl = dl <= r2, gr = dr <= r2;
                if (gl && gr) {
                    const bool left_first = dl <= dr;
                    stack[top++] = left_first ? r : l;
                    n = left_first ? l : r;
                    continue;
                }
                if (gl || gr) {
                    n = gl ? l : r;
                    continue;
                }
            }
            if (top == 0) return false;
            n = stack[--top];
        }
    }

private:
    struct node {
        float lo[3], hi[3];
        // Leaf (count > 0): triangles [index, index + count). Inner: right child at
        // index, left child right after this node.
        std::uint32_t index = 0, count = 0;
    };
    static_assert(sizeof(node) == 32);
    struct tri {
        vec3 a, b, c;
    };
    struct box {
        vec3 lo{inf(), inf(), inf()}, hi{-inf(), -inf(), -inf()};
        void grow(const vec3& p) {
            for (int k = 0; k < 3; ++k)
                lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
        }
        void grow(const box& b) { grow(b.lo), grow(b.hi); }
        double area() const {
            const vec3 d = hi - lo;
            if (!(d.x >= 0)) return 0;
            return 2 * (d.x * d.y + d.y * d.z + d.z * d.x);
        }
    };
    struct build_item {
        box bounds;
        vec3 centroid;
        index_t face;
    };

    static constexpr double inf() { return std::numeric_limits<double>::infinity(); }
    static constexpr std::uint32_t max_leaf = 4;
    static constexpr int bins = 16;
    // Beyond this depth splits are object medians, so depth stays below max_stack.
    static constexpr std::size_t sah_depth = 48;
    static constexpr std::size_t max_stack = 128;

    static double box_distance(const node& nd, const vec3& q) noexcept {
        const double dx = std::max(std::max(double(nd.lo[0]) - q.x, q.x - double(nd.hi[0])), 0.0);
        const double dy = std::max(std::max(double(nd.lo[1]) - q.y, q.y - double(nd.hi[1])), 0.0);
        const double dz = std::max(std::max(double(nd.lo[2]) - q.z, q.z - double(nd.hi[2])), 0.0);
        return dx * dx + dy * dy + dz * dz;
    }

    closest_point_result search(const vec3& q, double bound, index_t hint) const {
        closest_point_result best;
        if (nodes_.empty()) return best;
        double best_d = bound;
        auto test = [&](std::uint32_t i) {
            const tri& t = tris_[i];
            const vec3 p = closest_point_on_triangle(q, t.a, t.b, t.c);
            const double d = squared_norm(q - p);
            if (d < best.squared_distance && d <= best_d) {
                best.point = p, best.squared_distance = d, best.face = face_of_slot_[i];
                best_d = d;
            }
        };
        if (hint < slot_of_face_.size()) test(slot_of_face_[hint]);

        struct entry {
            std::uint32_t n;
            double d;
        };
        entry stack[max_stack];
        std::size_t top = 0;
        std::uint32_t n = 0;
        if (!(box_distance(nodes_[0], q) <= best_d)) return best;
        for (;;) {
            const node& nd = nodes_[n];
            if (nd.count > 0) {
                for (std::uint32_t i = nd.index, e = nd.index + nd.count; i < e; ++i) test(i);
            } else {
                const std::uint32_t l = n + 1, r = nd.index;
                const double dl = box_distance(nodes_[l], q), dr = box_distance(nodes_[r], q);
                const bool gl = dl <= best_d, gr = dr <= best_d;
                if (gl && gr) {
                    if (dl <= dr)
                        stack[top++] = {r, dr}, n = l;
                    else
                        stack[top++] = {l, dl}, n = r;
                    continue;
                }
                if (gl || gr) {
                    n = gl ? l : r;
                    continue;
                }
            }
            // Pop the next subtree still worth visiting.
            for (;;) {
                if (top == 0) return best;
                const entry& e = stack[--top];
                if (e.d <= best_d) {
                    n = e.n;
                    break;
                }
            }
        }
    }

    void build(const std::vector<vec3>& V, const std::vector<tri_indices>& F) {
        std::vector<build_item> items(F.size());
        box all;
        for (std::size_t f = 0; f < F.size(); ++f) {
            box b;
            for (index_t v : F[f]) {
                if (v >= V.size())
                    throw input_error("face " + std::to_string(f) + " has vertex index " +
                                      std::to_string(v) + " beyond the " +
                                      std::to_string(V.size()) + " vertices");
                b.grow(V[v]);
            }
            items[f] = {b, (b.lo + b.hi) * 0.5, static_cast<index_t>(f)};
            all.grow(b);
        }
        if (items.empty()) return;
        if (F.size() >= std::numeric_limits<std::uint32_t>::max() / 2)
            throw input_error("too many faces for triangle_aabb_tree");
        lo_ = all.lo, hi_ = all.hi;
        nodes_.reserve(2 * items.size() / max_leaf + 1);
        build_node(items, 0, static_cast<std::uint32_t>(items.size()), 1);

        tris_.resize(items.size());
        face_of_slot_.resize(items.size());
        slot_of_face_.resize(items.size());
        for (std::size_t i = 0; i < items.size(); ++i) {
            const auto& f = F[items[i].face];
            tris_[i] = {V[f[0]], V[f[1]], V[f[2]]};
            face_of_slot_[i] = items[i].face;
            slot_of_face_[items[i].face] = static_cast<index_t>(i);
        }
    }

    static void set_box(node& nd, const box& b) {
        // Outward rounding: the float box contains the double one.
        for (int k = 0; k < 3; ++k) {
            float lo = static_cast<float>(b.lo[k]), hi = static_cast<float>(b.hi[k]);
            if (static_cast<double>(lo) > b.lo[k])
                lo = std::nextafter(lo, -std::numeric_limits<float>::infinity());
            if (static_cast<double>(hi) < b.hi[k])
                hi = std::nextafter(hi, std::numeric_limits<float>::infinity());
            nd.lo[k] = lo, nd.hi[k] = hi;
        }
    }

    // Builds the subtree of items [begin, end) at nodes_.back() + 1; returns its index.
    std::uint32_t build_node(std::vector<build_item>& items, std::uint32_t begin, std::uint32_t end,
                             std::size_t depth) {
        depth_ = std::max(depth_, depth);
        const auto id = static_cast<std::uint32_t>(nodes_.size());
        nodes_.emplace_back();
        box bounds, cbounds;
        for (std::uint32_t i = begin; i < end; ++i)
            bounds.grow(items[i].bounds), cbounds.grow(items[i].centroid);
        set_box(nodes_[id], bounds);
        const std::uint32_t n = end - begin;
        auto make_leaf = [&] {
            nodes_[id].index = begin, nodes_[id].count = n;
            return id;
        };
        if (n <= 2) return make_leaf();

        const vec3 ext = cbounds.hi - cbounds.lo;
        const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
        std::uint32_t mid = begin;
        bool split_found = false;
        if (depth < sah_depth && ext[axis] > 0) {
            // Binned SAH along the widest centroid axis (binning all three axes builds
            // twice as slowly for no measurable gain in query time on scanned meshes).
            const double lo = cbounds.lo[axis], scale = bins / ext[axis];
            auto bin_of = [&](const build_item& x) {
                return std::min(bins - 1, static_cast<int>((x.centroid[axis] - lo) * scale));
            };
            box bb[bins];
            std::uint32_t cnt[bins] = {};
            for (std::uint32_t i = begin; i < end; ++i) {
                const int b = bin_of(items[i]);
                bb[b].grow(items[i].bounds), ++cnt[b];
            }
            double right_area[bins] = {};
            std::uint32_t right_count[bins] = {};
            box acc;
            std::uint32_t c = 0;
            for (int b = bins - 1; b > 0; --b) {
                acc.grow(bb[b]), c += cnt[b];
                right_area[b] = acc.area(), right_count[b] = c;
            }
            double best_cost = inf();
            int best_bin = -1;
            acc = box{}, c = 0;
            for (int b = 0; b < bins - 1; ++b) {
                acc.grow(bb[b]), c += cnt[b];
                if (c == 0 || right_count[b + 1] == 0) continue;
                const double cost = acc.area() * c + right_area[b + 1] * right_count[b + 1];
                if (cost < best_cost) best_cost = cost, best_bin = b;
            }
            if (best_bin >= 0) {
                // Traversal costs about as much as one triangle test.
                if (n <= max_leaf && bounds.area() * n <= bounds.area() + best_cost)
                    return make_leaf();
                const auto it =
                    std::partition(items.begin() + begin, items.begin() + end,
                                   [&](const build_item& x) { return bin_of(x) <= best_bin; });
                mid = static_cast<std::uint32_t>(it - items.begin());
                split_found = mid > begin && mid < end;
            }
        }
        if (!split_found) {
            if (n <= max_leaf) return make_leaf();
            // Object median along the widest centroid axis (also for coincident centroids).
            mid = begin + n / 2;
            std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end,
                             [axis](const build_item& x, const build_item& y) {
                                 return x.centroid[axis] < y.centroid[axis];
                             });
        }
        build_node(items, begin, mid, depth + 1);
        const std::uint32_t right = build_node(items, mid, end, depth + 1);
        nodes_[id].index = right, nodes_[id].count = 0;
        return id;
    }

    std::vector<node> nodes_;
    std::vector<tri> tris_;
    std::vector<index_t> face_of_slot_, slot_of_face_;
    vec3 lo_{}, hi_{};
    std::size_t depth_ = 0;
};

} // namespace idas
