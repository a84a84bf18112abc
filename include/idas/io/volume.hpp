// The in-memory tetrahedral mesh that the volume readers produce and the writers consume.
#pragma once

#include "idas/core/types.hpp"
#include "idas/io/surface.hpp"
#include "idas/predicates/orient.hpp"

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace idas::io {

/// Values given per vertex (MSH $NodeData) or per tet (MSH $ElementData): `components`
/// doubles per item, item after item; NaN where the file gives no value for an item.
struct field {
    std::string name;
    int components = 1;
    std::vector<double> values;
};
using vertex_field = field;
using tet_field = field;

/// Tets as stored in a file: positions and 0-based corner indices. Readers guarantee
/// every index is in range and no tet repeats a vertex; they do not check orientation
/// or manifoldness (tet_mesh does).
struct volume {
    std::vector<vec3> vertices;
    std::vector<tet_indices> tets;
    /// Elements of other types (points, lines, quads, higher-order cells...) that the
    /// reader skipped.
    std::size_t skipped_elements = 0;
    /// Per tet, its physical tag (MSH 2.2's first element tag, MSH 4.1's volume entity's
    /// first physical tag); the writers store it as the physical and elementary tag. Empty
    /// means tag 1 for every tet.
    std::vector<int> tags;
    /// Triangles stored with the tets (boundary and interface faces: MSH element type 2),
    /// and their physical tags, read and written like the tets'.
    std::vector<tri_indices> triangles;
    std::vector<int> triangle_tags;
    /// Per-vertex fields (MSH $NodeData, read and written; VTU point data).
    std::vector<vertex_field> vertex_fields;
    /// Per-tet fields (MSH $ElementData, read and written: TetWild's per-tet quality).
    std::vector<tet_field> tet_fields;
};

/// Swaps two corners of every negatively oriented tet (exact orient3d), for files
/// written with the opposite convention. Returns how many were flipped; flat tets are
/// left alone. Precondition: indices in range (as readers guarantee).
inline std::size_t orient_tets_positively(volume& v) {
    std::size_t flipped = 0;
    for (auto& t : v.tets)
        if (orient3d(v.vertices[t[0]], v.vertices[t[1]], v.vertices[t[2]], v.vertices[t[3]]) < 0)
            std::swap(t[2], t[3]), ++flipped;
    return flipped;
}

namespace detail {

/// Writers refuse what readers would refuse, so every file idas writes reads back.
inline void check_writable(const volume& v, std::string_view target) {
    if (v.vertices.size() >= invalid_index) fail(target, "too many vertices to write");
    if (v.tets.size() >= invalid_index) fail(target, "too many tets to write");
    for (std::size_t i = 0; i < v.vertices.size(); ++i)
        if (!is_finite(v.vertices[i]))
            fail(target, "vertex " + std::to_string(i) + " has a non-finite coordinate");
    // Tets and the triangles stored with them: indices in range, no vertex twice, one
    // positive tag each (or none).
    const auto check_cells = [&](const auto& cells, const std::vector<int>& tags,
                                 const std::string& what) {
        for (std::size_t t = 0; t < cells.size(); ++t) {
            const auto& c = cells[t];
            for (std::size_t i = 0; i < c.size(); ++i) {
                if (c[i] >= v.vertices.size())
                    fail(target, what + " " + std::to_string(t) + " references vertex " +
                                     std::to_string(c[i]) + " but there are only " +
                                     std::to_string(v.vertices.size()) + " vertices");
                for (std::size_t j = i + 1; j < c.size(); ++j)
                    if (c[i] == c[j])
                        fail(target,
                             what + " " + std::to_string(t) + " is degenerate (repeats a vertex)");
            }
        }
        if (!tags.empty() && tags.size() != cells.size())
            fail(target, "there are " + std::to_string(tags.size()) + " " + what + " tags for " +
                             std::to_string(cells.size()) + " " + what + "s");
        for (int tag : tags)
            if (tag <= 0) fail(target, what + " tags must be positive (MSH physical tags)");
    };
    check_cells(v.tets, v.tags, "tet");
    check_cells(v.triangles, v.triangle_tags, "triangle");
    const auto check_fields = [&](const std::vector<field>& fields, std::size_t items,
                                  const char* what, const char* plural) {
        for (const auto& f : fields) {
            if (f.components < 1 || f.components > 9)
                fail(target, std::string(what) + " field \"" + f.name + "\" has " +
                                 std::to_string(f.components) +
                                 " components (1 to 9 can be written)");
            if (f.values.size() != items * std::size_t(f.components))
                fail(target, std::string(what) + " field \"" + f.name + "\" has " +
                                 std::to_string(f.values.size()) + " values for " +
                                 std::to_string(items) + " " + plural);
            if (f.name.find_first_of("\"\n\r") != std::string::npos)
                fail(target,
                     std::string("a ") + what + " field's name holds a quote or a line break");
        }
    };
    check_fields(v.vertex_fields, v.vertices.size(), "vertex", "vertices");
    check_fields(v.tet_fields, v.tets.size(), "tet", "tets");
}

} // namespace detail

} // namespace idas::io
