// `idas remesh` and idas.remesh: the run (tool/remesh.hpp), compiled once for both.
#include "remesh.hpp"

#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/invariants/no_self_intersection.hpp>
#if IDAS_CLI_HAVE_CGAL
#include <idas/invariants/envelope.hpp>
#endif

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <ranges>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

namespace idas::tool {
namespace {

template <class Mesh>
phase_quality quality_of(const Mesh& m) {
    phase_quality q;
    double worst = 4; // radians, above any angle
    m.for_each_face([&](const typename Mesh::tuple& t) {
        const auto& f = m.face_vertices(t.fid);
        ++q.faces;
        const double a = idas::algorithms::detail::min_angle(m, f[0], f[1], f[2]);
        if (a < worst)
            worst = a,
            q.min_angle_at = (m.position(f[0]) + m.position(f[1]) + m.position(f[2])) / 3.0;
    });
    q.min_angle_deg = worst * 180 / std::numbers::pi;
    q.min_valence = std::numeric_limits<std::size_t>::max();
    m.for_each_vertex([&](const typename Mesh::tuple& t) {
        const auto n = static_cast<std::size_t>(std::ranges::distance(m.vertex_faces(t.vid))) +
                       (m.is_boundary_vertex(t.vid) ? 1 : 0); // edges: one more than faces
        q.min_valence = std::min(q.min_valence, n), q.max_valence = std::max(q.max_valence, n);
    });
    if (q.faces == 0) q.min_valence = 0;
    return q;
}

/// Runs the remeshing; `progress` (may be null) hears (fraction done, note) after every phase,
/// and `trace` (may be null) gets the mesh's quality after every phase.
template <class Lock, class Mesh, class... Extra>
idas::algorithms::remeshing_report
remesh_with(Mesh& m, const idas::algorithms::remeshing_options& o, unsigned threads,
            const phase_progress* progress, std::vector<phase_quality>* trace, Extra... extra) {
    idas::exec_options exec;
    exec.threads = threads;
    auto observer = [&](std::size_t phase, unsigned iteration, const idas::run_report&) {
        if (trace) {
            trace->push_back(quality_of(m));
            trace->back().iteration = iteration, trace->back().phase = phase % 4;
        }
        if (!progress) return;
        const double done = double(iteration * 4 + phase + 1) / double(4 * o.iterations);
        (*progress)(done, "iteration " + std::to_string(iteration + 1) + "/" +
                              std::to_string(o.iterations) + ", " +
                              remeshing_phase_names[phase % 4]);
    };
    return idas::algorithms::isotropic_remeshing<Mesh, Lock, idas::queue::dary_heap<4>,
                                                 idas::partition::morton,
                                                 Extra...>::run_observed(m, o, exec, observer,
                                                                         extra...);
}

/// Remeshes `s` (read from `source`, which error messages name) on the mesh type Mesh;
/// `progress` may be null. Laps "input_statistics" ... "check" on `phases`.
template <class Mesh>
remeshed remesh_on(const idas::io::surface& s, const std::string& source, const remesh_options& a,
                   phase_times& phases, const phase_progress* progress) {
    remeshed out;
    out.input_stats = compute_stats(s);
    phases.lap("input_statistics");
    std::optional<Mesh> built;
    auto& m = build_mesh(built, s, source);
    phases.lap("build");
    idas::algorithms::remeshing_options o;
    o.target_length = a.absolute ? a.edge_length : a.edge_length * out.input_stats.diagonal;
    if (!(o.target_length > 0) || !std::isfinite(o.target_length))
        throw idas::input_error(fmt::format("--edge-length {} gives a target length of {} on {}",
                                            a.edge_length, o.target_length, source));
    // A tiny length would grow the mesh until memory runs out: refuse it up front.
    if (const double n = estimated_faces(s, o.target_length); !(n <= double(a.max_faces)))
        throw idas::input_error(fmt::format(
            "--edge-length {} (target length {:.6g}) would make about {:.3g} faces on {}, more "
            "than --max-faces {}",
            a.edge_length, o.target_length, n, source, a.max_faces));
    out.target_length = o.target_length;
    o.iterations = a.iterations;
    o.preserve_boundary = a.keep_boundary;
    o.feature_angle_deg = a.feature_angle.value_or(-1);
    // The file's attributes ride along; boundary and features are the remesher's own.
    carried_attributes carried;
    o.transfer = carried.attach(m, s, {});
    phases.lap("attributes");

    // Faces that meet other faces are refused unless asked otherwise; the index of faces
    // lives through every phase, with cells of a few target lengths.
    std::optional<idas::self_intersection_index> index;
    if (!a.allow_self_intersections) index.emplace(m, 4 * o.target_length);
    const idas::no_self_intersection guard =
        index ? idas::no_self_intersection(*index) : idas::no_self_intersection();
    phases.lap("self_intersection_index");
    std::vector<phase_quality>* const tr = a.trace ? &out.trace : nullptr;
    if (a.envelope) {
#if IDAS_CLI_HAVE_CGAL
        out.envelope = *a.envelope * out.input_stats.diagonal;
        if (!std::isfinite(*out.envelope))
            throw idas::input_error(
                fmt::format("--envelope {} is too large for {}", *a.envelope, source));
        const idas::envelope env(s.vertices, s.faces, *out.envelope);
        out.report = a.deterministic
                         ? remesh_with<idas::lock::deterministic_rounds>(m, o, a.threads, progress,
                                                                         tr, env, guard)
                         : remesh_with<idas::lock::vertex_try_lock>(m, o, a.threads, progress, tr,
                                                                    env, guard);
#else
        throw idas::input_error("--envelope needs a build with CGAL");
#endif
    } else {
        out.report =
            a.deterministic
                ? remesh_with<idas::lock::deterministic_rounds>(m, o, a.threads, progress, tr,
                                                                guard)
                : remesh_with<idas::lock::vertex_try_lock>(m, o, a.threads, progress, tr, guard);
    }
    phases.lap("remeshing", out.report.setup_seconds, out.report.tail_seconds);
    std::tie(out.mesh.vertices, out.mesh.faces) = m.to_arrays();
    carried.export_to(m, out.mesh, s);
    phases.lap("export");
    out.output_stats = compute_stats(out.mesh);
    phases.lap("output_statistics");
    const stopwatch check_clock;
    check_result("remesh", summary_of(out.input_stats.topo), summary_of(out.output_stats.topo));
    out.check_seconds = check_clock.seconds();
    phases.lap("check");
    return out;
}

} // namespace

remeshed remesh_surface(const idas::io::surface& s, const std::string& source,
                        const remesh_options& a, phase_times& phases,
                        const phase_progress* progress) {
    return with_backend(a.backend, [&]<class Mesh>(std::type_identity<Mesh>) {
        return remesh_on<Mesh>(s, source, a, phases, progress);
    });
}

} // namespace idas::tool
