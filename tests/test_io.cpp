// File formats: round trips, the real data sets, and every kind of bad input the readers
// must refuse with a message that names the file and the problem.
#include "idas/io/io.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <sys/stat.h>
#include <vector>

namespace fs = std::filesystem;
using idas::index_t;
using idas::input_error;
using idas::tri_indices;
using idas::vec3;
using namespace idas::io;

namespace {

fs::path data_file(std::string_view name) {
    return fs::path(IDAS_DATA_DIR) / name;
}

fs::path tmp_file(std::string_view name) {
    fs::create_directories(IDAS_TEST_TMP);
    return fs::path(IDAS_TEST_TMP) / name;
}

/// Writes raw bytes (text or binary) to a scratch file and returns its path.
fs::path scratch(std::string_view name, std::string_view bytes) {
    const fs::path p = tmp_file(name);
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    REQUIRE(out.good());
    return p;
}

/// Reading `path` must fail with an input_error that starts with the path and mentions
/// every one of `words`.
void check_refused(const fs::path& path, std::initializer_list<std::string_view> words,
                   const read_options& options = {}) {
    INFO("file: " << path.string());
    try {
        (void)read_surface(path, options);
        FAIL("the file was accepted");
    } catch (const input_error& e) {
        const std::string msg = e.what();
        INFO("message: " << msg);
        CHECK(msg.starts_with(path.string() + ": "));
        for (std::string_view word : words) CHECK(msg.find(word) != std::string::npos);
    }
}

surface read_ok(const fs::path& path, const read_options& options = {}) {
    INFO("file: " << path.string());
    surface s;
    REQUIRE_NOTHROW(s = read_surface(path, options));
    return s;
}

/// Appends values in the given byte order (for hand-made binary PLY and STL files).
template <class T>
void put(std::string& out, T value, bool big_endian = false) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (big_endian != (std::endian::native == std::endian::big))
        std::reverse(bytes, bytes + sizeof(T));
    out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

/// A binary STL with the given header text and raw triangle corners.
std::string binary_stl(std::string_view header, const std::vector<std::array<vec3, 3>>& tris,
                       std::uint32_t claimed_count) {
    std::string out(header.substr(0, 80));
    out.resize(80, ' ');
    put(out, claimed_count);
    for (const auto& tri : tris) {
        for (int i = 0; i < 3; ++i) put(out, 0.0f);
        for (const vec3& p : tri)
            for (int axis = 0; axis < 3; ++axis) put(out, static_cast<float>(p[axis]));
        put(out, std::uint16_t{0});
    }
    return out;
}

std::string binary_stl(std::string_view header, const std::vector<std::array<vec3, 3>>& tris) {
    return binary_stl(header, tris, static_cast<std::uint32_t>(tris.size()));
}

/// Little PLY with a header, vertices as float x y z and triangles as uchar/int lists.
std::string binary_ply(std::uint64_t claimed_vertices, const std::vector<vec3>& vertices,
                       std::uint64_t claimed_faces, const std::vector<std::vector<int>>& faces,
                       bool big_endian = false) {
    std::string out =
        "ply\nformat " + std::string(big_endian ? "binary_big_endian" : "binary_little_endian") +
        " 1.0\nelement vertex " + std::to_string(claimed_vertices) +
        "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
        std::to_string(claimed_faces) + "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const vec3& p : vertices)
        for (int axis = 0; axis < 3; ++axis) put(out, static_cast<float>(p[axis]), big_endian);
    for (const auto& f : faces) {
        put(out, static_cast<std::uint8_t>(f.size()), big_endian);
        for (int v : f) put(out, static_cast<std::int32_t>(v), big_endian);
    }
    return out;
}

const std::vector<vec3> unit_quad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

std::string ascii_ply(std::string_view counts_and_body) {
    return "ply\nformat ascii 1.0\n" + std::string(counts_and_body);
}

/// Every face of `b` has the corner positions of the same face of `a`, each coordinate
/// passed through `round` (identity for double formats, float for STL).
template <class Round>
void check_same_geometry(const surface& a, const surface& b, Round round) {
    REQUIRE(a.faces.size() == b.faces.size());
    std::size_t mismatches = 0;
    for (std::size_t f = 0; f < a.faces.size(); ++f)
        for (std::size_t c = 0; c < 3; ++c) {
            const vec3& p = a.vertices[a.faces[f][c]];
            const vec3 expected{round(p.x), round(p.y), round(p.z)};
            if (!(b.vertices[b.faces[f][c]] == expected)) ++mismatches;
        }
    CHECK(mismatches == 0);
}

double to_float(double x) {
    return static_cast<double>(static_cast<float>(x));
}

/// Write then read back: exact for the double formats.
void check_exact_round_trip(const surface& original, const fs::path& path,
                            format_options options = {}) {
    write_surface(path, original, options);
    const surface back = read_ok(path);
    CHECK(back.vertices.size() == original.vertices.size());
    CHECK(back.faces == original.faces);
    CHECK(back.vertices == original.vertices);
}

/// Files in `dir` whose name contains ".tmp." (leftovers of write_atomically).
std::vector<fs::path> temp_files_in(const fs::path& dir) {
    std::vector<fs::path> found;
    for (const auto& entry : fs::directory_iterator(dir))
        if (entry.path().filename().string().find(".tmp.") != std::string::npos)
            found.push_back(entry.path());
    return found;
}

fs::path fresh_dir(std::string_view name) {
    const fs::path dir = tmp_file(name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

} // namespace

// ---- real data ------------------------------------------------------------------------

TEST_CASE("io: data sets load with the documented counts") {
    const surface bunny = read_ok(data_file("bunny.obj"));
    CHECK(bunny.vertices.size() == 35947);
    CHECK(bunny.faces.size() == 69451);

    const surface armadillo = read_ok(data_file("armadillo.obj"));
    CHECK(armadillo.vertices.size() == 43243);
    CHECK(armadillo.faces.size() == 86482);

    // Non-manifold, but a perfectly good file.
    const surface thingi = read_ok(data_file("37989_sf.obj"));
    CHECK(thingi.vertices.size() == 5233);
    CHECK(thingi.faces.size() == 11210);

    const surface fan = read_ok(data_file("edge_with_four_triangles.off"));
    CHECK(fan.vertices.size() == 6);
    CHECK(fan.faces.size() == 4);
    CHECK(fan.faces[0] == tri_indices{2, 1, 0});

    const surface small_bunny = read_ok(data_file("bunny.off"));
    CHECK(small_bunny.vertices.size() == 3485);
    CHECK(small_bunny.faces.size() == 6966);
}

TEST_CASE("io: blub.obj with v/vt/vn corners and a material library loads") {
    const surface blub = read_ok(data_file("blub.obj"));
    CHECK(blub.vertices.size() == 7106);
    CHECK(blub.faces.size() == 14208);
}

// ---- round trips ----------------------------------------------------------------------

TEST_CASE("io: OBJ round trip of bunny.off is exact") {
    check_exact_round_trip(read_ok(data_file("bunny.off")), tmp_file("rt_bunny.obj"));
}

TEST_CASE("io: OFF round trip of bunny.off is exact") {
    check_exact_round_trip(read_ok(data_file("bunny.off")), tmp_file("rt_bunny.off"));
}

TEST_CASE("io: ASCII PLY round trip of bunny.off is exact") {
    check_exact_round_trip(read_ok(data_file("bunny.off")), tmp_file("rt_bunny_ascii.ply"),
                           {encoding::ascii});
}

TEST_CASE("io: binary PLY round trip of bunny.off is exact") {
    check_exact_round_trip(read_ok(data_file("bunny.off")), tmp_file("rt_bunny_binary.ply"),
                           {encoding::binary});
}

TEST_CASE("io: round trips keep full double precision") {
    // Values whose shortest decimal form needs all 17 digits, and extremes.
    surface s;
    s.vertices = {{0.1, 1.0 / 3.0, -2.0 / 7.0},
                  {1e-300, -1e300, 4.9e-324},
                  {std::nextafter(1.0, 2.0), -0.0, 123456789.123456789}};
    s.faces = {{0, 1, 2}};
    check_exact_round_trip(s, tmp_file("rt_precise.obj"));
    check_exact_round_trip(s, tmp_file("rt_precise.off"));
    check_exact_round_trip(s, tmp_file("rt_precise_ascii.ply"), {encoding::ascii});
    check_exact_round_trip(s, tmp_file("rt_precise_binary.ply"), {encoding::binary});
}

TEST_CASE("io: ASCII STL round trip of bunny.off is float-exact and welds back") {
    const surface bunny = read_ok(data_file("bunny.off"));
    const fs::path p = tmp_file("rt_bunny_ascii.stl");
    write_surface(p, bunny, {encoding::ascii});
    const surface back = read_ok(p);
    CHECK(back.vertices.size() == bunny.vertices.size());
    check_same_geometry(bunny, back, to_float);
}

TEST_CASE("io: binary STL round trip of bunny.off is float-exact and welds back") {
    const surface bunny = read_ok(data_file("bunny.off"));
    const fs::path p = tmp_file("rt_bunny_binary.stl");
    write_surface(p, bunny, {encoding::binary});
    CHECK(fs::file_size(p) == 84 + 50 * bunny.faces.size());
    const surface back = read_ok(p);
    CHECK(back.vertices.size() == bunny.vertices.size());
    check_same_geometry(bunny, back, to_float);

    // Without welding every corner is its own vertex.
    const surface soup = read_ok(p, {.weld_stl = false});
    CHECK(soup.vertices.size() == 3 * bunny.faces.size());
    check_same_geometry(bunny, soup, to_float);
}

TEST_CASE("io: armadillo.obj survives a binary PLY round trip") {
    const surface armadillo = read_ok(data_file("armadillo.obj"));
    check_exact_round_trip(armadillo, tmp_file("rt_armadillo.ply"), {encoding::binary});
}

TEST_CASE("io: extensions are case-insensitive and unknown ones are refused") {
    const surface bunny = read_ok(data_file("bunny.off"));
    check_exact_round_trip(bunny, tmp_file("rt_upper.OBJ"));
    check_exact_round_trip(bunny, tmp_file("rt_mixed.Ply"), {encoding::ascii});
    CHECK_THROWS_WITH_AS(write_surface(tmp_file("mesh.xyz"), bunny),
                         doctest::Contains("unknown mesh file extension"), input_error);
    CHECK_THROWS_WITH_AS(read_surface(tmp_file("mesh.xyz")), doctest::Contains("mesh.xyz"),
                         input_error);
    CHECK_THROWS_AS(read_surface(tmp_file("no_extension")), input_error);
}

TEST_CASE("io: stream writers produce the same bytes as file writers") {
    const surface bunny = read_ok(data_file("bunny.off"));
    const fs::path p = tmp_file("stream_vs_file.ply");
    write_ply(p, bunny, encoding::binary);
    std::ostringstream os;
    write_ply(os, bunny, encoding::binary);
    std::ifstream in(p, std::ios::binary);
    const std::string from_file((std::istreambuf_iterator<char>(in)), {});
    CHECK(os.str() == from_file);
    CHECK(parse_ply(os.str(), "memory").faces == bunny.faces);
}

// ---- atomic writes ----------------------------------------------------------------------

TEST_CASE("io: writing into a missing directory fails and leaves nothing behind") {
    const fs::path dir = fresh_dir("atomic_missing_dir");
    const fs::path target = dir / "no_such_subdir" / "mesh.obj";
    CHECK_THROWS_AS(write_surface(target, read_ok(data_file("edge_with_four_triangles.off"))),
                    std::system_error);
    CHECK_FALSE(fs::exists(target));
    CHECK(temp_files_in(dir).empty());
}

TEST_CASE("io: a writer that throws midway leaves the old file and no temp file") {
    const fs::path dir = fresh_dir("atomic_throwing_writer");
    const fs::path target = dir / "mesh.off";
    write_surface(target, read_ok(data_file("edge_with_four_triangles.off")));
    const auto old_size = fs::file_size(target);

    CHECK_THROWS_WITH_AS(write_atomically(target,
                                          [](std::ostream& os) {
                                              os << "OFF\n6 4 0\n0 0 0\n"; // partial output
                                              throw std::runtime_error("disk on fire");
                                          }),
                         "disk on fire", std::runtime_error);
    CHECK(fs::file_size(target) == old_size);
    CHECK(read_ok(target).faces.size() == 4);
    CHECK(temp_files_in(dir).empty());

    // The same without a previous file: nothing at all appears.
    const fs::path fresh = dir / "never.off";
    CHECK_THROWS(write_atomically(fresh, [](std::ostream&) { throw 42; }));
    CHECK_FALSE(fs::exists(fresh));
    CHECK(temp_files_in(dir).empty());
}

TEST_CASE("io: an invalid surface is refused before any file is created") {
    const fs::path dir = fresh_dir("atomic_invalid_surface");
    surface bad;
    bad.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    bad.faces = {{0, 1, 7}};
    for (const char* name : {"bad.obj", "bad.off", "bad.ply", "bad.stl"}) {
        CHECK_THROWS_WITH_AS(write_surface(dir / name, bad),
                             doctest::Contains("references vertex 7"), input_error);
        CHECK_FALSE(fs::exists(dir / name));
    }
    bad.faces = {{0, 1, 2}};
    bad.vertices[1].y = std::nan("");
    CHECK_THROWS_WITH_AS(write_surface(dir / "nan.ply", bad), doctest::Contains("non-finite"),
                         input_error);
    bad.vertices[1].y = 1e300; // fine as double, not as float
    CHECK_NOTHROW(write_surface(dir / "big.ply", bad));
    CHECK_THROWS_WITH_AS(write_surface(dir / "big.stl", bad), doctest::Contains("single precision"),
                         input_error);
    CHECK(temp_files_in(dir).empty());
}

TEST_CASE("io: a successful write replaces the target with ordinary permissions") {
    const fs::path dir = fresh_dir("atomic_replace");
    const fs::path target = dir / "mesh.stl";
    { std::ofstream(target) << "old content"; }
    fs::permissions(target, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
    write_surface(target, read_ok(data_file("edge_with_four_triangles.off")));
    CHECK(read_ok(target).faces.size() == 4);
    CHECK(temp_files_in(dir).empty());
    // The replaced file keeps the permissions of the one it replaced, not mkstemp's 0600.
    CHECK(fs::status(target).permissions() ==
          (fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read));

    const fs::path created = dir / "new.obj";
    write_surface(created, read_ok(data_file("edge_with_four_triangles.off")));
    const mode_t mask = detail::current_umask();
    CHECK(static_cast<mode_t>(fs::status(created).permissions()) == (0666 & ~mask));
}

// ---- missing files ----------------------------------------------------------------------

TEST_CASE("io: OBJ missing file") {
    check_refused(tmp_file("does_not_exist.obj"), {"cannot open"});
}
TEST_CASE("io: OFF missing file") {
    check_refused(tmp_file("does_not_exist.off"), {"cannot open"});
}
TEST_CASE("io: PLY missing file") {
    check_refused(tmp_file("does_not_exist.ply"), {"cannot open"});
}
TEST_CASE("io: STL missing file") {
    check_refused(tmp_file("does_not_exist.stl"), {"cannot open"});
}

TEST_CASE("io: a directory is not a mesh file") {
    fs::create_directories(tmp_file("a_directory.obj"));
    check_refused(tmp_file("a_directory.obj"), {"cannot open", "directory"});
}

// ---- empty files ------------------------------------------------------------------------

TEST_CASE("io: OBJ empty file") {
    check_refused(scratch("empty.obj", ""), {"empty"});
    check_refused(scratch("blank.obj", "  \n\n \t\n"), {"empty"});
    check_refused(scratch("only_comments.obj", "# nothing here\ng group\n"), {"no vertices"});
}

TEST_CASE("io: OFF empty file") {
    check_refused(scratch("empty.off", ""), {"empty"});
    check_refused(scratch("only_comments.off", "# just a comment\n\n"), {"empty"});
}

TEST_CASE("io: PLY empty file") {
    check_refused(scratch("empty.ply", ""), {"empty"});
}

TEST_CASE("io: STL empty file") {
    check_refused(scratch("empty.stl", ""), {"empty"});
    check_refused(scratch("blank.stl", "\n\n"), {"empty"});
}

// ---- OBJ ----------------------------------------------------------------------------------

TEST_CASE("io: OBJ accepts v/vt/vn corners, relative indices, comments and groups") {
    const surface s = read_ok(scratch("forms.obj", "# a comment\n"
                                                   "mtllib x.mtl\n"
                                                   "o object\ng group\ns off\n"
                                                   "v 0 0 0\nv 1 0 0\nv 0 1 0 1.0\n"
                                                   "vt 0 0\nvn 0 0 1\n"
                                                   "usemtl m\n"
                                                   "f 1/1 2/1/1 3//1\n"
                                                   "v +0 0 1e-400\n"
                                                   "f -4 -2 -3 # trailing comment\n"
                                                   "\r\n"
                                                   "f 2 4 3\r\n"));
    REQUIRE(s.vertices.size() == 4);
    CHECK(s.faces == std::vector<tri_indices>{{0, 1, 2}, {0, 2, 1}, {1, 3, 2}});
    CHECK(s.vertices[3] == vec3{0, 0, 0});
}

TEST_CASE("io: OBJ faces may reference vertices defined later") {
    const surface s = read_ok(scratch("forward.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"));
    CHECK(s.faces.size() == 1);
    check_refused(scratch("forward_bad.obj", "v 0 0 0\nf 1 2 4\nv 1 0 0\nv 0 1 0\n"),
                  {"line 2", "references vertex 4", "only 3 vertices"});
}

TEST_CASE("io: OBJ truncated vertex line") {
    check_refused(scratch("truncated.obj", "v 0 0 0\nv 1 0 0\nv 0 1"),
                  {"line 3", "vertex 3", "fewer than 3 coordinates"});
}

TEST_CASE("io: OBJ garbage") {
    check_refused(scratch("garbage_number.obj", "v 0 0 0\nv 1 zero 0\n"),
                  {"line 2", "'zero'", "not a number"});
    check_refused(scratch("garbage_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n"),
                  {"line 4", "not a vertex index"});
    check_refused(scratch("garbage_binary.obj", std::string("\x7f\x01\x02\x00\xff", 5)),
                  {"line 1", "unexpected"});
    check_refused(scratch("garbage_plusminus.obj", "v +-1 0 0\n"), {"not a number"});
}

TEST_CASE("io: OBJ non-finite coordinates") {
    check_refused(scratch("nan.obj", "v 0 0 0\nv nan 0 0\n"), {"line 2", "vertex 2", "non-finite"});
    check_refused(scratch("inf.obj", "v 0 0 -inf\n"), {"vertex 1", "non-finite"});
    check_refused(scratch("overflow.obj", "v 0 1e999 0\n"), {"vertex 1", "non-finite"});
}

TEST_CASE("io: OBJ out-of-range indices") {
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    check_refused(scratch("range_high.obj", tri + "f 1 2 99\n"),
                  {"line 4", "face 1 references vertex 99 but there are only 3 vertices"});
    check_refused(scratch("range_zero.obj", tri + "f 0 1 2\n"), {"line 4", "vertex 0"});
    check_refused(scratch("range_relative.obj", tri + "f -1 -2 -4\n"),
                  {"line 4", "relative index -4"});
    check_refused(scratch("range_huge.obj", tri + "f 1 2 99999999999\n"), {"99999999999"});
    check_refused(scratch("range_overflow.obj", tri + "f 1 2 999999999999999999999\n"),
                  {"not a vertex index"});
}

TEST_CASE("io: OBJ degenerate face") {
    check_refused(scratch("degenerate.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n"),
                  {"line 4", "face 1", "degenerate", "vertex 2"});
    // Relative and absolute indices naming the same vertex are caught too.
    check_refused(scratch("degenerate_relative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 3 -1\n"),
                  {"degenerate", "vertex 3"});
}

TEST_CASE("io: OBJ polygons are fanned or refused") {
    const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    const surface s = read_ok(scratch("quad.obj", quad));
    CHECK(s.faces == std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
    check_refused(scratch("quad_refused.obj", quad), {"line 5", "face 1", "4 vertices"},
                  {.triangulate_polygons = false});
}

TEST_CASE("io: OBJ faces with fewer than three vertices") {
    check_refused(scratch("two_corners.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n"),
                  {"line 3", "face 1 has 2 vertices"});
    check_refused(scratch("no_corners.obj", "v 0 0 0\nf\n"), {"face 1 has 0 vertices"});
}

// ---- OFF ----------------------------------------------------------------------------------

TEST_CASE("io: OFF comments, header variants and face colours are accepted") {
    const surface s = read_ok(scratch("variants.off", "# leading comment\n"
                                                      "COFF # colours follow\n"
                                                      "\n"
                                                      "4 2 0\n"
                                                      "0 0 0 255 0 0 255\n"
                                                      "1 0 0 255 0 0 255 # inline comment\n"
                                                      "1 1 0 255 0 0 255\n"
                                                      "0 1 0 255 0 0 255\n"
                                                      "3 0 1 2 0.5 0.5 0.5\n"
                                                      "3 0 2 3\n"));
    CHECK(s.vertices.size() == 4);
    CHECK(s.faces == std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
    // Counts on the header line, no edge count.
    const surface t =
        read_ok(scratch("inline_counts.off", "OFF 3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
    CHECK(t.faces.size() == 1);
}

TEST_CASE("io: OFF truncated file") {
    check_refused(scratch("truncated_vertices.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n"),
                  {"truncated", "header says 4 vertices, found 3"});
    check_refused(scratch("truncated_faces.off", "OFF\n3 100 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
                  {"truncated", "header says 100 faces, found 1"});
    check_refused(scratch("truncated_face_line.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n"),
                  {"line 6", "face 0 announces 3 vertices but lists 2"});
    check_refused(scratch("truncated_counts.off", "OFF\n"), {"counts"});
}

TEST_CASE("io: OFF garbage") {
    check_refused(scratch("no_header.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
                  {"line 1", "missing OFF header"});
    check_refused(scratch("garbage_coordinate.off", "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"),
                  {"line 4", "vertex 1", "not a number"});
    check_refused(scratch("garbage_count.off", "OFF\nthree 1 0\n"),
                  {"line 2", "vertex count", "'three'"});
    check_refused(scratch("garbage_index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n"),
                  {"line 6", "face 0", "not a vertex index"});
    check_refused(scratch("binary.off", "OFF BINARY\n"), {"binary OFF"});
    check_refused(scratch("four_d.off", "4OFF\n"), {"not supported"});
}

TEST_CASE("io: OFF non-finite coordinates") {
    check_refused(scratch("nan.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 NaN 0\n3 0 1 2\n"),
                  {"line 5", "vertex 2", "non-finite"});
    check_refused(scratch("inf.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1e400 0\n3 0 1 2\n"),
                  {"vertex 2", "non-finite"});
}

TEST_CASE("io: OFF out-of-range indices") {
    const std::string head = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";
    check_refused(scratch("range_high.off", head + "3 0 1 99\n"),
                  {"line 6", "face 0 references vertex 99 but there are only 3 vertices"});
    check_refused(scratch("range_negative.off", head + "3 0 -1 2\n"),
                  {"line 6", "face 0 references vertex -1"});
}

TEST_CASE("io: OFF degenerate face") {
    check_refused(scratch("degenerate.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 0\n"),
                  {"line 6", "face 0", "degenerate", "vertex 0"});
}

TEST_CASE("io: OFF headers that lie about counts") {
    const std::string body = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n";
    // Too few faces declared: data remains.
    check_refused(scratch("lie_few_faces.off", "OFF\n4 1 0\n" + body),
                  {"line 8", "header says 1 faces", "more data"});
    // Too few vertices declared: a vertex line is read as a face.
    check_refused(scratch("lie_few_vertices.off", "OFF\n3 2 0\n" + body), {"line 6", "face 0"});
    // Too many vertices declared: a face line is read as a vertex.
    check_refused(scratch("lie_many_vertices.off", "OFF\n5 2 0\n" + body),
                  {"line 7", "vertex 4", "header's vertex count"});
    // Absurd counts neither allocate nor hang.
    check_refused(scratch("lie_huge_faces.off", "OFF\n4 4000000000 0\n" + body),
                  {"header says 4000000000 faces, found 2"});
    check_refused(scratch("lie_huge_vertices.off", "OFF\n4000000000 2 0\n" + body),
                  {"vertex 4", "gives a vertex 3 (position)", "header's vertex count"});
    check_refused(scratch("lie_too_big.off", "OFF\n99999999999 2 0\n" + body),
                  {"more than supported"});
    check_refused(scratch("lie_negative.off", "OFF\n-4 2 0\n" + body),
                  {"not a non-negative integer"});
    check_refused(scratch("lie_huge_polygon.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                                                  "4000000000 0 1 2\n"),
                  {"face 0 announces 4000000000 vertices but lists 3"});
}

TEST_CASE("io: OFF polygons are fanned or refused") {
    const std::string quad = "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    CHECK(read_ok(scratch("quad.off", quad)).faces ==
          std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
    check_refused(scratch("quad_refused.off", quad), {"line 7", "face 0", "polygon with 4"},
                  {.triangulate_polygons = false});
}

TEST_CASE("io: OFF faces with fewer than three vertices") {
    check_refused(scratch("two_corners.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n"),
                  {"line 6", "face 0 has 2 vertices"});
}

// ---- PLY ----------------------------------------------------------------------------------

TEST_CASE("io: PLY skips unknown properties, lists and elements in every encoding") {
    // One mesh, written three ways with extra data the reader must step over.
    const auto make = [](const std::string& format, bool big) {
        std::string out =
            "ply\r\nformat " + format +
            " 1.0\r\n"
            "comment made by hand\r\nobj_info nothing\r\n"
            "element material 2\r\nproperty uchar id\r\nproperty list uchar float rgb\r\n"
            "element vertex 4\r\nproperty double nx\r\nproperty float z\r\n"
            "property list ushort short tags\r\nproperty float x\r\nproperty float y\r\n"
            "element face 2\r\nproperty uchar flags\r\n"
            "property list uint ushort vertex_index\r\nproperty int16 group\r\n"
            "element empty 4000000000\r\n"
            "end_header\r\n";
        if (format == "ascii") {
            out += "7 3 0.1 0.2 0.3\n8 0\n";
            for (const vec3& p : unit_quad)
                out += "0.5 " + std::to_string(p.z) + " 2 -1 -2 " + std::to_string(p.x) + " " +
                       std::to_string(p.y) + "\n";
            out += "1 3 0 1 2 -5\n1 4 0 2 3 1 -5\n";
            return out;
        }
        put(out, std::uint8_t{7}, big);
        put(out, std::uint8_t{1}, big);
        put(out, 0.5f, big);
        put(out, std::uint8_t{8}, big);
        put(out, std::uint8_t{0}, big);
        for (const vec3& p : unit_quad) {
            put(out, 0.5, big);
            put(out, static_cast<float>(p.z), big);
            put(out, std::uint16_t{2}, big);
            put(out, std::int16_t{-1}, big);
            put(out, std::int16_t{-2}, big);
            put(out, static_cast<float>(p.x), big);
            put(out, static_cast<float>(p.y), big);
        }
        put(out, std::uint8_t{1}, big);
        put(out, std::uint32_t{3}, big);
        for (std::uint16_t v : {0, 1, 2}) put(out, v, big);
        put(out, std::int16_t{-5}, big);
        put(out, std::uint8_t{1}, big);
        put(out, std::uint32_t{4}, big);
        for (std::uint16_t v : {0, 2, 3, 1}) put(out, v, big);
        put(out, std::int16_t{-5}, big);
        return out;
    };
    for (const auto& [format, big] : {std::pair{std::string("ascii"), false},
                                      {std::string("binary_little_endian"), false},
                                      {std::string("binary_big_endian"), true}}) {
        CAPTURE(format);
        const surface s = read_ok(scratch("extras_" + format + ".ply", make(format, big)));
        CHECK(s.vertices == unit_quad);
        CHECK(s.faces == std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}, {0, 3, 1}});
    }
}

TEST_CASE("io: PLY binary big-endian with float coordinates") {
    const surface s = read_ok(
        scratch("big_endian.ply", binary_ply(4, unit_quad, 2, {{0, 1, 2}, {0, 2, 3}}, true)));
    CHECK(s.vertices == unit_quad);
    CHECK(s.faces == std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
}

TEST_CASE("io: PLY binary truncated file") {
    const std::string full = binary_ply(4, unit_quad, 2, {{0, 1, 2}, {0, 2, 3}});
    // Cut inside the vertices and inside the faces.
    const std::size_t header_end = full.find("end_header\n") + 11;
    check_refused(scratch("truncated_vertices.ply", full.substr(0, header_end + 30)),
                  {"truncated", "header says 4 vertices, found 2"});
    check_refused(scratch("truncated_faces.ply", full.substr(0, full.size() - 3)),
                  {"truncated", "header says 2 faces, found 1"});
    check_refused(scratch("truncated_header.ply", "ply\nformat binary_little_endian 1.0\n"),
                  {"no 'end_header'"});
}

TEST_CASE("io: PLY ascii truncated file") {
    check_refused(scratch("truncated_ascii.ply",
                          ascii_ply("element vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 100\n"
                                    "property list uchar int vertex_indices\nend_header\n"
                                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n")),
                  {"truncated", "header says 100 faces, found 2"});
    check_refused(scratch("truncated_ascii_list.ply",
                          ascii_ply("element vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 1\n"
                                    "property list uchar int vertex_indices\nend_header\n"
                                    "0 0 0\n1 0 0\n0 1 0\n3 0 1\n")),
                  {"truncated", "header says 1 faces, found 0"});
}

TEST_CASE("io: PLY garbage") {
    check_refused(scratch("no_magic.ply", "format ascii 1.0\nend_header\n"), {"not a PLY file"});
    check_refused(scratch("binary_garbage.ply", std::string("\x89PNG\r\n\x1a\n\0\0\0", 11)),
                  {"not a PLY file"});
    check_refused(
        scratch("unknown_format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n"),
        {"line 2", "unknown PLY format", "binary_middle_endian"});
    check_refused(scratch("no_format.ply", "ply\nelement vertex 0\nend_header\n"),
                  {"no 'format' line"});
    check_refused(scratch("unknown_type.ply",
                          ascii_ply("element vertex 1\nproperty float128 x\nend_header\n")),
                  {"line 4", "unknown PLY type", "float128"});
    check_refused(scratch("unknown_keyword.ply", ascii_ply("elephant vertex 1\nend_header\n")),
                  {"line 3", "unexpected header line"});
    check_refused(scratch("no_z.ply", ascii_ply("element vertex 1\nproperty float x\n"
                                                "property float y\nend_header\n0 0\n")),
                  {"no scalar property z"});
    check_refused(scratch("no_vertex.ply", ascii_ply("element face 0\nproperty list uchar int "
                                                     "vertex_indices\nend_header\n")),
                  {"no vertex element"});
    check_refused(
        scratch("no_indices.ply", ascii_ply("element vertex 0\nproperty float x\nproperty float y\n"
                                            "property float z\nelement face 0\nproperty int foo\n"
                                            "end_header\n")),
        {"no vertex_indices list"});
    check_refused(scratch("float_indices.ply",
                          ascii_ply("element vertex 0\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 0\n"
                                    "property list uchar float vertex_indices\nend_header\n")),
                  {"integer type"});
    check_refused(
        scratch("ascii_word.ply", ascii_ply("element vertex 1\nproperty float x\nproperty float y\n"
                                            "property float z\nproperty uchar red\nend_header\n"
                                            "0 0 0 red\n")),
        {"line 9", "'red'", "not a number"});
}

TEST_CASE("io: PLY non-finite coordinates") {
    std::vector<vec3> bad = unit_quad;
    bad[2].y = std::numeric_limits<double>::quiet_NaN();
    check_refused(scratch("nan_binary.ply", binary_ply(4, bad, 1, {{0, 1, 3}})),
                  {"vertex 2", "non-finite"});
    check_refused(scratch("inf_ascii.ply",
                          ascii_ply("element vertex 2\nproperty double x\nproperty double y\n"
                                    "property double z\nend_header\n0 0 0\n0 -inf 0\n")),
                  {"line 9", "vertex 1", "non-finite", "'-inf'"});
}

TEST_CASE("io: PLY out-of-range indices") {
    check_refused(scratch("range_binary.ply", binary_ply(4, unit_quad, 1, {{0, 1, 4}})),
                  {"face 0 references vertex 4 but there are only 4 vertices"});
    check_refused(scratch("range_binary_negative.ply", binary_ply(4, unit_quad, 1, {{0, -1, 2}})),
                  {"face 0 references vertex -1"});
    check_refused(scratch("range_ascii.ply",
                          ascii_ply("element vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 1\n"
                                    "property list uchar int vertex_indices\nend_header\n"
                                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 12\n")),
                  {"line 13", "face 0 references vertex 12 but there are only 3 vertices"});
}

TEST_CASE("io: PLY degenerate face") {
    check_refused(scratch("degenerate.ply", binary_ply(4, unit_quad, 2, {{0, 1, 2}, {3, 2, 3}})),
                  {"face 1", "degenerate", "vertex 3"});
}

TEST_CASE("io: PLY headers that lie about counts") {
    const std::vector<std::vector<int>> faces = {{0, 1, 2}, {0, 2, 3}};
    // Too few declared: data left over.
    check_refused(scratch("lie_few_faces.ply", binary_ply(4, unit_quad, 1, faces)),
                  {"13 bytes of data unread"});
    check_refused(scratch("lie_few_ascii.ply",
                          ascii_ply("element vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n")),
                  {"line 11", "data continues"});
    // Too many declared, including absurd counts: an error, quickly, without a huge allocation.
    check_refused(scratch("lie_many_vertices.ply", binary_ply(4000000000, unit_quad, 2, faces)),
                  {"truncated", "header says 4000000000 vertices"});
    check_refused(scratch("lie_many_faces.ply", binary_ply(4, unit_quad, 4000000000, faces)),
                  {"truncated", "header says 4000000000 faces, found 2"});
    check_refused(
        scratch("lie_too_many_vertices.ply", binary_ply(99999999999, unit_quad, 2, faces)),
        {"more than supported"});
    // A list length beyond the data.
    std::string huge_list = binary_ply(4, unit_quad, 1, {});
    huge_list += std::string("\xff\x00\x00\x00\x01", 5);
    check_refused(scratch("lie_list_length.ply", huge_list), {"truncated", "found 0"});
    // Lists with an int count can claim two billion items.
    std::string header =
        "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list int int vertex_indices\nend_header\n";
    put(header, std::int32_t{2000000000});
    put(header, std::int32_t{0});
    check_refused(scratch("lie_int_list_length.ply", header), {"truncated"});
    std::string negative = header.substr(0, header.size() - 8);
    put(negative, std::int32_t{-3});
    check_refused(scratch("negative_list_length.ply", negative), {"negative list length"});
}

TEST_CASE("io: PLY polygons are fanned or refused") {
    const std::string quad = binary_ply(4, unit_quad, 1, {{0, 1, 2, 3}});
    CHECK(read_ok(scratch("quad.ply", quad)).faces ==
          std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
    check_refused(scratch("quad_refused.ply", quad), {"face 0", "polygon with 4"},
                  {.triangulate_polygons = false});
}

TEST_CASE("io: PLY faces with fewer than three vertices") {
    check_refused(scratch("two_corners.ply", binary_ply(4, unit_quad, 1, {{0, 1}})),
                  {"face 0 has 2 vertices"});
    check_refused(scratch("no_corners.ply", binary_ply(4, unit_quad, 1, {{}})),
                  {"face 0 has 0 vertices"});
}

// ---- STL ----------------------------------------------------------------------------------

namespace {
const std::vector<std::array<vec3, 3>> two_triangles = {
    {vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{1, 1, 0}}, {vec3{0, 0, 0}, vec3{1, 1, 0}, vec3{0, 1, 0}}};

std::string ascii_stl_facet(const std::array<std::string, 3>& corners) {
    std::string out = "facet normal 0 0 1\n outer loop\n";
    for (const std::string& c : corners) out += "  vertex " + c + "\n";
    return out + " endloop\nendfacet\n";
}
} // namespace

TEST_CASE("io: STL binary welds shared corners unless told not to") {
    const fs::path p = scratch("weld.stl", binary_stl("made by hand", two_triangles));
    const surface welded = read_ok(p);
    CHECK(welded.vertices.size() == 4);
    CHECK(welded.faces == std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
    const surface soup = read_ok(p, {.weld_stl = false});
    CHECK(soup.vertices.size() == 6);
    CHECK(soup.faces == std::vector<tri_indices>{{0, 1, 2}, {3, 4, 5}});
}

TEST_CASE("io: STL binary whose header starts with 'solid' is still binary") {
    const surface s = read_ok(scratch("solid_binary.stl", binary_stl("solid lies", two_triangles)));
    CHECK(s.vertices.size() == 4);
    CHECK(s.faces.size() == 2);
}

TEST_CASE("io: STL ascii with several solids, mixed case and -0") {
    const std::string text = "solid first one\n" + ascii_stl_facet({"0 0 0", "1 0 0", "1 1 0"}) +
                             "endsolid first one\nSOLID second\n"
                             "FACET NORMAL nan nan nan\nOUTER LOOP\nVERTEX -0 0 0\n"
                             "VERTEX 1 1 0\nVERTEX 0 1 0\nENDLOOP\nENDFACET\nENDSOLID second\n";
    const surface s = read_ok(scratch("multi_solid.stl", text));
    CHECK(s.vertices.size() == 4); // -0 welds with 0
    CHECK(s.faces == std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
}

TEST_CASE("io: STL binary truncated file") {
    const std::string full = binary_stl("hand made", two_triangles);
    check_refused(scratch("truncated_short.stl", full.substr(0, 40)),
                  {"truncated", "at least 84 bytes"});
    check_refused(scratch("truncated_facet.stl", full.substr(0, full.size() - 10)),
                  {"header says 2 triangles", "184 bytes", "file has 174 bytes"});
    // A binary file whose header begins with "solid" must not be mistaken for bad ASCII.
    const std::string solid = binary_stl("solid but binary", two_triangles);
    check_refused(scratch("truncated_solid.stl", solid.substr(0, solid.size() - 10)),
                  {"header says 2 triangles"});
}

TEST_CASE("io: STL binary count that lies about the file size") {
    check_refused(scratch("lie_more.stl", binary_stl("hand made", two_triangles, 3)),
                  {"header says 3 triangles", "184 bytes", "file has 184"});
    check_refused(scratch("lie_huge.stl", binary_stl("hand made", two_triangles, 4000000000u)),
                  {"header says 4000000000 triangles"});
    check_refused(scratch("lie_fewer.stl", binary_stl("hand made", two_triangles, 1)),
                  {"header says 1 triangles", "134 bytes"});
}

TEST_CASE("io: STL ascii truncated file") {
    const std::string full =
        "solid s\n" + ascii_stl_facet({"0 0 0", "1 0 0", "1 1 0"}) + "endsolid s\n";
    check_refused(scratch("truncated_ascii.stl", full.substr(0, full.find("endloop"))),
                  {"truncated", "facet 0"});
    check_refused(scratch("truncated_ascii_end.stl", full.substr(0, full.find("endsolid"))),
                  {"truncated", "endsolid"});
    check_refused(scratch("truncated_ascii_number.stl", "solid s\nfacet normal 0 0"),
                  {"truncated", "facet 0"});
}

TEST_CASE("io: STL ascii garbage") {
    check_refused(scratch("garbage_keyword.stl", "solid s\nfacet normal 0 0 1\nouter lop\n"),
                  {"line 3", "expected 'loop'", "'lop'"});
    check_refused(scratch("garbage_number.stl",
                          "solid s\n" + ascii_stl_facet({"0 0 0", "1 zero 0", "1 1 0"})),
                  {"line 5", "'zero'", "not a number"});
    check_refused(scratch("garbage_text.stl", "this is not an STL file at all, not even close. "
                                              "It just rambles on for a bit longer than 84 "
                                              "bytes so the size rule is exercised.\n"),
                  {"binary STL header says"});
    check_refused(scratch("garbage_after.stl", "solid s\nendsolid s\nsomething else\n"),
                  {"line 3", "expected 'solid'"});
}

TEST_CASE("io: STL non-finite coordinates") {
    std::vector<std::array<vec3, 3>> bad = two_triangles;
    bad[1][2].z = std::numeric_limits<double>::infinity();
    check_refused(scratch("inf_binary.stl", binary_stl("hand made", bad)),
                  {"facet 1, corner 2", "non-finite"});
    check_refused(
        scratch("nan_ascii.stl",
                "solid s\n" + ascii_stl_facet({"0 0 0", "1 0 0", "nan 1 0"}) + "endsolid s\n"),
        {"line 6", "facet 0, corner 2", "non-finite"});
}

TEST_CASE("io: STL facets that welding makes degenerate are dropped and counted") {
    std::vector<std::array<vec3, 3>> bad = two_triangles;
    bad[1][2] = bad[1][0];
    const fs::path p = scratch("degenerate.stl", binary_stl("hand made", bad));
    const surface welded = read_ok(p);
    CHECK(welded.faces.size() == 1);
    CHECK(welded.dropped_faces == 1);
    // Unwelded, the corners are distinct vertices and nothing is dropped.
    const surface soup = read_ok(p, {.weld_stl = false});
    CHECK(soup.faces.size() == 2);
    CHECK(soup.dropped_faces == 0);
}

TEST_CASE("io: a face with distinct vertices at one position survives an STL round trip") {
    // Vertices 0 and 3 share a position: valid indexed input, but STL keeps positions only.
    surface s;
    s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}, {0, 0, 1}};
    s.faces = {{0, 1, 2}, {0, 3, 4}};
    for (const encoding enc : {encoding::binary, encoding::ascii}) {
        const fs::path p = tmp_file(enc == encoding::binary ? "shared_position_binary.stl"
                                                            : "shared_position_ascii.stl");
        write_surface(p, s, {enc});
        const surface back = read_ok(p);
        CHECK(back.faces.size() == 1);
        CHECK(back.dropped_faces == 1);
        CHECK(back.vertices.size() == 3);
    }
}

TEST_CASE("io: STL ascii polygons are fanned or refused, short loops refused") {
    const std::string quad = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                             "vertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\n"
                             "endsolid s\n";
    CHECK(read_ok(scratch("quad.stl", quad)).faces ==
          std::vector<tri_indices>{{0, 1, 2}, {0, 2, 3}});
    check_refused(scratch("quad_refused.stl", quad), {"face 0", "polygon with 4"},
                  {.triangulate_polygons = false});
    check_refused(scratch("short_loop.stl", "solid s\nfacet normal 0 0 1\nouter loop\n"
                                            "vertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n"
                                            "endsolid s\n"),
                  {"face 0 has 2 vertices"});
}

// ---- in-memory parsing ---------------------------------------------------------------

TEST_CASE("io: parse functions name the given source in errors") {
    CHECK_THROWS_WITH_AS(parse_off("OFF\n1 0 0\n0 0\n", "memory:mesh"),
                         doctest::Contains("memory:mesh: line 3"), input_error);
    CHECK_THROWS_WITH_AS(parse_obj("", "memory:obj"), "memory:obj: file is empty", input_error);
    CHECK(parse_obj("\xEF\xBB\xBFv 0 0 0\n", "bom").vertices.size() == 1);
}
