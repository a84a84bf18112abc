// Inputs that libFuzzer (scripts/fuzz.sh) found crashing, hanging or exhausting memory in
// the readers; each case failed before its fix. The same inputs sit in
// tests/fuzz/corpus/<target>/crash_*, so every fuzz run replays them too.
#include "idas/io/io.hpp"
#include "idas/io/msh.hpp"
#include "idas/io/points.hpp"

#include <doctest/doctest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

using idas::input_error;
using namespace idas::io;

namespace {

/// The reader must refuse `bytes` with an input_error naming the source and every word.
template <class Parse>
void check_refused(Parse&& parse, std::string_view bytes,
                   std::initializer_list<std::string_view> words) {
    try {
        (void)parse(bytes, "in.file");
        FAIL("the input was accepted");
    } catch (const input_error& e) {
        const std::string msg = e.what();
        INFO("message: " << msg);
        CHECK(msg.starts_with("in.file: "));
        for (std::string_view word : words) CHECK(msg.find(word) != std::string::npos);
    }
}

/// Every attribute column holds `width` values per vertex, face or face corner.
void check_columns(const surface& s) {
    for (const attribute_column& a : s.attributes) {
        std::size_t elements = s.vertices.size();
        if (a.domain == attribute_domain::face) elements = s.faces.size();
        if (a.domain == attribute_domain::corner) elements = 3 * s.faces.size();
        INFO("attribute " << a.name);
        CHECK(a.values.size() == elements * a.width);
    }
}

const auto ply_points = [](std::string_view bytes, std::string_view source) {
    return parse_points(bytes, source, ".ply");
};

} // namespace

TEST_CASE("fuzz: every corpus input is read or refused with input_error, in this build too") {
    // scripts/fuzz.sh replays the corpus under sanitizers; this catches a regression in a
    // build without clang. Each folder is named after its target: the format comes first.
    namespace fs = std::filesystem;
    std::size_t files = 0;
    for (const auto& dir : fs::directory_iterator(IDAS_FUZZ_CORPUS)) {
        const std::string target = dir.path().filename().string();
        for (const auto& file : fs::directory_iterator(dir.path())) {
            const std::string name = file.path().string();
            INFO("input: " << name);
            const std::string bytes = detail::read_file(file.path());
            try {
                if (target == "obj")
                    check_columns(parse_obj(bytes, name));
                else if (target == "off")
                    check_columns(parse_off(bytes, name));
                else if (target.starts_with("ply"))
                    check_columns(parse_ply(bytes, name));
                else if (target.starts_with("stl"))
                    check_columns(parse_stl(bytes, name));
                else if (target.starts_with("msh"))
                    (void)parse_msh(bytes, name);
                else if (target == "points_xyz")
                    (void)parse_points(bytes, name, ".xyz");
                else if (target == "points_ply")
                    (void)parse_points(bytes, name, ".ply");
                else
                    FAIL("unknown corpus folder " << target);
            } catch (const input_error& e) {
                CHECK(std::string_view(e.what()).starts_with(name + ": "));
            }
            ++files;
        }
    }
    CHECK(files > 40);
}

TEST_CASE("fuzz: PLY points with a huge vertex count are refused before allocating") {
    // Used to allocate 4e9 points (96 GB) up front.
    check_refused(ply_points,
                  "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\n"
                  "property float y\nproperty float z\nend_header\n0 0 0\n",
                  {"truncated", "4000000000 vertices", "found 1"});
}

TEST_CASE("fuzz: PLY points with a huge count in an element before the vertices end") {
    // Used to loop 1e15 times over the end of the data.
    check_refused(ply_points,
                  "ply\nformat ascii 1.0\nelement camera 1000000000000000\nproperty float f\n"
                  "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                  "end_header\n0 0 0\n",
                  {"truncated", "1000000000000000 'camera' elements", "found 1"});
}

TEST_CASE("fuzz: binary PLY points whose element sizes overflow the offset are refused") {
    // 2 bytes times this count wrapped the read offset to 2^64 - 4, just before the
    // buffer, and the bounds check (offset + 8 > size) wrapped with it.
    const std::string header_start = "ply\nformat binary_little_endian 1.0\ncomment a\n";
    const std::string header_end = "property short s\nelement vertex 1\nproperty double x\n"
                                   "property double y\nproperty double z\nend_header\n";
    std::string bytes;
    for (std::size_t digits = 1; digits < 21 && bytes.empty(); ++digits) {
        const std::uint64_t header =
            header_start.size() + header_end.size() + std::strlen("element camera \n") + digits;
        const std::uint64_t count = (0 - header - 4) / 2;
        if ((header % 2) == 0 && std::to_string(count).size() == digits)
            bytes = header_start + "element camera " + std::to_string(count) + "\n" + header_end;
    }
    REQUIRE(!bytes.empty());
    bytes.append(24, '\0');
    check_refused(ply_points, bytes, {"truncated", "'camera' elements"});
}

TEST_CASE("fuzz: PLY points refuse a repeated coordinate property") {
    // "x x y" used to pass the three-axes check and silently give z = 0.
    check_refused(ply_points,
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                  "property float x\nproperty float y\nend_header\n1 2 3\n",
                  {"property x twice"});
}

TEST_CASE("fuzz: OBJ relative index INT64_MIN is refused without overflow") {
    // Negating the index to compare it with the vertex count overflowed (UBSan).
    check_refused(
        [](std::string_view b, std::string_view s) { return parse_obj(b, s); },
        "v 0 0 0\nv 1 0 0\nf 1 2 -9223372036854775808\n",
        {"line 3", "relative index -9223372036854775808", "points before the first vertex"});
}

TEST_CASE("fuzz: a PLY face with two texcoord lists is refused") {
    // Both lists' values went to the second column: the first "texcoord" corner column
    // was left with no values for a face that has three corners (found by the fuzz
    // harness's attribute check, tests/fuzz/fuzz_support.hpp).
    check_refused([](std::string_view b, std::string_view s) { return parse_ply(b, s); },
                  "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                  "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                  "property list uchar float texcoord\nproperty list uchar float texcoord\n"
                  "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 6 0 0 1 0 0 1 0\n",
                  {"two texcoord lists"});
}
