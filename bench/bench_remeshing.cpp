// bench_remeshing: one isotropic remeshing run per process, for the side-by-side benchmark
// of bench/run_remeshing.sh (idas against CGAL::Polygon_mesh_processing::isotropic_remeshing).
//
//   bench_remeshing --peer idas|cgal --input bunny|armadillo|armadillo-x4 [--threads T]
//                   [--envelope EPS] [--length L] [--iterations K] [--samples N]
//                   [--data-dir DIR] [--lock try|det]
//
// Inputs: data/bunny.obj (open), data/armadillo.obj (closed) and armadillo x4 (armadillo
// after one 1-to-4 midpoint subdivision at run time: 345,928 faces, the same surface),
// without vertices that no face uses (bunny.obj has 1,113: scan points off the surface).
// Both peers get the same absolute target length L * (bounding-box diagonal), default
// L = 0.005, and the same iteration count (default 5). Both treat borders alike: border
// edges are split and collapsed along the border and border vertices are not smoothed
// (CGAL's defaults; idas with preserve_boundary = false). `--boundary keep` freezes
// idas's border vertices instead (the library's default). Neither protects sharp features.
// --lock det runs idas on lock::deterministic_rounds (same output at every thread count)
// instead of vertex_try_lock. --envelope EPS (idas only) adds the exact envelope
// invariant at EPS times the diagonal.
//
// Printed as one JSON object on one line:
//   seconds_algorithm   wall time of the remeshing call only (idas: isotropic_remeshing::run,
//                       which includes building its projection tree; CGAL:
//                       isotropic_remeshing, which builds its own). Reading, subdivision,
//                       building either mesh, the envelope (seconds_envelope_build) and
//                       extracting the result are excluded.
//   valence6            fraction of interior vertices of the output with 6 neighbours
//   min_angle_deg       smallest triangle angle of the output; mean_min_angle_deg is the mean
//                       over faces of each face's smallest angle; faces_below_{10,20}_deg count
//                       faces whose smallest angle is below 10 / 20 degrees
//   edge_length_ratio   mean edge length / target length
//   hausdorff_*         CGAL approximate_Hausdorff_distance (as bench_decimation: `--samples`
//                       random face samples per input surface area plus every vertex, fixed
//                       seed) divided by the diagonal; out_in samples the output, symmetric
//                       is the max of both ways. The x4 input is measured against armadillo.
//   envelope_check_*    independent check of the envelope (whether or not it was on): the
//                       output's faces are sampled (vertices, edge midpoints, centroid and
//                       16 stratified interior points each) and each sample's distance to the
//                       input is found with idas::triangle_aabb_tree; faces_outside counts
//                       faces with a sample farther than eps (1e-3 of the diagonal unless
//                       --envelope says otherwise), max_over_eps is the largest distance / eps.
//   manifold, euler     topology of the output (the input's Euler characteristic is given too)
#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/core/aabb_tree.hpp>
#include <idas/invariants/envelope.hpp>
#include <idas/io/io.hpp>
#include <idas/mesh/surface_distance.hpp>
#include <idas/mesh/topology_report.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include "bench_support.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <malloc.h>

#ifndef IDAS_DATA_DIR
#define IDAS_DATA_DIR "data"
#endif

namespace {

using namespace idas_bench;

struct options {
    std::string peer, input = "armadillo", data_dir = IDAS_DATA_DIR;
    unsigned threads = 1;
    double envelope = -1; // relative eps; <0: off
    double length = 0.005;
    unsigned iterations = 5;
    double samples = 500000;    // Hausdorff face samples per input surface area
    bool keep_boundary = false; // idas: freeze boundary vertices instead of remeshing along it
    bool deterministic = false; // idas: lock::deterministic_rounds
};

[[noreturn]] void usage(const std::string& message) {
    std::fprintf(stderr,
                 "bench_remeshing: %s\n"
                 "usage: bench_remeshing --peer idas|cgal --input bunny|armadillo|armadillo-x4\n"
                 "         [--threads T] [--envelope EPS] [--length L] [--iterations K]"
                 " [--samples N] [--data-dir DIR]\n"
                 "         [--boundary remesh|keep] [--lock try|det]\n",
                 message.c_str());
    std::exit(2);
}

options parse(int argc, char** argv) {
    options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (i + 1 >= argc) usage("missing value after " + a);
        const std::string v = argv[++i];
        if (a == "--peer")
            o.peer = v;
        else if (a == "--input")
            o.input = v;
        else if (a == "--threads")
            o.threads = static_cast<unsigned>(std::stoul(v));
        else if (a == "--envelope")
            o.envelope = std::stod(v);
        else if (a == "--length")
            o.length = std::stod(v);
        else if (a == "--iterations")
            o.iterations = static_cast<unsigned>(std::stoul(v));
        else if (a == "--samples")
            o.samples = std::stod(v);
        else if (a == "--data-dir")
            o.data_dir = v;
        else if (a == "--lock" && (v == "try" || v == "det"))
            o.deterministic = v == "det";
        else if (a == "--boundary" && (v == "remesh" || v == "keep"))
            o.keep_boundary = v == "keep";
        else
            usage("unknown option " + a);
    }
    if (o.peer != "idas" && o.peer != "cgal") usage("--peer must be idas or cgal");
    if (o.input != "bunny" && o.input != "armadillo" && o.input != "armadillo-x4")
        usage("--input must be bunny, armadillo or armadillo-x4");
    if (o.threads == 0) usage("--threads must be at least 1");
    if (!(o.length > 0)) usage("--length must be positive");
    if (o.peer == "cgal" && (o.threads != 1 || o.envelope > 0))
        usage("--threads and --envelope are for idas only");
    return o;
}

// ---- quality of a face list --------------------------------------------------------------

struct quality {
    double valence6 = 0, min_angle = 180, mean_min_angle = 0, edge_length = 0;
    std::size_t below10 = 0, below20 = 0;
};

quality measure(const surface& s) {
    quality q;
    const double deg = 180.0 / std::numbers::pi;
    double sum = 0;
    for (const tri_indices& f : s.faces) {
        const auto t = idas::triangle_angles(s.vertices[f[0]], s.vertices[f[1]], s.vertices[f[2]]);
        const double a = std::min({t[0], t[1], t[2]}) * deg;
        q.min_angle = std::min(q.min_angle, a);
        sum += a;
        q.below10 += a < 10;
        q.below20 += a < 20;
    }
    q.mean_min_angle = s.faces.empty() ? 0 : sum / double(s.faces.size());
    // Edges as sorted vertex pairs: an edge seen once is on the boundary.
    std::vector<std::uint64_t> edges;
    edges.reserve(3 * s.faces.size());
    for (const tri_indices& f : s.faces)
        for (int k = 0; k < 3; ++k) {
            const index_t a = f[k], b = f[(k + 1) % 3];
            edges.push_back(std::uint64_t{std::min(a, b)} << 32 | std::max(a, b));
        }
    std::sort(edges.begin(), edges.end());
    std::vector<std::uint32_t> valence(s.vertices.size(), 0);
    std::vector<char> boundary(s.vertices.size(), 0);
    double length = 0;
    std::size_t n_edges = 0;
    for (std::size_t i = 0; i < edges.size();) {
        std::size_t j = i;
        while (j < edges.size() && edges[j] == edges[i]) ++j;
        const auto a = static_cast<index_t>(edges[i] >> 32), b = static_cast<index_t>(edges[i]);
        ++valence[a], ++valence[b];
        if (j - i == 1) boundary[a] = boundary[b] = 1;
        length += idas::norm(s.vertices[a] - s.vertices[b]);
        ++n_edges;
        i = j;
    }
    q.edge_length = n_edges ? length / double(n_edges) : 0;
    std::size_t interior = 0, six = 0;
    for (std::size_t v = 0; v < valence.size(); ++v)
        if (valence[v] > 0 && !boundary[v]) ++interior, six += valence[v] == 6;
    q.valence6 = interior ? double(six) / double(interior) : 0;
    return q;
}

/// Faces of `s` with a sample farther than eps from `input`, and the largest sampled
/// distance (see the file comment for the samples).
std::pair<std::size_t, double> envelope_check(const surface& s,
                                              const idas::triangle_aabb_tree& input, double eps) {
    std::size_t outside = 0;
    double worst = 0;
    for (const tri_indices& f : s.faces) {
        double far = 0;
        idas::detail::for_each_triangle_sample(
            s.vertices[f[0]], s.vertices[f[1]], s.vertices[f[2]], 16,
            [&](const vec3& p) { far = std::max(far, input.closest_point(p).squared_distance); });
        far = std::sqrt(far);
        outside += far > eps;
        worst = std::max(worst, far);
    }
    return {outside, worst};
}

// ---- peers ---------------------------------------------------------------------------------

struct run_result {
    double seconds = 0, seconds_envelope = 0;
    surface output;
    std::string extra;
};

run_result run_idas(const surface& in, double L, const options& o, double eps) {
    using mesh = idas::tri_mesh<>;
    mesh m(in.vertices, in.faces);
    idas::algorithms::remeshing_options ro;
    ro.target_length = L;
    ro.iterations = o.iterations;
    ro.preserve_boundary = o.keep_boundary;
    const idas::exec_options exec{.threads = o.threads};
    idas::algorithms::remeshing_report r;
    run_result out;
    if (eps > 0) {
        idas::envelope env;
        out.seconds_envelope = timed([&] { env = idas::envelope(in.vertices, in.faces, eps); });
        out.seconds = timed([&] {
            r = idas::algorithms::isotropic_remeshing<
                mesh, idas::lock::vertex_try_lock, idas::queue::dary_heap<4>,
                idas::partition::morton, idas::envelope>::run(m, ro, exec, env);
        });
    } else if (o.deterministic) {
        out.seconds = timed([&] {
            r = idas::algorithms::isotropic_remeshing<mesh, idas::lock::deterministic_rounds>::run(
                m, ro, exec);
        });
    } else {
        out.seconds =
            timed([&] { r = idas::algorithms::isotropic_remeshing<mesh>::run(m, ro, exec); });
    }
    std::tie(out.output.vertices, out.output.faces) = m.to_arrays();
    out.extra = ",\"iterations_run\":" + std::to_string(r.iterations) +
                ",\"splits\":" + std::to_string(r.splits) +
                ",\"collapses\":" + std::to_string(r.collapses) +
                ",\"swaps\":" + std::to_string(r.swaps) +
                ",\"smooths\":" + std::to_string(r.smooths);
    return out;
}

run_result run_cgal(const surface& in, double L, const options& o) {
    using epick_mesh =
        CGAL::Surface_mesh<CGAL::Exact_predicates_inexact_constructions_kernel::Point_3>;
    epick_mesh m = to_cgal<epick_mesh>(in);
    run_result out;
    out.seconds = timed([&] {
        CGAL::Polygon_mesh_processing::isotropic_remeshing(
            faces(m), L, m, CGAL::parameters::number_of_iterations(o.iterations));
    });
    m.collect_garbage();
    out.output = from_cgal(m);
    return out;
}

int run(const options& o) {
    const std::string file = o.data_dir + (o.input == "bunny" ? "/bunny.obj" : "/armadillo.obj");
    const surface base = drop_unreferenced(idas::io::read_surface(file));
    const surface in = o.input == "armadillo-x4" ? subdivide(base) : base;
    const double diagonal = bbox_diagonal(base);
    const double L = o.length * diagonal;
    const double eps = (o.envelope > 0 ? o.envelope : 1e-3) * diagonal;
    const idas::topology_report in_topo = idas::diagnose_topology(in.vertices.size(), in.faces);

    malloc_trim(0);
    const bool peak_reset = reset_peak_rss();
    const double rss_loaded = current_rss_mb();
    const run_result r =
        o.peer == "idas" ? run_idas(in, L, o, o.envelope > 0 ? eps : -1) : run_cgal(in, L, o);
    const double peak = peak_rss_mb();

    const idas::topology_report topo =
        idas::diagnose_topology(r.output.vertices.size(), r.output.faces);
    const quality q = measure(r.output);

    double h_out_in = -1, h_in_out = -1;
    if (o.samples > 0 && !r.output.faces.empty()) {
        const cgal_mesh a = to_cgal(base), b = to_cgal(r.output);
        const double per_area = o.samples / surface_area(base);
        h_out_in = hausdorff(b, a, per_area) / diagonal;
        h_in_out = hausdorff(a, b, per_area) / diagonal;
    }
    const idas::triangle_aabb_tree tree(base.vertices, base.faces);
    const auto [outside, worst] = envelope_check(r.output, tree, eps);

    std::printf(
        "{\"peer\":\"%s\",\"input\":\"%s\",\"input_faces\":%zu,\"threads\":%u,\"envelope\":%s,"
        "\"boundary\":\"%s\",\"eps_relative\":%g,\"length_relative\":%g,\"target_length\":%.9g,"
        "\"iterations\":%u,"
        "\"seconds_algorithm\":%.6f,\"seconds_envelope_build\":%.3f,\"output_faces\":%zu,"
        "\"valence6\":%.6f,\"min_angle_deg\":%.4f,\"mean_min_angle_deg\":%.4f,"
        "\"faces_below_10_deg\":%zu,\"faces_below_20_deg\":%zu,\"edge_length_ratio\":%.5f,"
        "\"hausdorff_out_in\":%.6g,\"hausdorff_symmetric\":%.6g,\"hausdorff_samples_per_area\":%g,"
        "\"envelope_check_faces_outside\":%zu,\"envelope_check_max_over_eps\":%.5g,"
        "\"rss_loaded_mb\":%.1f,\"peak_rss_delta_mb\":%.1f,\"peak_reset\":%s,\"manifold\":%s,"
        "\"euler\":%ld,\"input_euler\":%ld%s}\n",
        o.peer.c_str(), o.input.c_str(), in.faces.size(), o.threads,
        o.envelope > 0 ? "true" : "false", o.keep_boundary ? "keep" : "remesh", eps / diagonal,
        o.length, L, o.iterations, r.seconds, r.seconds_envelope, r.output.faces.size(), q.valence6,
        q.min_angle, q.mean_min_angle, q.below10, q.below20, q.edge_length / L, h_out_in,
        std::max(h_out_in, h_in_out), o.samples, outside, worst / eps, rss_loaded,
        peak - rss_loaded, peak_reset ? "true" : "false", topo.editable() ? "true" : "false",
        static_cast<long>(topo.euler_characteristic),
        static_cast<long>(in_topo.euler_characteristic), r.extra.c_str());
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    try {
        return run(parse(argc, argv));
    } catch (const idas::input_error& e) { // a missing or malformed input file
        std::fprintf(stderr, "bench_remeshing: error: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_remeshing: error: %s\n", e.what());
        return 1;
    }
}
