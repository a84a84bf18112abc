// The harmonic command's result check (examples/tool/harmonic.hpp): exact orientation of
// every tet, no face in more than two tets, and a closed oriented 2-manifold boundary of
// the input hull's Euler characteristic. Each refusal is tested with the mesh that should
// cause it, and the answer does not depend on the thread count.
#include <doctest/doctest.h>

#include <tool/harmonic.hpp>

#include <tbb/global_control.h>

#include <random>

using idas::vec3;

namespace {

/// A cube of corners 0..7 (bit i of a corner's index: its coordinate i), in six tets
/// around the diagonal 0-7, each positively oriented.
idas::io::volume cube() {
    idas::io::volume v;
    for (int c = 0; c < 8; ++c)
        v.vertices.push_back(vec3{double(c & 1), double(c >> 1 & 1), double(c >> 2 & 1)});
    const int path[6][2] = {{1, 3}, {3, 2}, {2, 6}, {6, 4}, {4, 5}, {5, 1}};
    for (const auto& p : path) {
        idas::tet_indices t{0, idas::index_t(p[0]), idas::index_t(p[1]), 7};
        if (idas::orient3d(v.vertices[t[0]], v.vertices[t[1]], v.vertices[t[2]], v.vertices[t[3]]) <
            0)
            std::swap(t[1], t[2]);
        v.tets.push_back(t);
    }
    return v;
}

/// n x n x n cubes of cube(), sharing their corners.
idas::io::volume grid(int n) {
    const idas::io::volume one = cube();
    idas::io::volume v;
    auto id = [&](int x, int y, int z) { return idas::index_t((z * (n + 1) + y) * (n + 1) + x); };
    for (int z = 0; z <= n; ++z)
        for (int y = 0; y <= n; ++y)
            for (int x = 0; x <= n; ++x)
                v.vertices.push_back(vec3{double(x), double(y), double(z)});
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x)
                for (const auto& t : one.tets) {
                    idas::tet_indices g{};
                    for (int k = 0; k < 4; ++k) {
                        const int c = int(t[k]);
                        g[k] = id(x + (c & 1), y + (c >> 1 & 1), z + (c >> 2 & 1));
                    }
                    v.tets.push_back(g);
                }
    return v;
}

} // namespace

TEST_CASE("harmonic check: a valid mesh passes at any thread count") {
    for (const int threads : {1, 2, 3}) {
        const tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
        CHECK(!idas::tool::check_harmonic_result(cube(), 2));
        CHECK(!idas::tool::check_harmonic_result(grid(6), 2));
    }
}

TEST_CASE("harmonic check: each defect is named") {
    idas::io::volume flat = grid(3);
    std::swap(flat.tets[17][0], flat.tets[17][1]);
    CHECK(idas::tool::check_harmonic_result(flat, 2) == "tet 17 is flat or inverted");

    idas::io::volume missing = cube();
    missing.tets[2][3] = 99;
    CHECK(idas::tool::check_harmonic_result(missing, 2) == "tet 2 references a missing vertex");

    // A third tet on the face (0, 1, 3) of the cube, on the far side of it.
    idas::io::volume crowded = cube();
    crowded.vertices.push_back(vec3{0.6, 0.6, -1});
    crowded.tets.push_back({0, 1, 3, 8});
    if (idas::orient3d(crowded.vertices[0], crowded.vertices[1], crowded.vertices[3],
                       crowded.vertices[8]) < 0)
        std::swap(crowded.tets.back()[1], crowded.tets.back()[2]);
    crowded.tets.push_back(crowded.tets[0]); // and a repeat of a tet: faces in three tets
    const auto answer = idas::tool::check_harmonic_result(crowded, 2);
    REQUIRE(answer);
    CHECK(answer->find("is shared by more than two tets") != std::string::npos);

    // Two cubes that touch at one corner: the boundary is pinched there.
    idas::io::volume pinched = cube();
    const idas::index_t n = idas::index_t(pinched.vertices.size());
    for (idas::index_t c = 0; c < 8; ++c)
        pinched.vertices.push_back(pinched.vertices[c] + vec3{1, 1, 1});
    const auto tets = pinched.tets;
    for (auto t : tets) {
        for (auto& x : t) x = x == 0 ? 7 : x + n; // the second cube's corner 0 is the first's 7
        pinched.tets.push_back(t);
    }
    const auto pinch = idas::tool::check_harmonic_result(pinched, 2);
    REQUIRE(pinch);
    CHECK(pinch->find("boundary") != std::string::npos);

    // The right mesh with the wrong characteristic expected.
    CHECK(idas::tool::check_harmonic_result(cube(), 0) ==
          "the boundary has Euler characteristic 2, the input's has 0");
}
