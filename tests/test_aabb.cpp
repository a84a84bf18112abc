// triangle_aabb_tree (closest points) and the sampled surface distances built on it.
#include "test_support.hpp"

#include <idas/core/aabb_tree.hpp>
#include <idas/mesh/surface_distance.hpp>

#include <algorithm>
#include <random>
#include <thread>
#include <vector>

using namespace idas;

namespace {

struct soup {
    std::vector<vec3> V;
    std::vector<tri_indices> F;
};

soup load_soup(const std::string& name) {
    auto s = io::read_surface(test::data(name));
    return {std::move(s.vertices), std::move(s.faces)};
}

closest_point_result brute_force(const soup& s, const vec3& q) {
    closest_point_result best;
    for (std::size_t f = 0; f < s.F.size(); ++f) {
        const auto& t = s.F[f];
        const vec3 p = closest_point_on_triangle(q, s.V[t[0]], s.V[t[1]], s.V[t[2]]);
        const double d = squared_norm(q - p);
        if (d < best.squared_distance) best = {p, d, static_cast<index_t>(f)};
    }
    return best;
}

/// Query points: near the surface (a random surface point pushed off along a random
/// direction by up to 2% of the diagonal), anywhere in the enlarged bounding box, and far away.
std::vector<vec3> queries(const soup& s, const triangle_aabb_tree& tree, int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1), sym(-1, 1);
    const auto [lo, hi] = tree.bounds();
    const double diag = tree.diagonal();
    std::vector<vec3> out;
    for (int i = 0; i < n; ++i) {
        const int kind = i % 4;
        if (kind <= 1) {
            const auto& t = s.F[std::uniform_int_distribution<std::size_t>(0, s.F.size() - 1)(rng)];
            double a = u(rng), b = u(rng);
            if (a + b > 1) a = 1 - a, b = 1 - b;
            const vec3 p = s.V[t[0]] + (s.V[t[1]] - s.V[t[0]]) * a + (s.V[t[2]] - s.V[t[0]]) * b;
            out.push_back(p + vec3{sym(rng), sym(rng), sym(rng)} * (0.02 * diag * u(rng)));
        } else if (kind == 2) {
            const vec3 d = hi - lo;
            out.push_back(lo - d * 0.25 +
                          vec3{d.x * 1.5 * u(rng), d.y * 1.5 * u(rng), d.z * 1.5 * u(rng)});
        } else {
            out.push_back(lo + vec3{sym(rng), sym(rng), sym(rng)} * (10 * diag));
        }
    }
    return out;
}

} // namespace

TEST_CASE("aabb: closest point equals brute force on bunny.off") {
    const soup s = load_soup("bunny.off");
    const triangle_aabb_tree tree(s.V, s.F);
    REQUIRE(tree.n_faces() == s.F.size());
    CHECK(tree.depth() < 64);
    const auto Q = queries(s, tree, 2000, 7);
    std::mt19937 rng(11);
    for (const vec3& q : Q) {
        const auto bf = brute_force(s, q);
        const auto r = tree.closest_point(q);
        REQUIRE(r.face != invalid_index);
        CHECK(r.squared_distance == bf.squared_distance);
        // The reported point is on the reported face, at the reported distance.
        const auto& t = s.F[r.face];
        CHECK(r.point == closest_point_on_triangle(q, s.V[t[0]], s.V[t[1]], s.V[t[2]]));
        CHECK(squared_norm(q - r.point) == r.squared_distance);
        CHECK(tree.squared_distance(q) == bf.squared_distance);

        // A face hint changes nothing but speed.
        const auto hint = std::uniform_int_distribution<index_t>(0, index_t(s.F.size() - 1))(rng);
        CHECK(tree.closest_point_near(q, hint).squared_distance == bf.squared_distance);
        CHECK(tree.closest_point_near(q, invalid_index).squared_distance == bf.squared_distance);

        // Upper bounds: found iff within; then the same answer.
        const auto above = tree.closest_point(q, bf.squared_distance * 1.5 + 1e-300);
        CHECK(above.squared_distance == bf.squared_distance);
        CHECK_FALSE(tree.closest_point(q, bf.squared_distance * 0.5));
        CHECK(tree.closest_point(q, bf.squared_distance).squared_distance == bf.squared_distance);
        CHECK(tree.within_squared_distance(q, bf.squared_distance));
        CHECK_FALSE(tree.within_squared_distance(q, bf.squared_distance * (1 - 1e-9)));
    }
}

TEST_CASE("aabb: faces within a radius") {
    const soup s = load_soup("bunny.off");
    const triangle_aabb_tree tree(s.V, s.F);
    const auto Q = queries(s, tree, 300, 13);
    for (const vec3& q : Q) {
        const double r2 =
            brute_force(s, q).squared_distance * 1.5 + 1e-6 * tree.diagonal() * tree.diagonal();
        std::vector<index_t> expected, found;
        for (std::size_t f = 0; f < s.F.size(); ++f) {
            const auto& t = s.F[f];
            if (squared_norm(q - closest_point_on_triangle(q, s.V[t[0]], s.V[t[1]], s.V[t[2]])) <=
                r2)
                expected.push_back(index_t(f));
        }
        CHECK(tree.for_each_face_within(q, r2, [&](index_t f, double d) {
            found.push_back(f);
            CHECK(d <= r2);
            return true;
        }));
        std::sort(found.begin(), found.end());
        CHECK(found == expected);
        // Stopping early.
        int calls = 0;
        CHECK_FALSE(tree.for_each_face_within(q, r2, [&](index_t, double) { return ++calls < 1; }));
        CHECK(calls == 1);
    }
}

TEST_CASE("aabb: triangles are stored as given and surface points have distance zero") {
    const soup s = load_soup("bunny.off");
    const triangle_aabb_tree tree(s.V, s.F);
    for (index_t f = 0; f < s.F.size(); f += 37) {
        const auto t = tree.triangle(f);
        for (int k = 0; k < 3; ++k) CHECK(t[k] == s.V[s.F[f][k]]);
        CHECK(tree.squared_distance(s.V[s.F[f][0]]) == 0);
        const auto r = tree.closest_point_near(s.V[s.F[f][1]], f);
        CHECK(r.squared_distance == 0);
    }
}

TEST_CASE("aabb: empty, degenerate and repeated triangles") {
    const triangle_aabb_tree empty;
    CHECK(empty.empty());
    CHECK_FALSE(empty.closest_point({1, 2, 3}));
    CHECK(empty.squared_distance({1, 2, 3}) == std::numeric_limits<double>::infinity());
    CHECK_FALSE(empty.within_squared_distance({1, 2, 3}, 1e300));
    CHECK(triangle_aabb_tree({}, {}).empty());

    // Zero-area triangles (a point, a segment, a fold-back segment) and many copies of one
    // triangle (identical centroids defeat SAH binning).
    std::vector<vec3> V = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {5, 5, 5}};
    std::vector<tri_indices> F = {{0, 0, 0}, {0, 1, 2}, {2, 0, 1}, {4, 4, 4}};
    for (int i = 0; i < 100; ++i) F.push_back({0, 1, 3});
    const soup s{V, F};
    const triangle_aabb_tree tree(V, F);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-3, 8);
    for (int i = 0; i < 500; ++i) {
        const vec3 q{u(rng), u(rng), u(rng)};
        const auto r = tree.closest_point(q);
        REQUIRE(r.face != invalid_index);
        CHECK(is_finite(r.point));
        CHECK(r.squared_distance == brute_force(s, q).squared_distance);
    }
    CHECK(tree.closest_point({1.5, -1, 0}).squared_distance == 1.0);
    CHECK(tree.closest_point({5, 5, 6}).squared_distance == 1.0);

    CHECK_THROWS_AS(triangle_aabb_tree(V, {{0, 1, 9}}), input_error);
}

TEST_CASE("aabb: concurrent queries agree with serial ones") {
    const soup s = load_soup("bunny.off");
    const triangle_aabb_tree tree(s.V, s.F);
    const auto Q = queries(s, tree, 4000, 5);
    std::vector<closest_point_result> serial(Q.size()), parallel(Q.size());
    for (std::size_t i = 0; i < Q.size(); ++i) serial[i] = tree.closest_point(Q[i]);
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < 4; ++t)
        pool.emplace_back([&, t] {
            for (std::size_t i = t; i < Q.size(); i += 4) parallel[i] = tree.closest_point(Q[i]);
        });
    for (auto& th : pool) th.join();
    for (std::size_t i = 0; i < Q.size(); ++i) {
        CHECK(parallel[i].squared_distance == serial[i].squared_distance);
        CHECK(parallel[i].face == serial[i].face);
    }
}

TEST_CASE("aabb: sampled surface distances") {
    // A 10 x 10 grid of unit squares in z = 0, and the same grid lifted by 0.25.
    std::vector<vec3> V, W;
    std::vector<tri_indices> F;
    const index_t n = 11;
    for (index_t y = 0; y < n; ++y)
        for (index_t x = 0; x < n; ++x)
            V.push_back({double(x), double(y), 0}), W.push_back({double(x), double(y), 0.25});
    for (index_t y = 0; y + 1 < n; ++y)
        for (index_t x = 0; x + 1 < n; ++x) {
            const index_t a = y * n + x;
            F.push_back({a, a + 1, a + n + 1}), F.push_back({a, a + n + 1, a + n});
        }
    const triangle_aabb_tree flat(V, F);
    CHECK(max_sampled_distance(V, F, flat, 16) < 1e-14); // rounding of the projections only
    CHECK(max_sampled_distance(W, F, flat, 16) == doctest::Approx(0.25).epsilon(1e-12));
    const auto far = farthest_sampled_point(W, F, flat, 0);
    CHECK(far.distance == doctest::Approx(0.25).epsilon(1e-12));
    CHECK(far.face == 0); // every sample ties: the smallest face wins
    CHECK(hausdorff_symmetric(V, F, W, F) == doctest::Approx(0.25).epsilon(1e-12));

    // One vertex lifted by 1: the farthest sample is that vertex.
    std::vector<vec3> bump = V;
    bump[5 * n + 5].z = 1;
    const auto f = farthest_sampled_point(bump, F, flat, 9);
    CHECK(f.distance == 1.0);
    CHECK(f.point == bump[5 * n + 5]);
    CHECK(hausdorff_one_sided(bump, F, V, F) == 1.0);
    // The flat grid is within 1/sqrt(2)-ish of the bump surface, and not 0.
    const double back = hausdorff_one_sided(V, F, bump, F);
    CHECK(back > 0);
    CHECK(back < 1.0);
    CHECK(hausdorff_symmetric(V, F, bump, F) == 1.0);

    // Every sampling includes the vertices, midpoints and centroid; denser sampling finds
    // (up to rounding of the sample positions) at least what sparser sampling found.
    const soup s = load_soup("bunny.off");
    std::vector<vec3> moved = s.V;
    std::mt19937 rng(1);
    std::normal_distribution<double> g(0, 1e-3);
    for (auto& p : moved) p += vec3{g(rng), g(rng), g(rng)};
    const triangle_aabb_tree ref(s.V, s.F);
    const double d1 = max_sampled_distance(moved, s.F, ref, 1);
    const double d4 = max_sampled_distance(moved, s.F, ref, 4);
    const double d16 = max_sampled_distance(moved, s.F, ref, 16);
    CHECK(d1 > 0);
    CHECK(d4 >= d1);
    CHECK(d16 >= d1);
    CHECK(d16 >= d4 * (1 - 1e-12));
    // Deterministic whatever the thread schedule.
    CHECK(max_sampled_distance(moved, s.F, ref, 16) == d16);
    const auto a = farthest_sampled_point(moved, s.F, ref, 16),
               b = farthest_sampled_point(moved, s.F, ref, 16);
    CHECK(a.face == b.face);
    CHECK(a.point == b.point);
    // The farthest vertex bounds it from below.
    double vmax = 0;
    for (const auto& p : moved) vmax = std::max(vmax, std::sqrt(ref.squared_distance(p)));
    CHECK(d1 >= vmax);
}
