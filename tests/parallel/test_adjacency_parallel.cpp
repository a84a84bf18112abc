// The adjacency tet backend on the parallel executor: harmonic triangulations with 4
// workers (per-worker slot pools for 2-3 swaps, relaxed version reads, star walks under
// the vertex locks), and pools too small for the 2-3 growth. Needs CGAL for the input.
#if defined(IDAS_HAS_CGAL)
#include "../harmonic_support.hpp"
#include "../tet_support.hpp"

#include <idas/io/points.hpp>

using namespace idas;
using namespace idas::algorithms;
using adjacency_mesh = tet_mesh<backend::adjacency_tet>;

TEST_CASE("adjacency tet in parallel: harmonic triangulation on 4 threads, both modes") {
    const auto points = io::gaussian_points(4000, 13);
    for (const auto mode : {harmonic_mode::reduced, harmonic_mode::complete}) {
        CAPTURE(int(mode));
        auto m = test::delaunay_mesh<adjacency_mesh>(points);
        const auto before = harmonic_statistics(m);
        harmonic_options o;
        o.mode = mode;
        o.exec.threads = 4;
        o.exec.max_retry = 2;
        const auto r = harmonic_triangulation<adjacency_mesh>::run(m, o);
        CHECK(r.flips > 0);
        CHECK(find_inconsistency(m, true) == std::nullopt);
        CHECK(test::mismatches_against_search(m) == 0);
        CHECK(test::inverted_or_flat_tets(m) == 0);
        CHECK(harmonic_statistics(m).total_energy < before.total_energy);
    }
}

TEST_CASE("adjacency tet in parallel: 2-3 growth beyond the slot pools") {
    auto m = test::flat_bipyramids<adjacency_mesh>(8);
    const auto before = harmonic_statistics(m);
    test::small_pool spec;
    const auto r =
        executor<test::small_pool, adjacency_mesh, lock::vertex_try_lock, queue::fifo>::run(
            m, spec, {.threads = 4});
    // Every bipyramid was swapped once; at most the pools' 8 slots served the workers,
    // the other 2-3 swaps were set aside (then done on merged parts or in the serial pass).
    const auto pairs = before.tets / 2;
    CHECK(r.succeeded == pairs);
    CHECK(m.n_tets() == 3 * pairs);
    CHECK(r.deferred_to_serial + r.retaken >= pairs - 8);
    CHECK(find_inconsistency(m, true) == std::nullopt);
    CHECK(test::mismatches_against_search(m) == 0);
    CHECK(test::inverted_or_flat_tets(m) == 0);
    CHECK(harmonic_statistics(m).total_energy < before.total_energy);
}

#endif // IDAS_HAS_CGAL
