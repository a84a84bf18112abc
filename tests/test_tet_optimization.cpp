// Tetrahedral meshing of triangle soups, part 2: the AMIPS energy's derivatives, the
// optimization on the executor (include/idas/algorithms/tet_optimization.hpp) and the
// whole pipeline with its output (include/idas/cgal/tetmesh.hpp: mesh_volume).
#include <doctest/doctest.h>

#include <idas/mesh/tet_quality.hpp>

#include <cmath>
#include <random>

#if defined(IDAS_HAS_CGAL)
#include <idas/algorithms/tet_optimization.hpp>
#include <idas/cgal/tetmesh.hpp>
#include <idas/core/aabb_tree.hpp>
#include <idas/io/io.hpp>
#endif

using namespace idas;

TEST_CASE("amips derivatives: gradient and Hessian agree with finite differences") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    int checked = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const vec3 p{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)}, c{u(rng), u(rng), u(rng)},
            d{u(rng), u(rng), u(rng)};
        const auto x = tet_amips_derivatives(p, b, c, d);
        if (!std::isfinite(x.energy)) {
            CHECK(x.gradient == vec3{}); // flat or inverted: a barrier, no direction
            continue;
        }
        if (x.energy > 200) continue; // near-flat: finite differences lose their accuracy
        ++checked;
        CHECK(x.energy == doctest::Approx(tet_amips(p, b, c, d)).epsilon(1e-12));
        const double h = 1e-6;
        for (int k = 0; k < 3; ++k) {
            vec3 e{};
            e[k] = h;
            const auto plus = tet_amips_derivatives(p + e, b, c, d);
            const auto minus = tet_amips_derivatives(p - e, b, c, d);
            const double scale = 1 + std::abs(x.gradient[k]);
            CHECK((plus.energy - minus.energy) / (2 * h) ==
                  doctest::Approx(x.gradient[k]).epsilon(1e-4).scale(scale));
            for (int j = 0; j < 3; ++j) {
                const double fd = (plus.gradient[j] - minus.gradient[j]) / (2 * h);
                CHECK(fd == doctest::Approx(x.hessian[3 * j + k])
                                .epsilon(1e-4)
                                .scale(1 + std::abs(x.hessian[3 * j + k])));
            }
        }
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                CHECK(x.hessian[3 * i + j] == doctest::Approx(x.hessian[3 * j + i]));
    }
    CHECK(checked > 50);
    // The regular tet is the minimum: energy 3, zero gradient.
    const vec3 a{0, 0, 0}, b{1, 0, 0}, c{0.5, std::sqrt(3.0) / 2, 0},
        d{0.5, std::sqrt(3.0) / 6, std::sqrt(2.0 / 3.0)};
    const auto r = tet_amips_derivatives(a, b, c, d);
    CHECK(r.energy == doctest::Approx(3));
    CHECK(norm(r.gradient) < 1e-12);
    CHECK(!std::isfinite(tet_amips_derivatives(a, b, c, (a + b + c) / 3.0).energy));
}

#if defined(IDAS_HAS_CGAL)

namespace {

std::string data_file(const char* name) {
    return std::string(IDAS_DATA_DIR) + "/" + name;
}

/// Largest distance from the points of `from` (corners and centroids of its faces) to the
/// surface `to`.
double farthest(const std::vector<vec3>& VA, const std::vector<tri_indices>& FA,
                const std::vector<vec3>& VB, const std::vector<tri_indices>& FB) {
    const triangle_aabb_tree to(VB, FB);
    double worst = 0;
    for (const auto& f : FA) {
        const vec3 c = (VA[f[0]] + VA[f[1]] + VA[f[2]]) / 3.0;
        for (const vec3& q : {VA[f[0]], VA[f[1]], VA[f[2]], c})
            worst = std::max(worst, std::sqrt(to.squared_distance(q)));
    }
    return worst;
}

struct checked_run {
    tetmesh::volume_mesh mesh;
    std::vector<tri_indices> boundary;
};

/// Runs the whole pipeline and checks what every output must satisfy.
checked_run mesh_and_check(const char* name, unsigned threads, double edge_length = 1.0 / 20) {
    const auto s = io::read_surface(data_file(name));
    tetmesh::options o;
    o.edge_length = edge_length;
    tetmesh::quality_options q;
    q.threads = threads;
    checked_run out{tetmesh::mesh_volume(s.vertices, s.faces, o, q, name), {}};
    const auto& r = out.mesh.quality;
    INFO(name << " on " << threads << " threads");
    CHECK(out.mesh.insertion.covered_triangles == out.mesh.insertion.simplified_triangles);
    CHECK(out.mesh.insertion.simplified_triangles <= out.mesh.insertion.triangles);
    CHECK(r.flat_or_inverted == 0);
    CHECK(r.optimization.stopped == algorithms::tet_optimization_stop::energy_reached);
    CHECK(r.quality.amips.max <= 10);
    CHECK(r.quality.amips.min >= 3 - 1e-9);
    CHECK(r.non_manifold_edges == 0);
    CHECK(r.non_manifold_vertices == 0);
    out.boundary =
        tetmesh::detail::boundary_of(out.mesh.vertices.size(), out.mesh.tets, out.mesh.inside)
            .faces;
    CHECK(out.boundary.size() == r.boundary_faces);
    return out;
}

} // namespace

TEST_CASE("tetmesh optimization: sphere to AMIPS at most 10, within the envelope both ways") {
    const auto s = io::read_surface(data_file("sphere.obj"));
    const auto run = mesh_and_check("sphere.obj", 1);
    const double eps = run.mesh.insertion.epsilon;
    // Closed input: the boundary is the tracked surface, inside the envelope (a sampled
    // check, independent of the envelope's own), and it stays close to every input point.
    CHECK(farthest(run.mesh.vertices, run.boundary, s.vertices, s.faces) <= eps * (1 + 1e-9));
    CHECK(farthest(s.vertices, s.faces, run.mesh.vertices, run.boundary) <= eps * (1 + 1e-9));
    // The inside's volume is the enclosed volume (the sphere mesh's, up to the envelope).
    double inside = 0, enclosed = 0;
    for (std::size_t t = 0; t < run.mesh.tets.size(); ++t)
        if (run.mesh.inside[t]) {
            const auto& tv = run.mesh.tets[t];
            const auto& V = run.mesh.vertices;
            inside += tet_signed_volume(V[tv[0]], V[tv[1]], V[tv[2]], V[tv[3]]);
        }
    for (const auto& f : s.faces)
        enclosed += dot(s.vertices[f[0]], cross(s.vertices[f[1]], s.vertices[f[2]])) / 6;
    CHECK(inside == doctest::Approx(std::abs(enclosed)).epsilon(0.01));
}

TEST_CASE("tetmesh optimization: one thread gives the same mesh on every run") {
    const auto a = mesh_and_check("hour_glass.off", 1);
    const auto b = mesh_and_check("hour_glass.off", 1);
    CHECK(a.mesh.vertices == b.mesh.vertices);
    CHECK(a.mesh.tets == b.mesh.tets);
    CHECK(a.mesh.inside == b.mesh.inside);
}

TEST_CASE("tetmesh optimization: two and eight workers keep every invariant") {
    // More workers than cores: contention, retries and the serial tail all happen.
    for (unsigned threads : {2u, 8u}) mesh_and_check("sphere.obj", threads);
}

TEST_CASE("tetmesh optimization: an input whose edge rings start huge (x.stl) finishes") {
    // Its insertion leaves edges with hundreds of tets around them: a split refused there
    // made the splits around it refine the ring without end.
    mesh_and_check("x.stl", 1, 1.0 / 10);
}

TEST_CASE("tetmesh optimization: absurd options are input errors") {
    const auto s = io::read_surface(data_file("sphere.obj"));
    tetmesh::quality_options q;
    q.stop_energy = 2;
    CHECK_THROWS_AS(tetmesh::mesh_volume(s.vertices, s.faces, {}, q, "sphere"), input_error);
    q.stop_energy = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(tetmesh::mesh_volume(s.vertices, s.faces, {}, q, "sphere"), input_error);
}

#endif
