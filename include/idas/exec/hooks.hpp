// How the executor calls a spec's schedule hooks, with their defaults when a spec has
// none (exec/contract.hpp has checked that those it has are the right ones).
#pragma once

#include <idas/exec/contract.hpp>
#include <idas/exec/op_list.hpp>
#include <idas/exec/queue.hpp>
#include <idas/exec/report.hpp>
#include <idas/mesh/cells.hpp>

#include <cstdint>

namespace idas::detail {

template <class Spec, class Mesh>
struct hooks {
    using tuple = typename Mesh::tuple;
    using entry = queue_entry<tuple>;
    using ops = op_list_traits<typename Spec::operations>;

    template <class Op>
    static double priority(Spec& spec, const Mesh& m, const tuple& t) {
        if constexpr (priority_hook<Spec, Mesh, Op>)
            return static_cast<double>(spec.priority(Op{}, m, t));
        else
            return 0.0;
    }

    /// Builds the queue entry for Op at t.
    template <class Op>
    static entry make_entry(Spec& spec, const Mesh& m, const tuple& t) {
        return {priority<Op>(spec, m, t), t, ops::template id_of<Op>, 0};
    }

    static void prepare(Spec& spec, Mesh& m, const exec_options& o) {
        if constexpr (requires { spec.prepare(m, o); })
            spec.prepare(m, o);
        else if constexpr (requires { spec.prepare(m); })
            spec.prepare(m);
    }
    static void finish(Spec& spec, Mesh& m) {
        if constexpr (finish_hook<Spec, Mesh>) spec.finish(m);
    }

    /// Where no operation runs (serial runs and the final serial pass, after each
    /// success; before each deterministic round): a spec may refit what its operations
    /// read.
    static void quiescent(Spec& spec, Mesh& m, const progress& p) {
        if constexpr (quiescent_hook<Spec, Mesh>) spec.quiescent(m, p);
    }

    static constexpr bool seeds_per_vertex = initial_at_hook<Spec, Mesh>;

    /// The initial entries found at vertex v.
    template <class Push>
    static void initial_at(Spec& spec, const Mesh& m, index_t v, Push& push) {
        spec.initial_at(m, v, push);
    }

    /// Enqueues the initial entries through `push(Op, tuple)`: the spec's, or every simplex
    /// each operation kind acts on.
    template <class Push>
    static void initial(Spec& spec, const Mesh& m, Push& push) {
        if constexpr (initial_hook<Spec, Mesh>) {
            spec.initial(m, push);
        } else if constexpr (seeds_per_vertex) {
            for (index_t v = 0; v < m.vertex_slots(); ++v)
                if (m.vertex_alive(v)) spec.initial_at(m, v, push);
        } else {
            ops::for_each([&](auto op) {
                using Op = decltype(op);
                auto push_op = [&](const tuple& t) { push(Op{}, t); };
                if constexpr (Op::acts_on == simplex_kind::vertex)
                    m.for_each_vertex(push_op);
                else if constexpr (Op::acts_on == simplex_kind::edge)
                    m.for_each_edge(push_op);
                else if constexpr (Op::acts_on == simplex_kind::face)
                    m.for_each_face(push_op);
                else
                    m.for_each_tet(push_op);
            });
        }
    }

    template <class Op, class Push>
    static void renew(Spec& spec, const Mesh& m, const op_result<tuple>& r, Push& push) {
        if constexpr (renew_hook<Spec, Mesh, Op>) spec.renew(Op{}, m, r, push);
    }

    /// A spec that knows how many successes it still wants lets parallel workers stop
    /// right after the success that reaches the goal, not at the next periodic check.
    static bool goal_reached(Spec& spec, const progress& p) {
        if constexpr (remaining_hook<Spec>)
            return spec.remaining(p) <= 0;
        else
            return false;
    }

    /// Whether the spec wants a number of successes from parallel workers (`remaining`):
    /// then which operations run before the goal is met matters, not only that each does.
    static constexpr bool has_goal = remaining_hook<Spec>;

    /// Whether the spec stops on progress (a goal or a criterion). If not, parallel
    /// workers keep no shared live counts: one contended atomic add per success saved
    /// (the harmonic and remeshing phases run until their queues are empty).
    static constexpr bool watches_progress = remaining_hook<Spec> || stop_hook<Spec>;

    static bool should_stop(Spec& spec, const progress& p) {
        if constexpr (stop_hook<Spec>)
            return spec.stop(p);
        else
            return false;
    }

    template <class Op>
    static bool should_process(Spec& spec, const Mesh& m, const entry& e) {
        if constexpr (should_process_hook<Spec, Mesh, Op>)
            return spec.should_process(Op{}, m, e);
        else
            return true;
    }

    /// Tells the spec an operation was refused (in parallel its region is still held).
    template <class Op>
    static void refused(Spec& spec, const Mesh& m, const tuple& t) {
        if constexpr (refused_hook<Spec, Mesh, Op>) spec.refused(Op{}, m, t);
    }

    /// Slots to set aside for new simplices in parallel: the spec's, or room for the mesh
    /// to double: as many vertices as it has (at least 4096) and as many cells (at least
    /// twice the vertices). A tet mesh has about six tets a vertex, so twice the vertices
    /// alone sent two thirds of a tet mesh's first splits to the serial pass.
    static std::pair<index_t, index_t> parallel_growth(Spec& spec, const Mesh& m) {
        if constexpr (requires { spec.parallel_growth(m).first; }) {
            const auto [v, c] = spec.parallel_growth(m);
            return {static_cast<index_t>(v), static_cast<index_t>(c)};
        } else if constexpr (requires { spec.parallel_growth(m); }) {
            const auto v = static_cast<index_t>(spec.parallel_growth(m));
            return {v, 2 * v};
        } else {
            const index_t v = std::max<index_t>(4096, index_t(m.n_vertices()));
            return {v, std::max<index_t>(2 * v, index_t(cells::live(m)))};
        }
    }

    /// Lock words of a parallel run: one per vertex slot, then those of an invariant that
    /// claims space beyond the operation's star (its `claim` takes word k as
    /// vertex_slots() + k: for example the cells of a spatial index it reads and writes).
    static std::size_t lock_words(Spec& spec, const Mesh& m) {
        using set = std::remove_cvref_t<decltype(spec_invariants(spec))>;
        if constexpr (set::claims_space)
            return std::size_t(m.vertex_slots()) + spec_invariants(spec).extra_lock_words(m);
        else
            return m.vertex_slots();
    }

    static progress counts(const Mesh& m) {
        return {static_cast<std::int64_t>(cells::live(m)),
                static_cast<std::int64_t>(m.n_vertices()), 0};
    }
};

} // namespace idas::detail
