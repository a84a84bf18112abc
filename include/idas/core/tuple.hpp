// Cell tuples: the only way users name and navigate simplices.
#pragma once

#include <idas/core/types.hpp>

#include <compare>

namespace idas {

/// A triangle-mesh cell tuple: a vertex, an edge of a face containing it, and the face,
/// plus the face's version when the tuple was made (so later edits make it stale).
/// The edge is the face's local edge `local_edge`, the one opposite its corner of that index.
struct tri_tuple {
    index_t vid = invalid_index;
    index_t fid = invalid_index;
    std::uint8_t local_edge = 0;
    version_t version = 0;

    friend constexpr bool operator==(const tri_tuple&, const tri_tuple&) = default;
};

/// A tetrahedral-mesh cell tuple: vertex, edge, face of the tet, the tet, and its version.
struct tet_tuple {
    index_t vid = invalid_index;
    index_t tid = invalid_index;
    std::uint8_t local_edge = 0;
    std::uint8_t local_face = 0;
    version_t version = 0;

    friend constexpr bool operator==(const tet_tuple&, const tet_tuple&) = default;
};

} // namespace idas
