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

namespace {
adjacency_mesh delaunay_adjacency(const std::vector<vec3>& points) {
    const auto dt = cgal::delaunay_tetrahedralization(points);
    return {dt.vertices, dt.tets};
}
std::size_t inverted(const adjacency_mesh& m) {
    std::size_t n = 0;
    const auto p = m.positions();
    m.for_each_tet([&](const tet_tuple& t) {
        const auto& v = m.tet_vertices(t.tid);
        n += orient3d(p[v[0]], p[v[1]], p[v[2]], p[v[3]]) <= 0 ? 1 : 0;
    });
    return n;
}
struct small_pool : harmonic_flip_spec<harmonic_mode::complete> {
    template <class Mesh>
    std::pair<index_t, index_t> parallel_growth(const Mesh&) const {
        return {0, 8};
    }
};
} // namespace

TEST_CASE("adjacency tet in parallel: harmonic triangulation on 4 threads, both modes") {
    const auto points = io::gaussian_points(4000, 13);
    for (const auto mode : {harmonic_mode::reduced, harmonic_mode::complete}) {
        CAPTURE(int(mode));
        auto m = delaunay_adjacency(points);
        const auto before = harmonic_statistics(m);
        harmonic_options o;
        o.mode = mode;
        o.exec.threads = 4;
        o.exec.max_retry = 2;
        const auto r = harmonic_triangulation<adjacency_mesh>::run(m, o);
        CHECK(r.flips > 0);
        CHECK(find_inconsistency(m, true) == std::nullopt);
        CHECK(test::mismatches_against_search(m) == 0);
        CHECK(inverted(m) == 0);
        CHECK(harmonic_statistics(m).total_energy < before.total_energy);
    }
}

TEST_CASE("adjacency tet in parallel: 2-3 growth beyond the slot pools") {
    auto m = delaunay_adjacency(io::gaussian_points(3000, 5));
    const auto before = harmonic_statistics(m);
    small_pool spec;
    const auto r = executor<small_pool, adjacency_mesh, lock::vertex_try_lock, queue::fifo>::run(
        m, spec, {.threads = 4});
    CHECK(r.succeeded > 0);
    CHECK(r.deferred_to_serial > 0);
    CHECK(find_inconsistency(m, true) == std::nullopt);
    CHECK(test::mismatches_against_search(m) == 0);
    CHECK(inverted(m) == 0);
    CHECK(harmonic_statistics(m).total_energy < before.total_energy);
}

#endif // IDAS_HAS_CGAL
