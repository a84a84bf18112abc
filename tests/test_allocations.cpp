// No heap allocation per navigation step or per operation in steady state, shown with
// a counting global allocator (active for the whole test binary, counted only here).
#include "test_support.hpp"

#include <idas/algorithms/qslim.hpp>

// The replacement operators below pair malloc with free; g++ cannot see that once inlined.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<long> g_allocations{0};
}

void* operator new(std::size_t n) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}

using namespace idas;

namespace {
long allocations() {
    return g_allocations.load(std::memory_order_relaxed);
}

/// Runs one round of every operation around many edges: split then collapse the new
/// edge back, swap there and back, smooth. `spec` may fail at random (rollbacks);
/// `keep` never fails, so every undo step succeeds and the mesh returns to the same
/// state: a true steady state.
template <class Mesh, class Spec>
int round_of_operations(Mesh& m, Spec& spec, Spec& keep, const std::vector<index_t>& faces) {
    int done = 0;
    for (index_t f : faces) {
        if (!m.face_alive(f)) continue;
        auto t = m.tuple_from_edge(f, 0);
        if (auto r = split_edge(m, t, spec)) {
            ++done;
            REQUIRE(collapse_edge(m, m.switch_vertex(r->anchor), keep));
            ++done;
        }
        t = m.tuple_from_edge(f, 1);
        if (auto r = swap_edge(m, t, spec)) {
            ++done;
            REQUIRE(swap_edge(m, r->anchor)); // no invariants: the way back always exists
        }
        if (smooth_vertex(m, m.tuple_from_edge(f, 2), spec)) ++done;
    }
    return done;
}
} // namespace

TEST_CASE_TEMPLATE("navigation allocates nothing", Mesh, IDAS_TRI_MESHES) {
    auto m = idas::test::load<Mesh>("bunny.obj");
    const auto edges = m.get_edges();
    const long before = allocations();
    std::size_t sum = 0;
    for (const auto& e : edges) {
        auto t = m.switch_edge(m.switch_vertex(e));
        if (auto g = m.switch_face(t)) t = *g;
        sum += m.eid(t) + (m.is_valid(t) ? 1 : 0) + (m.is_boundary_vertex(t.vid) ? 1 : 0);
    }
    CHECK(allocations() == before);
    CHECK(sum > 0);
}

TEST_CASE_TEMPLATE("operations and rollbacks allocate nothing in steady state", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = idas::test::load<Mesh>("bunny.obj");
    idas::test::midpoint_spec spec;
    spec.attach(m);
    auto keep = spec;
    keep.collapse_to_survivor = true;
    std::mt19937 rng(11);
    spec.rng = &rng;
    std::vector<index_t> faces;
    for (index_t f = 0; f < m.face_slots(); f += 7) faces.push_back(f);

    // Warm-up: buffers, journals and recycled slots reach their working sizes.
    for (int k = 0; k < 3; ++k) round_of_operations(m, spec, keep, faces);
    spec.fail_probability = 0.5;
    round_of_operations(m, spec, keep, faces);
    spec.fail_probability = 0;

    const long before = allocations();
    const int done = round_of_operations(m, spec, keep, faces);
    spec.fail_probability = 0.5;
    const int done_with_failures = round_of_operations(m, spec, keep, faces);
    const long used = allocations() - before;
    CHECK(done > 10000);
    CHECK(done_with_failures > 1000);
    CHECK_MESSAGE(used == 0,
                  used << " allocations in " << done + done_with_failures << " operations");
    CHECK_FALSE(find_inconsistency(m).has_value());
}

TEST_CASE_TEMPLATE("the executor allocates nothing per operation", Mesh, IDAS_TRI_MESHES) {
    // Two serial QSlim runs that differ by tens of thousands of collapses (every step:
    // claim, hooks, attempt, renew, push, count) differ by far fewer allocations than
    // collapses: the geometric growth of a few buffers and, on the indexed backend, of the
    // per-vertex face lists of vertices whose valence grows past their inline capacity.
    auto allocations_to = [](double ratio, std::uint64_t& collapses) {
        auto m = idas::test::load<Mesh>("bunny.obj");
        algorithms::qslim_spec spec;
        spec.target_faces = std::int64_t(ratio * double(m.n_faces()));
        const long before = allocations();
        collapses = algorithms::qslim<Mesh, lock::none>::run(m, spec).succeeded;
        return allocations() - before;
    };
    std::uint64_t few = 0, many = 0;
    const long a = allocations_to(0.9, few), b = allocations_to(0.1, many);
    CHECK(many > few + 20000);
    CHECK(double(b - a) < double(many - few) / 50);
}
