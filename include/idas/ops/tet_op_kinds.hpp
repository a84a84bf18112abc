// Operation kinds of the tetrahedral core. split_edge, collapse_edge and smooth_vertex
// are the triangle core's kinds (ops/operation.hpp); the swaps are tet-only.
#pragma once

#include <idas/ops/operation.hpp>

#include <cstdint>

namespace idas::op {
/// 2-3 swap: the two tets on an interior face become three tets around a new edge.
struct face_swap_23 { static constexpr std::uint8_t id = 4; };
/// 3-2 swap: the three tets around an interior edge become two tets on a new face.
struct edge_swap_32 { static constexpr std::uint8_t id = 5; };
/// 4-4 swap: the four tets around an interior edge become four around the other diagonal.
struct edge_swap_44 { static constexpr std::uint8_t id = 6; };
/// Edge removal: the n tets around an interior edge become 2n - 4 tets.
struct edge_removal { static constexpr std::uint8_t id = 7; };
} // namespace idas::op
