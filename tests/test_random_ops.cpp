// Long randomized operation sequences on real meshes: the mesh stays a valid manifold
// with the same topology after every operation, and every failed operation (a failing
// after() or invariant, chosen at random) restores the mesh and its attributes bit for bit.
#include "test_support.hpp"

using namespace idas;
using idas::test::midpoint_spec;

namespace {

template <class Mesh>
std::optional<tri_tuple> random_edge(const Mesh& m, std::mt19937& rng) {
    std::uniform_int_distribution<index_t> pick(0, m.face_slots() - 1);
    for (int attempt = 0; attempt < 64; ++attempt) {
        const index_t f = pick(rng);
        if (m.face_alive(f)) return m.tuple_from_edge(f, static_cast<std::uint8_t>(rng() % 3));
    }
    return std::nullopt;
}

struct sequence_stats {
    int accepted = 0, refused = 0;
};

/// Runs `n` random operations; checks validity locally after each and globally every
/// `full_every` operations and at the end; Euler characteristic and boundary loops must
/// not change. If `compare_rollback`, each refused operation is compared bit for bit
/// with a copy taken before it.
template <class Mesh>
sequence_stats run_sequence(const std::string& file, unsigned seed, int n, int full_every,
                            double fail_p, bool compare_rollback) {
    auto m = idas::test::load<Mesh>(file);
    const auto [V0, F0] = m.to_arrays();
    const auto topo0 = diagnose_topology(V0.size(), F0);
    std::mt19937 rng(seed);
    midpoint_spec spec;
    spec.attach(m);
    spec.fail_probability = fail_p;
    spec.rng = &rng;
    sequence_stats st;
    for (int i = 0; i < n; ++i) {
        auto t = random_edge(m, rng);
        REQUIRE(t);
        if (rng() % 2) t = m.switch_vertex(*t);
        std::optional<Mesh> copy;
        if (compare_rollback) copy = m;
        const int kind = static_cast<int>(rng() % 4);
        std::optional<op_result<tri_tuple>> r;
        switch (kind) {
        case 0:
            r = split_edge(m, *t, spec);
            break;
        case 1:
            r = collapse_edge(m, *t, spec);
            break;
        case 2:
            r = swap_edge(m, *t, spec);
            break;
        default:
            r = smooth_vertex(m, *t, spec);
            break;
        }
        if (r) {
            ++st.accepted;
            const auto e = find_inconsistency_near(m, r->cells);
            REQUIRE_MESSAGE(!e, "after op " << i << " kind " << kind << ": " << *e);
        } else {
            ++st.refused;
            if (copy)
                REQUIRE_MESSAGE(identical(*copy, m),
                                "op " << i << " kind " << kind << " did not roll back exactly");
        }
        if ((i + 1) % full_every == 0 || i + 1 == n) {
            const auto e = find_inconsistency(m);
            REQUIRE_MESSAGE(!e, "after op " << i << ": " << *e);
            const auto [V, F] = m.to_arrays();
            const auto topo = diagnose_topology(V.size(), F);
            REQUIRE(topo.euler_characteristic == topo0.euler_characteristic);
            REQUIRE(topo.boundary_loops == topo0.boundary_loops);
            REQUIRE(topo.components == topo0.components);
        }
    }
    return st;
}

} // namespace

TEST_CASE_TEMPLATE("random operations keep bunny (open, 5 holes) valid", Mesh, IDAS_TRI_MESHES) {
    const auto st = run_sequence<Mesh>("bunny.obj", 1, 4000, 1000, 0.0, false);
    CHECK(st.accepted > 2000);
}

TEST_CASE_TEMPLATE("random operations keep armadillo (closed) valid", Mesh, IDAS_TRI_MESHES) {
    const auto st = run_sequence<Mesh>("armadillo.obj", 2, 4000, 1000, 0.0, false);
    CHECK(st.accepted > 2000);
}

TEST_CASE_TEMPLATE("random operations keep blub valid, and 100071 (genus 3)", Mesh,
                   IDAS_TRI_MESHES) {
    CHECK(run_sequence<Mesh>("blub.obj", 3, 4000, 500, 0.0, false).accepted > 2000);
    CHECK(run_sequence<Mesh>("100071_sf.obj", 4, 3000, 500, 0.0, false).accepted > 1000);
}

TEST_CASE_TEMPLATE("forced failures roll back bit for bit", Mesh, IDAS_TRI_MESHES) {
    // Half of all after() calls fail: the copies compare the whole mesh and attributes.
    const auto st = run_sequence<Mesh>("bunny.off", 5, 600, 200, 0.5, true);
    CHECK(st.refused > 200);
    CHECK(st.accepted > 100);
    const auto st2 = run_sequence<Mesh>("blub.obj", 6, 300, 100, 0.5, true);
    CHECK(st2.refused > 100);
}

TEST_CASE_TEMPLATE("stale tuples are detected after random edits", Mesh, IDAS_TRI_MESHES) {
    auto m = idas::test::load<Mesh>("bunny.off");
    std::mt19937 rng(7);
    midpoint_spec spec;
    spec.attach(m);
    const auto all = m.get_edges();
    int stale = 0;
    for (int i = 0; i < 500; ++i) {
        auto t = random_edge(m, rng);
        if (rng() % 2)
            split_edge(m, *t, spec);
        else
            collapse_edge(m, *t, spec);
    }
    for (const auto& t : all) {
        if (!m.is_valid(t)) {
            ++stale;
            continue;
        }
        // A tuple still valid names a face untouched since: its vertices still match.
        CHECK(m.face_alive(t.fid));
    }
    CHECK(stale > 500);
    CHECK(stale < static_cast<int>(all.size()));
}
