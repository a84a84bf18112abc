// `idas harmonic` and idas.harmonic: the run (tool/harmonic.hpp), compiled once for both.
#include "harmonic.hpp"

#if IDAS_CLI_HAVE_CGAL
#include <idas/cgal/delaunay.hpp>
#endif

#include <string>
#include <tuple>
#include <vector>

#if IDAS_CLI_HAVE_CGAL
namespace idas::tool {

harmonic_result harmonic_volume(const std::vector<idas::vec3>& points, const std::string& source,
                                const harmonic_options& a, phase_times& phases,
                                const phase_progress* progress) {
    check_range(source, points);
    harmonic_result out;
    const stopwatch delaunay_clock;
    idas::cgal::delaunay_result dt;
    try {
        dt = idas::cgal::delaunay_tetrahedralization(points, a.threads);
    } catch (const idas::input_error& e) {
        throw idas::input_error(source + ": " + e.what());
    }
    out.duplicate_points = dt.duplicates;
    out.delaunay_seconds = delaunay_clock.seconds();
    phases.lap("delaunay");
    idas::algorithms::harmonic_options o;
    o.mode = a.mode == "reduced" ? idas::algorithms::harmonic_mode::reduced
                                 : idas::algorithms::harmonic_mode::complete;
    o.rounds = a.rounds;
    o.exec.threads = a.threads;
    // The same run on either tet backend (--backend).
    // The flips keep the convex hull: its boundary is a sphere before and after.
    const auto flip = [&]<class Mesh>(Mesh m) {
        phases.lap("build");
        out.before = idas::algorithms::harmonic_statistics(m);
        phases.lap("statistics_before");
        const unsigned phase_count =
            o.mode == idas::algorithms::harmonic_mode::reduced ? 1 : 1 + 2 * o.rounds;
        unsigned ran = 0;
        auto observer = [&](std::size_t phase, unsigned round, const idas::run_report& pr) {
            static constexpr const char* names[] = {"3-2 flips", "smoothing", "seeded flips"};
            if (progress)
                (*progress)(double(++ran) / phase_count,
                            std::string(names[phase]) + ", round " + std::to_string(round + 1) +
                                ": " + std::to_string(pr.succeeded) + " done");
        };
        if (a.deterministic)
            out.report = idas::algorithms::harmonic_triangulation<
                Mesh, idas::lock::deterministic_rounds>::run_observed(m, o, observer);
        else
            out.report =
                idas::algorithms::harmonic_triangulation<Mesh>::run_observed(m, o, observer);
        phases.lap("flipping", out.report.setup_seconds, out.report.tail_seconds);
        out.after = idas::algorithms::harmonic_statistics(m);
        phases.lap("statistics_after");
        std::tie(out.mesh.vertices, out.mesh.tets) = m.to_arrays();
        phases.lap("export");
        const stopwatch check_clock;
        if (const auto failed = check_harmonic_result(out.mesh, 2))
            throw std::runtime_error("internal error: harmonic produced an invalid mesh (result "
                                     "check: " +
                                     *failed + "); nothing was written");
        out.check_seconds = check_clock.seconds();
        phases.lap("check");
    };
    if (a.backend == "adjacency")
        flip(idas::tet_mesh<idas::backend::adjacency_tet>(dt.vertices, dt.tets));
    else
        flip(idas::tet_mesh<idas::backend::indexed_tet>(dt.vertices, dt.tets));
    return out;
}

} // namespace idas::tool
#endif
