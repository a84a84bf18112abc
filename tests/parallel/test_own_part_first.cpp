// The own_part_first lock policy: a lock-free owner phase (each worker edits only inside
// its own part), then the claiming phase for what crossed parts. More workers than cores,
// on triangle meshes (collapses; splits, whose new vertices join their maker's part) and
// on tet meshes (harmonic smoothing; the whole harmonic run is in
// test_harmonic_parallel.cpp, over both lock policies). Test names start with "parallel"
// so the TSan preset runs them.
#include "../test_support.hpp"

#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/core/aabb_tree.hpp>
#include <idas/core/geometry.hpp>
#if defined(IDAS_HAS_CGAL)
#include "../harmonic_support.hpp"

#include <idas/io/points.hpp>
#endif

using namespace idas;
using namespace idas::algorithms;

using idas::test::topology_of;

namespace {
/// The mesh is consistent and has the topology it had (`before`).
template <class Mesh>
void check_valid_with_topology(const Mesh& m, const idas::test::topology& before) {
    const auto e = find_inconsistency(m);
    REQUIRE_MESSAGE(!e, *e);
    CHECK(topology_of(m) == before);
}
} // namespace

TEST_CASE_TEMPLATE("parallel own_part_first: no operation lost", Mesh, IDAS_TRI_MESHES) {
    // Every entry is popped once (or purged), and ends stale, skipped, attempted, retried
    // after a lock failure, or carried over to the claiming phase.
    for (unsigned threads : {2u, 8u}) {
        CAPTURE(threads);
        auto m = idas::test::load<Mesh>("blub.obj");
        const auto before = topology_of(m);
        shortest_edge_collapse_spec<> spec;
        spec.target_faces = 0;
        spec.serial_up_to_faces = 0; // blub would run serially
        const auto r = shortest_edge_collapse<true, Mesh, lock::own_part_first>::run(
            m, spec, {.threads = threads, .max_retry = 2});
        CHECK(r.succeeded > 1000);
        CHECK(r.crossed_parts > 0);
        CHECK(r.pushed == r.popped + r.purged);
        CHECK(r.popped == r.stale + r.skipped + r.attempted + r.lock_failures + r.crossed_parts);
        CHECK(r.attempted == r.succeeded + r.refused);
        check_valid_with_topology(m, before);
    }
}

TEST_CASE_TEMPLATE("parallel own_part_first: QSlim to a target under contention", Mesh,
                   IDAS_TRI_MESHES) {
    // blub: bunny.off's 6,966 faces were fewer than the serial tail of 16 parts (512
    // faces each), so its workers stopped as soon as they started.
    auto m = idas::test::load<Mesh>("blub.obj");
    const auto before = topology_of(m);
    qslim_spec spec;
    spec.target_faces = std::int64_t(m.n_faces() / 5);
    spec.serial_up_to_faces = 0; // blub would run serially
    const auto r =
        qslim<Mesh, lock::own_part_first>::run(m, spec, {.threads = 8, .parts_per_thread = 2});
    CHECK(r.threads == 8);
    CHECK(r.owner_seconds > 0);
    // Overshoot is bounded by the operations in flight: two faces per worker.
    CHECK(std::abs(double(m.n_faces()) - double(spec.target_faces)) <= 2.0 * 16 + 1);
    check_valid_with_topology(m, before);
}

TEST_CASE_TEMPLATE("parallel own_part_first: remeshing, whose splits make new vertices", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = idas::test::load<Mesh>("bunny.obj");
    const auto before = topology_of(m);
    const auto [V, F] = m.to_arrays();
    remeshing_options o;
    o.target_length = 0.01 * triangle_aabb_tree(V, F).diagonal();
    o.iterations = 3;
    const auto r = isotropic_remeshing<Mesh, lock::own_part_first>::run(m, o, {.threads = 8});
    CHECK(r.splits > 100);
    CHECK(r.collapses > 1000);
    check_valid_with_topology(m, before);
}

#if defined(IDAS_HAS_CGAL)
TEST_CASE("parallel own_part_first: a smoothing pass tries every vertex once") {
    // Entries that cross parts are carried over to the claiming phase, not dropped.
    auto m = test::delaunay_mesh(io::gaussian_points(4000, 3));
    harmonic_smooth_spec spec;
    const auto r =
        executor<harmonic_smooth_spec, tet_mesh<>, lock::own_part_first, queue::fifo>::run(
            m, spec, {.threads = 4});
    CHECK(r.crossed_parts > 0);
    CHECK(r.stale == 0);
    CHECK(r.attempted == m.n_vertices());
    CHECK(test::inverted_or_flat_tets(m) == 0);
}
#endif
