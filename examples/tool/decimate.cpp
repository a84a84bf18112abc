// `idas decimate` and idas.decimate: the run (tool/decimate.hpp), compiled once for both.
#include "decimate.hpp"

#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/invariants/no_self_intersection.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <tuple>
#include <type_traits>

namespace idas::tool {
namespace {

/// Wraps a decimation spec to report progress: the executor calls `stop` after every
/// success (serial) or every few (parallel workers), and every 256th calls
/// progress(fraction done, faces left). The wrapped type is the executor's spec
/// (Algorithm::with_spec), so this `stop` is the one called.
template <class Base>
struct with_progress : Base {
    std::int64_t start_faces = 0;
    const face_progress* progress = nullptr;

    bool stop(const idas::progress& p) {
        if (progress && (p.successes & 255) == 0)
            (*progress)(double(start_faces - p.faces) /
                            double(std::max<std::int64_t>(1, start_faces - this->target_faces)),
                        p.faces);
        return Base::stop(p);
    }
};

template <class Algorithm, class Spec, class Mesh>
idas::run_report decimate_with(Mesh& m, std::int64_t target, const decimate_options& o,
                               const idas::algorithms::attribute_transfer* transfer,
                               idas::no_self_intersection guard, const face_progress* progress) {
    with_progress<Spec> spec;
    spec.target_faces = target;
    if constexpr (requires { spec.attribute_weight; })
        spec.attribute_weight = o.attribute_weight.value_or(spec.attribute_weight);
    spec.transfer = transfer;
    spec.self_intersections = guard;
    spec.start_faces = static_cast<std::int64_t>(m.n_faces());
    spec.progress = progress;
    idas::exec_options options;
    options.threads = o.threads;
    return Algorithm::template with_spec<with_progress<Spec>>::run(m, spec, options);
}

/// Decimates `s` (read from `source`, which error messages name) on the mesh type Mesh;
/// `progress` may be null. Laps "build" ... "check" on `phases`.
template <class Mesh>
decimated decimate_on(const idas::io::surface& s, const std::string& source,
                      const decimate_options& o, phase_times& phases,
                      const face_progress* progress) {
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

} // namespace

decimated decimate_surface(const idas::io::surface& s, const std::string& source,
                           const decimate_options& o, phase_times& phases,
                           const face_progress* progress) {
    return with_backend(o.backend, [&]<class Mesh>(std::type_identity<Mesh>) {
        return decimate_on<Mesh>(s, source, o, phases, progress);
    });
}

} // namespace idas::tool
