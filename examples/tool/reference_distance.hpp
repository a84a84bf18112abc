// `idas info IN --reference REF`: how far a mesh's surface (a tet mesh's boundary) lies from
// a reference surface, both ways, as a sampled Hausdorff distance (mesh/surface_distance.hpp).
// This is what a tet mesher promises about its boundary (within epsilon of the input) and
// what a decimation costs; it measures any tool's output the same way, so bench/ compares
// idas with fTetWild and TetGen through it.
#pragma once

#include "surface_stats.hpp"

#include <idas/core/aabb_tree.hpp>
#include <idas/io/io.hpp>
#include <idas/mesh/surface_distance.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace idas::tool {

/// The farthest sample of each surface from the other, in absolute units and relative to
/// the diagonal of the reference's faces' bounding box.
struct reference_distance {
    std::string file;
    int samples_per_face = 0;
    double diagonal = 0;                        // of the reference
    idas::farthest_sample surface_to_reference; // a sample of the measured surface
    idas::farthest_sample reference_to_surface; // a sample of the reference
};

/// Samples per face from `--samples`: at most this many (a face then takes 10,000 distance
/// queries; more says nothing the default does not).
inline constexpr int max_samples_per_face = 10000;

/// Measures surface (V, F) against the reference `ref` read from `file`, with `samples`
/// samples per face (checked by the caller: 0 to max_samples_per_face).
inline reference_distance measure_against_reference(const std::vector<vec3>& V,
                                                    const std::vector<idas::tri_indices>& F,
                                                    const idas::io::surface& ref,
                                                    const std::string& file, int samples) {
    if (ref.faces.empty()) throw idas::input_error(file + ": the reference has no faces");
    reference_distance r;
    r.file = file, r.samples_per_face = samples;
    const idas::triangle_aabb_tree reference(ref.vertices, ref.faces);
    r.diagonal = reference.diagonal();
    r.surface_to_reference = idas::farthest_sampled_point(V, F, reference, samples);
    if (F.empty()) { // nothing to come near: every reference point is infinitely far
        r.reference_to_surface = {std::numeric_limits<double>::infinity(), ref.vertices.front(), 0};
    } else {
        r.reference_to_surface = idas::farthest_sampled_point(
            ref.vertices, ref.faces, idas::triangle_aabb_tree(V, F), samples);
    }
    return r;
}

inline json reference_distance_json(const reference_distance& r) {
    const auto side = [&](const idas::farthest_sample& s) {
        const bool finite = std::isfinite(s.distance);
        return json{
            {"max", finite ? json(s.distance) : json(nullptr)},
            {"relative", finite && r.diagonal > 0 ? json(s.distance / r.diagonal) : json(nullptr)},
            {"at", finite ? vec_json(s.point) : json(nullptr)}};
    };
    return {{"file", r.file},
            {"diagonal", r.diagonal},
            {"samples_per_face", r.samples_per_face},
            {"surface_to_reference", side(r.surface_to_reference)},
            {"reference_to_surface", side(r.reference_to_surface)}};
}

/// Two lines under `info`'s statistics; `what` names the measured surface.
inline void print_reference_distance(const reference_distance& r, const std::string& what) {
    const auto line = [&](const char* from, const char* to, const idas::farthest_sample& s) {
        fmt::print("  {:<22}max {:.6g} ({:.3g} of its diagonal)\n", std::string(from) + " -> " + to,
                   s.distance, r.diagonal > 0 ? s.distance / r.diagonal : 0.0);
    };
    fmt::print("  distance to reference {} ({} samples per face)\n", r.file, r.samples_per_face);
    line(what.c_str(), "reference", r.surface_to_reference);
    line("reference", what.c_str(), r.reference_to_surface);
}

} // namespace idas::tool
