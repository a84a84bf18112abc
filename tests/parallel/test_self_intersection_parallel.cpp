// no_self_intersection in parallel (issue 16 item 5 b): operations claim the lock cells
// of the space they read and write, so no two workers make faces that meet, and the index
// stays the mesh's. 8 threads on 2 cores race hardest; under TSan this is also the check
// that faces near an operation are only read by the worker that holds their cells.
#include "../test_support.hpp"

#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/invariants/no_self_intersection.hpp>

#include <optional>

using namespace idas;
using namespace idas::algorithms;

namespace {

template <class Algorithm, class Spec, class Mesh>
Mesh decimated(Mesh m, double ratio, unsigned threads) {
    Spec spec;
    spec.target_faces = static_cast<std::int64_t>(double(m.n_faces()) * ratio);
    spec.serial_up_to_faces = 0; // these meshes are small: load the workers all the same
    self_intersection_index index(m);
    spec.self_intersections = no_self_intersection(index);
    exec_options o;
    o.threads = threads;
    Algorithm::run(m, spec, o);
    CHECK(std::int64_t(m.n_faces()) <= spec.target_faces + 1);
    CHECK(!find_inconsistency(m));
    return m;
}

} // namespace

TEST_CASE_TEMPLATE("parallel no_self_intersection: decimation on 2 and 8 threads", Mesh,
                   IDAS_TRI_MESHES) {
    const Mesh plate = idas::test::noisy_thin_plate<Mesh>(32, 0.02, 0.5);
    const Mesh part = idas::test::load<Mesh>("100071_sf.obj");
    for (unsigned threads : {2u, 8u}) {
        CAPTURE(threads);
        CHECK(count_self_intersections(decimated<qslim<Mesh, lock::vertex_try_lock>, qslim_spec>(
                  plate, 0.1, threads)) == 0);
        CHECK(count_self_intersections(
                  decimated<shortest_edge_collapse<true, Mesh, lock::vertex_try_lock>,
                            shortest_edge_collapse_spec<true>>(part, 0.01, threads)) == 0);
    }
}

TEST_CASE("parallel no_self_intersection: a small detailed part far from the rest of its box") {
    // A millimetre cube of 768 faces and a tetrahedron a kilometre away: the grid's cells
    // could not be smaller than a quantum (1/65000 of the box) but their number, one lock
    // word each, was the box's 65,001^3 quanta, and every parallel run failed for want of
    // memory. The grid now stays within a few words per face.
    using Mesh = tri_mesh<>;
    auto [V, F] = idas::test::subdivided_cube<Mesh>(8).to_arrays();
    for (vec3& p : V) p = p * 1e-3;
    const auto far = index_t(V.size());
    for (const vec3& p : {vec3{1000, 1000, 1000}, vec3{1001, 1000, 1000}, vec3{1000, 1001, 1000},
                          vec3{1000, 1000, 1001}})
        V.push_back(p);
    for (const std::array<index_t, 3>& f :
         {std::array<index_t, 3>{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}})
        F.push_back({far + f[0], far + f[1], far + f[2]});
    const Mesh scene(V, F);
    {
        const self_intersection_index index(scene);
        CHECK(index.lock_cells() <= 16 * scene.n_faces() + 65536);
    }
    for (unsigned threads : {1u, 2u, 8u}) {
        CAPTURE(threads);
        const Mesh m =
            decimated<qslim<Mesh, lock::vertex_try_lock>, qslim_spec>(scene, 0.5, threads);
        CHECK(count_self_intersections(m) == 0);
    }
}

TEST_CASE("parallel no_self_intersection: deterministic rounds give one file at any thread "
          "count") {
    using Mesh = tri_mesh<>;
    // Small: a round's regions now span grid cells, so the rounds are many (RESULTS.md).
    const Mesh plate = idas::test::noisy_thin_plate<Mesh>(16, 0.02, 0.5);
    using A = qslim<Mesh, lock::deterministic_rounds>;
    const auto one = decimated<A, qslim_spec>(plate, 0.1, 1).to_arrays();
    for (unsigned threads : {2u, 8u}) {
        const Mesh m = decimated<A, qslim_spec>(plate, 0.1, threads);
        CHECK(m.to_arrays() == one);
        CHECK(count_self_intersections(m) == 0);
    }
}

TEST_CASE("parallel no_self_intersection: remeshing on 4 threads") {
    using Mesh = tri_mesh<>;
    Mesh m = idas::test::noisy_thin_plate<Mesh>(16, 0.02, 0.9);
    remeshing_options o;
    o.target_length = 0.08;
    o.iterations = 2;
    exec_options e;
    e.threads = 4;
    self_intersection_index index(m, 4 * o.target_length);
    isotropic_remeshing<Mesh, lock::vertex_try_lock, queue::dary_heap<4>, partition::morton,
                        no_self_intersection>::run(m, o, e, no_self_intersection(index));
    CHECK(!find_inconsistency(m));
    CHECK(count_self_intersections(m) == 0);
}

// Deterministic rounds run remeshing's collapses, swaps and smoothing in groups of shards
// first, the invariant's lock cells given to the groups along the vertices' Morton curve
// (exec/deterministic.hpp, own_space): still one mesh at any thread count, and no face
// meets another (under TSan, no group reads a cell another group writes).
TEST_CASE("parallel no_self_intersection: deterministic remeshing, one mesh at any thread "
          "count") {
    using Mesh = tri_mesh<>;
    const Mesh plate = idas::test::noisy_thin_plate<Mesh>(24, 0.02, 0.9);
    auto remeshed = [&](unsigned threads) {
        Mesh m = plate;
        remeshing_options o;
        o.target_length = 0.06;
        o.iterations = 2;
        exec_options e;
        e.threads = threads;
        self_intersection_index index(m, 4 * o.target_length);
        const auto r =
            isotropic_remeshing<Mesh, lock::deterministic_rounds, queue::dary_heap<4>,
                                partition::morton, no_self_intersection>::run(m, o, e,
                                                                              no_self_intersection(
                                                                                  index));
        CHECK(r.collapses > 0);
        CHECK(r.smooths > 0);
        CHECK(!find_inconsistency(m));
        CHECK(count_self_intersections(m) == 0);
        return m.to_arrays();
    };
    const auto one = remeshed(1);
    for (unsigned threads : {2u, 3u, 8u}) {
        CAPTURE(threads);
        CHECK(remeshed(threads) == one);
    }
}
