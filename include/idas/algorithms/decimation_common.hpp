// Pieces the decimation specs share.
#pragma once

#include <idas/exec/executor.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include <cstdint>

namespace idas::algorithms {

/// After a collapse into a, every edge of a's new star changed: the spokes (a, x) and
/// the rim edges (x, y) opposite a. Each is pushed once.
template <class Op, class Mesh, class Push>
void push_star_edges(const Mesh& m, const op_result<typename Mesh::tuple>& r, Push& push) {
    const bool open_fan = m.is_boundary_vertex(r.anchor.vid);
    for (const auto& spoke : r.cells) {
        push(Op{}, spoke);                                 // (a, next)
        push(Op{}, m.switch_edge(m.switch_vertex(spoke))); // the rim edge opposite a
        // In an open fan one spoke (prev, a) is on the boundary and in no other cell.
        if (open_fan) {
            const auto prev = m.switch_edge(spoke);
            if (m.is_boundary_edge(prev)) push(Op{}, prev);
        }
    }
}

/// Stops a decimation once the live face count reaches the target.
struct face_target {
    std::int64_t target_faces = 0;
    bool stop(const progress& p) const noexcept { return p.faces <= target_faces; }
    /// A collapse removes two faces (one on the boundary).
    std::int64_t remaining(const progress& p) const noexcept {
        return (p.faces - target_faces) / 2;
    }
};

} // namespace idas::algorithms
