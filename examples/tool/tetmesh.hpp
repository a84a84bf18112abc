// `idas tetmesh` and the Python module's idas.tetmesh: the options, their checks, the
// sizing field, and the full run (insertion and optimization) on a surface already read,
// down to the tets that are written (the inside, its vertices renumbered, or every tet with
// its tag). The run needs CGAL (IDAS_CLI_HAVE_CGAL); the options do not.
#pragma once

#include "common.hpp"

#if IDAS_CLI_HAVE_CGAL
#include <idas/cgal/tetmesh.hpp>
#endif
#include <idas/io/volume.hpp>
#include <idas/mesh/sizing_field.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace idas::tool {

struct tetmesh_options {
    std::string stage = "optimize"; // or "insertion": part 1 only
    std::string sizing;             // a constant or a .msh sizing mesh; empty: none
    double epsilon = 1e-3, edge_length = 1.0 / 20.0, stop_energy = 10;
    unsigned max_iterations = 80;
    unsigned stall_rounds = 12;
    bool absolute = false, keep_outside = false, no_simplify = false;
    bool deterministic = false; // lock::deterministic_rounds: the same mesh at any thread count
    unsigned threads = 1;
};

/// Every option that needs no input is checked before any reading; returns the constant
/// sizing when `sizing` is a number.
inline std::optional<double> check_tetmesh_options(const tetmesh_options& a) {
    if (a.stage != "optimize" && a.stage != "insertion")
        throw idas::input_error("--stage must be insertion or optimize (got '" + a.stage + "')");
    check_threads(a.threads);
    if (!(a.epsilon > 0) || !std::isfinite(a.epsilon) || (!a.absolute && a.epsilon > 1))
        throw idas::input_error("--epsilon must be positive and finite (at most 1 when relative)");
    if (!(a.edge_length > 0) || !std::isfinite(a.edge_length) ||
        (!a.absolute && a.edge_length > 10))
        throw idas::input_error(
            "--edge-length must be positive and finite (at most 10 when relative)");
    if (!(a.stop_energy >= 3) || !std::isfinite(a.stop_energy))
        throw idas::input_error("--stop-energy must be a finite number of at least 3 (the "
                                "AMIPS energy of a regular tet)");
    if (a.max_iterations > 100000)
        throw idas::input_error("--max-iterations must be at most 100000");
    if (a.stall_rounds > 100000) throw idas::input_error("--stall-rounds must be at most 100000");

    // A number is a constant field (the edge length itself); anything else a sizing mesh.
    if (a.sizing.empty()) return std::nullopt;
    if (a.stage != "optimize")
        throw idas::input_error("--sizing applies to the optimization, not to --stage " + a.stage);
    double x = 0;
    if (idas::io::detail::parse_double(a.sizing, x) == idas::io::detail::parse_status::ok) {
        if (!(x > 0) || !std::isfinite(x) || (!a.absolute && x > 10))
            throw idas::input_error("--sizing " + a.sizing +
                                    ": a constant sizing must be positive and finite (at "
                                    "most 10 when relative)");
        return x;
    }
    if (lowercase_extension(a.sizing) != ".msh")
        throw idas::input_error("--sizing " + a.sizing +
                                ": neither a number nor a .msh sizing mesh");
    return std::nullopt;
}

#if IDAS_CLI_HAVE_CGAL
/// The insertion's guarantee, checked: a failure is a bug in idas, not in the input
/// (exit 1).
inline void check_insertion_guarantee(const idas::tetmesh::report& r) {
    if (r.covered_triangles != r.simplified_triangles || r.inverted_tets != 0)
        throw std::runtime_error(
            "internal error: tetmesh covered " + std::to_string(r.covered_triangles) + " of " +
            std::to_string(r.simplified_triangles) + " triangles exactly and left " +
            std::to_string(r.inverted_tets) + " inverted tets; nothing was written");
}

/// The user's sizing field from a .msh file: its first scalar $NodeData, absolute lengths.
inline idas::background_sizing read_sizing_mesh(const std::string& path, double outside) {
    idas::io::volume bg = load_tets(path);
    const auto field = std::find_if(bg.vertex_fields.begin(), bg.vertex_fields.end(),
                                    [](const auto& f) { return f.components == 1; });
    if (field == bg.vertex_fields.end())
        throw idas::input_error(path + ": a sizing mesh needs a scalar $NodeData block (one " +
                                "length per node); this file has " +
                                std::to_string(bg.vertex_fields.size()) +
                                " $NodeData blocks, none scalar");
    return idas::background_sizing(std::move(bg.vertices), std::move(bg.tets), field->values,
                                   outside, path);
}

/// What the run needs besides the soup: the library's options and the sizing field.
struct tetmesh_setup {
    idas::tetmesh::options options;
    std::optional<idas::background_sizing> sizing;
};

/// The library's options for `s` (read from `source`); reads a sizing mesh if one is named.
inline tetmesh_setup prepare_tetmesh(const tetmesh_options& a, const idas::io::surface& s,
                                     const std::optional<double>& constant_sizing) {
    tetmesh_setup setup;
    auto& o = setup.options;
    o.epsilon = a.epsilon, o.edge_length = a.edge_length, o.absolute = a.absolute;
    if (constant_sizing) o.edge_length = *constant_sizing;
    o.simplify = !a.no_simplify;
    o.deterministic = a.deterministic;
    if (!a.sizing.empty() && !constant_sizing) {
        // Outside the sizing mesh: the run's own edge length, which needs the diagonal.
        double outside = a.edge_length;
        if (!a.absolute) {
            idas::vec3 lo = s.vertices.empty() ? idas::vec3{} : s.vertices[0], hi = lo;
            for (const auto& p : s.vertices)
                for (int k = 0; k < 3; ++k)
                    lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
            outside *= idas::norm(hi - lo);
        }
        setup.sizing.emplace(
            read_sizing_mesh(a.sizing, outside > 0 && std::isfinite(outside) ? outside : 1.0));
    }
    return setup;
}

struct tetmeshed {
    idas::io::volume mesh; // the tets written, tag 1 inside and 2 outside
    idas::tetmesh::report insertion;
    idas::tetmesh::quality_report quality;
};

/// Hears every round of the optimization: (round, largest energy).
using round_observer = callback<unsigned, double>;

/// The full run (parts 1 and 2) on `s` (from `source`); `observer` (may be null) hears
/// every round of the optimization. Compiled once, in tetmesh.cpp.
tetmeshed tetmesh_volume(const idas::io::surface& s, const std::string& source,
                         const tetmesh_options& a, const tetmesh_setup& setup,
                         const round_observer* observer);
#endif

} // namespace idas::tool
