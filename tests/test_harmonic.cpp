// Harmonic triangulations: the energy, the point readers, and the algorithm on Gaussian
// points (data/gaussian_points_100k.ply in reduced mode; 10k generated points in complete
// mode, which smooths and so takes longer per point). CGAL builds the Delaunay input, so
// the file compiles to nothing without it.
#if defined(IDAS_HAS_CGAL)
#include "harmonic_support.hpp"

#include <idas/io/points.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using namespace idas;
using namespace idas::algorithms;

TEST_CASE("harmonic energy: regular tet, scale, inversion, gradient") {
    // Regular tet of edge 1.
    const vec3 a{1, 1, 1}, b{1, -1, -1}, c{-1, 1, -1}, d{-1, -1, 1}; // edge 2*sqrt(2)
    const double l = 2 * std::sqrt(2.0);
    REQUIRE(orient3d(a, b, c, d) != 0);
    const auto [p, q, r, s] =
        orient3d(a, b, c, d) > 0 ? std::array{a, b, c, d} : std::array{a, b, d, c};
    CHECK(harmonic_energy(p, q, r, s) == doctest::Approx(l / std::sqrt(2.0)));
    CHECK(harmonic_index(p, q, r, s) == doctest::Approx(9 * l / std::sqrt(2.0)));
    // Energy scales with length; inverted and flat tets are infinitely bad.
    CHECK(harmonic_energy(p * 3.0, q * 3.0, r * 3.0, s * 3.0) ==
          doctest::Approx(3 * harmonic_energy(p, q, r, s)));
    CHECK(std::isinf(harmonic_energy(p, q, s, r)));
    CHECK(std::isinf(harmonic_energy(p, q, r, (p + q) * 0.5)));
    // The smoothing gradient matches central differences on a skewed tet.
    const vec3 x{0.1, 0.2, 0.05}, y{1, 0, 0}, z{0.3, 1.1, 0}, w{0.2, 0.1, 0.9};
    REQUIRE(orient3d(x, y, z, w) > 0);
    vec3 g;
    const double e = harmonic_smooth_spec::energy_and_gradient(x, y, z, w, g);
    CHECK(e == doctest::Approx(harmonic_energy(x, y, z, w)));
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
        vec3 dp{}, dm{};
        dp[k] = h, dm[k] = -h;
        const double fd =
            (harmonic_energy(x + dp, y, z, w) - harmonic_energy(x + dm, y, z, w)) / (2 * h);
        CHECK(g[k] == doctest::Approx(fd).epsilon(1e-5));
    }
}

TEST_CASE("point readers: PLY with a dummy face, XYZ, Gaussian generator, bad input") {
    const auto pts = io::read_points(std::string(IDAS_DATA_DIR) + "/gaussian_points_100k.ply");
    REQUIRE(pts.size() == 100000);
    const std::filesystem::path dir = IDAS_TEST_TMP;
    {
        std::ofstream(dir / "h.xyz") << "# comment\n1 2 3\n\n4 5 6 0 0 1\n";
        const auto xyz = io::read_points(dir / "h.xyz");
        REQUIRE(xyz.size() == 2);
        CHECK(xyz[1] == vec3{4, 5, 6});
    }
    std::ofstream(dir / "bad.xyz") << "1 2 3\n4 five 6\n";
    CHECK_THROWS_WITH_AS(io::read_points(dir / "bad.xyz"), doctest::Contains("bad.xyz"),
                         input_error);
    std::ofstream(dir / "short.xyz") << "1 2\n";
    CHECK_THROWS_AS(io::read_points(dir / "short.xyz"), input_error);
    CHECK_THROWS_AS(io::read_points(dir / "missing.xyz"), std::exception);
    const auto g1 = io::gaussian_points(1000, 7), g2 = io::gaussian_points(1000, 7);
    CHECK(g1 == g2);
    CHECK(io::gaussian_points(1000, 8) != g1);
    double mean = 0, var = 0;
    for (const auto& p : g1) mean += p.x;
    mean /= 1000;
    for (const auto& p : g1) var += (p.x - mean) * (p.x - mean);
    CHECK(std::abs(mean) < 0.15);
    CHECK(var / 1000 == doctest::Approx(1.0).epsilon(0.15));
    // Degenerate point sets have no tetrahedralization.
    CHECK_THROWS_AS(cgal::delaunay_tetrahedralization({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}),
                    input_error);
    const auto dup =
        cgal::delaunay_tetrahedralization({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 0}});
    CHECK(dup.duplicates == 1);
    CHECK(dup.vertices.size() == 4);
    CHECK(dup.tets.size() == 1);
}

TEST_CASE("harmonic reduced on 100k Gaussian points: valid, better, same hull and vertices") {
    auto m = test::delaunay_mesh(
        io::read_points(std::string(IDAS_DATA_DIR) + "/gaussian_points_100k.ply"));
    REQUIRE(test::inverted_or_flat_tets(m) == 0);
    harmonic_options o;
    o.mode = harmonic_mode::reduced;
    const auto before = m.n_tets();
    const auto rep = test::check_run(m, o, false);
    CHECK(rep.smoothed == 0);
    // Every 3-2 swap removes a tet.
    CHECK(m.n_tets() == before - rep.flips);
}

TEST_CASE("harmonic complete on 10k Gaussian points: valid, better, deterministic") {
    const auto points = io::gaussian_points(10000, 3);
    harmonic_options o;
    o.mode = harmonic_mode::complete;
    auto m1 = test::delaunay_mesh(points);
    const auto reduced_energy = [&] {
        auto m = test::delaunay_mesh(points);
        harmonic_options r;
        r.mode = harmonic_mode::reduced;
        harmonic_triangulation<>::run(m, r);
        return harmonic_statistics(m).total_energy;
    }();
    const auto rep = test::check_run(m1, o);
    CHECK(rep.smoothed > 0);
    // Smoothing and the other flips reach a lower energy than 3-2 swaps alone.
    CHECK(harmonic_statistics(m1).total_energy < reduced_energy);
    // Serial runs are deterministic: the same input gives the same mesh, bit for bit.
    auto m2 = test::delaunay_mesh(points);
    harmonic_triangulation<>::run(m2, o);
    const auto [V1, T1] = m1.to_arrays();
    const auto [V2, T2] = m2.to_arrays();
    CHECK(V1 == V2);
    CHECK(T1 == T2);
}

TEST_CASE("harmonic flips: cached energies stay exact, lock regions are the flipped tets") {
    auto m = test::delaunay_mesh(io::gaussian_points(3000, 9));
    using spec_t = harmonic_flip_spec<harmonic_mode::complete>;
    spec_t spec;
    const auto r = executor<spec_t, tet_mesh<>, lock::vertex_try_lock, queue::fifo>::run(m, spec);
    REQUIRE(r.succeeded > 0);
    // Every flip's renew recorded its new tets' energies: the cache matches the mesh.
    std::size_t checked = 0, wrong = 0;
    for (index_t t = 0; t < m.tet_slots() && t < spec.energies.size(); ++t)
        if (m.tet_alive(t)) {
            ++checked;
            wrong += spec.energies[t] == harmonic_energy(m, m.tet_vertices(t)) ? 0 : 1;
        }
    CHECK(checked == m.n_tets());
    CHECK(wrong == 0);

    // The region a flip claims: exactly the vertices of the tets it replaces.
    const auto region = [&](auto op, const tet_tuple& t) {
        std::vector<index_t> held;
        const bool ok = spec.lock_region(op, m, t, [&](index_t v) {
            if (std::find(held.begin(), held.end(), v) == held.end()) held.push_back(v);
            return true;
        });
        REQUIRE(ok);
        std::sort(held.begin(), held.end());
        return held;
    };
    const auto vertices_of = [&](std::initializer_list<index_t> tets) {
        std::vector<index_t> out;
        for (index_t g : tets)
            for (index_t v : m.tet_vertices(g)) out.push_back(v);
        std::sort(out.begin(), out.end());
        out.erase(std::unique(out.begin(), out.end()), out.end());
        return out;
    };
    bool seen3 = false, seen4 = false, seen_face = false;
    for (index_t t = 0; t < m.tet_slots() && !(seen3 && seen4 && seen_face); ++t) {
        if (!m.tet_alive(t)) continue;
        const auto& tv = m.tet_vertices(t);
        const tet_tuple e = m.tuple_at(t, tv[0], tv[1]);
        idas::detail::edge_ring ring;
        if (idas::detail::closed_edge_ring(m, tv[0], tv[1], ring) && ring.tets.size() <= 4) {
            std::vector<index_t> want;
            if (ring.tets.size() == 3)
                want = vertices_of({ring.tets[0], ring.tets[1], ring.tets[2]}), seen3 = true;
            else if (ring.tets.size() == 4)
                want = vertices_of({ring.tets[0], ring.tets[1], ring.tets[2], ring.tets[3]}),
                seen4 = true;
            if (!want.empty()) {
                CHECK(region(op::edge_swap_32{}, e) == want);
                CHECK(region(op::edge_swap_44{}, e) == want);
                CHECK(want.size() == ring.tets.size() + 2);
            }
        }
        const index_t t2 = m.connectivity().opposite_tet(t, 0);
        if (t2 != invalid_index && !seen_face) {
            const auto got = region(op::face_swap_23{}, m.tuple_from_face(t, 0));
            CHECK(got == vertices_of({t, t2}));
            CHECK(got.size() == 5);
            seen_face = true;
        }
    }
    CHECK(seen3);
    CHECK(seen4);
    CHECK(seen_face);
}

#endif // IDAS_HAS_CGAL
