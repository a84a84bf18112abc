// Input ranges, result checks and interrupted writes (issue 16, "Reliability").
#include "test_support.hpp"

#include <idas/io/atomic_file.hpp>
#include <idas/mesh/geometry_range.hpp>
#include <idas/mesh/surface_check.hpp>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

using namespace idas;
namespace fs = std::filesystem;

namespace {

// The regular tetrahedron-ish surface of the CLI reports, scaled.
std::vector<vec3> tet_points(double scale) {
    return {vec3{0, 0, 0} * scale, vec3{1, 0, 0} * scale, vec3{0, 1, 0} * scale,
            vec3{0, 0, 1} * scale};
}

bool refused_with(const std::vector<vec3>& points, const std::string& word) {
    const auto problem = check_geometry_range(points);
    INFO("problem: " << problem.value_or("(none)"));
    return problem && problem->find(word) != std::string::npos;
}

const std::vector<tri_indices> tet_faces = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};

} // namespace

TEST_CASE("geometry range: coordinates whose lengths over- or underflow are refused") {
    // Ordinary scales pass, including the documented limits themselves.
    for (const double scale : {1.0, 1e-40, 1e40, 1e50})
        CHECK_FALSE(check_geometry_range(tet_points(scale)).has_value());
    CHECK_FALSE(check_geometry_range(tet_points(1e-50)).has_value());
    // The inputs: a diagonal that overflows to inf, or underflows to 0.
    CHECK(refused_with(tet_points(9e307), "beyond the supported range"));
    CHECK(refused_with(tet_points(1e308), "beyond the supported range"));
    CHECK(refused_with(tet_points(1e51), "beyond the supported range"));
    CHECK(refused_with(tet_points(1e-320), "below the supported minimum"));
    CHECK(refused_with(tet_points(1e-310), "below the supported minimum"));
    CHECK(refused_with(tet_points(1e-60), "below the supported minimum"));
    // A far-away mesh of ordinary size is fine; one point, or all at one place, is not.
    std::vector<vec3> offset = tet_points(1);
    for (auto& p : offset) p += vec3{1e40, -1e40, 0};
    CHECK_FALSE(check_geometry_range(offset).has_value());
    CHECK(refused_with({{1, 2, 3}, {1, 2, 3}, {1, 2, 3}}, "at one point"));
    CHECK(refused_with({{0, 0, 0}, {std::nan(""), 0, 0}}, "non-finite"));
    CHECK(refused_with({{0, 0, 0}, {1, 0, 0}, {0, 0, -1e60}}, "vertex 2"));
    // bunny.off scaled so its coordinates reach 9e307 (the report).
    auto bunny = io::read_surface(test::data("bunny.off"));
    double largest = 0;
    for (const auto& p : bunny.vertices)
        largest = std::max({largest, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    for (auto& p : bunny.vertices) p = p / largest * 9e307; // 9e307 / largest overflows
    CHECK(refused_with(bunny.vertices, "beyond the supported range"));
}

TEST_CASE("surface check: oriented manifolds pass with their Euler characteristic and loops") {
    const auto tet = summarize_surface(4, tet_faces);
    CHECK_FALSE(tet.problem.has_value());
    CHECK(tet.euler_characteristic == 2);
    CHECK(tet.boundary_loops == 0);

    // bunny.obj: open, 5 boundary loops, Euler characteristic -3 (as `idas info` reports).
    const auto bunny = io::read_surface(test::data("bunny.obj"));
    const auto b = summarize_surface(bunny.vertices.size(), bunny.faces);
    CHECK_FALSE(b.problem.has_value());
    CHECK(b.euler_characteristic == -3);
    CHECK(b.boundary_loops == 5);
    CHECK(b.boundary_edges == 223);

    // An open strip: two triangles, one loop.
    const auto strip = summarize_surface(4, std::vector<tri_indices>{{0, 1, 2}, {2, 1, 3}});
    CHECK_FALSE(strip.problem.has_value());
    CHECK(strip.euler_characteristic == 1);
    CHECK(strip.boundary_loops == 1);

    // The double triangle is a closed oriented manifold (a sphere).
    const auto pair = summarize_surface(3, std::vector<tri_indices>{{0, 1, 2}, {0, 2, 1}});
    CHECK_FALSE(pair.problem.has_value());
    CHECK(pair.euler_characteristic == 2);
}

TEST_CASE("surface check: non-manifold edges and vertices and flipped faces are caught") {
    // What a split of the double triangle's edge made: four faces on the edge (3, 2).
    const std::vector<tri_indices> split_pair = {{0, 3, 2}, {3, 1, 2}, {3, 0, 2}, {1, 3, 2}};
    const auto nm = summarize_surface(4, split_pair);
    REQUIRE(nm.problem.has_value());
    CHECK(nm.problem->find("same direction") != std::string::npos);

    // One flipped face of a tetrahedron.
    auto flipped = tet_faces;
    std::swap(flipped[2][0], flipped[2][1]);
    CHECK(summarize_surface(4, flipped).problem.has_value());

    // Two tetrahedra sharing only vertex 0: every edge is fine, vertex 0 is not.
    std::vector<tri_indices> bowtie = tet_faces;
    for (auto f : tet_faces) {
        for (auto& v : f) v = v == 0 ? 0 : v + 3;
        bowtie.push_back(f);
    }
    const auto pinched = summarize_surface(7, bowtie);
    REQUIRE(pinched.problem.has_value());
    CHECK(pinched.problem->find("vertex 0") != std::string::npos);

    // Degenerate and out-of-range faces.
    CHECK(summarize_surface(3, std::vector<tri_indices>{{0, 1, 1}}).problem.has_value());
    CHECK(summarize_surface(3, std::vector<tri_indices>{{0, 1, 5}}).problem.has_value());
}

TEST_CASE("atomic write: SIGTERM in the middle of a write removes the temporary file") {
    const fs::path dir = test::tmp("signal_cleanup");
    fs::remove_all(dir);
    fs::create_directories(dir);
    const fs::path target = dir / "mesh.obj";
    for (const int sig : {SIGTERM, SIGINT}) {
        CAPTURE(sig);
        const pid_t child = ::fork();
        REQUIRE(child >= 0);
        if (child == 0) {
            // The child dies by the signal while the temporary file is open and half written.
            io::remove_temporary_files_on_signals();
            io::write_atomically(target, [&](std::ostream& os) {
                os << "v 0 0 0\n" << std::flush;
                std::raise(sig);
            });
            ::_exit(0); // not reached when the handler re-raises
        }
        int status = 0;
        REQUIRE(::waitpid(child, &status, 0) == child);
        CHECK(WIFSIGNALED(status));
        CHECK(WTERMSIG(status) == sig);
        CHECK_FALSE(fs::exists(target));
        std::size_t left = 0;
        for (const auto& entry : fs::directory_iterator(dir)) {
            INFO("left behind: " << entry.path());
            ++left;
        }
        CHECK(left == 0);
    }
}
