// Operation kinds of the tetrahedral core. split_edge, collapse_edge and smooth_vertex
// are the triangle core's kinds (ops/operation.hpp); the swaps are tet-only. On tet
// meshes `adds_faces` counts new top-simplex (tet) slots.
#pragma once

#include <idas/ops/operation.hpp>

#include <cstddef>
#include <cstdint>

namespace idas {

/// Longest edge ring edge_removal handles (its dynamic programme is cubic in the ring).
inline constexpr std::size_t max_edge_ring = 24;

/// Most tets around an edge that split_tet_edge handles. Far more than a good mesh has:
/// an edge that cannot be split while it is too long makes the splits around it refine
/// its ring without end, and meshes straight out of triangle insertion have edges with
/// over a hundred tets.
inline constexpr std::size_t max_split_ring = 512;

namespace op {
/// 2-3 swap: the two tets on an interior face become three tets around a new edge.
struct face_swap_23 {
    static constexpr simplex_kind acts_on = simplex_kind::face;
    static constexpr index_t adds_vertices = 0, adds_faces = 1;
    static constexpr idas::new_facets new_facets = idas::new_facets::inside_region;
};
/// 3-2 swap: the three tets around an interior edge become two tets on a new face.
struct edge_swap_32 {
    static constexpr simplex_kind acts_on = simplex_kind::edge;
    static constexpr index_t adds_vertices = 0, adds_faces = 0;
    static constexpr idas::new_facets new_facets = idas::new_facets::inside_region;
};
/// 4-4 swap: the four tets around an interior edge become four around the other diagonal.
struct edge_swap_44 {
    static constexpr simplex_kind acts_on = simplex_kind::edge;
    static constexpr index_t adds_vertices = 0, adds_faces = 0;
    static constexpr idas::new_facets new_facets = idas::new_facets::inside_region;
};
/// Edge split on a tet mesh (ops/tet_ops.hpp's split_edge under a kind of its own): the
/// n tets around the edge become 2n, so a parallel worker needs room for n new tets. It is
/// refused on edges with more than max_split_ring tets, so the room it asks for suffices.
struct split_tet_edge {
    static constexpr simplex_kind acts_on = simplex_kind::edge;
    static constexpr index_t adds_vertices = 1, adds_faces = index_t(max_split_ring);
    static constexpr idas::new_facets new_facets = idas::new_facets::through_anchor;
};
/// Edge removal: the n tets around an interior edge become 2n - 4 tets.
struct edge_removal {
    static constexpr simplex_kind acts_on = simplex_kind::edge;
    static constexpr index_t adds_vertices = 0, adds_faces = index_t(max_edge_ring - 4);
    static constexpr idas::new_facets new_facets = idas::new_facets::inside_region;
};
} // namespace op

static_assert(operation_kind<op::split_tet_edge> && operation_kind<op::face_swap_23> &&
              operation_kind<op::edge_swap_32> && operation_kind<op::edge_swap_44> &&
              operation_kind<op::edge_removal>);

} // namespace idas
