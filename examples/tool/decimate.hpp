// `idas decimate` and the Python module's idas.decimate: the options, their checks and the
// run (mesh built, attributes attached, collapses guarded against self-intersections,
// result checked), on a surface already read. The front ends read, write and report.
#pragma once

#include "common.hpp"

#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/invariants/no_self_intersection.hpp>

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

/// Wraps a decimation spec to report progress: the executor calls `stop` after every
/// success (serial) or every few (parallel workers), and every 256th calls
/// progress(fraction done, faces left). The wrapped type is the executor's spec
/// (Algorithm::with_spec), so this `stop` is the one called.
template <class Base, class Progress>
struct with_progress : Base {
    std::int64_t start_faces = 0;
    const Progress* progress = nullptr;

    bool stop(const idas::progress& p) {
        if (progress && (p.successes & 255) == 0)
            (*progress)(double(start_faces - p.faces) /
                            double(std::max<std::int64_t>(1, start_faces - this->target_faces)),
                        p.faces);
        return Base::stop(p);
    }
};

template <class Algorithm, class Spec, class Mesh, class Progress>
idas::run_report decimate_with(Mesh& m, std::int64_t target, const decimate_options& o,
                               const idas::algorithms::attribute_transfer* transfer,
                               idas::no_self_intersection guard, const Progress* progress) {
    with_progress<Spec, Progress> spec;
    spec.target_faces = target;
    if constexpr (requires { spec.attribute_weight; })
        spec.attribute_weight = o.attribute_weight.value_or(spec.attribute_weight);
    spec.transfer = transfer;
    spec.self_intersections = guard;
    spec.start_faces = static_cast<std::int64_t>(m.n_faces());
    spec.progress = progress;
    idas::exec_options options;
    options.threads = o.threads;
    return Algorithm::template with_spec<with_progress<Spec, Progress>>::run(m, spec, options);
}

struct decimated {
    idas::io::surface mesh;
    idas::run_report report;
    std::int64_t input_faces = 0, target_faces = 0;
    std::size_t constrained_vertices = 0;
    double check_seconds = 0;
};

/// Decimates `s` (read from `source`, which error messages name) on the mesh type Mesh;
/// `progress` may be null. Laps "build" ... "check" on `phases`.
template <class Mesh, class Progress>
decimated decimate_surface(const idas::io::surface& s, const std::string& source,
                           const decimate_options& o, phase_times& phases,
                           const Progress* progress) {
    using namespace idas::algorithms;
    std::optional<Mesh> built;
    Mesh& m = build_mesh(built, s, source);
    phases.lap("build");
    decimated d;
    d.input_faces = static_cast<std::int64_t>(m.n_faces());
    d.target_faces = o.ratio
                         ? static_cast<std::int64_t>(std::llround(*o.ratio * double(d.input_faces)))
                         : o.faces;

    carried_attributes carried;
    attribute_transfer_options keep;
    keep.keep_boundary = o.keep_boundary;
    keep.feature_angle_deg = o.feature_angle.value_or(-1);
    const attribute_transfer* transfer = carried.attach(m, s, keep);
    phases.lap("attributes");

    // Collapses that make faces meet are refused unless asked otherwise.
    std::optional<idas::self_intersection_index> index;
    if (!o.allow_self_intersections) index.emplace(m);
    const idas::no_self_intersection guard =
        index ? idas::no_self_intersection(*index) : idas::no_self_intersection();
    phases.lap("self_intersection_index");

    const auto run = [&]<class Lock>(std::type_identity<Lock>) {
        if (o.algorithm == "qslim")
            d.report = decimate_with<qslim<Mesh, Lock>, qslim_spec>(m, d.target_faces, o, transfer,
                                                                    guard, progress);
        else
            d.report = decimate_with<shortest_edge_collapse<true, Mesh, Lock>,
                                     shortest_edge_collapse_spec<true>>(m, d.target_faces, o,
                                                                        transfer, guard, progress);
    };
    if (o.deterministic)
        run(std::type_identity<idas::lock::deterministic_rounds>{});
    else
        run(std::type_identity<idas::lock::vertex_try_lock>{});
    phases.lap("decimation", d.report.setup_seconds, d.report.tail_seconds);

    std::tie(d.mesh.vertices, d.mesh.faces) = m.to_arrays();
    carried.export_to(m, d.mesh, s);
    d.constrained_vertices = transfer ? carried.transfer.constrained_count(m) : 0;
    phases.lap("export");
    const stopwatch check_clock;
    check_result("decimate", idas::summarize_surface(s.vertices.size(), s.faces), d.mesh);
    d.check_seconds = check_clock.seconds();
    phases.lap("check");
    return d;
}

} // namespace idas::tool
