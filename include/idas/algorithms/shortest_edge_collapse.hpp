// Shortest edge collapse (the paper's first example): collapse the shortest
// edge to its midpoint until the mesh has the target number of faces.
//
//   I  link condition (always), no normal flip (optional), optionally no
//      self-intersection
//   D  priority: edge length, shortest first
//   A  position of the merged vertex: the midpoint (a boundary vertex stays put)
//   S  collapse every edge; after a success, renew the edges of the new star;
//      stop at the target face count
#pragma once

#include <idas/algorithms/decimation_common.hpp>
#include <idas/invariants/no_normal_flip.hpp>

#include <optional>

namespace idas::algorithms {

template <bool NoNormalFlip = true>
struct shortest_edge_collapse_spec : collapse_schedule {
    using operations = op_list<op::collapse_edge>;

    template <class Mesh>
    void prepare(Mesh& m, const exec_options& o) {
        forget_refusals(m);
        plan_serial_tail(o, std::int64_t(m.n_faces()));
    }

    template <class Mesh>
    double priority(op::collapse_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return squared_norm(m.position(a) - m.position(b));
    }

    using collapse_cache = placed_values; // the position, and the file's attributes there

    template <class Mesh>
    std::optional<collapse_cache> before(op::collapse_edge, const Mesh& m,
                                         const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const bool on_a = m.is_boundary_vertex(a), on_b = m.is_boundary_vertex(b);
        std::optional<collapse_cache> c(std::in_place);
        // An open boundary stays where it is.
        c->position =
            on_a != on_b ? m.position(on_a ? a : b) : (m.position(a) + m.position(b)) * 0.5;
        if (transfer && !transfer->collapse_before(m, t, c->position, c->carried)) c.reset();
        return c;
    }

    template <class Mesh>
    bool after(op::collapse_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const collapse_cache& c) const {
        m.positions(r).set(r.anchor.vid, c.position);
        return !transfer || transfer->collapse_after(m, r, c.carried);
    }

    auto invariants() const {
        if constexpr (NoNormalFlip)
            return invariant_set<no_normal_flip, no_self_intersection>{no_normal_flip{},
                                                                       self_intersections};
        else
            return invariant_set<no_self_intersection>{self_intersections};
    }
};

/// The algorithm as a type: spec + data structure + lock + queue + partition.
template <bool NoNormalFlip = true, class Mesh = tri_mesh<>, class Lock = lock::vertex_try_lock,
          class Queue = queue::dary_heap<4>, class Partition = partition::morton>
using shortest_edge_collapse =
    executor<shortest_edge_collapse_spec<NoNormalFlip>, Mesh, Lock, Queue, Partition>;

static_assert(spec_for<shortest_edge_collapse_spec<true>, tri_mesh<>> &&
              spec_for<shortest_edge_collapse_spec<false>, tri_mesh<>>);

} // namespace idas::algorithms
