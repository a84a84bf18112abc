// Construction, navigation, ids, iteration, boundary queries, attributes and export of
// the tetrahedral core.
#include "slot_pool_check.hpp"
#include "tet_support.hpp"

#include <algorithm>
#include <map>
#include <set>
#include <string>

using namespace idas;
using idas::test::cube;
using idas::test::cube_arrays;
using idas::test::edge_ring_mesh;

namespace {

template <class Mesh>
void expect_refusal(const std::vector<vec3>& V, const std::vector<tet_indices>& T,
                    const std::string& what) {
    try {
        Mesh m(V, T);
        FAIL("accepted bad tet mesh, expected: " << what);
    } catch (const input_error& e) {
        const std::string msg = e.what();
        CHECK_MESSAGE(msg.find(what) != std::string::npos, msg);
    }
}

const std::vector<vec3> unit_tet = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

} // namespace

TEST_CASE_TEMPLATE("tet mesh: a single tet navigates by the switch identities", Mesh,
                   IDAS_TET_MESHES) {
    Mesh m(unit_tet, {{0, 1, 2, 3}});
    CHECK(m.n_vertices() == 4);
    CHECK(m.n_edges() == 6);
    CHECK(m.n_faces() == 4);
    CHECK(m.n_tets() == 1);
    CHECK(euler_characteristic(m) == 1);
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    for (index_t v = 0; v < 4; ++v) CHECK(m.is_boundary_vertex(v));
    for (const auto& e : m.get_edges()) CHECK(m.is_boundary_edge(e));
    for (const auto& f : m.get_faces()) {
        CHECK(m.is_boundary_face(f));
        CHECK_FALSE(m.switch_tetrahedron(f).has_value());
    }
    // Boundary faces are outward: the tet's fourth vertex lies behind each.
    const auto bf = m.boundary_faces();
    REQUIRE(bf.size() == 4);
    for (const auto& f : bf) {
        index_t apex = 0;
        while (apex == f[0] || apex == f[1] || apex == f[2]) ++apex;
        CHECK(orient3d(unit_tet[f[0]], unit_tet[f[1]], unit_tet[f[2]], unit_tet[apex]) < 0);
    }
    const auto t = m.tuple_from_tet(0);
    CHECK(m.is_valid(t));
    CHECK(m.edge_vertices(t) == std::pair<index_t, index_t>{0, 1});
    const auto f = m.face_vertices(t);
    CHECK(f[0] == 0);
    CHECK(f[1] == 1);
    CHECK(m.opposite_vertex(t) != f[2]);
    // The 24 tuples of a tet are all reached from one by switches.
    std::set<std::tuple<index_t, int, int>> seen;
    std::vector<tet_tuple> stack = {t};
    while (!stack.empty()) {
        const auto u = stack.back();
        stack.pop_back();
        if (!seen.insert({u.vid, u.local_edge, u.local_face}).second) continue;
        CHECK(m.is_valid(u));
        stack.push_back(m.switch_vertex(u));
        stack.push_back(m.switch_edge(u));
        stack.push_back(m.switch_face(u));
    }
    CHECK(seen.size() == 24);
}

TEST_CASE_TEMPLATE("tet mesh: subdivided cubes have the expected counts, ids and boundary", Mesh,
                   IDAS_TET_MESHES) {
    for (bool five : {false, true}) {
        CAPTURE(five);
        const int n = 3;
        auto m = cube<Mesh>(n, five, 0.1, 3);
        const std::size_t cells = n * n * n;
        CHECK(m.n_vertices() == 64);
        CHECK(m.n_tets() == cells * (five ? 5 : 6));
        CHECK(euler_characteristic(m) == 1);
        CHECK_FALSE(find_inconsistency(m, true).has_value());
        const auto topo = boundary_topology(m);
        CHECK(topo.editable());
        CHECK(topo.closed());
        CHECK(topo.euler_characteristic == 2);
        CHECK(topo.faces == 6 * n * n * 2);
        // Boundary vertices: all but the (n-1)^3 interior ones.
        CHECK(m.boundary_vertices().size() == 64 - 8);
        std::size_t interior = 0;
        m.for_each_vertex([&](const tet_tuple& v) { interior += !m.is_boundary_vertex(v.vid); });
        CHECK(interior == 8);
        // Ids: one per simplex, the same from every tuple of it.
        std::set<index_t> eids, fids;
        m.for_each_edge([&](const tet_tuple& e) { eids.insert(m.eid(e)); });
        m.for_each_face([&](const tet_tuple& f) { fids.insert(m.fid(f)); });
        CHECK(eids.size() == m.n_edges());
        CHECK(fids.size() == m.n_faces());
        for (index_t t = 0; t < m.tet_slots(); ++t)
            for (std::uint8_t le = 0; le < 6; ++le) {
                const auto e = m.tuple_from_edge(t, le);
                CHECK(eids.count(m.eid(e)) == 1);
                CHECK(m.eid(m.switch_vertex(e)) == m.eid(e));
                CHECK(m.eid(m.switch_face(e)) == m.eid(e));
                CHECK(fids.count(m.fid(e)) == 1);
            }
        // Boundary edges are exactly the edges of boundary faces.
        std::set<std::pair<index_t, index_t>> from_faces;
        for (const auto& f : m.boundary_faces())
            for (int i = 0; i < 3; ++i) from_faces.insert(std::minmax(f[i], f[(i + 1) % 3]));
        std::set<std::pair<index_t, index_t>> from_edges;
        for (const auto& e : m.boundary_edges()) {
            const auto [a, b] = m.edge_vertices(e);
            from_edges.insert(std::minmax(a, b));
        }
        CHECK(from_faces == from_edges);
        // V - E + F - T = 1 for a ball, and the boundary is a sphere.
        CHECK(long(m.n_vertices()) - long(m.n_edges()) + long(m.n_faces()) - long(m.n_tets()) == 1);
    }
}

TEST_CASE_TEMPLATE("tet mesh: one-ring, edge tets, find_edge and find_face", Mesh,
                   IDAS_TET_MESHES) {
    auto m = edge_ring_mesh<Mesh>(5);
    std::vector<index_t> ring;
    m.one_ring_vertices(0, ring);
    std::sort(ring.begin(), ring.end());
    CHECK(ring == std::vector<index_t>{1, 2, 3, 4, 5, 6});
    const auto ab = m.find_edge(0, 1);
    REQUIRE(ab);
    CHECK_FALSE(m.is_boundary_edge(*ab));
    std::vector<index_t> around;
    m.edge_tets(*ab, around);
    CHECK(around.size() == 5);
    CHECK(m.is_boundary_vertex(0));
    CHECK_FALSE(m.find_edge(2, 4)); // ring chords do not exist
    const auto f = m.find_face(0, 2, 3);
    REQUIRE(f);
    CHECK(m.face_vertices(*f) == tri_indices{0, 2, 3});
    CHECK(m.is_boundary_face(*f));
    const auto inner = m.find_face(0, 2, 1);
    REQUIRE(inner);
    CHECK_FALSE(m.is_boundary_face(*inner));
    CHECK_FALSE(m.find_face(2, 3, 4).has_value());
    // Walking around the edge by switch_tetrahedron / switch_face visits all 5 tets.
    auto u = *ab;
    std::set<index_t> visited;
    for (int k = 0; k < 5; ++k) {
        visited.insert(u.tid);
        auto g = m.switch_tetrahedron(u);
        REQUIRE(g);
        u = m.switch_face(*g);
        CHECK(m.edge_vertices(u) == m.edge_vertices(*ab));
    }
    CHECK(visited.size() == 5);
    CHECK(u.tid == ab->tid);
}

TEST_CASE_TEMPLATE("tet mesh: invalid input is refused with a message naming the element", Mesh,
                   IDAS_TET_MESHES) {
    expect_refusal<Mesh>({{0, 0, 0}, {1, 0, 0}, {0, std::nan(""), 0}, {0, 0, 1}}, {{0, 1, 2, 3}},
                         "vertex 2 has a non-finite coordinate");
    expect_refusal<Mesh>(unit_tet, {{0, 1, 2, 9}}, "tet 0 references vertex 9");
    expect_refusal<Mesh>(unit_tet, {{0, 1, 2, 2}}, "tet 0 is degenerate: it uses vertex 2 twice");
    expect_refusal<Mesh>({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}, {{0, 1, 2, 3}},
                         "tet 0 is degenerate: its vertices are coplanar");
    expect_refusal<Mesh>(unit_tet, {{0, 2, 1, 3}}, "tet 0 is inverted");
    // Three tets on one face (0, 1, 2).
    std::vector<vec3> V = unit_tet;
    V.push_back({0.2, 0.2, -1});
    V.push_back({0.3, 0.3, 2});
    std::vector<tet_indices> T = {{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}};
    expect_refusal<Mesh>(V, T, "face (0, 1, 2) is shared by 3 tets");
    // Two tets on the same side of a face overlap.
    expect_refusal<Mesh>(V, {{0, 1, 2, 3}, {0, 1, 2, 5}}, "tet 0 and tet 1 overlap");
    // A duplicated tet too.
    expect_refusal<Mesh>(unit_tet, {{0, 1, 2, 3}, {0, 1, 2, 3}}, "overlap");
    // Unused vertices are fine (they are not exported).
    Mesh m(V, {{0, 1, 2, 3}, {0, 2, 1, 4}});
    CHECK(m.n_vertices() == 5);
    CHECK(m.to_arrays().first.size() == 5);
    CHECK_FALSE(find_inconsistency(m, true).has_value());
}

namespace {
// Keys that survive renumbering: vertices are told apart by their positions.
using pkey = std::array<double, 3>;
pkey key(const vec3& p) {
    return {p.x, p.y, p.z};
}
template <std::size_t N, class Mesh>
std::array<pkey, N> sorted_keys(const Mesh& m, const std::array<index_t, N>& vs) {
    std::array<pkey, N> k;
    for (std::size_t i = 0; i < N; ++i) k[i] = key(m.position(vs[i]));
    std::sort(k.begin(), k.end());
    return k;
}
} // namespace

TEST_CASE_TEMPLATE("tet mesh: attributes of every kind follow their simplices through consolidate",
                   Mesh, IDAS_TET_MESHES) {
    auto m = cube<Mesh>(3, false, 0.1, 9);
    auto va = m.template add_vertex_attribute<double>("vd", 1.5);
    auto ea = m.template add_edge_attribute<int>("ei", -1);
    auto fa = m.template add_face_attribute<int>("fi", -1);
    auto ta = m.template add_tet_attribute<int>("ti", -1);
    CHECK(m.attribute(va)[3] == 1.5);
    CHECK(m.attribute(ea)[0] == -1);
    // Make dead slots: collapse a few interior edges (the spec keeps tets positive).
    idas::test::tet_spec<> spec;
    spec.attach(m);
    int collapsed = 0;
    for (const auto& e : m.get_edges())
        if (m.is_valid(e) && collapse_edge(m, e, spec)) ++collapsed;
    CHECK(collapsed > 0);
    REQUIRE_FALSE(find_inconsistency(m, true).has_value());
    CHECK(m.tet_slots() > m.n_tets());
    int counter = 0;
    m.for_each_edge([&](const tet_tuple& x) { m.attribute(ea).raw(m.eid(x)) = counter++; });
    m.for_each_face([&](const tet_tuple& x) { m.attribute(fa).raw(m.fid(x)) = counter++; });
    m.for_each_tet([&](const tet_tuple& x) { m.attribute(ta).raw(x.tid) = counter++; });
    m.for_each_vertex([&](const tet_tuple& x) { m.attribute(va).raw(x.vid) = counter++; });
    std::map<std::array<pkey, 2>, int> edges;
    std::map<std::array<pkey, 3>, int> faces;
    std::map<std::array<pkey, 4>, int> tets;
    std::map<pkey, double> verts;
    auto snapshot = [&] {
        edges.clear(), faces.clear(), tets.clear(), verts.clear();
        m.for_each_edge([&](const tet_tuple& x) {
            const auto [a, b] = m.edge_vertices(x);
            edges[sorted_keys<2>(m, {a, b})] = m.attribute(ea)[m.eid(x)];
        });
        m.for_each_face([&](const tet_tuple& x) {
            faces[sorted_keys<3>(m, m.face_vertices(x))] = m.attribute(fa)[m.fid(x)];
        });
        m.for_each_tet([&](const tet_tuple& x) {
            tets[sorted_keys<4>(m, m.tet_vertices(x.tid))] = m.attribute(ta)[x.tid];
        });
        m.for_each_vertex(
            [&](const tet_tuple& x) { verts[key(m.position(x.vid))] = m.attribute(va)[x.vid]; });
    };
    snapshot();
    const auto e0 = edges;
    const auto f0 = faces;
    const auto t0 = tets;
    const auto v0 = verts;
    const auto [V0, T0] = m.to_arrays();

    m.consolidate();
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    CHECK(m.tet_slots() == m.n_tets());
    CHECK(m.vertex_slots() == m.n_vertices());
    snapshot();
    CHECK(edges == e0);
    CHECK(faces == f0);
    CHECK(tets == t0);
    CHECK(verts == v0);
    const auto [V1, T1] = m.to_arrays();
    CHECK(V1 == V0);
    CHECK(T1 == T0);
}

TEST_CASE_TEMPLATE("tet mesh: copies are identical, stale tuples detected after edits", Mesh,
                   IDAS_TET_MESHES) {
    auto m = cube<Mesh>(2, true, 0.1, 4);
    auto copy = m;
    CHECK(identical(m, copy));
    const auto all = m.get_tets();
    const auto e = m.tuple_from_edge(0, 0);
    idas::test::tet_spec<> spec;
    spec.attach(m);
    copy = m;
    REQUIRE(split_edge(m, e, spec));
    CHECK_FALSE(identical(m, copy));
    CHECK_FALSE(m.is_valid(e));
    int stale = 0;
    for (const auto& t : all) stale += !m.is_valid(t);
    std::vector<index_t> around;
    copy.edge_tets(e, around);
    CHECK(stale == int(around.size()));
}

TEST_CASE_TEMPLATE(
    "tet mesh: without slot recycling removed slots stay dead and rollback stays exact", Mesh,
    IDAS_TET_MESHES) {
    auto m = cube<Mesh>(2, false, 0.1, 6);
    idas::test::tet_spec<> spec;
    spec.attach(m);
    m.set_slot_recycling(false);
    const index_t slots0 = m.tet_slots();
    // Collapse some interior edge, then split: the split may not reuse the freed slots.
    bool collapsed = false;
    for (const auto& e : m.get_edges())
        if (!collapsed && m.is_valid(e) && collapse_edge(m, e, spec)) collapsed = true;
    REQUIRE(collapsed);
    const index_t after_collapse = m.tet_slots();
    CHECK(after_collapse == slots0);
    const auto before = m;
    spec.fail_probability = 1; // every after() fails: the split is rolled back
    std::mt19937 rng(1);
    spec.rng = &rng;
    CHECK_FALSE(split_edge(m, m.tuple_from_tet(m.get_tets().front().tid), spec));
    CHECK(identical(before, m));
    spec.fail_probability = 0;
    auto r = split_edge(m, m.tuple_from_tet(m.get_tets().front().tid), spec);
    REQUIRE(r);
    CHECK(m.tet_slots() > after_collapse);
    CHECK(m.tet_slots() - after_collapse == r->cells.size() / 2); // all new tets got fresh slots
    CHECK_FALSE(find_inconsistency(m, true).has_value());
    m.consolidate();
    CHECK(m.tet_slots() == m.n_tets());
    CHECK_FALSE(find_inconsistency(m, true).has_value());
}

TEST_CASE_TEMPLATE("tet mesh: new simplices come from the slot pool their undo log names", Mesh,
                   IDAS_TET_MESHES) {
    Mesh m(unit_tet, {{0, 1, 2, 3}});
    idas::test::check_slots_come_from_the_logs_pool(m);
    CHECK_FALSE(find_inconsistency(m, true).has_value());
}
