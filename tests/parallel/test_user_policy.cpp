// A new lock policy and a new operation kind, each written here without touching the
// library: the executor runs them in parallel (under contention: more threads than cores).
#include "../test_support.hpp"
#include "../user_face_split.hpp"

#include <idas/algorithms/qslim.hpp>

#include <atomic>

using namespace idas;

namespace {

/// One try-lock for the whole mesh: a worker runs an operation only while no other does.
/// Slow by design (no two operations overlap in time), but a complete policy: it owns its
/// phase, composed of the run's pieces, and hands lost races to the final serial pass.
struct whole_mesh_try_lock {
    static constexpr bool parallel = true;
    std::atomic<std::uint32_t> owner{0};
    std::atomic<std::uint64_t> claims{0};
    explicit whole_mesh_try_lock(std::size_t) {}
    bool try_lock(index_t, std::uint32_t me) {
        std::uint32_t expected = 0;
        return owner.compare_exchange_strong(expected, me) || expected == me;
    }
    void unlock(index_t, std::uint32_t) { owner.store(0, std::memory_order_release); }

    /// Holds the whole mesh for one operation.
    template <class Run>
    struct claimer {
        Run& run;
        std::uint32_t me;
        bool held = false;
        template <class Op>
        claim_result claim(Op, typename Run::tuple& t) {
            if (!run.locks().try_lock(0, me)) return claim_result::busy;
            held = true;
            run.locks().claims.fetch_add(1, std::memory_order_relaxed);
            auto everything = [](index_t) { return true; };
            return run.template claim_footprint<Op>(t, everything);
        }
        void release() {
            if (held) run.locks().unlock(0, me);
            held = false;
        }
    };

    template <class Run>
    static void execute(Run& run) {
        if (!run.parallel()) return run.serial_phase();
        run.parallel_run([&] {
            run.each_worker([&](typename Run::worker& me) {
                claimer<Run> claim{run, me.index + 1};
                typename Run::entry e;
                while (!run.stopped() && run.pop(me, e)) {
                    const auto s = run.template step<true>(me, e, claim, [](auto, const auto&) {});
                    if (s == step_outcome::busy || s == step_outcome::no_room)
                        run.defer_to_final_pass(e);
                }
            });
        });
    }
};
static_assert(lock_policy<whole_mesh_try_lock>);

} // namespace

TEST_CASE_TEMPLATE("parallel: a user's lock policy runs QSlim on 4 threads", Mesh,
                   IDAS_TRI_MESHES) {
    auto m = test::load<Mesh>("bunny.off");
    const auto before = test::topology_of(m);
    algorithms::qslim_spec spec;
    spec.target_faces = std::int64_t(m.n_faces()) / 4;
    spec.serial_up_to_faces = 0; // bunny.off would run serially
    exec_options o;
    o.threads = 4;
    const auto r = algorithms::qslim<Mesh, whole_mesh_try_lock>::run(m, spec, o);
    CHECK(r.threads == 4);
    CHECK(r.succeeded > 0);
    CHECK(std::abs(std::int64_t(m.n_faces()) - spec.target_faces) <= 8);
    CHECK(find_inconsistency(m) == std::nullopt);
    CHECK(test::topology_of(m) == before);
}

TEST_CASE_TEMPLATE("parallel: a user's operation kind runs on 4 threads", Mesh, IDAS_TRI_MESHES) {
    auto m = test::load<Mesh>("bunny.off");
    const auto before = test::topology_of(m);
    const std::size_t faces = m.n_faces();
    user_ops::split_largest_faces spec;
    spec.target_faces = std::int64_t(faces) + 20000;
    exec_options o;
    o.threads = 4;
    const auto r =
        executor<user_ops::split_largest_faces, Mesh, lock::vertex_try_lock>::run(m, spec, o);
    CHECK(r.threads == 4);
    // Parallel workers stop right after the success that reaches the goal: one each at most.
    CHECK(m.n_faces() >= faces + 20000);
    CHECK(m.n_faces() <= faces + 20000 + 2 * 4);
    CHECK(find_inconsistency(m) == std::nullopt);
    CHECK(test::topology_of(m) == before);
}
