// `idas decimate` and the Python module's idas.decimate: the options, their checks and the
// run (mesh built, attributes attached, collapses guarded against self-intersections,
// result checked), on a surface already read. The front ends read, write and report.
#pragma once

#include "common.hpp"

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

namespace idas::tool {

struct decimate_options {
    std::string algorithm = "qslim"; // or "shortest-edge"
    std::optional<double> ratio;     // the target as a fraction of the input's faces, or
    std::int64_t faces = -1;         // a face count
    unsigned threads = 1;
    bool deterministic = false; // lock::deterministic_rounds
    bool keep_boundary = false;
    bool allow_self_intersections = false; // no_self_intersection off
    std::optional<double> feature_angle;   // degrees
    std::string backend = "indexed";
    /// QSlim: how much the attributes weigh against the shape (qslim_spec::attribute_weight;
    /// its default when not given).
    std::optional<double> attribute_weight;
};

/// Every option that needs no input is checked before any reading.
inline void check_decimate_options(const decimate_options& o) {
    if (o.algorithm != "qslim" && o.algorithm != "shortest-edge")
        throw idas::input_error("--algorithm must be shortest-edge or qslim (got '" + o.algorithm +
                                "')");
    check_backend(o.backend);
    check_threads(o.threads);
    if (o.ratio && !(*o.ratio > 0 && *o.ratio <= 1))
        throw idas::input_error("--ratio must be in (0, 1]");
    if (!o.ratio && o.faces < 0) throw idas::input_error("--faces must be non-negative");
    if (o.feature_angle && !(*o.feature_angle >= 0 && *o.feature_angle <= 180))
        throw idas::input_error("--feature-angle must be between 0 and 180 degrees");
    if (o.attribute_weight && !(*o.attribute_weight >= 0 && std::isfinite(*o.attribute_weight)))
        throw idas::input_error("--attribute-weight must be a finite number >= 0 (got " +
                                std::to_string(*o.attribute_weight) + ")");
    if (o.attribute_weight && o.algorithm != "qslim")
        throw idas::input_error("--attribute-weight applies to --algorithm qslim only");
}

struct decimated {
    idas::io::surface mesh;
    idas::run_report report;
    std::int64_t input_faces = 0, target_faces = 0;
    std::size_t constrained_vertices = 0;
    double check_seconds = 0;
};

/// Decimates `s` (read from `source`, which error messages name) on the backend o.backend
/// names; `progress` may be null. Laps "build" ... "check" on `phases`. Compiled once, in
/// decimate.cpp.
decimated decimate_surface(const idas::io::surface& s, const std::string& source,
                           const decimate_options& o, phase_times& phases,
                           const face_progress* progress);

} // namespace idas::tool
