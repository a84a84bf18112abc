// Harmonic triangulations on the parallel executor: valid under contention (8 workers on
// the machine's cores), energy not higher, hull and vertices kept. Needs CGAL for the
// Delaunay input.
#if defined(IDAS_HAS_CGAL)
#include "../harmonic_support.hpp"

#include <idas/io/points.hpp>

using namespace idas;
using namespace idas::algorithms;

TYPE_TO_STRING_AS("vertex_try_lock", lock::vertex_try_lock);
TYPE_TO_STRING_AS("own_part_first", lock::own_part_first);

TEST_CASE_TEMPLATE("harmonic triangulation in parallel: 8 threads, both modes", Lock,
                   lock::vertex_try_lock, lock::own_part_first) {
    const auto points = io::gaussian_points(10000, 11);
    for (const auto mode : {harmonic_mode::reduced, harmonic_mode::complete}) {
        CAPTURE(int(mode));
        auto m = test::delaunay_mesh(points);
        harmonic_options o;
        o.mode = mode;
        o.exec.threads = 8;
        o.exec.max_retry = 2; // more entries take the final serial pass too
        const auto rep = test::check_run<harmonic_triangulation<tet_mesh<>, Lock>>(m, o);
        if constexpr (std::is_same_v<Lock, lock::own_part_first>) CHECK(rep.crossed_parts > 0);
        // Within reach of the serial result (the order of flips differs).
        auto s = test::delaunay_mesh(points);
        o.exec.threads = 1;
        harmonic_triangulation<>::run(s, o);
        CHECK(harmonic_statistics(m).mean_index ==
              doctest::Approx(harmonic_statistics(s).mean_index).epsilon(0.02));
    }
}

TEST_CASE("harmonic triangulation in parallel: 2-3 growth beyond the slot pools") {
    auto m = test::flat_bipyramids(10);
    const auto before = harmonic_statistics(m);
    test::small_pool spec;
    const auto r = executor<test::small_pool, tet_mesh<>, lock::vertex_try_lock, queue::fifo>::run(
        m, spec, {.threads = 4});
    // Every bipyramid was swapped once; at most the pools' 8 slots served the workers,
    // the other 2-3 swaps were set aside (then done on merged parts or in the serial pass).
    const auto pairs = before.tets / 2;
    CHECK(r.succeeded == pairs);
    CHECK(m.n_tets() == 3 * pairs);
    CHECK(r.deferred_to_serial + r.retaken >= pairs - 8);
    // No stopping criterion, so the workers kept no live counts: the report sums them.
    CHECK(r.faces == std::int64_t(m.n_tets()));
    CHECK(r.vertices == std::int64_t(m.n_vertices()));
    CHECK(find_inconsistency(m, true) == std::nullopt);
    CHECK(test::inverted_or_flat_tets(m) == 0);
    CHECK(harmonic_statistics(m).total_energy < before.total_energy);
}

TEST_CASE("harmonic smoothing pass: every vertex is tried once, serial and on 4 threads") {
    // Moving a vertex renews its star's tets, which the queued tuples of its neighbours
    // were made in; the executor re-anchors vertex entries instead of dropping them (which
    // once left two thirds of the vertices unsmoothed).
    for (const unsigned threads : {1u, 4u}) {
        CAPTURE(threads);
        auto m = test::delaunay_mesh(io::gaussian_points(4000, 3));
        const auto before = harmonic_statistics(m);
        harmonic_smooth_spec spec;
        const auto r =
            executor<harmonic_smooth_spec, tet_mesh<>, lock::vertex_try_lock, queue::fifo>::run(
                m, spec, {.threads = threads});
        CHECK(r.stale == 0);
        CHECK(r.attempted == m.n_vertices());
        CHECK(r.succeeded > m.n_vertices() / 2);
        CHECK(test::inverted_or_flat_tets(m) == 0);
        CHECK(harmonic_statistics(m).total_energy < before.total_energy);
    }
}

#endif // IDAS_HAS_CGAL
