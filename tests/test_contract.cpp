// The IDAS contract: specs checked at compile time, the executor knows its spec, user
// operation kinds run without touching the library, algorithms leave no columns behind,
// and a const mesh gives read-only attributes. The compile errors themselves are tested
// by building tests/compile_fail/spec_mistakes.cpp (see tests/CMakeLists.txt).
#include "test_support.hpp"
#include "user_face_split.hpp"

#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/mesh/tet_mesh.hpp>

using namespace idas;

namespace {

struct priority_on_mutable_mesh {
    using operations = op_list<op::collapse_edge>;
    double priority(op::collapse_edge, tri_mesh<>&, const tri_tuple&) const { return 0; }
};
struct after_for_unlisted_operation {
    using operations = op_list<op::split_edge>;
    bool after(op::collapse_edge, tri_mesh<>&, const op_result<tri_tuple>&) const { return true; }
};
struct cache_not_taken {
    using operations = op_list<op::split_edge>;
    std::optional<vec3> before(op::split_edge, const tri_mesh<>&, const tri_tuple&) const {
        return vec3{};
    }
};
struct stop_without_progress {
    using operations = op_list<op::split_edge>;
    bool stop() const { return true; }
};
struct misspelled_invariants {
    using operations = op_list<op::split_edge>;
    auto invariant() const { return invariant_set<>{}; }
};
struct quiescent_without_progress {
    using operations = op_list<op::split_edge>;
    void quiescent(tri_mesh<>&) {}
};
struct no_operations {};

// What the executor would have skipped in silence is not a spec.
static_assert(!spec_for<priority_on_mutable_mesh, tri_mesh<>>);
static_assert(!spec_for<after_for_unlisted_operation, tri_mesh<>>);
static_assert(!spec_for<cache_not_taken, tri_mesh<>>);
static_assert(!spec_for<stop_without_progress, tri_mesh<>>);
static_assert(!spec_for<misspelled_invariants, tri_mesh<>>);
static_assert(!spec_for<quiescent_without_progress, tri_mesh<>>);
static_assert(!spec_for<no_operations, tri_mesh<>>);
// The library's own specs and the user's are.
static_assert(spec_for<algorithms::qslim_spec, tri_mesh<backend::corner_table_tri>>);
static_assert(spec_for<user_ops::split_largest_faces, tri_mesh<>>);

// A const mesh hands out read-only attributes: `before` cannot write. A mutable one
// writes through the journal of the operation that the op_result names (in `after`);
// `m.attribute(h).set(...)` without it is a compile error (spec mistake 9).
template <class M>
concept writes_attributes = requires(M& m, vertex_attribute<int> h,
                                     const op_result<typename M::tuple>& r) {
    m.attribute(h, r).set(0, 1);
};
template <class M>
concept writes_positions = requires(M& m, const op_result<typename M::tuple>& r) {
    m.positions(r).set(0, vec3{});
};
static_assert(!writes_attributes<const tri_mesh<>> && !writes_positions<const tri_mesh<>>);
static_assert(writes_attributes<tri_mesh<>> && writes_positions<tri_mesh<>>);
static_assert(!writes_positions<const tet_mesh<>> && writes_positions<tet_mesh<>>);

/// A decorated spec: counts how often the executor asks it to stop.
template <class Base>
struct counting_stops : Base {
    std::uint64_t stops = 0;
    bool stop(const progress& p) {
        ++stops;
        return Base::stop(p);
    }
};

/// Counts finish() calls, to see the executor make them.
struct finishing_qslim : algorithms::qslim_spec {
    int finished = 0;
    template <class Mesh>
    void finish(Mesh& m) {
        ++finished;
        algorithms::qslim_spec::finish(m);
    }
};

} // namespace

TEST_CASE_TEMPLATE("contract: an algorithm knows its spec, and a decorated spec's hooks run", Mesh,
                   IDAS_TRI_MESHES) {
    using algorithm = algorithms::qslim<Mesh, lock::none>;
    static_assert(std::is_same_v<typename algorithm::spec_type, algorithms::qslim_spec>);
    using decorated =
        typename algorithm::template with_spec<counting_stops<algorithms::qslim_spec>>;
    static_assert(
        std::is_same_v<typename decorated::spec_type, counting_stops<algorithms::qslim_spec>>);

    auto m = test::load<Mesh>("bunny.off");
    counting_stops<algorithms::qslim_spec> spec;
    spec.target_faces = std::int64_t(m.n_faces()) / 2;
    const auto r = decorated::run(m, spec);
    // Serial runs ask after every success (the CLI's progress bar was never asked: 0 calls).
    CHECK(spec.stops >= r.succeeded);
    CHECK(r.succeeded > 0);
    // A collapse removes two faces: an odd distance to the target ends one below it.
    CHECK(std::int64_t(m.n_faces()) <= spec.target_faces);
    CHECK(std::int64_t(m.n_faces()) >= spec.target_faces - 1);
}

TEST_CASE_TEMPLATE("contract: a user's operation kind runs on the executor", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = test::load<Mesh>("bunny.off");
    const auto before = test::topology_of(m);
    const std::size_t faces = m.n_faces(), vertices = m.n_vertices();
    user_ops::split_largest_faces spec;
    spec.target_faces = std::int64_t(faces) + 2000;
    const auto r = executor<user_ops::split_largest_faces, Mesh>::run(m, spec);
    CHECK(r.succeeded == 1000);
    CHECK(m.n_faces() == faces + 2000);
    CHECK(m.n_vertices() == vertices + 1000);
    CHECK(test::topology_of(m) == before);
    CHECK(find_inconsistency(m) == std::nullopt);
    // New vertices sit at their faces' centroids, inside the input's bounding box.
    const auto [V, F] = m.to_arrays();
    for (const auto& p : V) CHECK(is_finite(p));
}

TEST_CASE_TEMPLATE("contract: algorithms remove their own attribute columns", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = test::load<Mesh>("bunny.off");
    const auto user = m.template add_vertex_attribute<float>("user_weight", 1.f);
    const std::size_t columns = m.attributes().size();

    algorithms::remeshing_options o;
    o.target_length = 0.004, o.iterations = 1;
    algorithms::isotropic_remeshing<Mesh, lock::none>::run(m, o);
    CHECK(m.attributes().size() == columns);
    algorithms::isotropic_remeshing<Mesh, lock::none>::run(m, o); // a second run: no eight
    CHECK(m.attributes().size() == columns);

    using algorithm =
        typename algorithms::qslim<Mesh, lock::none>::template with_spec<finishing_qslim>;
    finishing_qslim spec;
    spec.target_faces = std::int64_t(m.n_faces()) / 2;
    algorithm::run(m, spec);
    CHECK(spec.finished == 1);
    CHECK(m.attributes().size() == columns);
    // The user's column came through both algorithms, still readable by name.
    CHECK(m.attributes().template find<float, simplex_kind::vertex>("user_weight").valid());
    CHECK(m.attribute(user)[0] == 1.f);
}
