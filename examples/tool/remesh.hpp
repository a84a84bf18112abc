// `idas remesh` and the Python module's idas.remesh: isotropic remeshing's options, their
// checks and the run on a surface already read (target length from the diagonal, the
// output-size limit, attributes, self-intersections and the envelope, the result check).
// The envelope needs CGAL (IDAS_CLI_HAVE_CGAL).
#pragma once

#include "surface_stats.hpp"

#include <idas/algorithms/isotropic_remeshing.hpp> // remeshing_report

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace idas::tool {

struct remesh_options {
    double edge_length = 0.01; // relative to the bounding-box diagonal unless absolute
    bool absolute = false;
    unsigned iterations = 5;
    unsigned threads = 1;
    std::optional<double> envelope;      // relative eps
    std::optional<double> feature_angle; // degrees
    bool keep_boundary = true;
    bool deterministic = false;            // lock::deterministic_rounds
    bool allow_self_intersections = false; // no_self_intersection off
    std::string backend = "indexed";
    bool trace = false; // the mesh's quality after every phase (remeshed::trace)
    // The default output limit: about 15 GB while remeshing (connectivity, queues,
    // attributes and the written copy take some 150 bytes per face).
    std::uint64_t max_faces = 100'000'000;
};

/// Every option that needs no input is checked before any reading.
inline void check_remesh_options(const remesh_options& o) {
    check_backend(o.backend);
    check_threads(o.threads);
    if (!(o.edge_length > 0) || !std::isfinite(o.edge_length))
        throw idas::input_error("--edge-length must be a positive number");
    if (o.envelope && !(*o.envelope > 0 && std::isfinite(*o.envelope)))
        throw idas::input_error("--envelope must be a positive number");
    if (o.feature_angle && !(*o.feature_angle >= 0 && *o.feature_angle <= 180))
        throw idas::input_error("--feature-angle must be between 0 and 180 degrees");
}

/// Faces of an isotropic mesh of edge length L on the surface: area / (sqrt(3)/4 L^2).
inline double estimated_faces(const idas::io::surface& s, double target_length) {
    double area = 0;
    for (const auto& f : s.faces)
        area += 0.5 * idas::norm(idas::cross(s.vertices[f[1]] - s.vertices[f[0]],
                                             s.vertices[f[2]] - s.vertices[f[0]]));
    return area / (std::sqrt(3.0) / 4 * target_length * target_length);
}

inline constexpr const char* remeshing_phase_names[] = {"split", "collapse", "swap", "smooth"};

/// The mesh after one phase of one iteration (`--trace`): where a run loses quality.
struct phase_quality {
    unsigned iteration = 0;
    std::size_t phase = 0; // index into remeshing_phase_names
    std::size_t faces = 0;
    double min_angle_deg = 180;
    idas::vec3 min_angle_at{}; // the centroid of the face with the smallest angle
    std::size_t min_valence = 0, max_valence = 0;
};

struct remeshed {
    idas::io::surface mesh;
    idas::algorithms::remeshing_report report;
    double target_length = 0;
    std::optional<double> envelope; // absolute
    mesh_stats input_stats, output_stats;
    double check_seconds = 0;
    std::vector<phase_quality> trace; // with remesh_options::trace
};

/// Remeshes `s` (read from `source`, which error messages name) on the backend a.backend
/// names; `progress` (may be null) hears (fraction done, note) after every phase. Laps
/// "input_statistics" ... "check" on `phases`. Compiled once, in remesh.cpp.
remeshed remesh_surface(const idas::io::surface& s, const std::string& source,
                        const remesh_options& a, phase_times& phases,
                        const phase_progress* progress);

} // namespace idas::tool
