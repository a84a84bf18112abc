// The envelope invariant (exact containment in the eps-envelope of the input, through
// CGAL::Polyhedral_envelope). Built only when CGAL is found (IDAS_HAS_CGAL).
#if defined(IDAS_HAS_CGAL)

#include "test_support.hpp"

#include <idas/core/aabb_tree.hpp>
#include <idas/invariants/envelope.hpp>
#include <idas/mesh/surface_distance.hpp>

#include <boost/container/small_vector.hpp>

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

vec3 unit_normal(const vec3& a, const vec3& b, const vec3& c) {
    const vec3 n = cross(b - a, c - a);
    return n / norm(n);
}

using triangle = std::array<vec3, 3>;

triangle face_triangle(const soup& s, std::size_t f) {
    return {s.V[s.F[f][0]], s.V[s.F[f][1]], s.V[s.F[f][2]]};
}

/// The filter's verdicts on queries beside CGAL's: wherever the filter decides, it must
/// agree; counts of each verdict and of CGAL's insides.
struct verdict_tally {
    int count[3] = {0, 0, 0}, inside = 0;
    void add(const envelope& env, const triangle& t) {
        const bool exact = env.contains_exact(t[0], t[1], t[2]);
        const auto v = env.fast_verdict(t[0], t[1], t[2]);
        if (v != envelope::verdict::unknown) REQUIRE((v == envelope::verdict::inside) == exact);
        ++count[int(v)], inside += exact;
    }
    int decided(envelope::verdict v) const { return count[int(v)]; }
};

triangle moved(const triangle& t, double distance) {
    const vec3 d = unit_normal(t[0], t[1], t[2]) * distance;
    return {t[0] + d, t[1] + d, t[2] + d};
}

/// Moves the smoothed vertex along its (area-weighted) normal by `distance`.
struct push_along_normal {
    envelope env;
    double distance = 0;

    template <class Mesh>
    bool after(op::smooth_vertex, Mesh& m, const op_result<tri_tuple>& r) {
        const index_t v = r.anchor.vid;
        vec3 n{};
        for (index_t f : m.vertex_faces(v)) n += face_normal_unnormalised(m, f);
        m.positions(r).set(v, m.position(v) + n / norm(n) * distance);
        return true;
    }
    auto invariants() const { return invariant_set{env}; }
};

} // namespace

TEST_CASE("envelope: accepts the input's own triangles") {
    const soup s = load_soup("bunny.off");
    const auto env = envelope::relative(s.V, s.F);
    REQUIRE(env.enabled());
    CHECK(env.eps() == doctest::Approx(1e-3 * envelope::bounding_diagonal(s.V, s.F)));
    CHECK(env.n_prisms() + env.n_skipped_degenerate() == s.F.size());
    for (std::size_t f = 0; f < s.F.size(); ++f) {
        const auto t = face_triangle(s, f);
        REQUIRE(env.contains(t[0], t[1], t[2]));
        REQUIRE(env.contains_exact(t[0], t[1], t[2]));
    }
    for (const vec3& p : s.V) CHECK(env.contains(p));
}

TEST_CASE("envelope: a triangle moved off the surface by 2 eps is refused, by 0.5 eps accepted") {
    const soup s = load_soup("bunny.off");
    const auto env = envelope::relative(s.V, s.F, 1e-3);
    const double eps = env.eps();
    const triangle_aabb_tree tree(s.V, s.F);
    std::mt19937 rng(42);
    int refused_checked = 0;
    for (int i = 0; i < 300; ++i) {
        const std::size_t f = std::uniform_int_distribution<std::size_t>(0, s.F.size() - 1)(rng);
        const auto t = face_triangle(s, f);
        for (double sign : {1.0, -1.0}) {
            // Inside the face's own prism (half-thickness eps/sqrt(3) > 0.5 eps).
            const auto in = moved(t, sign * 0.5 * eps);
            CHECK(env.contains(in[0], in[1], in[2]));
            CHECK(env.contains_exact(in[0], in[1], in[2]));
            // At 2 eps the triangle leaves the envelope wherever some point of it is more
            // than eps from the surface (not so where the surface folds back nearby).
            const auto out = moved(t, sign * 2 * eps);
            const double far = max_sampled_distance({out[0], out[1], out[2]}, {{0, 1, 2}}, tree, 4);
            if (far > eps * (1 + 1e-9)) {
                CHECK_FALSE(env.contains(out[0], out[1], out[2]));
                CHECK_FALSE(env.contains_exact(out[0], out[1], out[2]));
                ++refused_checked;
            }
            // Whatever is accepted is within eps, by the independent check.
            if (env.contains(out[0], out[1], out[2])) CHECK(far <= eps);
        }
    }
    CHECK(refused_checked > 500); // nearly every case is a clean one
}

TEST_CASE("envelope: disabled by default, bad input refused") {
    const envelope off;
    CHECK_FALSE(off.enabled());
    CHECK(off.contains({1e9, 0, 0}, {0, 1e9, 0}, {0, 0, 1e9}));
    const soup s = load_soup("bunny.off");
    CHECK_THROWS_AS(envelope(s.V, s.F, 0.0), input_error);
    CHECK_THROWS_AS(envelope(s.V, s.F, -1.0), input_error);
    CHECK_THROWS_AS(envelope(s.V, {{0, 1, 100000}}, 1.0), input_error);

    // Degenerate input triangles are skipped, not turned into NaN prisms.
    const std::vector<vec3> V = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}};
    const envelope e(V, {{0, 1, 2}, {0, 1, 3}}, 0.01);
    CHECK(e.n_prisms() == 1);
    CHECK(e.n_skipped_degenerate() == 1);
    CHECK(e.contains({0.1, 0.1, 0.005}));
    CHECK_FALSE(e.contains({0.1, 0.1, 0.02}));
    // Collinear and point-like query triangles are tested as segments and points.
    CHECK(e.contains({0.1, 0.1, 0}, {0.2, 0.2, 0}, {0.3, 0.3, 0}));
    CHECK(e.contains({0.1, 0.1, 0}, {0.1, 0.1, 0}, {0.1, 0.1, 0}));
    CHECK_FALSE(e.contains({0.1, 0.1, 0}, {0.2, 0.2, 0}, {3, 3, 0}));
}

TEST_CASE("envelope: an operation leaving the envelope is refused and rolled back") {
    auto m = test::load("bunny.off");
    const auto env = envelope_from(m);
    const double eps = env.eps();
    const auto pristine = test::load("bunny.off");

    push_along_normal far{env, 10 * eps};
    push_along_normal near{env, 0.2 * eps};
    push_along_normal unchecked{envelope{}, 10 * eps};
    int accepted = 0, refused = 0;
    std::mt19937 rng(9);
    auto vertices = m.get_vertices();
    std::shuffle(vertices.begin(), vertices.end(), rng);
    for (std::size_t i = 0; i < 50; ++i) {
        const auto t = m.tuple_from_vertex(vertices[i].vid);
        const vec3 before = m.position(t.vid);
        // Far: refused, and the mesh is bit-for-bit what it was.
        CHECK_FALSE(smooth_vertex(m, t, far));
        CHECK(m.position(t.vid) == before);
        // Near: accepted, the vertex moved.
        const auto r = smooth_vertex(m, t, near);
        CHECK(r);
        if (r) {
            ++accepted;
            CHECK(norm(m.position(t.vid) - before) == doctest::Approx(0.2 * eps));
            // Put it back so the mesh returns to the input exactly.
            m.positions().raw(t.vid) = before;
        } else {
            ++refused;
        }
    }
    CHECK(accepted == 50);
    CHECK(refused == 0);

    // The refused operations left no trace: only the accepted ones (undone by hand)
    // touched the mesh, and those bumped face versions; compare with a mesh that saw
    // only accepted operations.
    auto expected = test::load("bunny.off");
    for (std::size_t i = 0; i < 50; ++i) {
        const auto t = expected.tuple_from_vertex(vertices[i].vid);
        const vec3 before = expected.position(t.vid);
        REQUIRE(smooth_vertex(expected, t, near));
        expected.positions().raw(t.vid) = before;
    }
    CHECK(identical(m, expected));

    // A refused operation on a fresh mesh leaves it identical to the input.
    auto fresh = test::load("bunny.off");
    CHECK_FALSE(smooth_vertex(fresh, fresh.tuple_from_vertex(vertices[0].vid), far));
    CHECK(identical(fresh, pristine));
    // Without the envelope the same far move goes through.
    CHECK(smooth_vertex(fresh, fresh.tuple_from_vertex(vertices[0].vid), unchecked));
    CHECK_FALSE(identical(fresh, pristine));
}

TEST_CASE("envelope: the filter never contradicts CGAL") {
    // Remeshing-like triangles: chords of the surface (corners projected onto it) of
    // several sizes, some corners pushed off the surface, so that every verdict occurs.
    const soup s = load_soup("bunny.off");
    const auto env = envelope::relative(s.V, s.F, 1e-3);
    const double eps = env.eps();
    const triangle_aabb_tree tree(s.V, s.F);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0, 1);
    int count[3] = {0, 0, 0}, inside = 0;
    for (int i = 0; i < 600; ++i) {
        const auto t =
            face_triangle(s, std::uniform_int_distribution<std::size_t>(0, s.F.size() - 1)(rng));
        const vec3 n = unit_normal(t[0], t[1], t[2]);
        const vec3 e1 = (t[1] - t[0]) / norm(t[1] - t[0]), e2 = cross(n, e1);
        const vec3 center = (t[0] + t[1] + t[2]) / 3.0;
        const double size = eps * (1 + 19 * u(rng)), jitter = i % 3 == 0 ? eps * u(rng) : 0.0;
        const double phi = 6.283185307179586 * u(rng);
        triangle q;
        for (int k = 0; k < 3; ++k) {
            const double a = phi + k * 2.0943951023931953;
            const vec3 p = center + (e1 * std::cos(a) + e2 * std::sin(a)) * size;
            q[k] = tree.closest_point(p).point +
                   vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * (2 * jitter);
        }
        const bool exact = env.contains_exact(q[0], q[1], q[2]);
        const auto v = env.fast_verdict(q[0], q[1], q[2]);
        ++count[int(v)], inside += exact;
        if (v != envelope::verdict::unknown) REQUIRE((v == envelope::verdict::inside) == exact);
        REQUIRE(env.contains(q[0], q[1], q[2]) == exact);
    }
    // Both proofs are exercised, and most triangles are decided by the filter.
    CHECK(count[int(envelope::verdict::inside)] > 100);
    CHECK(count[int(envelope::verdict::outside)] > 50);
    CHECK(count[int(envelope::verdict::unknown)] < 150);
    CHECK(inside > 100);
    CHECK(inside < 550);
}

namespace {

/// Random triangles near surface s: chords of 0.3-15 eps (corners projected onto the
/// surface, or the input's own corners), their corners then moved along the normal by up to
/// eps, so that many lie near the envelope's boundary, on both sides.
std::vector<triangle> near_surface_triangles(const soup& s, double eps, int count, unsigned seed) {
    const triangle_aabb_tree tree(s.V, s.F);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<triangle> out;
    while (int(out.size()) < count) {
        const auto t =
            face_triangle(s, std::uniform_int_distribution<std::size_t>(0, s.F.size() - 1)(rng));
        const vec3 n = unit_normal(t[0], t[1], t[2]);
        const vec3 e1 = (t[1] - t[0]) / norm(t[1] - t[0]), e2 = cross(n, e1);
        const vec3 center = (t[0] + t[1] + t[2]) / 3.0;
        const double size = eps * (0.3 + 14.7 * u(rng) * u(rng));
        const double lift = out.size() % 4 == 0 ? 0.0 : eps * u(rng);
        const double phi = 6.283185307179586 * u(rng);
        triangle q;
        for (int k = 0; k < 3; ++k) {
            const double a = phi + k * 2.0943951023931953 + 0.5 * (u(rng) - 0.5);
            const vec3 p = center + (e1 * std::cos(a) + e2 * std::sin(a)) * size;
            const auto r = tree.closest_point(p);
            const auto f = face_triangle(s, r.face);
            q[k] = (out.size() % 8 == 1 ? f[k] : r.point) +
                   unit_normal(f[0], f[1], f[2]) * (lift * (u(rng) * 2 - 1));
        }
        out.push_back(q);
    }
    return out;
}

/// An open, folded surface: a height field z = h(x, y) on a grid with sharp creases (a
/// zigzag in x), a saddle and a step, so that projections fold and edges are on the
/// boundary.
soup folded_sheet(int n) {
    soup s;
    auto h = [](double x, double y) {
        const double zig = std::abs(std::fmod(x * 3 + 10, 2.0) - 1.0) * 0.4; // creases
        return zig + 0.3 * (x * x - y * y) + (y > 0.5 ? 0.15 : 0.0);
    };
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const double x = -1 + 2.0 * i / n, y = -1 + 2.0 * j / n;
            s.V.push_back({x, y, h(x, y)});
        }
    auto id = [&](int i, int j) { return index_t(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            s.F.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            s.F.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    return s;
}

} // namespace

TEST_CASE("envelope: the covering test only accepts triangles CGAL accepts") {
    // Every triangle the covering test accepts must be inside by CGAL's exact test; most
    // inside triangles are accepted, and the filter as a whole agrees with CGAL.
    struct input {
        const char* name;
        soup s;
        int count;
    };
    input inputs[] = {{"bunny", load_soup("bunny.off"), 1500},
                      {"folded sheet", folded_sheet(40), 1000}};
    for (auto& [name, s, count] : inputs) {
        CAPTURE(name);
        const auto env = envelope::relative(s.V, s.F, 1e-3);
        const auto Q = near_surface_triangles(s, env.eps(), count, 11);
        int covered = 0, inside = 0, missed = 0;
        envelope::filter_cache cache; // shared, as the invariant hook does
        for (const auto& q : Q) {
            const bool exact = env.contains_exact(q[0], q[1], q[2]);
            const bool c = env.covers(q[0], q[1], q[2]);
            inside += exact, covered += c, missed += exact && !c;
            REQUIRE((!c || exact));
            REQUIRE(env.contains(q[0], q[1], q[2], cache) == exact);
        }
        CHECK(covered > inside / 2);
        CHECK(missed > 0); // the test reaches the envelope's boundary
        CHECK(inside < int(Q.size()));
    }
}

TEST_CASE("envelope: the filter stays exact next to needle triangles") {
    // A strip of triangles in z = 0 with one needle (height 1e-9 of its length) in it:
    // its prism's normal is rounded, so the filter must defer to CGAL near it.
    std::vector<vec3> V = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0},     {0, 1, 0},
                           {1, 1, 0}, {2, 1, 0}, {3, 1, 0}, {1.5, 1e-9, 0}};
    std::vector<tri_indices> F = {{0, 1, 5}, {0, 5, 4}, {1, 8, 5}, {8, 2, 6},
                                  {8, 6, 5}, {1, 2, 8}, {2, 3, 7}, {2, 7, 6}};
    const envelope env(V, F, 0.05);
    REQUIRE(env.n_prisms() == 8);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> x(-0.2, 3.2), y(-0.2, 1.2), z(-0.1, 0.1), r(0.02, 0.5);
    int decided = 0;
    for (int i = 0; i < 400; ++i) {
        const vec3 c{x(rng), y(rng), z(rng)};
        const double size = r(rng);
        const triangle q = {c, c + vec3{size, 0, z(rng) * 0.3}, c + vec3{0, size, z(rng) * 0.3}};
        const bool exact = env.contains_exact(q[0], q[1], q[2]);
        const auto v = env.fast_verdict(q[0], q[1], q[2]);
        if (v != envelope::verdict::unknown) {
            ++decided;
            REQUIRE((v == envelope::verdict::inside) == exact);
        }
        REQUIRE(env.contains(q[0], q[1], q[2]) == exact);
        // Never an outside verdict from the filter when the triangle's box meets the
        // needle's (grown by eps).
        const bool near_needle = std::max({q[0].x, q[1].x, q[2].x}) > 1 - 0.049 &&
                                 std::min({q[0].x, q[1].x, q[2].x}) < 2 + 0.049 &&
                                 std::min({q[0].y, q[1].y, q[2].y}) < 0.049 &&
                                 std::max({q[0].y, q[1].y, q[2].y}) > -0.049 &&
                                 std::min({q[0].z, q[1].z, q[2].z}) < 0.049 &&
                                 std::max({q[0].z, q[1].z, q[2].z}) > -0.049;
        if (near_needle) CHECK(v != envelope::verdict::outside);
    }
    CHECK(decided > 100);
}

namespace {

// Query triangles of every kind: input triangles, triangles moved by various fractions of
// eps (some exactly onto the prism's top: the CGAL filter fails there and exact
// evaluation runs, computing shared lazy values), triangles spanning distant faces, and
// collinear ones; with CGAL's serial answers on a fresh envelope.
struct concurrency_case {
    soup s;
    double rel = 1e-3;
    std::vector<triangle> Q;
    std::vector<char> serial;
};

const concurrency_case& concurrency_data() {
    static const concurrency_case c = [] {
        concurrency_case c;
        c.s = load_soup("bunny.off");
        const soup& s = c.s;
        const double eps = c.rel * envelope::bounding_diagonal(s.V, s.F);
        std::mt19937 rng(17);
        std::uniform_real_distribution<double> u(0, 1);
        for (int i = 0; i < 1200; ++i) {
            const std::size_t f =
                std::uniform_int_distribution<std::size_t>(0, s.F.size() - 1)(rng);
            const auto t = face_triangle(s, f);
            switch (i % 6) {
            case 0:
                c.Q.push_back(t);
                break;
            case 1:
                c.Q.push_back(moved(t, (u(rng) * 3 - 1.5) * eps));
                break;
            case 2:
                c.Q.push_back(moved(t, eps / std::sqrt(3.0)));
                break;
            case 3: {
                const std::size_t g =
                    std::uniform_int_distribution<std::size_t>(0, s.F.size() - 1)(rng);
                const auto t2 = face_triangle(s, g);
                c.Q.push_back({t[0], t2[1], t2[2]});
                break;
            }
            case 4:
                c.Q.push_back({t[0], t[1], t[0] + (t[1] - t[0]) * 2.0});
                break;
            default:
                c.Q.push_back({t[0],
                               (t[0] + t[1]) * 0.5 + unit_normal(t[0], t[1], t[2]) * (0.3 * eps),
                               t[2]});
                break;
            }
        }
        const auto env = envelope::relative(s.V, s.F, c.rel);
        for (const auto& q : c.Q) c.serial.push_back(env.contains_exact(q[0], q[1], q[2]));
        return c;
    }();
    return c;
}

} // namespace

TEST_CASE("envelope: CGAL's structure is built on the first question the filter leaves open") {
    // The soup simplification asks the filter alone: its envelope never needs CGAL's.
    const soup s = load_soup("bunny.off");
    const auto env = envelope::relative(s.V, s.F, 1e-3);
    const envelope copy = env;
    for (std::size_t f = 0; f < s.F.size(); f += 7) {
        const triangle t = face_triangle(s, f);
        REQUIRE(env.fast_verdict(t[0], t[1], t[2]) == envelope::verdict::inside);
    }
    CHECK_FALSE(env.exact_built());
    // Far outside: the filter proves it without CGAL too.
    const triangle far = moved(face_triangle(s, 0), 100 * env.eps());
    CHECK_FALSE(env.contains(far[0], far[1], far[2]));
    CHECK_FALSE(env.exact_built());
    // An exact question builds it, once, for every copy.
    const triangle t = face_triangle(s, 3);
    CHECK(copy.contains_exact(t[0], t[1], t[2]));
    CHECK(env.exact_built());
    CHECK(env.cgal() == copy.cgal());
    CHECK_FALSE(env.contains_exact(far[0], far[1], far[2]));
    // Or ahead of time, for parallel users.
    const auto ahead = envelope::relative(s.V, s.F, 1e-3);
    CHECK_FALSE(ahead.exact_built());
    ahead.prepare_exact();
    CHECK(ahead.exact_built());
}

TEST_CASE("envelope: concurrent checks on one envelope agree with a serial pass") {
    const auto& [s, rel, Q, serial] = concurrency_data();
    std::size_t inside = 0;
    for (char c : serial) inside += c;
    CHECK(inside > Q.size() / 4);
    CHECK(inside < Q.size() * 3 / 4 + Q.size() / 8);

    // Each parallel pass uses a fresh envelope, so it starts with no exact value computed
    // yet, and CGAL's structure is built by whichever thread asks first while the others
    // wait for it. contains_exact runs CGAL on every triangle; contains the filter first.
    auto run_parallel = [&](bool same_set) {
        const auto env = envelope::relative(s.V, s.F, rel);
        const envelope copy = env; // copies share the CGAL structure
        constexpr unsigned threads = 4;
        // Per thread: CGAL's answers, then the filtered ones.
        std::vector<std::vector<char>> exact(threads, std::vector<char>(Q.size(), 2)),
            filtered = exact;
        std::vector<std::thread> pool;
        for (unsigned w = 0; w < threads; ++w)
            pool.emplace_back([&, w] {
                const envelope& e = w % 2 ? copy : env;
                for (std::size_t i = 0; i < Q.size(); ++i)
                    if (same_set || i % threads == w) {
                        exact[w][i] = e.contains_exact(Q[i][0], Q[i][1], Q[i][2]);
                        filtered[w][i] = e.contains(Q[i][0], Q[i][1], Q[i][2]);
                    }
            });
        for (auto& th : pool) th.join();
        for (std::size_t i = 0; i < Q.size(); ++i)
            for (unsigned w = 0; w < threads; ++w)
                if (same_set || i % threads == w) {
                    REQUIRE(exact[w][i] == serial[i]);
                    REQUIRE(filtered[w][i] == serial[i]);
                }
    };
    SUBCASE("each thread its own triangles") {
        run_parallel(false);
    }
    SUBCASE("every thread all triangles") {
        run_parallel(true);
    }

    // The invariant hook itself, from several threads on disjoint regions of one mesh.
    SUBCASE("invariant after() from several threads") {
        auto m = test::load("bunny.off");
        const auto env = envelope_from(m, rel);
        const double eps = env.eps();
        std::vector<tri_tuple> faces = m.get_faces();
        std::vector<char> ok(faces.size()), ok_serial(faces.size());
        // Move every 7th vertex off the surface so some faces are outside.
        for (index_t v = 0; v < m.vertex_slots(); v += 7) {
            vec3 n{};
            for (index_t f : m.vertex_faces(v)) n += face_normal_unnormalised(m, f);
            m.positions().raw(v) = m.position(v) + n / norm(n) * (v % 2 ? 2.0 : 0.3) * eps;
        }
        auto check = [&](std::size_t i) {
            envelope::state st;
            const std::span<const tri_tuple> cells(&faces[i], 1);
            return char(env.after(op::smooth_vertex{}, std::as_const(m),
                                  op_result<tri_tuple>{faces[i], cells, {}}, st));
        };
        std::vector<std::thread> pool;
        for (unsigned w = 0; w < 4; ++w)
            pool.emplace_back([&, w] {
                for (std::size_t i = w; i < faces.size(); i += 4) ok[i] = check(i);
            });
        for (auto& th : pool) th.join();
        for (std::size_t i = 0; i < faces.size(); ++i) ok_serial[i] = check(i);
        CHECK(ok == ok_serial);
        std::size_t bad = 0;
        for (char c : ok_serial) bad += !c;
        CHECK(bad > 0);
        CHECK(bad < faces.size());
    }
}

TEST_CASE("envelope: the filter decides queries around vertices where many triangles meet") {
    // A floor of 6 x 6 cells (two triangles each, one removed: a hole) and a wall along
    // its edge x = 0, sharing its vertices: queries of 20-100 eps in the floor's plane
    // around its vertices, where up to six triangles meet, and along the hole and the wall.
    // The filter must agree with CGAL and decide most of what CGAL finds inside (split to
    // 1/32 of the query, it left a quarter of them to CGAL).
    constexpr int n = 6;
    std::vector<vec3> V;
    std::vector<tri_indices> F;
    index_t floor[n + 1][n + 1], wall[n + 1][n + 1]; // [i][j]: x = i/n, y = j/n; [k][j]: z = k/n
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
            floor[i][j] = index_t(V.size());
            V.push_back({double(i) / n, double(j) / n, 0});
        }
    for (int k = 0; k <= n; ++k)
        for (int j = 0; j <= n; ++j) {
            wall[k][j] = k == 0 ? floor[0][j] : index_t(V.size());
            if (k > 0) V.push_back({0, double(j) / n, double(k) / n});
        }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            if (i != 2 || j != 3) F.push_back({floor[i][j], floor[i + 1][j], floor[i + 1][j + 1]});
            F.push_back({floor[i][j], floor[i + 1][j + 1], floor[i][j + 1]});
            F.push_back({wall[i][j], wall[i][j + 1], wall[i + 1][j + 1]});
            F.push_back({wall[i][j], wall[i + 1][j + 1], wall[i + 1][j]});
        }
    const auto env = envelope::relative(V, F, 1e-3);
    const double eps = env.eps();
    std::mt19937 rng(53);
    std::uniform_real_distribution<double> u(0, 1);
    std::uniform_int_distribution<int> vertex(0, n);
    int inside = 0, decided_inside = 0;
    for (int q = 0; q < 400; ++q) {
        const vec3 c = V[floor[vertex(rng)][vertex(rng)]];
        triangle t;
        const double size = eps * (20 + 80 * u(rng)), phi = 6.283185307179586 * u(rng);
        for (int k = 0; k < 3; ++k) {
            const double a = phi + k * 2.0943951023931953;
            t[k] = {std::clamp(c.x + size * std::cos(a), 0.0, 1.0),
                    std::clamp(c.y + size * std::sin(a), 0.0, 1.0), 0};
        }
        if (squared_norm(cross(t[1] - t[0], t[2] - t[0])) < 1e-6 * eps * eps * eps * eps) continue;
        const bool exact = env.contains_exact(t[0], t[1], t[2]);
        const auto v = env.fast_verdict(t[0], t[1], t[2]);
        if (v != envelope::verdict::unknown) REQUIRE((v == envelope::verdict::inside) == exact);
        inside += exact, decided_inside += v == envelope::verdict::inside;
    }
    CHECK(inside > 200);
    CHECK(decided_inside >= inside * 95 / 100);
}

TEST_CASE("envelope: the filter decides what the covering test leaves in parts") {
    // A sheet whose grid vertices lie up to 0.7 eps off its plane, and flat queries one to
    // six cells wide near the plane: over most cells a query is within the prisms' inner
    // radius (0.58 eps), over a few it is not, and there it may or may not leave the
    // envelope. The covering test proves the query over the good cells and leaves the
    // others in parts for the pieces, which must decide them as CGAL does (split whole, the
    // queries that leave the envelope only a little were left to CGAL: 74 of 1,000).
    constexpr int n = 40;
    const double eps = 1e-3;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<vec3> V;
    std::vector<tri_indices> F;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i)
            V.push_back({double(i) / n, double(j) / n, 0.7 * eps * (2 * u(rng) - 1)});
    auto id = [&](int i, int j) { return index_t(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            F.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            F.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    const envelope env(V, F, eps);
    verdict_tally tally;
    for (int q = 0; q < 1000; ++q) {
        const double cx = 0.2 + 0.6 * u(rng), cy = 0.2 + 0.6 * u(rng);
        const double size = (0.5 + 2.5 * u(rng)) / n, phi = 6.283185307179586 * u(rng);
        triangle t;
        for (int k = 0; k < 3; ++k) {
            const double a = phi + k * 2.0943951023931953;
            t[k] = {cx + size * std::cos(a), cy + size * std::sin(a), 0.2 * eps * (2 * u(rng) - 1)};
        }
        tally.add(env, t);
    }
    CHECK(tally.inside > 200);
    CHECK(tally.inside < 800);
    CHECK(tally.decided(envelope::verdict::inside) >= tally.inside * 98 / 100);
    CHECK(tally.decided(envelope::verdict::unknown) < 15);
}

TEST_CASE("envelope: queries along a fold and a border, where the covering test lists slivers") {
    // A floor z = 0 on [0, 1] x [0, 1], folded back under itself along x = 1 (a second
    // sheet from x = 1 to x = 0.4, sinking to z = -0.25), open along y = 0 and y = 1. Queries in
    // the floor's plane touch the fold's line or the border from the floor's side, or pass them by
    // up to 2 eps: across the fold the next triangle turns the other way along z, so the covering
    // test can only list the query's sliver beyond the line for the pieces. Every verdict must
    // agree with CGAL.
    constexpr int n = 10;
    std::vector<vec3> V;
    std::vector<tri_indices> F;
    auto row = [&](auto&& point) {
        const index_t first = index_t(V.size());
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) V.push_back(point(double(i) / n, double(j) / n));
        return first;
    };
    const index_t floor = row([](double s, double y) { return vec3{s, y, 0}; });
    const index_t under = row([](double s, double y) { return vec3{1 - 0.6 * s, y, -0.25 * s}; });
    // Both sheets in the order of their parameters: the fold turns the under sheet over, so
    // the surface is consistently oriented and the under sheet faces down.
    auto quads = [&](index_t first) {
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const index_t p = first + index_t(j * (n + 1) + i), q = p + 1;
                const index_t r = p + index_t(n + 1), w = r + 1;
                F.push_back({p, q, w});
                F.push_back({p, w, r});
            }
    };
    quads(floor);
    quads(under);
    // The fold's vertices are shared: the under sheet's first column is the floor's last.
    for (auto& f : F)
        for (index_t& v : f)
            if (v >= under && (v - under) % (n + 1) == 0) v = floor + (v - under) + index_t(n);
    const auto env = envelope::relative(V, F, 1e-3);
    const double eps = env.eps();
    std::mt19937 rng(59);
    std::uniform_real_distribution<double> u(0, 1);
    verdict_tally tally;
    for (int q = 0; q < 600; ++q) {
        // Two corners on (or past) the fold's line x = 1 or the border y = 0, one inside.
        const bool fold = q % 2 == 0;
        const double past = q % 3 == 0 ? 2 * eps * u(rng) : 0.0, len = 0.05 + 0.25 * u(rng);
        const double along = 0.2 + 0.5 * u(rng), depth = 0.02 + 0.2 * u(rng);
        triangle t;
        if (fold)
            t = {vec3{1 + past, along, 0}, vec3{1 - depth, along + len / 2, 0},
                 vec3{1 + past * u(rng), along + len, 0}};
        else
            t = {vec3{along, -past, 0}, vec3{along + len, -past * u(rng), 0},
                 vec3{along + len / 2, depth, 0}};
        tally.add(env, t);
    }
    CHECK(tally.inside > 100);
    CHECK(tally.inside < 550);
    CHECK(tally.decided(envelope::verdict::inside) >= tally.inside * 9 / 10);
    CHECK(tally.decided(envelope::verdict::outside) > 20);
}

#endif // IDAS_HAS_CGAL
