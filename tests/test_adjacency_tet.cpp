// What only the adjacency tet backend has: stored face links and vertex anchors. Its
// links are checked against a search (indexed_tet built from the same tets) through
// random edits, gluing tets onto an existing boundary (settle), pinched input, and the
// harmonic-triangulation algorithm run on it against the indexed backend.
#include "tet_support.hpp"

#if defined(IDAS_HAS_CGAL)
#include "harmonic_support.hpp"

#include <idas/io/points.hpp>
#endif

#include <algorithm>
#include <random>
#include <vector>

using namespace idas;
using adjacency_mesh = tet_mesh<backend::adjacency_tet>;

using test::mismatches_against_search;

TEST_CASE("adjacency tet: links and stars match a search through random edits") {
    auto m = test::cube<adjacency_mesh>(4, true, 0.15, 31);
    REQUIRE(mismatches_against_search(m) == 0);
    test::tet_spec<true> spec; // the boundary may change too
    spec.attach(m);
    std::mt19937 rng(17);
    int accepted = 0;
    for (int i = 0; i < 3000; ++i) {
        index_t t = rng() % m.tet_slots();
        while (!m.tet_alive(t)) t = rng() % m.tet_slots();
        auto u = m.tuple_from_edge(t, std::uint8_t(rng() % 6));
        if (rng() % 2) u = m.switch_face(u);
        bool ok = false;
        switch (rng() % 6) {
        case 0:
            ok = bool(split_edge(m, u, spec));
            break;
        case 1:
            ok = bool(collapse_edge(m, u, spec));
            break;
        case 2:
            ok = bool(face_swap_23(m, u, spec));
            break;
        case 3:
            ok = bool(edge_swap_32(m, u, spec));
            break;
        case 4:
            ok = bool(edge_swap_44(m, u, spec));
            break;
        default:
            ok = bool(edge_removal(m, u, spec));
            break;
        }
        accepted += ok;
        if (i % 300 == 299) {
            CAPTURE(i);
            REQUIRE(mismatches_against_search(m) == 0);
        }
    }
    CHECK(accepted > 300);
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    m.consolidate();
    CHECK(mismatches_against_search(m) == 0);
}

TEST_CASE("adjacency tet: a tet glued back onto the boundary links up in settle") {
    const auto [V, T] = test::cube_arrays(2, false, 0.1, 5);
    backend::adjacency_tet b;
    b.build(index_t(V.size()), T);
    const auto original = b;
    // An interior tet: all four faces linked.
    index_t t = 0;
    while (t < T.size() &&
           (b.opposite_tet(t, 0) == invalid_index || b.opposite_tet(t, 1) == invalid_index ||
            b.opposite_tet(t, 2) == invalid_index || b.opposite_tet(t, 3) == invalid_index))
        ++t;
    REQUIRE(t < T.size());
    backend::adjacency_tet::undo_log log;
    b.remove_tet(t, log);
    log.resize(0); // committed: the hole is part of the mesh now
    const auto holed = b;
    for (std::uint8_t lf = 0; lf < 4; ++lf) CHECK(original.opposite_tet(t, lf) != invalid_index);
    const index_t again = b.add_tet(T[t], log);
    CHECK(again == t); // the dead slot is recycled
    int linked = 0;
    for (std::uint8_t lf = 0; lf < 4; ++lf) linked += b.opposite_tet(again, lf) != invalid_index;
    CHECK(linked == 0); // the hole's faces were not touched by this operation
    b.settle(log);
    for (std::uint8_t lf = 0; lf < 4; ++lf) {
        CHECK(b.opposite_tet(again, lf) == original.opposite_tet(t, lf));
        CHECK_FALSE(b.check_tet(again).has_value());
    }
    for (index_t v = 0; v < V.size(); ++v) {
        auto s0 = original.vertex_tets(v), s1 = b.vertex_tets(v);
        std::sort(s0.begin(), s0.end()), std::sort(s1.begin(), s1.end());
        CHECK(s0 == s1);
    }
    b.rollback(log, 0);
    CHECK(b == holed);
}

TEST_CASE("adjacency tet: pinched vertices are refused, naming the vertex") {
    std::vector<vec3> V = {{0, 0, 0},  {1, 0, 0},  {0, 1, 0}, {0, 0, 1},
                           {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    std::vector<tet_indices> T = {{0, 1, 2, 3}, {0, 4, 5, 6}};
    for (auto& t : T) test::orient_positively(V, t);
    CHECK_THROWS_WITH_AS(adjacency_mesh(V, T), doctest::Contains("vertex 0 is pinched"),
                         input_error);
    CHECK_NOTHROW(tet_mesh<>(V, T));
}

#if defined(IDAS_HAS_CGAL)
TEST_CASE("adjacency tet: harmonic reduced on Gaussian points matches the indexed backend") {
    using namespace idas::algorithms;
    const auto points = io::gaussian_points(4000, 11);
    const auto dt = cgal::delaunay_tetrahedralization(points);
    tet_mesh<> ref(dt.vertices, dt.tets);
    adjacency_mesh m(dt.vertices, dt.tets);
    harmonic_options o;
    o.mode = harmonic_mode::reduced;
    const auto e0 = harmonic_statistics(m);
    const auto r_ref = harmonic_triangulation<>::run(ref, o);
    const auto r = harmonic_triangulation<adjacency_mesh>::run(m, o);
    CHECK(r.flips > 0);
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    std::size_t inverted = 0;
    const auto p = m.positions();
    m.for_each_tet([&](const tet_tuple& t) {
        const auto& v = m.tet_vertices(t.tid);
        inverted += orient3d(p[v[0]], p[v[1]], p[v[2]], p[v[3]]) <= 0;
    });
    CHECK(inverted == 0);
    CHECK(harmonic_statistics(m).total_energy < e0.total_energy);
    CHECK(mismatches_against_search(m) == 0);
    // Same input, same serial run: the same flips, so the same tets (slots and the order
    // of a tet's vertices may differ: the backends list stars and edge rings in different
    // orders).
    CHECK(r.flips == r_ref.flips);
    auto [V1, T1] = ref.to_arrays();
    auto [V2, T2] = m.to_arrays();
    CHECK(V1 == V2);
    for (auto* T : {&T1, &T2}) {
        for (auto& t : *T) std::sort(t.begin(), t.end());
        std::sort(T->begin(), T->end());
    }
    CHECK(T1 == T2);
}
#endif

TEST_CASE("adjacency tet: a star bigger than the walk's buffer is walked completely") {
    // 300 tets around one edge: both its ends have 300 tets.
    const int n = 300;
    std::vector<vec3> V = {{0, 0, 1}, {0, 0, -1}};
    for (int i = 0; i < n; ++i) {
        const double phi = 2 * std::numbers::pi * i / n;
        V.push_back({std::cos(phi), std::sin(phi), 0});
    }
    std::vector<tet_indices> T;
    for (int i = 0; i < n; ++i) {
        tet_indices t = {0, 1, index_t(2 + i), index_t(2 + (i + 1) % n)};
        test::orient_positively(V, t);
        T.push_back(t);
    }
    adjacency_mesh m(V, T);
    CHECK(m.vertex_tets(0).size() == n);
    CHECK(m.vertex_tets(1).size() == n);
    CHECK(mismatches_against_search(m) == 0);
    CHECK_FALSE(find_inconsistency(m, true).has_value());
}
