// Operations of the tetrahedral core: each one on hand-built configurations, the link
// condition and boundary policy, and long randomized sequences of every operation with
// forced rollbacks compared bit for bit.
#include "tet_support.hpp"

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>

using namespace idas;
using idas::test::cube;
using idas::test::edge_ring_mesh;
using idas::test::tet_spec;

namespace {

template <class Mesh>
double volume(const Mesh& m) {
    double v = 0;
    m.for_each_tet([&](const tet_tuple& t) {
        const auto& tv = m.tet_vertices(t.tid);
        const auto p = m.positions();
        v += dot(p[tv[1]] - p[tv[0]], cross(p[tv[2]] - p[tv[0]], p[tv[3]] - p[tv[0]])) / 6;
    });
    return v;
}

template <class Mesh>
double min_quality(const Mesh& m, std::span<const tet_tuple> cells) {
    double q = std::numeric_limits<double>::infinity();
    for (const auto& c : cells) q = std::min(q, tet_quality(m, m.tet_vertices(c.tid)));
    return q;
}

/// Two tets on the face (0, 1, 2), apexes 3 above and 4 below; `offset` moves the apexes
/// sideways so the segment 34 can miss the triangle.
template <class Mesh>
Mesh bipyramid(double offset = 0) {
    std::vector<vec3> V = {
        {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3 + offset, 0.3, 1}, {0.3 + offset, 0.3, -1}};
    std::vector<tet_indices> T = {{0, 1, 2, 3}, {0, 2, 1, 4}};
    for (auto& t : T) idas::test::orient_positively(V, t);
    return {V, T};
}

/// Best min-quality over all triangulations of the ring polygon of edge ab, by brute
/// force: the reference for edge_removal's dynamic programme.
template <class Mesh>
double brute_force_best(const Mesh& m, index_t a, index_t b, const std::vector<index_t>& ring) {
    const std::size_t n = ring.size();
    const auto p = m.positions();
    auto chord_ok = [&](std::size_t i, std::size_t k) {
        return k == i + 1 || (i == 0 && k == n - 1) || !m.find_edge(ring[i], ring[k]);
    };
    auto tri = [&](std::size_t i, std::size_t j, std::size_t k) {
        const index_t x = ring[i], y = ring[j], z = ring[k];
        if (orient3d(p[x], p[y], p[z], p[b]) <= 0 || orient3d(p[x], p[z], p[y], p[a]) <= 0)
            return -std::numeric_limits<double>::infinity();
        return std::min(tet_quality(p[x], p[y], p[z], p[b]), tet_quality(p[x], p[z], p[y], p[a]));
    };
    // Every triangulation of i..k: the triangle on chord (i, k) has apex j.
    std::function<double(std::size_t, std::size_t)> best = [&](std::size_t i, std::size_t k) {
        if (k - i < 2) return std::numeric_limits<double>::infinity();
        double top = -std::numeric_limits<double>::infinity();
        if (!chord_ok(i, k)) return top;
        for (std::size_t j = i + 1; j < k; ++j)
            top = std::max(top, std::min({best(i, j), best(j, k), tri(i, j, k)}));
        return top;
    };
    return best(0, n - 1);
}

/// The ring of edge ab in cyclic order (each (a, b, x_i, x_i+1) positive).
template <class Mesh>
std::vector<index_t> ordered_ring(const Mesh& m, index_t a, index_t b) {
    detail::edge_ring r;
    REQUIRE(detail::closed_edge_ring(m, a, b, r));
    return {r.verts.begin(), r.verts.end()};
}

} // namespace

TEST_CASE_TEMPLATE("tet ops: split and collapse back on a ring of n tets", Mesh, IDAS_TET_MESHES) {
    for (int n = 3; n <= 7; ++n) {
        CAPTURE(n);
        auto m = edge_ring_mesh<Mesh>(n);
        tet_spec<> spec;
        spec.attach(m);
        const auto ab = m.find_edge(0, 1);
        REQUIRE(ab);
        const double v0 = volume(m);
        auto r = split_edge(m, *ab, spec);
        REQUIRE(r);
        CHECK(r->cells.size() == std::size_t(2 * n));
        CHECK(m.n_tets() == std::size_t(2 * n));
        CHECK(m.edge_vertices(r->anchor) == std::pair<index_t, index_t>{index_t(n + 2), 0});
        CHECK_FALSE(m.is_boundary_vertex(r->anchor.vid)); // the new vertex is inside
        CHECK(m.position(r->anchor.vid) == vec3{0, 0, 0});
        CHECK_FALSE(find_inconsistency(m, true).has_value());
        CHECK(volume(m) == doctest::Approx(v0));
        for (std::size_t i = 0; i < r->cells.size(); ++i) CHECK(r->origins[i] < index_t(n));
        // The interior vertex may be collapsed away again, into a.
        auto back = collapse_edge(m, m.switch_vertex(r->anchor), spec);
        REQUIRE(back);
        CHECK(m.n_tets() == std::size_t(n));
        CHECK(m.n_vertices() == std::size_t(n + 2));
        CHECK_FALSE(find_inconsistency(m, true).has_value());
        CHECK(volume(m) == doctest::Approx(v0));
    }
}

TEST_CASE_TEMPLATE("tet ops: edge removal on rings of valence 3 to 7 matches brute force", Mesh,
                   IDAS_TET_MESHES) {
    for (int n = 3; n <= 7; ++n)
        for (double wobble : {0.0, 0.3}) {
            CAPTURE(n);
            CAPTURE(wobble);
            auto m = edge_ring_mesh<Mesh>(n, wobble);
            tet_spec<> spec;
            spec.attach(m);
            const auto ring = ordered_ring(m, 0, 1);
            const double expected = brute_force_best(m, 0, 1, ring);
            const double v0 = volume(m);
            // The swaps of fixed valence take only their own.
            auto copy = m;
            CHECK(bool(edge_swap_32(copy, *copy.find_edge(0, 1), spec)) == (n == 3));
            copy = m;
            CHECK(bool(edge_swap_44(copy, *copy.find_edge(0, 1), spec)) == (n == 4));
            const auto snapshot = m;
            auto r = edge_removal(m, *m.find_edge(0, 1), spec);
            REQUIRE(r);
            CHECK(r->cells.size() == std::size_t(2 * n - 4));
            CHECK(m.n_tets() == std::size_t(2 * n - 4));
            CHECK_FALSE(m.find_edge(0, 1));
            CHECK_FALSE(find_inconsistency(m, true).has_value());
            CHECK(volume(m) == doctest::Approx(v0));
            CHECK(min_quality(m, r->cells) == doctest::Approx(expected));
            CHECK(boundary_topology(m).euler_characteristic == 2);
            // The boundary faces did not change.
            auto bf0 = snapshot.boundary_faces(), bf1 = m.boundary_faces();
            for (auto* bf : {&bf0, &bf1}) {
                for (auto& f : *bf)
                    std::rotate(f.begin(), std::min_element(f.begin(), f.end()), f.end());
                std::sort(bf->begin(), bf->end());
            }
            CHECK(bf0 == bf1);
            // Boundary edges are never swapped.
            for (const auto& e : m.boundary_edges()) {
                auto c2 = m;
                CHECK_FALSE(edge_removal(c2, e, spec));
                CHECK_FALSE(edge_swap_32(c2, e, spec));
                CHECK_FALSE(edge_swap_44(c2, e, spec));
                CHECK(identical(c2, m));
            }
        }
}

TEST_CASE_TEMPLATE("tet ops: 4-4 swap picks the diagonal through the tuple's face", Mesh,
                   IDAS_TET_MESHES) {
    auto m = edge_ring_mesh<Mesh>(4);
    const auto ab = *m.find_edge(0, 1);
    for (int side = 0; side < 2; ++side) {
        auto c = m;
        const auto t = side ? c.switch_face(ab) : ab;
        const index_t x = c.face_vertices(t)[2];
        auto r = edge_swap_44(c, t);
        REQUIRE(r);
        CHECK(r->cells.size() == 4);
        CHECK(r->anchor.vid == x);
        const auto [p, q] = c.edge_vertices(r->anchor);
        CHECK(p == x);
        CHECK(q == x + 2 - (x >= 4 ? 4 : 0)); // the ring vertex opposite x
        CHECK_FALSE(c.find_edge(0, 1));
        CHECK_FALSE(find_inconsistency(c, true).has_value());
        // And back: the new diagonal has valence 4 too.
        REQUIRE(edge_swap_44(c, *c.find_edge(p, q)));
        CHECK(c.find_edge(0, 1).has_value());
        CHECK_FALSE(find_inconsistency(c, true).has_value());
    }
}

TEST_CASE_TEMPLATE("tet ops: 2-3 and 3-2 swaps undo each other and non-convex ones are refused",
                   Mesh, IDAS_TET_MESHES) {
    auto m = bipyramid<Mesh>();
    tet_spec<> spec;
    spec.attach(m);
    const auto f = m.find_face(0, 1, 2);
    REQUIRE(f);
    REQUIRE_FALSE(m.is_boundary_face(*f));
    const double v0 = volume(m);
    auto r = face_swap_23(m, *f, spec);
    REQUIRE(r);
    CHECK(r->cells.size() == 3);
    CHECK(m.n_tets() == 3);
    const auto [d, e] = m.edge_vertices(r->anchor);
    CHECK(std::min(d, e) == 3);
    CHECK(std::max(d, e) == 4);
    CHECK_FALSE(m.find_face(0, 1, 2));
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    CHECK(volume(m) == doctest::Approx(v0));
    // Boundary faces are never swapped, and the new edge now exists.
    for (const auto& g : m.get_faces())
        if (m.is_boundary_face(g)) CHECK_FALSE(face_swap_23(m, g, spec));
    auto back = edge_swap_32(m, r->anchor, spec);
    REQUIRE(back);
    CHECK(back->cells.size() == 2);
    CHECK(m.n_tets() == 2);
    CHECK(m.find_face(0, 1, 2).has_value());
    CHECK_FALSE(m.find_edge(3, 4));
    CHECK_FALSE(find_inconsistency(m, true).has_value());

    // Apexes far to the side: segment 34 misses triangle 012, a new tet would invert.
    auto skew = bipyramid<Mesh>(2.0);
    tet_spec<> s2;
    s2.attach(skew);
    const auto before = skew;
    CHECK_FALSE(face_swap_23(skew, *skew.find_face(0, 1, 2), s2));
    CHECK(identical(before, skew));
    // Without the invariant the swap goes through and the checker sees the inversion.
    REQUIRE(face_swap_23(skew, *skew.find_face(0, 1, 2)));
    const auto problem = find_inconsistency(skew);
    REQUIRE(problem);
    CHECK(problem->find("inverted") != std::string::npos);
}

TEST_CASE_TEMPLATE("tet ops: edge removal refuses when no triangulation is valid or a chord exists",
                   Mesh, IDAS_TET_MESHES) {
    // A valence-4 ring whose polygon is reflex at x2 (seen from the a-b axis, which still
    // passes inside it): the diagonal x1-x3 would make the ear x1 x2 x3 invert, so only
    // the diagonal x0-x2 is possible.
    std::vector<vec3> V = {{0, 0, 1},    {0, 0, -1},   {1, 0, 0},
                           {-0.3, 1, 0}, {-0.2, 0, 0}, {-0.3, -1, 0}};
    std::vector<tet_indices> T;
    for (index_t i = 0; i < 4; ++i) {
        tet_indices t = {0, 1, index_t(2 + i), index_t(2 + (i + 1) % 4)};
        idas::test::orient_positively(V, t);
        T.push_back(t);
    }
    Mesh m(V, T);
    auto copy = m;
    auto r = edge_removal(m, *m.find_edge(0, 1));
    REQUIRE(r);
    CHECK(m.find_edge(2, 4).has_value());
    CHECK_FALSE(m.find_edge(3, 5));
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    // The 4-4 swap asked for the bad diagonal is refused by the orientation invariant.
    tet_spec<> spec;
    spec.attach(copy);
    const auto before = copy;
    auto ab = *copy.find_edge(0, 1);
    if (copy.face_vertices(ab)[2] != 3 && copy.face_vertices(ab)[2] != 5) ab = copy.switch_face(ab);
    REQUIRE((copy.face_vertices(ab)[2] == 3 || copy.face_vertices(ab)[2] == 5));
    CHECK_FALSE(edge_swap_44(copy, ab, spec));
    CHECK(identical(before, copy));

    // A square ring whose chord 2-4 already exists in another tet (2, 4, 6, 7): that tet
    // overlaps the ring geometrically, but the check is combinatorial, and creating the
    // edge again would pinch the mesh. The other diagonal must be taken.
    std::vector<vec3> W = V;
    W[4] = {-1, 0, 0};
    W.push_back({0, 0, 3});
    W.push_back({0, 0.2, 3});
    std::vector<tet_indices> U;
    for (index_t i = 0; i < 4; ++i) {
        tet_indices t = {0, 1, index_t(2 + i), index_t(2 + (i + 1) % 4)};
        idas::test::orient_positively(W, t);
        U.push_back(t);
    }
    tet_indices extra = {2, 4, 6, 7};
    idas::test::orient_positively(W, extra);
    U.push_back(extra);
    if constexpr (idas::test::refuses_pinched<Mesh>) {
        // Vertices 2 and 4 are pinched (the extra tet meets the ring only at them).
        CHECK_THROWS_WITH_AS(Mesh(W, U), doctest::Contains("vertex 2 is pinched"), input_error);
        return;
    }
    Mesh k(W, U);
    auto r2 = edge_removal(k, *k.find_edge(0, 1));
    REQUIRE(r2);
    CHECK(k.find_edge(3, 5).has_value()); // the free diagonal was taken
    CHECK_FALSE(find_inconsistency(k).has_value());
}

TEST_CASE_TEMPLATE("tet ops: the 3D link condition and the boundary policy", Mesh,
                   IDAS_TET_MESHES) {
    // A single tet: no collapse keeps a 3-manifold, even when the boundary may change.
    Mesh one({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 1, 2, 3}});
    for (const auto& e : one.get_edges()) {
        CHECK_FALSE(link_condition_3d_holds(one, e.vid, one.switch_vertex(e).vid));
        CHECK_FALSE(collapse_edge(one, e, tet_spec<true>{}));
    }
    // The ring: a and b are on the boundary but ab is interior, so ab may not collapse.
    auto ring = edge_ring_mesh<Mesh>(5);
    CHECK_FALSE(link_condition_3d_holds(ring, 0, 1));
    // Two tets sharing only vertex 0: that vertex is non-manifold and never collapses.
    std::vector<vec3> V = {{0, 0, 0},  {1, 0, 0},  {0, 1, 0}, {0, 0, 1},
                           {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    std::vector<tet_indices> T = {{0, 1, 2, 3}, {0, 4, 5, 6}};
    for (auto& t : T) idas::test::orient_positively(V, t);
    if constexpr (idas::test::refuses_pinched<Mesh>) {
        CHECK_THROWS_WITH_AS(Mesh(V, T), doctest::Contains("vertex 0 is pinched"), input_error);
    } else {
        Mesh bow(V, T);
        CHECK_FALSE(find_inconsistency(bow).has_value());
        CHECK_FALSE(boundary_topology(bow).editable()); // a pinched boundary
        for (const auto& e : bow.get_edges()) {
            const auto [a, b] = bow.edge_vertices(e);
            if (a == 0 || b == 0) CHECK_FALSE(link_condition_3d_holds(bow, a, b));
        }
    }

    // Cube: boundary vertices are not removed and not moved unless the spec allows it.
    auto m = cube<Mesh>(3, false, 0.1, 7);
    tet_spec<false> keep;
    keep.attach(m);
    int refused_boundary = 0, accepted_interior = 0;
    for (const auto& e : m.get_edges()) {
        if (!m.is_valid(e)) continue;
        const auto [a, b] = m.edge_vertices(e);
        const bool bb = m.is_boundary_vertex(b);
        const auto before = m;
        auto r = collapse_edge(m, e, keep);
        if (bb) {
            CHECK_FALSE(r);
            CHECK(identical(before, m));
            ++refused_boundary;
        } else if (r) {
            ++accepted_interior;
            CHECK_FALSE(find_inconsistency_near(m, r->cells).has_value());
        }
        (void)a;
    }
    CHECK(refused_boundary > 0);
    CHECK(accepted_interior > 0);
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    CHECK(volume(m) == doctest::Approx(1.0));
    for (index_t v : m.boundary_vertices())
        CHECK_FALSE(smooth_vertex(m, m.tuple_from_vertex(v), keep));

    auto w = cube<Mesh>(3, false, 0.1, 7);
    tet_spec<true> free_spec;
    free_spec.attach(w);
    int boundary_collapses = 0;
    for (const auto& e : w.get_edges()) {
        if (!w.is_valid(e)) continue;
        const bool bb = w.is_boundary_vertex(w.switch_vertex(e).vid);
        if (auto r = collapse_edge(w, e, free_spec)) {
            boundary_collapses += bb;
            CHECK_FALSE(find_inconsistency_near(w, r->cells).has_value());
        }
    }
    CHECK(boundary_collapses > 0);
    CHECK_FALSE(find_inconsistency(w, true).has_value());
    const auto topo = boundary_topology(w);
    CHECK(topo.euler_characteristic == 2);
    CHECK(topo.components == 1);
    CHECK(euler_characteristic(w) == 1);
}

namespace {

/// The 3D link condition by its definition, with sets: the closed links of a and b
/// (boundary faces coned to ω, found by counting the mesh's faces) must be 2-spheres
/// and meet in exactly lk(ab). The reference for link_condition_3d_holds.
using face_counts = std::map<std::array<index_t, 3>, int>;

/// How many tets hold each face (sorted corners): 1 on the boundary.
template <class Mesh>
face_counts count_face_tets(const Mesh& m) {
    face_counts face_tets;
    m.for_each_tet([&](const tet_tuple& t) {
        const auto& tv = m.tet_vertices(t.tid);
        for (int skip = 0; skip < 4; ++skip) {
            std::array<index_t, 3> f{};
            for (int k = 0, n = 0; k < 4; ++k)
                if (k != skip) f[n++] = tv[k];
            std::sort(f.begin(), f.end());
            ++face_tets[f];
        }
    });
    return face_tets;
}

template <class Mesh>
bool link_condition_by_definition(const Mesh& m, const face_counts& face_tets, index_t a,
                                  index_t b) {
    constexpr index_t omega = invalid_index - 1;
    using tri = std::array<index_t, 3>;
    auto sorted = [](tri f) { return std::sort(f.begin(), f.end()), f; };
    struct link {
        std::set<tri> tris;
        std::set<std::pair<index_t, index_t>> edges;
        std::set<index_t> verts;
    };
    auto closed_link = [&](index_t v, bool& sphere) {
        link l;
        m.for_each_tet([&](const tet_tuple& t) {
            const auto& tv = m.tet_vertices(t.tid);
            if (std::find(tv.begin(), tv.end(), v) == tv.end()) return;
            tri f{};
            for (int k = 0, j = 0; k < 4; ++k)
                if (tv[k] != v) f[j++] = tv[k];
            l.tris.insert(sorted(f));
        });
        for (const auto& [f, n] : face_tets) {
            if (n != 1 || std::find(f.begin(), f.end(), v) == f.end()) continue;
            tri g{};
            for (int k = 0, j = 0; k < 3; ++k)
                if (f[k] != v) g[j++] = f[k];
            g[2] = omega;
            l.tris.insert(sorted(g));
        }
        std::map<std::pair<index_t, index_t>, int> edge_tris;
        for (const auto& f : l.tris)
            for (int k = 0; k < 3; ++k)
                for (int j = k + 1; j < 3; ++j) ++edge_tris[{f[k], f[j]}];
        sphere = true;
        for (const auto& [e, n] : edge_tris) {
            sphere &= n == 2;
            l.edges.insert(e), l.verts.insert(e.first), l.verts.insert(e.second);
        }
        sphere &= long(l.verts.size()) - long(l.edges.size()) + long(l.tris.size()) == 2;
        return l;
    };
    bool sphere_a = false, sphere_b = false;
    const link la = closed_link(a, sphere_a), lb = closed_link(b, sphere_b);
    if (!sphere_a || !sphere_b) return false;
    link ab; // lk(ab): no triangles
    for (const auto& [f, n] : face_tets) {
        const bool has_a = std::find(f.begin(), f.end(), a) != f.end();
        const bool has_b = std::find(f.begin(), f.end(), b) != f.end();
        if (!has_a || !has_b) continue;
        index_t x = f[0] != a && f[0] != b ? f[0] : f[1] != a && f[1] != b ? f[1] : f[2];
        ab.verts.insert(x);
        if (n == 1) ab.verts.insert(omega), ab.edges.insert({x, omega});
    }
    m.for_each_tet([&](const tet_tuple& t) {
        const auto& tv = m.tet_vertices(t.tid);
        if (std::find(tv.begin(), tv.end(), a) == tv.end() ||
            std::find(tv.begin(), tv.end(), b) == tv.end())
            return;
        std::vector<index_t> xy;
        for (index_t x : tv)
            if (x != a && x != b) xy.push_back(x);
        ab.edges.insert({std::min(xy[0], xy[1]), std::max(xy[0], xy[1])});
    });
    auto meet = [](const auto& s, const auto& t) {
        std::decay_t<decltype(s)> out;
        std::set_intersection(s.begin(), s.end(), t.begin(), t.end(),
                              std::inserter(out, out.end()));
        return out;
    };
    return meet(la.verts, lb.verts) == ab.verts && meet(la.edges, lb.edges) == ab.edges &&
           meet(la.tris, lb.tris).empty();
}

} // namespace

TEST_CASE("tet ops: the link condition's key counts") {
    // Counts survive growth (64 slots at first) and a reset forgets them all.
    detail::key_counts counts;
    std::mt19937_64 rng(9);
    for (int round = 0; round < 3; ++round) {
        counts.reset();
        std::map<std::uint64_t, std::uint32_t> expected;
        const int keys = round == 1 ? 3000 : 40;
        for (int i = 0; i < 4 * keys; ++i) {
            const std::uint64_t key = rng() % std::uint64_t(keys) * 0x100000001ull;
            CHECK(counts.add(key) == ++expected[key]);
        }
        for (const auto& [key, n] : expected) CHECK(counts.count(key) == n);
        CHECK(counts.count(std::uint64_t(keys) * 0x100000001ull) == 0);
    }
    counts.reset();
    CHECK(counts.count(0) == 0);
}

TEST_CASE_TEMPLATE("tet ops: the link condition agrees with its definition through random "
                   "collapses",
                   Mesh, IDAS_TET_MESHES) {
    // Links that share a real triangle xyz while their vertex and edge counts match lk(ab)
    // need the 4-simplex's boundary around ab, which no positively oriented mesh holds (the
    // constructors refuse it): the triangle test is asked directly.
    {
        detail::link_buffers la, lb;
        la.tris = {{1, 2, 4}, {2, 3, 4}, {0, 2, 3}};
        lb.tris = {{2, 3, 5}, {2, 3, 4}};
        const std::vector<index_t> common = {2, 3, 4}, fewer = {2, 3};
        CHECK(detail::share_real_triangle(la, lb, common));
        CHECK_FALSE(detail::share_real_triangle(la, lb, fewer));
        lb.tris = {{2, 3, 5}, {1, 2, 4}}; // shared, but 4 is not a common vertex
        const std::vector<index_t> without_four = {1, 2, 3}, with_four = {1, 2, 4};
        CHECK_FALSE(detail::share_real_triangle(la, lb, without_four));
        CHECK(detail::share_real_triangle(la, lb, with_four));
    }
    // Collapses that change the boundary walk the mesh through open and closed links,
    // valence-3 rings and shared triangles; every ordered edge of every state is asked.
    for (unsigned seed : {3u, 4u}) {
        auto m = cube<Mesh>(3, seed == 4, 0.15, seed);
        tet_spec<true> spec;
        spec.attach(m);
        std::mt19937 rng(seed);
        int held = 0, refused = 0;
        for (int step = 0; step < 12 && m.n_tets() > 4; ++step) {
            auto edges = m.get_edges();
            const auto faces = count_face_tets(m);
            for (const auto& e : edges) {
                const auto [a, b] = m.edge_vertices(e);
                for (const auto& [x, y] : {std::pair{a, b}, std::pair{b, a}}) {
                    const bool fast = link_condition_3d_holds(m, x, y);
                    REQUIRE_MESSAGE(fast == link_condition_by_definition(m, faces, x, y),
                                    "edge " << x << "-" << y << " after " << step << " collapses");
                    (fast ? held : refused) += 1;
                }
            }
            std::shuffle(edges.begin(), edges.end(), rng);
            for (const auto& e : edges)
                if (m.is_valid(e) && collapse_edge(m, e, spec)) break;
        }
        CHECK(held > 0);
        CHECK(refused > 0);
    }
}

TEST_CASE_TEMPLATE("tet ops: edge removal around interior edges of valence 3 to 7 in a cube", Mesh,
                   IDAS_TET_MESHES) {
    // Random splits and 2-3 swaps make interior edges of many valences.
    auto m = cube<Mesh>(3, false, 0.1, 21);
    tet_spec<> spec;
    spec.attach(m);
    std::mt19937 rng(5);
    for (int i = 0; i < 400; ++i) {
        const index_t t = rng() % m.tet_slots();
        if (!m.tet_alive(t)) continue;
        const auto u = m.tuple_from_face(t, std::uint8_t(rng() % 4));
        if (i % 2)
            face_swap_23(m, u, spec);
        else
            split_edge(m, u, spec);
    }
    REQUIRE_FALSE(find_inconsistency(m, true).has_value());
    std::map<std::size_t, int> removed;
    for (int round = 0; round < 4; ++round)
        for (const auto& e : m.get_edges()) {
            if (!m.is_valid(e)) continue;
            const auto [a, b] = m.edge_vertices(e);
            if (m.is_boundary_vertex(a) || m.is_boundary_vertex(b)) continue;
            std::vector<index_t> around;
            m.edge_tets(e, around);
            const std::size_t n = around.size();
            if (n < 3 || n > 7 || removed[n] >= 3) continue;
            const auto ring = ordered_ring(m, a, b);
            if (n == 3 && m.find_face(ring[0], ring[1], ring[2])) continue;
            const double expected = brute_force_best(m, a, b, ring);
            const auto before = m;
            auto r = edge_removal(m, e, spec);
            if (!(expected > -std::numeric_limits<double>::infinity())) {
                CHECK_FALSE(r);
                CHECK(identical(before, m));
                continue;
            }
            REQUIRE(r);
            ++removed[n];
            CHECK(r->cells.size() == 2 * n - 4);
            CHECK(min_quality(m, r->cells) == doctest::Approx(expected));
            CHECK_FALSE(find_inconsistency_near(m, r->cells).has_value());
        }
    for (std::size_t n = 3; n <= 7; ++n) {
        CAPTURE(n);
        CHECK(removed[n] > 0);
    }
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    CHECK(volume(m) == doctest::Approx(1.0));
}

TEST_CASE_TEMPLATE("tet ops: a spec's tet_quality steers edge removal", Mesh, IDAS_TET_MESHES) {
    // A square ring: both diagonals are equally good by the default measure; a spec
    // that penalises tets holding both ends of one diagonal makes the DP take the other.
    struct avoid_chord {
        index_t x, y;
        double tet_quality(const Mesh& m, const tet_indices& t) const {
            return tet_local::contains(t, x) && tet_local::contains(t, y) ? 0.01
                                                                          : idas::tet_quality(m, t);
        }
    };
    auto m = edge_ring_mesh<Mesh>(4);
    REQUIRE(edge_removal(m, *m.find_edge(0, 1), avoid_chord{2, 4}));
    CHECK(m.find_edge(3, 5).has_value());
    CHECK_FALSE(m.find_edge(2, 4).has_value());
    auto k = edge_ring_mesh<Mesh>(4);
    REQUIRE(edge_removal(k, *k.find_edge(0, 1), avoid_chord{3, 5}));
    CHECK(k.find_edge(2, 4).has_value());
    CHECK_FALSE(k.find_edge(3, 5).has_value());
}

// ---------------------------------------------------------------------------------
// Randomized sequences
// ---------------------------------------------------------------------------------

namespace {

struct tet_sequence_stats {
    std::array<int, 7> accepted{}, refused{};
};

const char* op_name(int k) {
    static const char* names[] = {"split",        "collapse",     "smooth",      "face_swap_23",
                                  "edge_swap_32", "edge_swap_44", "edge_removal"};
    return names[k];
}

template <bool Allow, class Mesh>
tet_sequence_stats run_tet_sequence(Mesh m, unsigned seed, int n, int full_every, double fail_p,
                                    bool compare_rollback) {
    const long chi0 = euler_characteristic(m);
    const auto topo0 = boundary_topology(m);
    const double volume0 = volume(m);
    // The live-count deltas the operations report (for executors) match the real counts.
    const auto& ctx = thread_context<Mesh>();
    const std::int64_t tets0 = std::int64_t(m.n_tets()) - ctx.face_delta;
    const std::int64_t verts0 = std::int64_t(m.n_vertices()) - ctx.vertex_delta;
    std::mt19937 rng(seed);
    tet_spec<Allow> spec;
    spec.attach(m);
    spec.fail_probability = fail_p;
    spec.rng = &rng;
    tet_sequence_stats st;
    for (int i = 0; i < n; ++i) {
        const int kind = int(rng() % 7);
        // The fixed-valence swaps look a little for an edge they apply to.
        const std::size_t want = kind == 4 ? 3 : (kind == 5 ? 4 : 0);
        tet_tuple u;
        for (int attempt = 0; attempt < (want ? 30 : 1); ++attempt) {
            index_t t = rng() % m.tet_slots();
            while (!m.tet_alive(t)) t = rng() % m.tet_slots();
            u = m.tuple_from_edge(t, std::uint8_t(rng() % 6));
            if (rng() % 2) u = m.switch_vertex(u);
            if (rng() % 2) u = m.switch_face(u);
            std::vector<index_t> around;
            if (want) m.edge_tets(u, around);
            if (around.size() == want) break;
        }
        std::optional<Mesh> copy;
        if (compare_rollback) copy = m;
        std::optional<op_result<tet_tuple>> r;
        switch (kind) {
        case 0:
            r = split_edge(m, u, spec);
            break;
        case 1:
            r = collapse_edge(m, u, spec);
            break;
        case 2:
            r = smooth_vertex(m, u, spec);
            break;
        case 3:
            r = face_swap_23(m, u, spec);
            break;
        case 4:
            r = edge_swap_32(m, u, spec);
            break;
        case 5:
            r = edge_swap_44(m, u, spec);
            break;
        default:
            r = edge_removal(m, u, spec);
            break;
        }
        if (r) {
            ++st.accepted[kind];
            REQUIRE(r->cells.size() == r->origins.size());
            const auto e = find_inconsistency_near(m, r->cells);
            REQUIRE_MESSAGE(!e, "after op " << i << " " << op_name(kind) << ": " << *e);
        } else {
            ++st.refused[kind];
            if (copy)
                REQUIRE_MESSAGE(identical(*copy, m),
                                "op " << i << " " << op_name(kind) << " did not roll back exactly");
        }
        if ((i + 1) % full_every == 0 || i + 1 == n) {
            const auto e = find_inconsistency(m, true);
            REQUIRE_MESSAGE(!e, "after op " << i << ": " << *e);
            REQUIRE(euler_characteristic(m) == chi0);
            REQUIRE(std::int64_t(m.n_tets()) == tets0 + ctx.face_delta);
            REQUIRE(std::int64_t(m.n_vertices()) == verts0 + ctx.vertex_delta);
            const auto topo = boundary_topology(m);
            REQUIRE(topo.euler_characteristic == topo0.euler_characteristic);
            REQUIRE(topo.components == topo0.components);
            REQUIRE(topo.closed());
            if (!Allow) REQUIRE(volume(m) == doctest::Approx(volume0).epsilon(1e-9));
        }
    }
    return st;
}

void check_every_kind(const tet_sequence_stats& st, bool expect_all) {
    for (int k = 0; k < 7; ++k) {
        INFO(std::string(op_name(k))
             << ": " << st.accepted[k] << " accepted, " << st.refused[k] << " refused");
        if (std::getenv("IDAS_TET_STATS"))
            MESSAGE(std::string(op_name(k))
                    << ": " << st.accepted[k] << " accepted, " << st.refused[k] << " refused");
        if (expect_all) CHECK(st.accepted[k] > 0);
    }
}

} // namespace

TEST_CASE_TEMPLATE("tet ops: random sequences keep a 6-tet cube valid (boundary fixed)", Mesh,
                   IDAS_TET_MESHES) {
    const auto st =
        run_tet_sequence<false>(cube<Mesh>(4, false, 0.15, 11), 1, 6000, 500, 0.0, false);
    check_every_kind(st, true);
}

TEST_CASE_TEMPLATE("tet ops: random sequences keep a 5-tet cube valid (boundary may change)", Mesh,
                   IDAS_TET_MESHES) {
    const auto st = run_tet_sequence<true>(cube<Mesh>(4, true, 0.15, 12), 2, 6000, 500, 0.0, false);
    check_every_kind(st, true);
}

TEST_CASE_TEMPLATE("tet ops: forced failures roll back bit for bit", Mesh, IDAS_TET_MESHES) {
    const auto st =
        run_tet_sequence<false>(cube<Mesh>(3, false, 0.15, 13), 3, 1500, 250, 0.5, true);
    check_every_kind(st, true);
    const auto st2 = run_tet_sequence<true>(cube<Mesh>(3, true, 0.15, 14), 4, 1500, 250, 0.5, true);
    check_every_kind(st2, false);
}

TEST_CASE_TEMPLATE("tet ops: stale tuples are detected after random edits", Mesh, IDAS_TET_MESHES) {
    auto m = cube<Mesh>(3, false, 0.1, 15);
    tet_spec<true> spec;
    spec.attach(m);
    std::mt19937 rng(7);
    const auto all = m.get_edges();
    // (Not many more edits: the backends see different random sequences, and after ~300
    // nearly every tet has been touched.)
    for (int i = 0; i < 150; ++i) {
        index_t t = rng() % m.tet_slots();
        if (!m.tet_alive(t)) continue;
        const auto u = m.tuple_from_edge(t, std::uint8_t(rng() % 6));
        if (i % 3 == 0)
            split_edge(m, u, spec);
        else if (i % 3 == 1)
            collapse_edge(m, u, spec);
        else
            edge_removal(m, u, spec);
    }
    int stale = 0;
    for (const auto& t : all) {
        if (!m.is_valid(t)) {
            ++stale;
            continue;
        }
        // A tuple still valid names a tet untouched since: its vertices still match.
        CHECK(m.tet_alive(t.tid));
        CHECK(tet_local::contains(m.tet_vertices(t.tid), t.vid));
    }
    CHECK(stale > 100);
    CHECK(stale < int(all.size()));
}
