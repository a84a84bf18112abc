// Attributes: typed columns through handles, journaled writes, consolidation.
#include "test_support.hpp"

using namespace idas;

TEST_CASE_TEMPLATE("attribute writes are journaled only inside operations", Mesh, IDAS_TRI_MESHES) {
    Mesh m({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}, {{0, 1, 2}, {1, 3, 2}});
    auto tag = m.template add_vertex_attribute<int>("tag", 7);
    auto area = m.template add_face_attribute<double>("area", 0.5);
    auto sharp = m.template add_edge_attribute<std::uint8_t>("sharp", 0);
    CHECK(m.attribute(tag)[3] == 7);
    CHECK(m.attribute(area)[1] == 0.5);
    CHECK(m.attributes().template find<int, simplex_kind::vertex>("tag").column == tag.column);
    CHECK_FALSE(m.attributes().template find<double, simplex_kind::vertex>("tag").valid());

    m.attribute(tag).raw(0) = 1; // outside an operation: a plain write
    CHECK(m.attribute(tag)[0] == 1);

    // A failing after() undoes every write it made, on every kind of simplex.
    struct failing {
        vertex_attribute<int> tag;
        face_attribute<double> area;
        edge_attribute<std::uint8_t> sharp;
        bool after(op::smooth_vertex, Mesh& m, const op_result<tri_tuple>& r) {
            m.attribute(tag, r).set(r.anchor.vid, 42);
            for (const auto& c : r.cells) m.attribute(area, r).set(c.fid, 99.0);
            m.attribute(sharp, r).set(m.eid(r.anchor), 1);
            m.positions(r).set(r.anchor.vid, {5, 5, 5});
            return false;
        }
    } spec{tag, area, sharp};
    const auto copy = m;
    CHECK_FALSE(smooth_vertex(m, m.tuple_from_vertex(1), spec));
    CHECK(identical(copy, m));
    CHECK(m.attribute(tag)[1] == 7);
    CHECK(m.position(1) == vec3{1, 0, 0});
}

TEST_CASE_TEMPLATE("consolidate compacts slots and carries attributes along", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = idas::test::load<Mesh>("bunny.off");
    auto id = m.template add_vertex_attribute<index_t>("original_id");
    auto fid = m.template add_face_attribute<index_t>("original_face");
    auto eid = m.template add_edge_attribute<double>("edge_length");
    for (index_t v = 0; v < m.vertex_slots(); ++v) m.attribute(id).raw(v) = v;
    for (index_t f = 0; f < m.face_slots(); ++f) m.attribute(fid).raw(f) = f;
    m.for_each_edge([&](const tri_tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        m.attribute(eid).raw(m.eid(t)) = norm(m.position(a) - m.position(b));
    });
    std::mt19937 rng(3);
    int collapsed = 0;
    for (int i = 0; i < 400; ++i) {
        const index_t f = rng() % m.face_slots();
        if (!m.face_alive(f)) continue;
        collapsed += collapse_edge(m, m.tuple_from_edge(f, 0)).has_value();
    }
    REQUIRE(collapsed > 100);
    const auto n_v = m.n_vertices(), n_f = m.n_faces();
    // Positions of survivors keyed by their original id, before compaction.
    std::map<index_t, vec3> pos;
    for (index_t v = 0; v < m.vertex_slots(); ++v)
        if (m.vertex_alive(v)) pos[m.attribute(id)[v]] = m.position(v);
    m.consolidate();
    CHECK(m.vertex_slots() == n_v);
    CHECK(m.face_slots() == n_f);
    CHECK_FALSE(find_inconsistency(m).has_value());
    for (index_t v = 0; v < m.vertex_slots(); ++v)
        CHECK(pos.at(m.attribute(id)[v]) == m.position(v));
    // Edges not touched by any collapse keep their length attribute exactly.
    int kept = 0;
    m.for_each_edge([&](const tri_tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        if (m.attribute(eid)[m.eid(t)] == norm(m.position(a) - m.position(b))) ++kept;
    });
    CHECK(kept > int(m.n_edges() * 8 / 10));
}
