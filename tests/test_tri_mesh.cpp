// Navigation, operations, invariants and rollback of the triangle-mesh core.
#include "slot_pool_check.hpp"
#include "test_support.hpp"

#include <algorithm>
#include <set>
#include <tuple>

using namespace idas;
using idas::test::midpoint_spec;

namespace {

// A 3x3 vertex grid, 8 triangles, consistently oriented, open.
template <class Mesh>
Mesh grid() {
    std::vector<vec3> V;
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 3; ++x) V.push_back({double(x), double(y), 0});
    std::vector<tri_indices> F;
    for (index_t y = 0; y < 2; ++y)
        for (index_t x = 0; x < 2; ++x) {
            index_t a = y * 3 + x, b = a + 1, c = a + 3, d = c + 1;
            F.push_back({a, b, d});
            F.push_back({a, d, c});
        }
    return {V, F};
}

// Regular octahedron: closed, every vertex of valence 4.
template <class Mesh>
Mesh octahedron() {
    std::vector<vec3> V = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    std::vector<tri_indices> F = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                  {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    return {V, F};
}

template <class Mesh>
long euler(const Mesh& m) {
    return long(m.n_vertices()) - long(m.n_edges()) + long(m.n_faces());
}

} // namespace

TEST_CASE_TEMPLATE("tuple navigation obeys the switch identities", Mesh, IDAS_TRI_MESHES) {
    auto m = grid<Mesh>();
    CHECK(m.n_vertices() == 9);
    CHECK(m.n_faces() == 8);
    CHECK(m.n_edges() == 16);
    CHECK(euler(m) == 1);
    CHECK_FALSE(find_inconsistency(m).has_value());
    m.for_each_face([&](const tri_tuple& t) {
        auto e = t;
        for (int k = 0; k < 3; ++k) {
            CHECK(m.is_valid(e));
            CHECK(m.switch_vertex(m.switch_vertex(e)) == e);
            CHECK(m.switch_edge(m.switch_edge(e)) == e);
            CHECK(m.switch_vertex(e).vid != e.vid);
            if (auto g = m.switch_face(e)) {
                CHECK(g->fid != e.fid);
                CHECK(*m.switch_face(*g) == e);
                CHECK(m.eid(*g) == m.eid(e)); // one edge, one id
                CHECK_FALSE(m.is_boundary_edge(e));
            } else {
                CHECK(m.is_boundary_edge(e));
            }
            e = m.switch_edge(m.switch_vertex(e));
        }
    });
    // Centre vertex 4 is interior, corners and sides are on the boundary.
    CHECK_FALSE(m.is_boundary_vertex(4));
    for (index_t v : {0u, 1u, 2u, 3u, 5u, 6u, 7u, 8u}) CHECK(m.is_boundary_vertex(v));
    std::vector<index_t> ring;
    m.one_ring_vertices(4, ring);
    std::sort(ring.begin(), ring.end());
    // The diagonals run (x,y)-(x+1,y+1), so the centre sees its 4 sides and 2 corners.
    CHECK(ring == std::vector<index_t>{0, 1, 3, 5, 7, 8});
    // Edge ids are unique per edge.
    std::set<index_t> ids;
    m.for_each_edge([&](const tri_tuple& t) { ids.insert(m.eid(t)); });
    CHECK(ids.size() == 16);
}

TEST_CASE_TEMPLATE("operations make earlier tuples stale and return the new faces", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = octahedron<Mesh>();
    const auto t = m.tuple_from_face(0);
    const auto other = m.tuple_from_face(6); // far from edge 0
    auto r = split_edge(m, t);
    REQUIRE(r);
    CHECK(r->cells.size() == 4);
    CHECK_FALSE(m.is_valid(t));
    CHECK(m.is_valid(other));
    CHECK(m.n_vertices() == 7);
    CHECK(m.n_faces() == 10);
    CHECK(euler(m) == 2);
    for (const auto& c : r->cells) CHECK(m.is_valid(c));
    CHECK(r->anchor.vid == 6);
    CHECK_FALSE(find_inconsistency(m).has_value());

    // Collapsing the new edge back restores the counts.
    auto back = collapse_edge(m, m.switch_vertex(r->anchor));
    REQUIRE(back);
    CHECK(m.n_vertices() == 6);
    CHECK(m.n_faces() == 8);
    CHECK_FALSE(find_inconsistency(m).has_value());
}

TEST_CASE_TEMPLATE("link condition refuses collapses that change topology", Mesh, IDAS_TRI_MESHES) {
    auto m = octahedron<Mesh>();
    // Every octahedron edge collapse would create a double face pair (the link of the
    // edge's endpoints share four vertices); all must be refused... except none pass.
    int accepted = 0;
    for (const auto& e : m.get_edges()) {
        auto copy = m;
        if (collapse_edge(copy, e)) {
            ++accepted;
            CHECK_FALSE(find_inconsistency(copy).has_value());
        }
    }
    // In an octahedron lk(a) ∩ lk(b) has 2 vertices (the opposite ones) and the two
    // remaining... each collapse is legal and gives a 5-vertex sphere.
    CHECK(accepted == 12);

    // A tetrahedron: every collapse would leave a degenerate double triangle.
    std::vector<vec3> V = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    std::vector<tri_indices> F = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
    Mesh tet(V, F);
    for (const auto& e : tet.get_edges()) CHECK_FALSE(collapse_edge(tet, e));

    // A lone triangle: no collapse is allowed.
    Mesh tri({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
    for (const auto& e : tri.get_edges()) CHECK_FALSE(collapse_edge(tri, e));

    // Grid: an interior edge joining two boundary vertices must not be collapsed
    // (it would pinch the boundary); the edge (0,4) joins corner 0 and the centre.
    auto g = grid<Mesh>();
    int refused = 0;
    for (const auto& e : g.get_edges()) {
        const auto [a, b] = g.edge_vertices(e);
        if (!g.is_boundary_edge(e) && g.is_boundary_vertex(a) && g.is_boundary_vertex(b)) {
            CHECK_FALSE(collapse_edge(g, e));
            ++refused;
        }
    }
    CHECK(refused > 0);
}

TEST_CASE_TEMPLATE("swap refuses boundary edges and existing diagonals", Mesh, IDAS_TRI_MESHES) {
    auto g = grid<Mesh>();
    for (const auto& e : g.get_edges())
        if (g.is_boundary_edge(e)) CHECK_FALSE(swap_edge(g, e));
    // In a tetrahedron the two vertices opposite any edge are already joined.
    std::vector<vec3> V = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    std::vector<tri_indices> F = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
    Mesh tet(V, F);
    for (const auto& e : tet.get_edges()) CHECK_FALSE(swap_edge(tet, e));
    // In an octahedron they never are: every swap is legal and keeps a valid sphere.
    auto m = octahedron<Mesh>();
    for (const auto& e : m.get_edges()) {
        auto copy = m;
        REQUIRE(swap_edge(copy, e));
        CHECK_FALSE(find_inconsistency(copy).has_value());
        CHECK(euler(copy) == 2);
    }
}

TEST_CASE_TEMPLATE("a double triangle (two faces on the same three vertices) is never edited "
                   "into a non-manifold",
                   Mesh, IDAS_TRI_MESHES) {
    // The smallest closed surface: one triangle glued to its reverse along all three edges.
    // Every edge has the same opposite vertex on both sides, so a split would join the new
    // vertex to it twice (an edge of four faces), a swap would make a loop edge, and a
    // collapse would leave an edge without faces. Alone, and as a component of an
    // octahedron (where the same must hold while the octahedron stays editable).
    const std::vector<vec3> octa_v = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                      {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
    const std::vector<tri_indices> octa_f = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                             {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    for (const bool with_octahedron : {false, true}) {
        CAPTURE(with_octahedron);
        std::vector<vec3> V = {{3, 0, 0}, {4, 0, 0}, {3, 1, 0}};
        std::vector<tri_indices> F = {{0, 1, 2}, {0, 2, 1}};
        if (with_octahedron) {
            for (const auto& p : octa_v) V.push_back(p);
            for (const auto& f : octa_f) F.push_back({f[0] + 3, f[1] + 3, f[2] + 3});
        }
        Mesh m(V, F);
        REQUIRE_FALSE(find_inconsistency(m).has_value());
        const auto before = test::topology_of(m);
        CHECK(before.chi == (with_octahedron ? 4 : 2));
        int pair_edges = 0, octahedron_splits = 0;
        for (const auto& e : m.get_edges()) {
            if (!m.is_valid(e)) continue; // made stale by an earlier split
            const auto [a, b] = m.edge_vertices(e);
            if (a >= 3 || b >= 3) { // an octahedron edge: still editable
                octahedron_splits += split_edge(m, e).has_value() ? 1 : 0;
                continue;
            }
            ++pair_edges;
            CHECK_FALSE(link_condition_holds(m, e));
            CHECK_FALSE(collapse_edge(m, e));
            CHECK_FALSE(swap_edge(m, e));
            CHECK_FALSE(split_edge(m, e));
            CHECK_FALSE(find_inconsistency(m).has_value());
        }
        CHECK(pair_edges == 3);
        CHECK((octahedron_splits > 0) == with_octahedron);
        CHECK(m.n_faces() == 2 + (with_octahedron ? 8 : 0) + 2 * octahedron_splits);
        CHECK_FALSE(find_inconsistency(m).has_value());
        CHECK(test::topology_of(m) == before);
    }
}

namespace {
struct no_new_vertices_above_plane {
    struct state {};
    template <class Mesh>
    bool after(op::split_edge, const Mesh& m, const op_result<tri_tuple>& r, state&) const {
        return m.position(r.anchor.vid).z <= 0.25;
    }
};
} // namespace

TEST_CASE_TEMPLATE("a user invariant vetoes operations and they roll back exactly", Mesh,
                   IDAS_TRI_MESHES) {
    static_assert(invariant<no_new_vertices_above_plane>);
    static_assert(invariant_for<no_new_vertices_above_plane, op::split_edge, Mesh>);
    struct spec {
        std::optional<vec3> before(op::split_edge, const Mesh& m, const tri_tuple& t) {
            const auto [a, b] = m.edge_vertices(t);
            return (m.position(a) + m.position(b)) * 0.5;
        }
        bool after(op::split_edge, Mesh& m, const op_result<tri_tuple>& r, vec3& p) {
            m.positions(r).set(r.anchor.vid, p);
            return true;
        }
        auto invariants() const {
            return invariant_set<no_new_vertices_above_plane, no_normal_flip>{};
        }
    } s;
    auto m = octahedron<Mesh>();
    int accepted = 0, refused = 0;
    std::vector<std::pair<index_t, index_t>> edges;
    for (const auto& e : m.get_edges()) edges.push_back(m.edge_vertices(e));
    for (const auto& [ea, eb] : edges) {
        // Earlier splits make old tuples stale, so find the edge afresh.
        std::optional<tri_tuple> found;
        m.for_each_edge([&](const tri_tuple& t) {
            const auto [x, y] = m.edge_vertices(t);
            if ((x == ea && y == eb) || (x == eb && y == ea)) found = t;
        });
        REQUIRE(found);
        const auto e = *found;
        const auto before = m;
        const auto [a, b] = m.edge_vertices(e);
        const bool high = (m.position(a).z + m.position(b).z) / 2 > 0.25;
        auto r = split_edge(m, e, s);
        CHECK(bool(r) == !high);
        if (r)
            ++accepted;
        else {
            ++refused;
            CHECK(identical(before, m));
        }
    }
    CHECK(accepted == 8);
    CHECK(refused == 4);
    CHECK_FALSE(find_inconsistency(m).has_value());
}

TEST_CASE_TEMPLATE("non-manifold input is refused with a message that says where", Mesh,
                   IDAS_TRI_MESHES) {
    auto expect_refusal = [](const std::string& file, const std::string& what) {
        const auto s = io::read_surface(idas::test::data(file));
        try {
            Mesh m(s.vertices, s.faces);
            FAIL("accepted non-manifold mesh " << file);
        } catch (const input_error& e) {
            const std::string msg = e.what();
            CHECK_MESSAGE(msg.find(what) != std::string::npos, msg);
        }
    };
    expect_refusal("hour_glass.off", "non-manifold vertex");
    expect_refusal("edge_with_four_triangles.off", "non-manifold edge");
    expect_refusal("37989_sf.obj", "non-manifold edge");

    const auto s = io::read_surface(idas::test::data("37989_sf.obj"));
    const auto r = diagnose_topology(s.vertices.size(), s.faces);
    CHECK(r.nonmanifold_edges == 232);
    CHECK_FALSE(r.editable());

    const auto h = io::read_surface(idas::test::data("hour_glass.off"));
    CHECK(diagnose_topology(h.vertices.size(), h.faces).nonmanifold_vertices == 1);
    const auto q = io::read_surface(idas::test::data("edge_with_four_triangles.off"));
    CHECK(diagnose_topology(q.vertices.size(), q.faces).nonmanifold_edges == 1);

    CHECK_THROWS_AS(Mesh({{0, 0, 0}, {1, 0, 0}, {0, std::nan(""), 0}}, {{0, 1, 2}}), input_error);
    CHECK_THROWS_AS(Mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 7}}), input_error);
}

TEST_CASE_TEMPLATE("real meshes load with the expected topology", Mesh, IDAS_TRI_MESHES) {
    struct expected {
        const char* file;
        std::size_t v, f;
        long chi;
        std::size_t loops;
    };
    for (auto e :
         {expected{"bunny.obj", 35947, 69451, -3, 5}, expected{"armadillo.obj", 43243, 86482, 2, 0},
          expected{"blub.obj", 7106, 14208, 2, 0}, expected{"100071_sf.obj", 5516, 11040, -4, 0}}) {
        CAPTURE(e.file);
        const auto s = io::read_surface(idas::test::data(e.file));
        const auto r = diagnose_topology(s.vertices.size(), s.faces);
        CHECK(r.editable());
        CHECK(r.euler_characteristic == e.chi);
        CHECK(r.boundary_loops == e.loops);
        Mesh m(s.vertices, s.faces);
        CHECK(m.n_vertices() == e.v);
        CHECK(m.n_faces() == e.f);
    }
}

namespace {
/// Every (face, edge, face across) of a mesh, faces named by their vertices (rotated to
/// start at the smallest), so meshes can be compared whatever their slot numbers.
template <class Mesh>
std::set<std::tuple<tri_indices, index_t, index_t, tri_indices>> adjacency(const Mesh& m) {
    auto key = [&](index_t f) {
        tri_indices v = m.face_vertices(f);
        std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
        return v;
    };
    std::set<std::tuple<tri_indices, index_t, index_t, tri_indices>> out;
    m.for_each_face([&](const tri_tuple& t) {
        auto e = t;
        for (int k = 0; k < 3; ++k, e = m.switch_edge(m.switch_vertex(e))) {
            const auto [a, b] = m.edge_vertices(e);
            const auto g = m.switch_face(e);
            out.insert(
                {key(e.fid), a, b,
                 g ? key(g->fid) : tri_indices{invalid_index, invalid_index, invalid_index}});
        }
    });
    return out;
}
} // namespace

TEST_CASE_TEMPLATE("raw edits keep neighbours right, also across boundaries made earlier", Mesh,
                   IDAS_TRI_MESHES) {
    // Removing faces and adding them back, in the same edit or in later ones (which then
    // glue the new face onto boundary edges that existed before they began), must give
    // the original neighbours back; and every edit rolls back bit for bit.
    typename Mesh::undo_log log;
    attribute_journal attrs; // new face slots' attribute resets (positions are per vertex)
    auto check = [](const Mesh& m) {
        const auto e = find_inconsistency(m);
        CHECK_MESSAGE(!e, *e);
    };
    auto commit = [&] { log.resize(0), attrs.clear(); };

    const auto closed = octahedron<Mesh>();
    const auto want = adjacency(closed);
    for (index_t f = 0; f < closed.face_slots(); ++f) {
        CAPTURE(f);
        auto m = closed;
        const tri_indices fv = m.face_vertices(f);
        // One edit: remove and add back.
        m.remove_face(f, log);
        m.add_face(fv, log, attrs);
        check(m);
        CHECK(adjacency(m) == want);
        m.rollback(log, 0);
        CHECK(identical(closed, m));
        // Two edits: the second closes a hole that the first one left.
        m.remove_face(f, log);
        commit();
        check(m);
        CHECK(m.is_boundary_vertex(fv[0]));
        const auto holed = m;
        m.add_face(fv, log, attrs);
        check(m);
        CHECK(adjacency(m) == want);
        CHECK_FALSE(m.is_boundary_vertex(fv[0]));
        m.rollback(log, 0);
        CHECK(identical(holed, m));
        m.add_face(fv, log, attrs);
        commit();
        check(m);
        CHECK(adjacency(m) == want);
    }

    // An open mesh: take out two neighbouring faces far from the boundary, then put them
    // back one edit at a time (the first glues onto two old boundary edges and leaves a
    // new one, the second closes everything).
    auto m = idas::test::load<Mesh>("bunny.off");
    const auto bunny = adjacency(m);
    // Local checks around the hole (the whole mesh is checked once at the end).
    auto check_near = [](const Mesh& x, const tri_indices& a, const tri_indices& b) {
        std::vector<tri_tuple> cells;
        for (const auto& fv : {a, b})
            for (index_t v : fv)
                for (index_t g : x.vertex_faces(v)) cells.push_back(x.tuple_in_face(v, g));
        const auto e = find_inconsistency_near(x, cells);
        CHECK_MESSAGE(!e, *e);
    };
    int holes = 0;
    for (index_t f = 0; f < m.face_slots() && holes < 40; f += 97) {
        const tri_tuple t = m.tuple_from_edge(f, 0);
        const auto g = m.switch_face(t);
        if (!g) continue;
        bool interior = true;
        for (index_t x : {f, g->fid})
            for (index_t v : m.face_vertices(x)) interior &= !m.is_boundary_vertex(v);
        if (!interior) continue;
        ++holes;
        const tri_indices a = m.face_vertices(f), b = m.face_vertices(g->fid);
        m.remove_face(f, log);
        m.remove_face(g->fid, log);
        commit();
        check_near(m, a, b);
        CHECK(m.is_boundary_vertex(a[0]));
        m.add_face(b, log, attrs);
        commit();
        check_near(m, a, b);
        m.add_face(a, log, attrs);
        commit();
        check_near(m, a, b);
        CHECK_FALSE(m.is_boundary_vertex(a[0]));
    }
    CHECK(holes >= 20);
    check(m);
    CHECK(adjacency(m) == bunny);
}

TEST_CASE_TEMPLATE("new simplices come from the slot pool their undo log names", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = octahedron<Mesh>();
    idas::test::check_slots_come_from_the_logs_pool(m);
    CHECK_FALSE(find_inconsistency(m).has_value());
}
