// Gmsh MSH (2.2 and 4.1, ASCII and binary) and VTU: round trips, files written by Gmsh,
// arbitrary node tags, and bad input that must be refused with a message that starts
// with the path, without crashing, hanging or leaving partial output.
#include "tet_support.hpp"

#include <idas/io/msh.hpp>
#include <idas/io/vtu.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using namespace idas;
using namespace idas::io;

namespace {

const fs::path test_data = fs::path(__FILE__).parent_path() / "data";

fs::path msh_tmp(const std::string& name) {
    fs::create_directories(IDAS_TEST_TMP);
    return fs::path(IDAS_TEST_TMP) / name;
}

fs::path msh_scratch(const std::string& name, std::string_view bytes) {
    const fs::path p = msh_tmp(name);
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    REQUIRE(out.good());
    return p;
}

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// Reading must fail with an input_error that starts with the path and names the problem.
void msh_refused(const fs::path& path, std::initializer_list<std::string_view> words) {
    INFO("file: " << path.string() << "\n" << slurp(path).substr(0, 400));
    try {
        (void)read_msh(path);
        FAIL("the file was accepted");
    } catch (const input_error& e) {
        const std::string msg = e.what();
        INFO("message: " << msg);
        CHECK(msg.starts_with(path.string() + ": "));
        for (std::string_view w : words) CHECK(msg.find(w) != std::string::npos);
    }
}

void msh_refused_text(const std::string& name, const std::string& text,
                      std::initializer_list<std::string_view> words) {
    msh_refused(msh_scratch(name, text), words);
}

template <class T>
void put(std::string& out, T value, bool big_endian = false) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    if (big_endian != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
    out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

volume volume_of(std::vector<idas::vec3> V, std::vector<idas::tet_indices> T) {
    volume v;
    v.vertices = std::move(V), v.tets = std::move(T);
    return v;
}

volume cube_volume(int n = 2) {
    auto [V, T] = idas::test::cube_arrays(n, false, 0.2, 5);
    return volume_of(V, T);
}

struct variant {
    msh_version version;
    encoding enc;
    const char* name;
};
constexpr variant variants[] = {{msh_version::v2_2, encoding::ascii, "22a"},
                                {msh_version::v2_2, encoding::binary, "22b"},
                                {msh_version::v4_1, encoding::ascii, "41a"},
                                {msh_version::v4_1, encoding::binary, "41b"}};

// A small 2.2 ASCII file: sparse, unordered node tags and mixed element types.
const std::string sparse_22 = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
1
3 1 "ball $weird"
$EndPhysicalNames
$Nodes
5
100 0 0 0
7 1 0 0
3000000000 0 1 0
42 0 0 1
5 0 0 -1
$EndNodes
$Elements
5
1 15 2 0 1 100
2 1 2 0 1 100 7
3 4 2 1 1 100 7 3000000000 42
4 2 2 0 1 100 7 3000000000
9 4 3 1 1 0 100 3000000000 7 5
$EndElements
)";

} // namespace

TEST_CASE_TEMPLATE("msh: round trips in all four variants are exact", Mesh, IDAS_TET_MESHES) {
    const volume v = cube_volume(3);
    for (const auto& var : variants) {
        INFO(std::string(var.name));
        const fs::path p = msh_tmp(std::string("round_") + var.name + ".msh");
        write_msh(p, v, var.version, var.enc);
        const volume r = read_msh(p);
        CHECK(r.skipped_elements == 0);
        REQUIRE(r.vertices.size() == v.vertices.size());
        REQUIRE(r.tets.size() == v.tets.size());
        for (std::size_t i = 0; i < v.vertices.size(); ++i) {
            CHECK(std::bit_cast<std::uint64_t>(r.vertices[i].x) ==
                  std::bit_cast<std::uint64_t>(v.vertices[i].x));
            CHECK(std::bit_cast<std::uint64_t>(r.vertices[i].y) ==
                  std::bit_cast<std::uint64_t>(v.vertices[i].y));
            CHECK(std::bit_cast<std::uint64_t>(r.vertices[i].z) ==
                  std::bit_cast<std::uint64_t>(v.vertices[i].z));
        }
        CHECK(r.tets == v.tets);
        // Into a mesh and out again, through a stream this time.
        Mesh m(r.vertices, r.tets);
        auto [V, T] = m.to_arrays();
        std::stringstream s;
        write_msh(s, volume_of(V, T), var.version, var.enc);
        const volume again = parse_msh(s.str(), "stream");
        CHECK(again.vertices == V);
        CHECK(again.tets == T);
    }
    // Empty meshes too.
    for (const auto& var : variants) {
        const fs::path p = msh_tmp(std::string("empty_") + var.name + ".msh");
        write_msh(p, volume{}, var.version, var.enc);
        const volume r = read_msh(p);
        CHECK(r.vertices.empty());
        CHECK(r.tets.empty());
    }
}

TEST_CASE_TEMPLATE("msh: files written by Gmsh read the same in all four variants", Mesh,
                   IDAS_TET_MESHES) {
    volume first;
    for (const char* name : {"gmsh_sphere_22_ascii.msh", "gmsh_sphere_22_binary.msh",
                             "gmsh_sphere_41_ascii.msh", "gmsh_sphere_41_binary.msh"}) {
        INFO(std::string(name));
        volume v = read_msh(test_data / name);
        CHECK(v.vertices.size() == 205);
        CHECK(v.tets.size() == 679);
        CHECK(v.triangles.size() == 320); // the sphere's boundary
        CHECK(v.skipped_elements == 12);
        CHECK(orient_tets_positively(v) == 0); // Gmsh's convention is idas's
        if (first.tets.empty()) first = v;
        CHECK(v.tets == first.tets);
        CHECK(v.triangles == first.triangles);
        CHECK(v.triangle_tags == first.triangle_tags);
        // Gmsh prints 16 significant digits, so ASCII and binary agree to rounding.
        REQUIRE(v.vertices.size() == first.vertices.size());
        for (std::size_t i = 0; i < v.vertices.size(); ++i)
            CHECK(norm(v.vertices[i] - first.vertices[i]) < 1e-15);
        Mesh m(v.vertices, v.tets);
        CHECK_FALSE(find_inconsistency(m, true).has_value());
        CHECK(euler_characteristic(m) == 1);
        const auto topo = boundary_topology(m);
        CHECK(topo.closed());
        CHECK(topo.euler_characteristic == 2);
    }
}

TEST_CASE("msh: arbitrary node tags are mapped and other elements skipped") {
    const volume v = read_msh(msh_scratch("sparse.msh", sparse_22));
    REQUIRE(v.vertices.size() == 5);
    CHECK(v.vertices[2] == vec3{0, 1, 0});
    CHECK(v.skipped_elements == 2);
    CHECK(v.triangles == std::vector<idas::tri_indices>{{0, 1, 2}});
    REQUIRE(v.tets.size() == 2);
    CHECK(v.tets[0] == tet_indices{0, 1, 2, 3});
    CHECK(v.tets[1] == tet_indices{0, 2, 1, 4});
    tet_mesh<> m(v.vertices, v.tets);
    CHECK(m.n_tets() == 2);

    // 4.1 ASCII: two node blocks (one parametric on a surface), unordered sparse tags.
    const std::string text41 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                               "$Nodes\n2 5 5 900\n"
                               "2 1 1 2\n900\n17\n0 0 0 0.5 0.5\n1 0 0 0.1 0.2\n"
                               "3 1 0 3\n5\n6\n8\n0 1 0\n0 0 1\n0 0 -1\n$EndNodes\n"
                               "$Elements\n3 4 1 4\n"
                               "2 1 2 1\n1 900 17 5\n"
                               "3 1 4 2\n2 900 17 5 6\n3 900 5 17 8\n"
                               "0 3 15 1\n4 6\n$EndElements\n";
    const volume w = read_msh(msh_scratch("sparse41.msh", text41));
    REQUIRE(w.vertices.size() == 5);
    CHECK(w.vertices[1] == vec3{1, 0, 0});
    CHECK(w.skipped_elements == 1);
    CHECK(w.triangles == std::vector<idas::tri_indices>{{0, 1, 2}});
    CHECK(w.tets == std::vector<tet_indices>{{0, 1, 2, 3}, {0, 2, 1, 4}});

    // 4.1 binary with sparse 64-bit tags, and the same file big-endian.
    for (bool big : {false, true}) {
        std::string b = "$MeshFormat\n4.1 1 8\n";
        put<std::int32_t>(b, 1, big);
        b += "\n$EndMeshFormat\n$Nodes\n";
        for (std::uint64_t x :
             {std::uint64_t(1), std::uint64_t(4), std::uint64_t(10), std::uint64_t(1) << 40})
            put<std::uint64_t>(b, x, big);
        put<std::int32_t>(b, 3, big), put<std::int32_t>(b, 1, big), put<std::int32_t>(b, 0, big);
        put<std::uint64_t>(b, 4, big);
        for (std::uint64_t tag :
             {std::uint64_t(1) << 40, std::uint64_t(10), std::uint64_t(77), std::uint64_t(12)})
            put<std::uint64_t>(b, tag, big);
        for (double x : {0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.}) put<double>(b, x, big);
        b += "\n$EndNodes\n$Elements\n";
        for (std::uint64_t x : {1, 1, 1, 1}) put<std::uint64_t>(b, x, big);
        put<std::int32_t>(b, 3, big), put<std::int32_t>(b, 1, big), put<std::int32_t>(b, 4, big);
        put<std::uint64_t>(b, 1, big);
        for (std::uint64_t x : {std::uint64_t(1), std::uint64_t(1) << 40, std::uint64_t(10),
                                std::uint64_t(77), std::uint64_t(12)})
            put<std::uint64_t>(b, x, big);
        b += "\n$EndElements\n";
        const volume x = read_msh(msh_scratch(big ? "big41.msh" : "little41.msh", b));
        REQUIRE(x.vertices.size() == 4);
        CHECK(x.vertices[3] == vec3{0, 0, 1});
        CHECK(x.tets == std::vector<tet_indices>{{0, 1, 2, 3}});
    }
}

TEST_CASE("msh: bad headers and bad values are refused with a clear message") {
    msh_refused_text("empty.msh", "", {"empty"});
    msh_refused_text("blank.msh", "  \n\n", {"empty"});
    msh_refused_text("notmsh.msh", "solid cube\n", {"does not start with $MeshFormat"});
    msh_refused_text("v40.msh", "$MeshFormat\n4 0 8\n$EndMeshFormat\n", {"4.0 is not supported"});
    msh_refused_text("v3.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n",
                     {"'3.0'", "not supported"});
    msh_refused_text("ds4.msh", "$MeshFormat\n2.2 0 4\n$EndMeshFormat\n", {"data size"});
    msh_refused_text("ft2.msh", "$MeshFormat\n2.2 2 8\n$EndMeshFormat\n", {"file type"});
    msh_refused_text("nofmtend.msh", "$MeshFormat\n2.2 0 8\n", {"truncated", "$EndMeshFormat"});
    const std::string head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
    const std::string one_tet = "$Elements\n1\n1 4 2 0 1 1 2 3 4\n$EndElements\n";
    const std::string four_nodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";
    msh_refused_text("noelems.msh", head + four_nodes, {"no $Elements section"});
    msh_refused_text("nonodes.msh", head + one_tet, {"no $Nodes section"});
    msh_refused_text("lying_nodes.msh",
                     head + "$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n" + one_tet,
                     {"line 10", "announces 6 nodes but only 4"});
    msh_refused_text("extra_nodes.msh",
                     head + "$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n" + one_tet,
                     {"line 9", "expected $EndNodes, found '4'"});
    msh_refused_text("huge_count.msh", head + "$Nodes\n99999999999999\n1 0 0 0\n", {"truncated"});
    msh_refused_text("negative_count.msh", head + "$Nodes\n-4\n$EndNodes\n", {"negative"});
    msh_refused_text(
        "nan.msh", head + "$Nodes\n4\n1 0 0 0\n2 nan 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n" + one_tet,
        {"line 7", "node 2 has a non-finite coordinate"});
    msh_refused_text(
        "inf.msh", head + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 -inf 0\n4 0 0 1\n$EndNodes\n" + one_tet,
        {"node 3 has a non-finite coordinate"});
    msh_refused_text("overflow.msh",
                     head + "$Nodes\n4\n1 0 0 0\n2 1e999 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n" +
                         one_tet,
                     {"'1e999' is out of range"});
    msh_refused_text(
        "word.msh", head + "$Nodes\n4\n1 0 0 0\n2 one 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n" + one_tet,
        {"'one' is not a number"});
    msh_refused_text("undefined.msh",
                     head + four_nodes + "$Elements\n1\n57 4 2 0 1 1 2 3 99\n$EndElements\n",
                     {"element 57 references node 99, which is not defined"});
    msh_refused_text("twice.msh",
                     head + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n2 0 1 0\n4 0 0 1\n$EndNodes\n" + one_tet,
                     {"node tag 2 is defined twice"});
    msh_refused_text("degenerate.msh",
                     head + four_nodes + "$Elements\n1\n8 4 2 0 1 1 2 3 3\n$EndElements\n",
                     {"element 8 is degenerate: it uses node 3 twice"});
    msh_refused_text("short_line.msh",
                     head + four_nodes + "$Elements\n1\n8 4 2 0 1 1 2 3\n$EndElements\n",
                     {"line 13", "element 8 has 8 values"});
    msh_refused_text("lying_elems.msh",
                     head + four_nodes + "$Elements\n3\n1 4 2 0 1 1 2 3 4\n$EndElements\n",
                     {"announces 3 elements but only 1"});
    msh_refused_text("negative_tag.msh",
                     head + four_nodes + "$Elements\n1\n1 4 0 1 2 3 -4\n$EndElements\n",
                     {"negative node tag -4"});
    msh_refused_text("noend.msh", head + four_nodes + "$Comments\nhello\n",
                     {"truncated", "$EndComments"});
    msh_refused_text("stray.msh", head + "hello\n" + four_nodes + one_tet,
                     {"expected a section", "'hello'"});
    msh_refused_text("twonodes.msh", head + four_nodes + four_nodes + one_tet, {"second $Nodes"});
    msh_refused_text("endmismatch.msh", head + "$Nodes\n0\n$EndElements\n" + one_tet,
                     {"expected $EndNodes"});
    // 4.1: block counts that do not add up.
    const std::string head41 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
    msh_refused_text(
        "blocks41.msh",
        head41 + "$Nodes\n1 5 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n",
        {"announces 5 nodes but the blocks hold 4"});
    msh_refused_text("blocks41b.msh", head41 + "$Nodes\n1 3 1 4\n3 1 0 4\n1\n2\n3\n4\n",
                     {"blocks hold more"});
    msh_refused_text("dim41.msh", head41 + "$Nodes\n1 1 1 1\n7 1 0 1\n1\n0 0 0\n$EndNodes\n",
                     {"dimension 7"});

    // Readers of binary files check counts against the bytes present.
    std::string b = "$MeshFormat\n4.1 1 8\n";
    put<std::int32_t>(b, 1);
    b += "\n$EndMeshFormat\n$Nodes\n";
    for (std::uint64_t x :
         {std::uint64_t(1), std::uint64_t(1) << 60, std::uint64_t(1), std::uint64_t(4)})
        put(b, x);
    msh_refused(msh_scratch("lying41b.msh", b), {"byte", "announces 1152921504606846976 nodes"});
    std::string e = "$MeshFormat\n2.2 1 8\n";
    put<std::int32_t>(e, 7);
    e += "\n$EndMeshFormat\n";
    msh_refused(msh_scratch("endian.msh", e), {"endianness marker is 7"});
    std::string u = "$MeshFormat\n2.2 1 8\n";
    put<std::int32_t>(u, 1);
    u += "\n$EndMeshFormat\n$Nodes\n0\n\n$EndNodes\n$Elements\n1\n";
    for (std::int32_t x : {77, 1, 0}) put(u, x);
    msh_refused(msh_scratch("unknown_type.msh", u), {"element type 77 is unknown"});
}

TEST_CASE("msh: every truncation of every variant is refused, never crashes") {
    volume v = cube_volume(1);
    v.vertices.push_back({5, 5, 5}); // an unused node
    for (const auto& var : variants) {
        INFO(std::string(var.name));
        std::stringstream s;
        write_msh(s, v, var.version, var.enc);
        const std::string full = s.str();
        int refused = 0;
        for (std::size_t len = 0; len < full.size(); ++len) {
            const std::string cut = full.substr(0, len);
            try {
                const volume r = parse_msh(cut, "cut");
                // Only losing trailing white space leaves a complete file.
                CHECK(io::detail::is_blank(std::string_view(full).substr(len)));
                CHECK(r.tets == v.tets);
            } catch (const input_error& err) {
                ++refused;
                CHECK(std::string(err.what()).starts_with("cut: "));
            }
        }
        CHECK(refused >= int(full.size()) - 2);
    }
}

TEST_CASE("msh: random corruption is refused or read, never crashes or hangs") {
    const volume v = cube_volume(1);
    std::mt19937 rng(99);
    for (const auto& var : variants) {
        INFO(std::string(var.name));
        std::stringstream s;
        write_msh(s, v, var.version, var.enc);
        const std::string full = s.str();
        int refused = 0, accepted = 0;
        for (int trial = 0; trial < 1500; ++trial) {
            std::string bad = full;
            const int flips = 1 + int(rng() % 3);
            for (int f = 0; f < flips; ++f) {
                const std::size_t at = rng() % bad.size();
                switch (rng() % 3) {
                case 0:
                    bad[at] = char(rng() % 256);
                    break;
                case 1:
                    bad[at] = "0123456789 -.e$\n"[rng() % 16];
                    break;
                default:
                    bad.erase(at, 1 + rng() % 8);
                    break;
                }
            }
            try {
                const volume r = parse_msh(bad, "fuzz");
                ++accepted;
                for (const auto& t : r.tets)
                    for (index_t x : t) CHECK(x < r.vertices.size());
                for (const auto& p : r.vertices) CHECK(is_finite(p));
            } catch (const input_error& err) {
                ++refused;
                CHECK(std::string(err.what()).starts_with("fuzz: "));
            }
        }
        CHECK(refused > 0);
        CHECK(accepted + refused == 1500);
    }
}

TEST_CASE("msh: writers refuse bad volumes and leave the target untouched") {
    const fs::path p = msh_tmp("keep.msh");
    const volume good = cube_volume(1);
    write_msh(p, good);
    const std::string before = slurp(p);
    volume bad = good;
    bad.vertices[3].y = std::nan("");
    CHECK_THROWS_AS(write_msh(p, bad), input_error);
    bad = good;
    bad.tets[0][2] = 999;
    CHECK_THROWS_AS(write_msh(p, bad, msh_version::v2_2, encoding::ascii), input_error);
    bad = good;
    bad.tets[1][0] = bad.tets[1][1];
    CHECK_THROWS_AS(write_vtu(p, bad), input_error);
    CHECK(slurp(p) == before);
    // No temporary files were left behind.
    for (const auto& entry : fs::directory_iterator(p.parent_path()))
        CHECK(entry.path().filename().string().find("keep.msh.tmp") == std::string::npos);
}

namespace {
std::string base64_decode(std::string_view s) {
    auto val = [](char c) -> int {
        if (c >= 'A' && c <= 'Z') return c - 'A';
        if (c >= 'a' && c <= 'z') return c - 'a' + 26;
        if (c >= '0' && c <= '9') return c - '0' + 52;
        return c == '+' ? 62 : (c == '/' ? 63 : -1);
    };
    std::string out;
    std::uint32_t acc = 0;
    int bits = 0;
    for (char c : s) {
        const int v = val(c);
        if (v < 0) continue;
        acc = acc << 6 | std::uint32_t(v), bits += 6;
        if (bits >= 8) bits -= 8, out += char((acc >> bits) & 0xff);
    }
    return out;
}

/// The text between the opening tag of the DataArray named `name` and its closing tag.
std::string data_array(const std::string& xml, const std::string& name) {
    const auto at = xml.find("Name=\"" + name + "\"");
    REQUIRE(at != std::string::npos);
    const auto open = xml.find('>', at) + 1;
    return xml.substr(open, xml.find("</DataArray>", open) - open);
}
} // namespace

TEST_CASE("msh: VTU output, ASCII and binary, holds the points, tets and fields") {
    const volume v = cube_volume(2);
    vtu_options o;
    vtu_field q{"quality <q>", 1, {}};
    for (const auto& t : v.tets)
        q.values.push_back(
            tet_quality(v.vertices[t[0]], v.vertices[t[1]], v.vertices[t[2]], v.vertices[t[3]]));
    o.cell_data.push_back(q);
    vtu_field h{"height", 1, {}};
    for (const auto& p : v.vertices) h.values.push_back(p.z);
    o.point_data.push_back(h);
    for (encoding enc : {encoding::ascii, encoding::binary}) {
        o.enc = enc;
        const fs::path p = msh_tmp(enc == encoding::ascii ? "cube_a.vtu" : "cube_b.vtu");
        write_vtu(p, v, o);
        const std::string xml = slurp(p);
        CHECK(xml.find("NumberOfPoints=\"27\"") != std::string::npos);
        CHECK(xml.find("NumberOfCells=\"48\"") != std::string::npos);
        CHECK(xml.find("quality &lt;q&gt;") != std::string::npos);
        CHECK(xml.find("</VTKFile>") != std::string::npos);
        std::vector<double> pts;
        std::vector<std::int64_t> conn;
        if (enc == encoding::ascii) {
            std::istringstream a(data_array(xml, "Points"));
            for (double x; a >> x;) pts.push_back(x);
            std::istringstream c(data_array(xml, "connectivity"));
            for (std::int64_t x; c >> x;) conn.push_back(x);
        } else {
            const std::string raw = base64_decode(data_array(xml, "Points"));
            std::uint64_t bytes = 0;
            std::memcpy(&bytes, raw.data(), 8);
            REQUIRE(bytes == 27 * 3 * 8);
            REQUIRE(raw.size() == 8 + bytes);
            pts.resize(27 * 3);
            std::memcpy(pts.data(), raw.data() + 8, bytes);
            const std::string rc = base64_decode(data_array(xml, "connectivity"));
            conn.resize((rc.size() - 8) / 8);
            std::memcpy(conn.data(), rc.data() + 8, rc.size() - 8);
        }
        REQUIRE(pts.size() == 81);
        for (std::size_t i = 0; i < 27; ++i)
            CHECK(vec3{pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]} == v.vertices[i]);
        REQUIRE(conn.size() == 4 * v.tets.size());
        for (std::size_t t = 0; t < v.tets.size(); ++t)
            for (int k = 0; k < 4; ++k) CHECK(conn[4 * t + k] == std::int64_t(v.tets[t][k]));
    }
    o.cell_data[0].values.pop_back();
    CHECK_THROWS_WITH_AS(write_vtu(msh_tmp("bad.vtu"), v, o),
                         doctest::Contains("has 47 values, expected 48"), input_error);
}

TEST_CASE("msh: $NodeData fields round trip in all four variants, and tags in 4.1") {
    volume v = cube_volume(2);
    const std::size_t n = v.vertices.size();
    vertex_field length{"target length", 1, {}}, velocity{"velocity", 3, {}};
    for (std::size_t i = 0; i < n; ++i) {
        length.values.push_back(0.1 + 0.001 * double(i) / 3);
        for (int k = 0; k < 3; ++k) velocity.values.push_back(double(i) * 1e-3 - k / 7.0);
    }
    length.values[2] = std::numeric_limits<double>::quiet_NaN(); // no value at vertex 2
    v.vertex_fields = {length, velocity};
    for (std::size_t t = 0; t < v.tets.size(); ++t) v.tags.push_back(t % 3 == 0 ? 2 : 1);
    for (const auto& var : variants) {
        INFO(std::string(var.name));
        const fs::path p = msh_tmp(std::string("fields_") + var.name + ".msh");
        write_msh(p, v, var.version, var.enc);
        const volume r = read_msh(p);
        REQUIRE(r.vertex_fields.size() == 2);
        CHECK(r.vertex_fields[0].name == "target length");
        CHECK(r.vertex_fields[1].components == 3);
        for (std::size_t f = 0; f < 2; ++f) {
            const auto& a = v.vertex_fields[f].values;
            const auto& b = r.vertex_fields[f].values;
            REQUIRE(a.size() == b.size());
            for (std::size_t i = 0; i < a.size(); ++i) {
                if (std::isnan(a[i])) {
                    CHECK(std::isnan(b[i]));
                    continue;
                }
                CHECK(std::bit_cast<std::uint64_t>(a[i]) == std::bit_cast<std::uint64_t>(b[i]));
            }
        }
        // 4.1 groups the tets by tag (one entity each): the same tets, maybe reordered.
        auto sorted = [](std::vector<idas::tet_indices> t) {
            std::sort(t.begin(), t.end());
            return t;
        };
        CHECK(sorted(r.tets) == sorted(v.tets));
        // 2.2 gives each tet its physical tag back (issue 21); 4.1 keeps them per entity.
        if (var.version == msh_version::v2_2) CHECK(r.tags == v.tags);
        if (var.version == msh_version::v4_1) {
            const std::string text = slurp(p);
            CHECK(text.find("$Entities") != std::string::npos);
        }
    }
}

TEST_CASE("msh: $NodeData as Gmsh writes it, and bad $NodeData refused") {
    const std::string head = sparse_22;
    const std::string good = head + R"($NodeData
1
"A scalar view"
1
0.0
3
0
1
2
42 0.25
100 0.5
$EndNodeData
)";
    const volume r = read_msh(msh_scratch("nodedata_good.msh", good));
    REQUIRE(r.vertex_fields.size() == 1);
    CHECK(r.vertex_fields[0].name == "A scalar view");
    // Nodes in file order: 100, 7, 3000000000, 42, 5.
    CHECK(r.vertex_fields[0].values[0] == 0.5);
    CHECK(r.vertex_fields[0].values[3] == 0.25);
    CHECK(std::isnan(r.vertex_fields[0].values[1]));

    msh_refused_text("nodedata_undefined.msh",
                     head + "$NodeData\n1\n\"s\"\n1\n0\n3\n0\n1\n1\n8 0.5\n$EndNodeData\n",
                     {"node 8", "not defined"});
    msh_refused_text("nodedata_components.msh",
                     head + "$NodeData\n0\n0\n3\n0\n0\n1\n42 0.5\n$EndNodeData\n", {"components"});
    msh_refused_text("nodedata_ints.msh", head + "$NodeData\n0\n0\n2\n0\n1\n$EndNodeData\n",
                     {"integer tags"});
    msh_refused_text("nodedata_lying.msh",
                     head + "$NodeData\n0\n0\n3\n0\n1\n1000000\n42 0.5\n$EndNodeData\n",
                     {"announces"});
    msh_refused_text("nodedata_quote.msh", head + "$NodeData\n1\n\"never closed\n", {"quote"});
    msh_refused_text("nodedata_value.msh",
                     head + "$NodeData\n0\n0\n3\n0\n1\n1\n42 abc\n$EndNodeData\n",
                     {"not a number"});
}

TEST_CASE("msh: triangles, physical tags and $ElementData round trip in all four variants") {
    volume v = cube_volume(2);
    const std::size_t m = v.tets.size();
    for (std::size_t t = 0; t < m; ++t) v.tags.push_back(t % 3 == 0 ? 2 : 7);
    for (std::size_t t = 0; t < 10; ++t) {
        v.triangles.push_back({v.tets[t][0], v.tets[t][1], v.tets[t][2]});
        v.triangle_tags.push_back(int(5 + t % 2));
    }
    tet_field quality{"quality", 1, {}}, pair{"pair", 2, {}};
    for (std::size_t t = 0; t < m; ++t) {
        quality.values.push_back(3 + double(t) / 7);
        pair.values.push_back(-double(t)), pair.values.push_back(1e-300 * double(t));
    }
    quality.values[4] = std::numeric_limits<double>::quiet_NaN(); // no value for tet 4
    v.tet_fields = {quality, pair};
    // 4.1 groups elements by tag: match read tets to written ones by their corners.
    std::map<idas::tet_indices, std::size_t> written;
    for (std::size_t t = 0; t < m; ++t) written[v.tets[t]] = t;
    for (const auto& var : variants) {
        INFO(std::string(var.name));
        const fs::path p = msh_tmp(std::string("tagged_") + var.name + ".msh");
        write_msh(p, v, var.version, var.enc);
        const volume r = read_msh(p);
        CHECK(r.skipped_elements == 0);
        REQUIRE(r.tets.size() == m);
        REQUIRE(r.tags.size() == m);
        REQUIRE(r.tet_fields.size() == 2);
        CHECK(r.tet_fields[0].name == "quality");
        CHECK(r.tet_fields[1].components == 2);
        for (std::size_t i = 0; i < m; ++i) {
            const std::size_t t = written.at(r.tets[i]);
            CHECK(r.tags[i] == v.tags[t]);
            for (std::size_t f = 0; f < 2; ++f) {
                const std::size_t c = std::size_t(v.tet_fields[f].components);
                for (std::size_t k = 0; k < c; ++k) {
                    const double a = v.tet_fields[f].values[t * c + k];
                    const double b = r.tet_fields[f].values[i * c + k];
                    if (std::isnan(a))
                        CHECK(std::isnan(b));
                    else
                        CHECK(std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b));
                }
            }
        }
        std::vector<std::pair<idas::tri_indices, int>> a, b;
        for (std::size_t t = 0; t < v.triangles.size(); ++t)
            a.push_back({v.triangles[t], v.triangle_tags[t]});
        REQUIRE(r.triangle_tags.size() == r.triangles.size());
        for (std::size_t t = 0; t < r.triangles.size(); ++t)
            b.push_back({r.triangles[t], r.triangle_tags[t]});
        if (var.version == msh_version::v4_1)
            std::sort(a.begin(), a.end()), std::sort(b.begin(), b.end());
        CHECK(a == b);
    }
    // Writers refuse fields and triangles that do not fit the volume.
    volume bad = v;
    bad.tet_fields[1].values.pop_back();
    CHECK_THROWS_WITH_AS(write_msh(msh_tmp("bad_field.msh"), bad),
                         doctest::Contains("tet field \"pair\" has"), idas::input_error);
    bad = v;
    bad.triangles[3] = {0, 0, 1};
    CHECK_THROWS_WITH_AS(write_msh(msh_tmp("bad_triangle.msh"), bad),
                         doctest::Contains("triangle 3 is degenerate"), idas::input_error);
    bad = v;
    bad.triangle_tags.pop_back();
    CHECK_THROWS_WITH_AS(write_msh(msh_tmp("bad_tags.msh"), bad),
                         doctest::Contains("triangle tags for"), idas::input_error);
}

TEST_CASE("msh: 4.1 physical tags come from $Entities, not from the entity tags") {
    // Volume entity 7 carries physical tag 42, surface entity 3 physical tag 9; volume
    // entity 8 has no physical tag, so its tets' tags cannot be kept.
    const std::string head = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                             "$Entities\n1 0 1 2\n"
                             "1 0 0 0 0\n"
                             "3 0 0 0 1 1 1 1 9 0\n"
                             "7 0 0 0 1 1 1 2 42 43 1 3\n"
                             "8 0 0 0 1 1 1 0 0\n"
                             "$EndEntities\n"
                             "$Nodes\n1 5 1 5\n3 7 0 5\n1\n2\n3\n4\n5\n"
                             "0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 -1\n$EndNodes\n";
    const volume v = read_msh(msh_scratch("entities41.msh", head + "$Elements\n2 3 1 3\n"
                                                                   "3 7 4 2\n1 1 2 3 4\n2 1 3 2 5\n"
                                                                   "2 3 2 1\n3 1 2 3\n"
                                                                   "$EndElements\n"));
    CHECK(v.tags == std::vector<int>{42, 42});
    CHECK(v.triangle_tags == std::vector<int>{9});
    const volume w = read_msh(
        msh_scratch("entities41_untagged.msh", head + "$Elements\n2 2 1 2\n"
                                                      "3 7 4 1\n1 1 2 3 4\n3 8 4 1\n2 1 3 2 5\n"
                                                      "$EndElements\n"));
    CHECK(w.tags.empty());
    msh_refused_text("entities41_short.msh",
                     "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n7 0 0 0 1 1 1 "
                     "$EndEntities\n",
                     {"number of physical tags", "not an integer"});
}

TEST_CASE("msh: $ElementData as TetWild writes it keeps the tets' values") {
    const std::string text = sparse_22 + "$ElementData\n1\n\"quality\"\n1\n0.0\n3\n0\n1\n3\n"
                                         "3 2.5\n9 7.25\n4 1\n$EndElementData\n";
    const volume v = read_msh(msh_scratch("element_data.msh", text));
    REQUIRE(v.tets.size() == 2);
    REQUIRE(v.tet_fields.size() == 1);
    CHECK(v.tet_fields[0].name == "quality");
    CHECK(v.tet_fields[0].values == std::vector<double>{2.5, 7.25}); // element 4: a triangle
    msh_refused_text("element_data_components.msh",
                     sparse_22 +
                         "$ElementData\n1\n\"q\"\n1\n0.0\n3\n0\n0\n1\n3 1\n$EndElementData\n",
                     {"$ElementData has 0 components per element"});
    msh_refused_text("element_data_truncated.msh",
                     sparse_22 + "$ElementData\n1\n\"q\"\n1\n0.0\n3\n0\n1\n2\n3 1\n", {"element"});
}
