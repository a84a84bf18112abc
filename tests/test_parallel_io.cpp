// What runs in parallel around the algorithms (issue 20) gives what one thread gives: the
// OBJ reader in stretches, the block-parallel text writers, the surface and tet checks,
// and CGAL's parallel Delaunay, numbered by the points alone.
#include "test_support.hpp"

#include <idas/io/obj.hpp>
#include <idas/mesh/surface_check.hpp>
#include <idas/mesh/tet_mesh.hpp>

#if IDAS_HAS_CGAL
#include <idas/cgal/delaunay.hpp>
#include <idas/io/points.hpp>
#endif

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

using namespace idas;

namespace {

std::string file_text(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// Equal surfaces, attribute values compared bit for bit (NaN marks "none").
void check_same(const io::surface& a, const io::surface& b) {
    REQUIRE(a.vertices.size() == b.vertices.size());
    CHECK(a.vertices == b.vertices);
    CHECK(a.faces == b.faces);
    CHECK(a.header_lines == b.header_lines);
    REQUIRE(a.attributes.size() == b.attributes.size());
    for (std::size_t i = 0; i < a.attributes.size(); ++i) {
        const auto &x = a.attributes[i], &y = b.attributes[i];
        CHECK(x.name == y.name);
        CHECK(x.domain == y.domain);
        CHECK(x.width == y.width);
        CHECK(x.labels == y.labels);
        REQUIRE(x.values.size() == y.values.size());
        std::size_t differ = 0;
        for (std::size_t k = 0; k < x.values.size(); ++k)
            differ += std::memcmp(&x.values[k], &y.values[k], sizeof(double)) != 0;
        CHECK(differ == 0);
    }
}

/// The result, or the error message, of parsing `text` in `n` stretches.
struct outcome {
    std::optional<io::surface> surface;
    std::string error;
};
outcome parse_in(const std::string& text, std::size_t n) {
    try {
        return {io::detail::parse_obj_in(text, "memory.obj", {}, n), {}};
    } catch (const input_error& e) {
        return {std::nullopt, e.what()};
    }
}

void check_stretches_agree(const std::string& text) {
    const outcome one = parse_in(text, 1);
    for (std::size_t n : {2, 3, 7, 50}) {
        CAPTURE(n);
        const outcome many = parse_in(text, n);
        CHECK(many.error == one.error);
        REQUIRE(many.surface.has_value() == one.surface.has_value());
        if (one.surface) check_same(*one.surface, *many.surface);
    }
}

/// An OBJ with everything that carries state from line to line: relative and forward
/// indices, vt/vn streams, colours on some vertices, usemtl and g switching, polygons.
std::string stateful_obj() {
    std::string t = "mtllib a.mtl\n# a comment\n";
    for (int i = 0; i < 40; ++i) {
        t += "v " + std::to_string(i) + " " + std::to_string(i % 7) + " " + std::to_string(i % 3) +
             (i % 5 == 0 ? " 0.5 0.25 1\n" : "\n");
        t += "vt " + std::to_string(i * 0.01) + " 0.5\n";
        if (i % 4 == 0) t += "vn 0 0 1\n";
    }
    for (int i = 0; i < 30; ++i) {
        if (i % 6 == 0) t += "usemtl m" + std::to_string(i % 4) + "\n";
        if (i % 9 == 0) t += "g part" + std::to_string(i / 9) + "\n";
        // relative vertex indices, absolute vt, relative vn
        t += "f -" + std::to_string(40 - i) + "/" + std::to_string(i + 1) + "/-1 -" +
             std::to_string(39 - i) + "/" + std::to_string(i + 2) + " " + std::to_string(i + 3) +
             "/" + std::to_string(i + 3) + "\n";
        if (i % 10 == 0) t += "f 1 2 3 4\n"; // a quad, fanned
    }
    t += "f 41 1 2\n"; // a forward reference...
    t += "v 9 9 9\n";  // ...defined after it
    return t;
}

} // namespace

TEST_CASE("the OBJ reader gives the same surface in any number of stretches") {
    check_stretches_agree(stateful_obj());
    check_stretches_agree(file_text(test::data("blub.obj")));  // vt, vn, seams
    check_stretches_agree(file_text(test::data("bunny.obj"))); // plain v/f
}

TEST_CASE("the OBJ reader reports the first problem in the file in any number of stretches") {
    const std::string good = stateful_obj();
    const std::vector<std::string> bad = {
        good + "v 1 2 nan\n" + good,                // non-finite, midway
        good + good + "f 1 2 999999\n",             // forward reference never defined
        good + "f -999 1 2\n" + good,               // relative index before the first vertex
        good + "what is this\n" + good + "v 1 2\n", // not a statement, then another problem
        good + "f 1 1 2\n" + good + "f 0 1 2\n",    // degenerate, then index 0
        "v 1 2 3\n" + std::string(5000, '\n') + "f 1 2 3\n", // fewer than three distinct
    };
    for (const auto& text : bad) {
        const outcome one = parse_in(text, 1);
        CHECK_FALSE(one.surface);
        CHECK_FALSE(one.error.empty());
        check_stretches_agree(text);
    }
    // The line number counts the lines of earlier stretches.
    const outcome late = parse_in(good + "v 1 2 nan\n", 9);
    const auto lines = static_cast<std::size_t>(std::count(good.begin(), good.end(), '\n'));
    CHECK(late.error.find("line " + std::to_string(lines + 1)) != std::string::npos);
}

TEST_CASE("every OBJ of the fuzz corpus parses alike in one and in several stretches") {
    std::size_t files = 0;
    for (const auto& e :
         std::filesystem::directory_iterator(std::string(IDAS_FUZZ_CORPUS) + "/obj")) {
        CAPTURE(e.path().string());
        check_stretches_agree(file_text(e.path()));
        ++files;
    }
    CHECK(files > 3);
}

TEST_CASE("block-parallel writers keep every line in order") {
    // Enough vertices and faces for many blocks of the parallel writer.
    io::surface s = io::read_surface(test::data("bunny.obj"));
    for (int copy = 0; copy < 2; ++copy) {
        const auto n = static_cast<index_t>(s.vertices.size());
        const std::size_t faces = s.faces.size();
        for (std::size_t v = 0; v < n; ++v) s.vertices.push_back(s.vertices[v] + vec3{1.5, 0, 0});
        for (std::size_t f = 0; f < faces; ++f)
            s.faces.push_back({s.faces[f][0] + n, s.faces[f][1] + n, s.faces[f][2] + n});
    }
    REQUIRE(s.faces.size() > 8 * (1u << 14));
    for (const char* name : {"blocks.obj", "blocks.off", "blocks.ply"}) {
        CAPTURE(name);
        io::format_options ascii;
        ascii.encoding = io::encoding::ascii;
        tbb::task_arena arena(4);
        arena.execute([&] { io::write_surface(test::tmp(name), s, ascii); });
        const io::surface back = io::read_surface(test::tmp(name));
        CHECK(back.vertices == s.vertices);
        CHECK(back.faces == s.faces);
    }
}

TEST_CASE("the surface check says the same on one thread and on several") {
    const io::surface bunny = io::read_surface(test::data("bunny.obj"));
    io::surface broken = bunny;
    broken.faces[broken.faces.size() / 2] = broken.faces[broken.faces.size() / 3]; // doubled
    broken.faces.push_back({broken.faces[0][0], broken.faces[0][2], 35000});       // fan break
    for (const io::surface* s : {&bunny, static_cast<const io::surface*>(&broken)}) {
        surface_summary serial, parallel;
        tbb::task_arena(1).execute(
            [&] { serial = summarize_surface(s->vertices.size(), s->faces); });
        tbb::task_arena(4).execute(
            [&] { parallel = summarize_surface(s->vertices.size(), s->faces); });
        CHECK(serial.problem == parallel.problem);
        CHECK(serial.euler_characteristic == parallel.euler_characteristic);
        CHECK(serial.boundary_edges == parallel.boundary_edges);
        CHECK(serial.boundary_loops == parallel.boundary_loops);
    }
}

#if IDAS_HAS_CGAL
TEST_CASE("CGAL's parallel Delaunay gives the serial result, numbered alike") {
    // Gaussian points with exact duplicates, and a grid (every cube cospherical).
    std::vector<vec3> points = io::gaussian_points(20000, 3);
    // Enough points for the parallel insertion (fewer are triangulated on one thread).
    static_assert(20000 >= cgal::detail::parallel_delaunay_min_points);
    for (std::size_t i = 0; i < 500; ++i) points.push_back(points[i * 7]);
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j)
            for (int k = 0; k < 12; ++k) points.push_back({5.0 + i, 5.0 + j, 5.0 + k});
    const auto serial = cgal::delaunay_tetrahedralization(points, 1);
    CHECK(serial.duplicates == 500);
    for (std::size_t i = 0; i < 500; ++i) CHECK(serial.index_of[20000 + i] == invalid_index);
    for (unsigned threads : {2u, 4u}) {
        CAPTURE(threads);
        const auto parallel = cgal::delaunay_tetrahedralization(points, threads);
        CHECK(parallel.vertices == serial.vertices);
        CHECK(parallel.tets == serial.tets);
        CHECK(parallel.index_of == serial.index_of);
        CHECK(parallel.duplicates == serial.duplicates);
    }
    // Every tet positive, written from its smallest vertex, and the list sorted.
    std::size_t bad = 0;
    for (std::size_t t = 0; t < serial.tets.size(); ++t) {
        const auto& tv = serial.tets[t];
        const auto& p = serial.vertices;
        bad += orient3d(p[tv[0]], p[tv[1]], p[tv[2]], p[tv[3]]) <= 0;
        bad += tv[0] > tv[1] || tv[0] > tv[2] || tv[0] > tv[3];
        bad += t > 0 && !(serial.tets[t - 1] < tv);
    }
    CHECK(bad == 0);
    // The tet check of the mesh constructor accepts it.
    CHECK_NOTHROW(tet_mesh<>(serial.vertices, serial.tets));
}

TEST_CASE("CGAL's parallel Delaunay takes no more threads than the processors it may use") {
    // Its workers spin on locked cells: with more threads than processors a descheduled
    // holder stalls the rest (100k points on 8 threads of 2 cores: 305 s, not 0.5 s).
    const auto cores = static_cast<unsigned>(tbb::info::default_concurrency());
    CHECK(cgal::detail::delaunay_threads(1) == 1);
    CHECK(cgal::detail::delaunay_threads(cores) == cores);
    CHECK(cgal::detail::delaunay_threads(4 * cores + 3) == cores);
}
#endif

TEST_CASE("the tet mesh check reports the smallest bad face whatever the threads") {
    // Two tets on the same side of their shared face, far into a valid list.
    std::vector<vec3> V;
    std::vector<tet_indices> T;
    for (int i = 0; i < 3000; ++i) {
        const auto b = static_cast<index_t>(V.size());
        const double x = 3.0 * i;
        V.insert(V.end(), {{x, 0, 0}, {x + 1, 0, 0}, {x, 1, 0}, {x, 0, 1}});
        T.push_back({b, b + 1, b + 2, b + 3});
    }
    const auto b = static_cast<index_t>(V.size());
    V.push_back({0.2, 0.2, 0.2}); // on tet 0's side of its face (1, 2, 3)
    tet_indices overlapping = {1, 2, 3, b};
    if (orient3d(V[1], V[2], V[3], V[b]) < 0) std::swap(overlapping[0], overlapping[1]);
    T.push_back(overlapping);
    std::string serial, parallel;
    auto build = [&](std::string& message) {
        try {
            tet_mesh<> m(V, T);
        } catch (const input_error& e) {
            message = e.what();
        }
    };
    tbb::task_arena(1).execute([&] { build(serial); });
    tbb::task_arena(4).execute([&] { build(parallel); });
    CHECK(serial.find("overlap") != std::string::npos);
    CHECK(serial == parallel);
}
