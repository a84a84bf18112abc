// Attributes through the file formats (issue 21): what a file carries beyond positions and
// triangles is read into io::surface::attributes and written back bit for bit.
#include "idas/io/io.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace fs = std::filesystem;
using namespace idas::io;

namespace {

fs::path tmp_path(std::string_view name) {
    fs::create_directories(IDAS_TEST_TMP);
    return fs::path(IDAS_TEST_TMP) / name;
}

fs::path scratch(std::string_view name, std::string_view bytes) {
    const fs::path p = tmp_path(name);
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    REQUIRE(out.good());
    return p;
}

/// Bit-for-bit equality of two value arrays (NaN equal to NaN with the same bits).
bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (std::bit_cast<std::uint64_t>(a[i]) != std::bit_cast<std::uint64_t>(b[i])) return false;
    return true;
}

/// Everything of `a` is in `b`: positions, faces and every attribute, bit for bit.
void check_same(const surface& a, const surface& b) {
    REQUIRE(a.vertices.size() == b.vertices.size());
    REQUIRE(a.faces.size() == b.faces.size());
    for (std::size_t v = 0; v < a.vertices.size(); ++v)
        for (int k = 0; k < 3; ++k) CHECK(a.vertices[v][k] == b.vertices[v][k]);
    CHECK(a.faces == b.faces);
    REQUIRE(a.attributes.size() == b.attributes.size());
    for (const attribute_column& x : a.attributes) {
        INFO("attribute " << x.name);
        const attribute_column* y = find_attribute(b, x.name, x.domain);
        REQUIRE(y != nullptr);
        CHECK(y->type == x.type);
        CHECK(y->width == x.width);
        CHECK(same_bits(x.values, y->values));
        CHECK(x.labels == y->labels);
    }
}

} // namespace

TEST_CASE("attribute io: blub.obj keeps its texture coordinates, seams and mtllib") {
    const surface s = read_surface(fs::path(IDAS_DATA_DIR) / "blub.obj");
    const attribute_column* uv = find_attribute(s, "uv", attribute_domain::corner);
    REQUIRE(uv != nullptr);
    CHECK(uv->width == 2);
    CHECK(uv->values.size() == 6 * s.faces.size());
    REQUIRE(s.header_lines.size() == 1);
    CHECK(s.header_lines[0] == "mtllib ./blub.mtl");
    // Seams: some vertex has two different texture coordinates in two of its faces.
    std::vector<double> first(2 * s.vertices.size(), std::nan(""));
    std::size_t seam_corners = 0;
    for (std::size_t c = 0; c < 3 * s.faces.size(); ++c) {
        const auto v = s.faces[c / 3][c % 3];
        CHECK(!std::isnan(uv->values[2 * c]));
        if (std::isnan(first[2 * v]))
            first[2 * v] = uv->values[2 * c], first[2 * v + 1] = uv->values[2 * c + 1];
        else if (first[2 * v] != uv->values[2 * c] || first[2 * v + 1] != uv->values[2 * c + 1])
            ++seam_corners;
    }
    CHECK(seam_corners > 0);

    const fs::path out = tmp_path("blub_roundtrip.obj");
    write_surface(out, s);
    const surface back = read_surface(out);
    check_same(s, back);
    CHECK(back.header_lines == s.header_lines);

    // Skipping attributes on request.
    read_options bare;
    bare.attributes = false;
    CHECK(read_surface(out, bare).attributes.empty());
}

TEST_CASE("attribute io: OBJ normals, colours, materials, groups, polygons, faces without vt") {
    const fs::path in = scratch("attrs.obj", "mtllib a.mtl\n"
                                             "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\n"
                                             "v 0 1 0 0.5 0.25 0.125\nv 2 0 0 0 0 0\n"
                                             "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                             "vn 0 0 1\nvn 0 0 -1\n"
                                             "g left part\nusemtl red\n"
                                             "f 1/1/1 2/2/1 3/3/1 4/4/1\n"
                                             "usemtl blue\ng right\n"
                                             "f 2//2 5//2 3//2\n");
    const surface s = read_surface(in);
    REQUIRE(s.faces.size() == 3); // the quad as two triangles of a fan
    const auto* uv = find_attribute(s, "uv", attribute_domain::corner);
    const auto* normal = find_attribute(s, "normal", attribute_domain::corner);
    const auto* color = find_attribute(s, "color", attribute_domain::vertex);
    const auto* material = find_attribute(s, "material", attribute_domain::face);
    const auto* group = find_attribute(s, "group", attribute_domain::face);
    REQUIRE((uv && normal && color && material && group));
    // The fan's second triangle uses corners 1, 3, 4 of the quad.
    CHECK(uv->values[6] == 0);
    CHECK(uv->values[8] == 1);
    CHECK(uv->values[10] == 0);
    CHECK(uv->values[11] == 1);
    CHECK(std::isnan(uv->values[12])); // the last face has no vt
    CHECK(normal->values[3 * 6 + 2] == -1);
    CHECK(color->values[3 * 3 + 2] == 0.125);
    CHECK(material->labels == std::vector<std::string>{"red", "blue"});
    CHECK(material->values == std::vector<double>{0, 0, 1});
    CHECK(group->labels == std::vector<std::string>{"left part", "right"});

    const fs::path out = tmp_path("attrs_roundtrip.obj");
    write_surface(out, s);
    check_same(s, read_surface(out));
    CHECK(unstored_attributes(out, s).empty());
    // OFF keeps the vertex colours; corner values and named tags it cannot hold.
    CHECK(unstored_attributes(tmp_path("attrs.off"), s) ==
          std::vector<std::string>{"uv (corner)", "normal (corner)", "material (face)",
                                   "group (face)"});
}

TEST_CASE("attribute io: PLY properties of every type, binary and ASCII, both byte orders") {
    // A coloured, textured square with one property of every type.
    std::string header = "ply\nformat ascii 1.0\nelement vertex 4\n"
                         "property float x\nproperty float y\nproperty float z\n"
                         "property uchar red\nproperty char offset\nproperty ushort id\n"
                         "property short level\nproperty float quality\nproperty double u\n"
                         "element face 2\nproperty list uchar int vertex_indices\n"
                         "property uint label\nproperty int region\n"
                         "property list uchar float texcoord\nend_header\n";
    const std::string body = "0 0 0 255 -7 65535 -300 0.1 0.333\n"
                             "1 0 0 0 127 1 32767 1e-7 1e300\n"
                             "1 1 0 17 -128 2 -32768 3.5 -2.5\n"
                             "0 1 0 200 0 3 0 -0 0.1\n"
                             "3 0 1 2 4000000000 -5 6 0 0 1 0 1 1\n"
                             "3 0 2 3 7 2147483647 6 0 0 1 1 0 1\n";
    const surface s = read_surface(scratch("props.ply", header + body));
    REQUIRE(s.attributes.size() == 9);
    const auto* quality = find_attribute(s, "quality", attribute_domain::vertex);
    REQUIRE(quality);
    CHECK(quality->type == scalar_type::float32);
    CHECK(quality->values[0] == double(0.1f)); // parsed as a float, as binary gives it
    const auto* label = find_attribute(s, "label", attribute_domain::face);
    REQUIRE(label);
    CHECK(label->type == scalar_type::uint32);
    CHECK(label->values[0] == 4000000000.0);
    const auto* tc = find_attribute(s, "texcoord", attribute_domain::corner);
    REQUIRE(tc);
    CHECK(tc->width == 2);
    CHECK(tc->values.size() == 12);

    for (const auto enc : {encoding::binary, encoding::ascii}) {
        const fs::path out = tmp_path(enc == encoding::binary ? "props_bin.ply" : "props_asc.ply");
        format_options o;
        o.encoding = enc;
        write_surface(out, s, o);
        check_same(s, read_surface(out));
    }
    // Big-endian input gives the same values.
    {
        std::string big = "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
                          "property float x\nproperty float y\nproperty float z\n"
                          "property short level\nelement face 1\n"
                          "property list uchar int vertex_indices\nend_header\n";
        const auto put_be = [&](auto value) {
            unsigned char bytes[sizeof value];
            std::memcpy(bytes, &value, sizeof value);
            for (std::size_t i = sizeof value; i-- > 0;) big.push_back(static_cast<char>(bytes[i]));
        };
        const float xs[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        const std::int16_t levels[3] = {-2, 300, 7};
        for (int v = 0; v < 3; ++v) {
            for (float x : xs[v]) put_be(x);
            put_be(levels[v]);
        }
        big.push_back(3);
        for (std::int32_t i : {0, 1, 2}) put_be(i);
        const surface b = read_surface(scratch("big.ply", big));
        const auto* level = find_attribute(b, "level", attribute_domain::vertex);
        REQUIRE(level);
        CHECK(level->values == std::vector<double>{-2, 300, 7});
    }
    // A texcoord list that does not match the corners is refused, naming the face.
    const std::string bad_body = "0 0 0 255 -7 65535 -300 0.1 0.333\n"
                                 "1 0 0 0 127 1 32767 1e-7 1e300\n"
                                 "1 1 0 17 -128 2 -32768 3.5 -2.5\n"
                                 "0 1 0 200 0 3 0 -0 0.1\n"
                                 "3 0 1 2 4 -5 4 0 0 1 0\n"
                                 "3 0 2 3 7 2 6 0 0 1 1 0 1\n";
    const fs::path bad = scratch("bad_texcoord.ply", header + bad_body);
    try {
        (void)read_surface(bad);
        FAIL("accepted");
    } catch (const idas::input_error& e) {
        const std::string msg = e.what();
        CHECK(msg.starts_with(bad.string()));
        CHECK(msg.find("face 0 has 4 texcoord values for 3 corners") != std::string::npos);
    }
    // Values that do not fit the property's type are refused in ASCII.
    for (const char* wrong : {"-7e9", "2.5", "128"}) {
        std::string overflow = header + body;
        overflow.replace(overflow.find("255 -7"), 6, std::string("255 ") + wrong);
        const fs::path p = scratch("wide.ply", overflow);
        CHECK_THROWS_WITH_AS((void)read_surface(p), doctest::Contains("does not fit in a PLY char"),
                             idas::input_error);
    }
}

TEST_CASE("attribute io: STL keeps the facets' attribute words") {
    surface s;
    s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    s.faces = {{0, 1, 2}, {1, 3, 2}};
    s.attributes.push_back(
        {"stl_attribute", attribute_domain::face, scalar_type::uint16, 1, {0x7c1f, 65535}, {}});
    const fs::path out = tmp_path("words.stl");
    write_surface(out, s);
    check_same(s, read_surface(out));
    CHECK(unstored_attributes(out, s).empty());
    format_options text;
    text.encoding = encoding::ascii;
    CHECK(unstored_attributes(out, s, text).size() == 1);
}

TEST_CASE("attribute io: writers refuse attribute columns of the wrong size") {
    surface s;
    s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    s.faces = {{0, 1, 2}};
    s.attributes.push_back(
        {"quality", attribute_domain::vertex, scalar_type::float32, 1, {1, 2}, {}});
    CHECK_THROWS_WITH_AS(write_surface(tmp_path("short.ply"), s),
                         doctest::Contains("vertex attribute \"quality\" has 2 values"),
                         idas::input_error);
}

TEST_CASE("attribute io: OFF normals, colours, texture coordinates and face colours") {
    // A quad and a triangle: the quad's colour goes to both of its triangles; the triangle
    // has none (NaN). Integer colours 0..255 are bytes, fractions doubles.
    const surface s = read_surface(scratch("stcn.off", "STCNOFF\n4 2 0\n"
                                                       "0 0 0  0 0 1  255 0 0 255  0 0\n"
                                                       "1 0 0  0 0 1  0 255 0 255  1 0\n"
                                                       "1 1 0  0 0 1  0 0 255 128  1 1\n"
                                                       "0 1 0  0 0 1  9 9 9 0      0 1\n"
                                                       "4 0 1 2 3 0.25 0.5 0.75\n"
                                                       "3 0 2 3\n"));
    REQUIRE(s.faces.size() == 3);
    const attribute_column* normal = find_attribute(s, "normal", attribute_domain::vertex);
    const attribute_column* colour = find_attribute(s, "color", attribute_domain::vertex);
    const attribute_column* uv = find_attribute(s, "uv", attribute_domain::vertex);
    const attribute_column* face_colour = find_attribute(s, "color", attribute_domain::face);
    REQUIRE(normal);
    REQUIRE(colour);
    REQUIRE(uv);
    REQUIRE(face_colour);
    CHECK(colour->width == 4);
    CHECK(colour->type == scalar_type::uint8);
    CHECK(colour->values[11] == 128);
    CHECK(uv->values == std::vector<double>{0, 0, 1, 0, 1, 1, 0, 1});
    CHECK(face_colour->type == scalar_type::float64);
    CHECK(face_colour->values[3] == 0.25); // the quad's second triangle
    CHECK(std::isnan(face_colour->values[6]));
    // Written back with the same header and read again bit for bit.
    const fs::path out = tmp_path("stcn_out.off");
    write_surface(out, s);
    CHECK(unstored_attributes(out, s).empty());
    check_same(s, read_surface(out));
    std::ifstream in(out);
    std::string header;
    std::getline(in, header);
    CHECK(header == "STCNOFF");
    // Attributes off: positions and faces only.
    read_options plain;
    plain.attributes = false;
    CHECK(read_surface(out, plain).attributes.empty());
}

TEST_CASE("attribute io: OFF colours through other formats, and what OFF cannot hold") {
    // A colour-map index per face, as Geomview's own files have.
    const surface indexed =
        read_surface(scratch("index.off", "OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 7\n"));
    const attribute_column* index = find_attribute(indexed, "color_index", attribute_domain::face);
    REQUIRE(index);
    CHECK(index->values == std::vector<double>{7});
    // A coloured OFF becomes a coloured PLY (uchar red, green, blue) and comes back.
    const surface coloured = read_surface(scratch("c.off", "COFF\n3 1\n0 0 0 10 20 30\n"
                                                           "1 0 0 40 50 60\n0 1 0 70 80 90\n"
                                                           "3 0 1 2\n"));
    const fs::path ply = tmp_path("c.ply");
    write_surface(ply, coloured);
    CHECK(unstored_attributes(ply, coloured).empty());
    const surface back = read_surface(ply);
    CHECK(find_attribute(back, "red", attribute_domain::vertex)->values ==
          std::vector<double>{10, 40, 70});
    // Corner uv (an OBJ's seams) cannot go into OFF: the writer's caller is told.
    surface seamed = coloured;
    seamed.attributes.push_back(
        {"uv", attribute_domain::corner, scalar_type::float64, 2, {0, 0, 1, 0, 0, 1}, {}});
    CHECK(unstored_attributes(tmp_path("seams.off"), seamed) ==
          std::vector<std::string>{"uv (corner)"});
}

TEST_CASE("attribute io: OFF lines that do not match their header are refused") {
    const auto refused = [](std::string_view name, std::string_view text,
                            std::vector<std::string> parts) {
        const fs::path p = scratch(name, text);
        try {
            (void)read_surface(p);
            FAIL("accepted " << name);
        } catch (const idas::input_error& e) {
            for (const std::string& part : parts)
                CHECK(std::string(e.what()).find(part) != std::string::npos);
        }
    };
    refused("short_colour.off", "COFF\n3 1\n0 0 0 1 1\n1 0 0 1 1\n0 1 0 1 1\n3 0 1 2\n",
            {"vertex 0 has 5 values", "3 or 4 (colour)"});
    refused("mixed_colour.off", "COFF\n3 1\n0 0 0 1 1 1\n1 0 0 1 1 1 1\n0 1 0 1 1 1\n3 0 1 2\n",
            {"vertex 1", "3 (colour, as earlier vertices)"});
    refused("no_normal.off", "NOFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            {"vertex 0 has 3 values", "3 (normal)"});
    refused("word_colour.off", "OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 red\n",
            {"face 0", "'red' is not a finite number"});
    refused("two_values.off", "OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 1\n",
            {"face 0 has 2 values after its indices"});
    refused("nan_colour.off", "COFF\n3 1\n0 0 0 nan 1 1\n1 0 0 1 1 1\n0 1 0 1 1 1\n3 0 1 2\n",
            {"vertex 0", "not a finite number"});
}

TEST_CASE("attribute io: PLY lists and elements the reader cannot keep are named") {
    const fs::path p =
        scratch("lists.ply", "ply\nformat ascii 1.0\n"
                             "element vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nproperty list uchar int neighbours\n"
                             "element face 1\nproperty list uchar int vertex_indices\n"
                             "property list uchar float texcoord\n"
                             "property list uchar uchar flags\n"
                             "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
                             "end_header\n"
                             "0 0 0 2 1 2\n1 0 0 0\n0 1 0 1 0\n"
                             "3 0 1 2 6 0 0 1 0 0 1 2 7 7\n"
                             "0 1\n");
    const surface s = read_surface(p);
    CHECK(s.faces.size() == 1);
    CHECK(find_attribute(s, "texcoord", attribute_domain::corner) != nullptr);
    CHECK(s.skipped == std::vector<std::string>{"neighbours (vertex list property)",
                                                "flags (face list property)",
                                                "edge (PLY element of 1 item)"});
    read_options plain;
    plain.attributes = false;
    CHECK(read_surface(p, plain).skipped.empty());
}
