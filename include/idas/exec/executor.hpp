// The IDAS schedule as a compile-time executor. An algorithm is a type alias:
//
//   using my_algorithm = idas::executor<my_spec, idas::tri_mesh<>, idas::lock::vertex_try_lock,
//                                       idas::queue::binary_heap, idas::partition::morton>;
//
// The spec names its operations (`using operations = idas::op_list<...>`) and may give
// any of the hooks listed in exec/contract.hpp, which checks them when the executor is
// instantiated: a hook with the right name and the wrong signature is a compile error
// that names the hook. The same executor runs triangle meshes (cells are faces) and
// tetrahedral meshes (cells are tets); `progress::faces` counts the mesh's top cells.
// The operation functions are found by argument-dependent lookup (`apply(Op, mesh,
// tuple, spec, context)`), so a user's operation kind needs no registration.
// The lock policy owns the run's phases (exec/lock.hpp); the run (exec/run.hpp) owns the
// queues, workers and the one step they all take. No std::function, no virtual call, no
// string, and no allocation per operation once buffers are warm.
#pragma once

#include <idas/exec/contract.hpp>
#include <idas/exec/deterministic.hpp>
#include <idas/exec/lock.hpp>
#include <idas/exec/op_list.hpp>
#include <idas/exec/partition.hpp>
#include <idas/exec/queue.hpp>
#include <idas/exec/report.hpp>
#include <idas/exec/run.hpp>
#include <idas/exec/workers.hpp>
#include <idas/mesh/cells.hpp>
#include <idas/ops/operation.hpp>
#include <idas/ops/tet_op_kinds.hpp>
#include <idas/ops/tri_ops.hpp>

#include <chrono>
#include <concepts>

namespace idas {

template <class Spec, executable_mesh Mesh, lock_policy Lock = lock::none,
          class Queue = queue::binary_heap, class Partition = partition::morton>
requires queue_policy<Queue, queue_entry<typename Mesh::tuple>> && partition_policy<Partition, Mesh>
class executor {
    static_assert(detail::check_contract<Spec, Mesh>());

public:
    using spec_type = Spec;
    using mesh_type = Mesh;
    using lock_type = Lock;
    using queue_policy_type = Queue;
    using partition_type = Partition;
    using tuple = typename Mesh::tuple;
    using entry = queue_entry<tuple>;

    /// The same algorithm with another spec, e.g. a decorated one (progress, logging, a
    /// user's extra stopping criterion): `qslim<>::with_spec<with_progress<qslim_spec>>`.
    template <class OtherSpec>
    using with_spec = executor<OtherSpec, Mesh, Lock, Queue, Partition>;

    /// Runs the schedule to completion (or until `stop`). Serial when the lock policy is
    /// `lock::none` or one thread is asked for; otherwise on one thread per worker.
    /// Takes exactly `spec_type`: a spec derived from it would be run as its base, and the
    /// derived hooks never called; name the derived type with `with_spec` instead.
    template <class S>
    static run_report run(Mesh& m, S& spec, const exec_options& options = {}) {
        static_assert(std::same_as<S, Spec>,
                      "idas: executor::run takes the executor's spec_type exactly; a derived or "
                      "decorated spec would run as its base and its own hooks would never be "
                      "called: run it with Algorithm::with_spec<Decorated>::run");
        const detail::stopwatch total;
        exec_options o = options;
        o.deterministic = deterministic_policy<Lock>;
        detail::hooks<Spec, Mesh>::prepare(spec, m, o);
        const double prepared = total.seconds();
        schedule_run<Spec, Mesh, Lock, Queue, Partition> run(m, spec, o);
        Lock::execute(run);
        const detail::stopwatch finishing;
        detail::hooks<Spec, Mesh>::finish(spec, m);
        run_report report = run.report();
        report.setup_seconds += prepared;
        report.tail_seconds += finishing.seconds();
        report.seconds = total.seconds();
        return report;
    }
};

} // namespace idas
