// bench_decimation: one decimation run per process, for the side-by-side benchmark of
// bench/run_decimation.sh. Not a Google Benchmark program: each run lasts seconds, and
// peak memory is only meaningful for a process that does one thing.
//
//   bench_decimation --peer P --input x1|x4|x16|bunny|box --ratio R [--threads T]
//                    [--samples N] [--data FILE.obj] [--shuffle SEED] [--serial-tail N]
//                    [--self-intersections]
//
// Peers (shortest edge collapse, then quadric decimation):
//   idas-sec        idas::algorithms::shortest_edge_collapse<true> (link condition, no normal flip)
//   cgal-sec        CGAL Surface_mesh_simplification: Edge_length_cost + Midpoint_placement,
//                   filtered by Bounded_normal_change_filter
//   idas-qslim      idas::algorithms::qslim (area-weighted plane quadrics, no normal flip)
//   idas-sec-det, idas-qslim-det
//                   the same two on lock::deterministic_rounds (the same output at every
//                   thread count) instead of vertex_try_lock
//   idas-sec-attr, idas-qslim-attr
//                   the same two carrying attributes (algorithms/attribute_transfer.hpp):
//                   an 8-bit colour and a float normal per vertex and a seamless texture
//                   coordinate per corner (8 components per vertex), made up at run time
//                   from the positions; attaching them is timed, exporting them is not
//   cgal-gh         CGAL GarlandHeckbert_plane_policies (classic Garland-Heckbert plane
//                   quadrics, optimal placement), filtered by Bounded_normal_change_filter
//   openmesh-quadric OpenMesh DecimaterT with ModQuadricT (priority) and ModNormalFlippingT
//                   (binary, 90 degrees: refuses normal flips); halfedge collapses, so the
//                   merged vertex stays at an endpoint
//
// Inputs: x1 is data/armadillo.obj (86,482 faces, closed, genus 0; --data replaces it),
// refined at run time by 1-to-4 midpoint subdivision: x4 = one level (345,928 faces),
// x16 = two (1,383,712). bunny is data/bunny.off (6,966 faces, closed, genus 0); box a unit
// cube, each side a 32 x 32 grid of right triangles with shared vertices (12,288 faces,
// made at run time: a CAD-like input, flat sides and sharp edges).
// The target is round(ratio * input faces) faces. --shuffle SEED (not 0) renumbers the
// input's vertices and faces at random and rotates each face's corners: the same surface,
// other tie-breaks, to see how much a serial run's distances depend on the input's order.
// --serial-tail N (experiment) leaves a parallel run's final serial pass F * target + N
// faces per part instead of the library's target / 4 + 512 per part (idas peers on
// vertex_try_lock only); --serial-tail-share F sets F (default the library's 1/4).
// --self-intersections: the idas peers refuse collapses that make faces meet (the index is
// built inside the timed call). Every peer reports `self_intersections`, the face pairs of
// its output that meet (exact).
//
// Measured, and printed as one JSON object on one line:
//   seconds_algorithm  wall time of the decimation call(s) only; see `timed` in each peer.
//                      Reading, subdivision, building the peer's mesh from the face list,
//                      and extracting or compacting the result are excluded for every peer.
//   output_faces       faces of the result; face_error = (output - target) / target
//   hausdorff_*        approximate Hausdorff distances, divided by the input's bounding-box
//                      diagonal, by CGAL::Polygon_mesh_processing::approximate_Hausdorff_distance
//                      on CGAL Surface_mesh copies of input and output, for every peer alike:
//                      random uniform samples on faces at one fixed density (`--samples` per
//                      base surface area: armadillo's for x1/x4/x16, which all have the same
//                      area; bunny's or the box's for those) plus every vertex, fixed seed;
//                      `--samples 0` skips them. The input side is the base surface (for
//                      x4/x16 armadillo itself, the same surface as its subdivisions). out_in
//                      samples the output and measures to the input (how far the result strays);
//                      symmetric is the max of both ways.
//   mean_distance_*    the mean distance of the same samples to the other surface, divided
//                      by the diagonal (out_in: samples on the output; in_out: on the input).
//   peak_rss_delta_mb  getrusage(RUSAGE_SELF) peak RSS once the decimation is done and its
//                      result extracted (before the Hausdorff step), minus the RSS once the
//                      input arrays are loaded: the peer's mesh, its working memory and the
//                      (small) result arrays. The kernel's high-water mark is reset after
//                      loading (writing 5 to /proc/self/clear_refs) so the subdivision's
//                      temporary hash map does not hide it; `peak_reset` says whether it was.
//   manifold, euler    topology of the output face list (the input has Euler characteristic 2).
//   idas peers also print their run_report's counters and phase times (setup_seconds: the
//   spec's set-up and seeding the queues; tail_seconds: the final serial pass of a parallel
//   run).
#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/invariants/no_self_intersection.hpp>
#include <idas/io/io.hpp>
#include <idas/mesh/topology_report.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include "bench_support.hpp"

#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Bounded_normal_change_filter.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Edge_length_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Midpoint_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <numeric>
#include <optional>
#include <random>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#ifndef IDAS_DATA_DIR
#define IDAS_DATA_DIR "data"
#endif

namespace {

using namespace idas_bench; // bench_support.hpp: subdivision, memory, CGAL conversion

// ---- peers -------------------------------------------------------------------------------

struct run_result {
    double seconds = 0;
    surface output;
    std::string extra; // peer-specific JSON members, each starting with a comma
};

using idas_mesh = idas::tri_mesh<>;

/// The attributes of the -attr peers: colour (uint8) and normal (float) per vertex, a
/// texture coordinate per corner (a spherical projection, the same in every face of a
/// vertex: no seams, so nothing is constrained and the work is the same as without).
surface with_attributes(const surface& in) {
    using idas::io::attribute_domain;
    using idas::io::scalar_type;
    surface s = in;
    vec3 lo = in.vertices[0], hi = lo, centre{};
    for (const vec3& p : in.vertices)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    centre = (lo + hi) * 0.5;
    std::vector<vec3> normal(in.vertices.size());
    for (const auto& f : in.faces) {
        const vec3 n = idas::cross(in.vertices[f[1]] - in.vertices[f[0]],
                                   in.vertices[f[2]] - in.vertices[f[0]]);
        for (idas::index_t v : f) normal[v] += n;
    }
    idas::io::attribute_column colour{"color", attribute_domain::vertex, scalar_type::uint8, 3, {},
                                      {}},
        normals{"normal", attribute_domain::vertex, scalar_type::float32, 3, {}, {}},
        uv{"uv", attribute_domain::corner, scalar_type::float32, 2, {}, {}};
    for (std::size_t v = 0; v < in.vertices.size(); ++v) {
        const vec3& p = in.vertices[v];
        const double l = idas::norm(normal[v]);
        for (int k = 0; k < 3; ++k) {
            colour.values.push_back(std::round(255 * (p[k] - lo[k]) / (hi[k] - lo[k])));
            normals.values.push_back(double(float(l > 0 ? normal[v][k] / l : 0)));
        }
    }
    for (const auto& f : in.faces)
        for (idas::index_t v : f) {
            const vec3 d = in.vertices[v] - centre;
            uv.values.push_back(double(float(std::atan2(d.y, d.x))));
            uv.values.push_back(double(float(d.z / (hi.z - lo.z))));
        }
    s.attributes = {std::move(colour), std::move(normals), std::move(uv)};
    return s;
}

/// --serial-tail N (an experiment, not a library setting): a parallel run leaves the final
/// serial pass `share * target + N * parts` faces instead of the library's
/// face_target::tail_faces_per_part (512) per part. Negative: the library's own.
std::int64_t serial_tail_per_part = -1;
/// --serial-tail-share F (with --serial-tail): the share of the target the serial pass gets
/// besides the faces per part.
double serial_tail_share =
    1.0 / double(idas::algorithms::face_target::tail_share_of_target_inverse);

/// --self-intersections: the idas peers refuse collapses that make faces meet (the
/// no_self_intersection invariant; its index is built inside the timed run).
bool refuse_self_intersections = false;

template <class Base>
struct serial_tail_override : Base {
    template <class Mesh>
    void prepare(Mesh& m, const idas::exec_options& o) {
        Base::prepare(m, o);
        if (this->serial_tail > 0)
            this->serial_tail =
                std::int64_t(serial_tail_share * double(this->target_faces)) +
                serial_tail_per_part * std::int64_t(o.threads) * std::max(1u, o.parts_per_thread);
    }
};

template <class Algorithm, class Spec, bool Overridden = false>
run_result run_idas(const surface& in, std::int64_t target, unsigned threads,
                    bool attributes = false) {
    if constexpr (!Overridden && !idas::deterministic_policy<typename Algorithm::lock_type>)
        if (serial_tail_per_part >= 0)
            return run_idas<typename Algorithm::template with_spec<serial_tail_override<Spec>>,
                            serial_tail_override<Spec>, true>(in, target, threads, attributes);
    idas_mesh m(in.vertices, in.faces);
    Spec spec;
    spec.target_faces = target;
    idas::run_report r;
    run_result out;
    idas::algorithms::attribute_transfer transfer;
    const surface carried = attributes ? with_attributes(in) : surface{};
    // Includes the spec's one-off set-up (QSlim's quadrics) and filling the queue.
    std::optional<idas::self_intersection_index> index;
    out.seconds = timed([&] {
        if (attributes) transfer.attach(m, carried), spec.transfer = &transfer;
        if (refuse_self_intersections)
            index.emplace(m), spec.self_intersections = idas::no_self_intersection(*index);
        r = Algorithm::run(m, spec, {.threads = threads});
    });
    std::tie(out.output.vertices, out.output.faces) = m.to_arrays();
    if (attributes) {
        out.output.attributes = transfer.exported(m);
        out.extra += ",\"attribute_components\":" + std::to_string(3 + 3 + 2) +
                     ",\"constrained_vertices\":" + std::to_string(transfer.constrained_count(m));
    }
    auto member = [&](const char* name, std::uint64_t value) {
        out.extra += std::string(",\"") + name + "\":" + std::to_string(value);
    };
    member("collapses", r.succeeded);
    member("refused", r.refused);
    member("pushed", r.pushed);
    member("popped", r.popped);
    member("stale", r.stale);
    member("purged", r.purged);
    member("lock_failures", r.lock_failures);
    member("deferred_to_serial", r.deferred_to_serial);
    member("stolen", r.stolen);
    member("rounds", r.rounds);
    out.extra += ",\"setup_seconds\":" + std::to_string(r.setup_seconds) +
                 ",\"tail_seconds\":" + std::to_string(r.tail_seconds);
    return out;
}

namespace SMS = CGAL::Surface_mesh_simplification;

/// Live face count for CGAL's stop predicate, kept exact by the collapse visitor (CGAL
/// itself counts edges).
struct face_count_visitor : SMS::Edge_collapse_visitor_base<cgal_mesh> {
    std::int64_t* faces = nullptr;
    std::uint64_t* collapses = nullptr;
    void OnCollapsing(const Profile& p, const boost::optional<Point>&) {
        *faces -= (p.left_face_exists() ? 1 : 0) + (p.right_face_exists() ? 1 : 0);
        ++*collapses;
    }
};

struct face_count_stop {
    const std::int64_t* faces = nullptr;
    std::int64_t target = 0;
    template <class FT, class Profile>
    bool operator()(const FT&, const Profile&, std::size_t, std::size_t) const {
        return *faces <= target;
    }
};

/// Runs `collapse(stop, visitor)` (which calls SMS::edge_collapse) on a copy of the input
/// with a face-count stop, timing the call.
template <class Collapse>
run_result run_cgal(const surface& in, std::int64_t target, Collapse&& collapse) {
    cgal_mesh m = to_cgal(in);
    std::int64_t faces = static_cast<std::int64_t>(m.number_of_faces());
    std::uint64_t collapses = 0;
    face_count_visitor visitor;
    visitor.faces = &faces, visitor.collapses = &collapses;
    const face_count_stop stop{&faces, target};
    run_result out;
    out.seconds = timed([&] { collapse(m, stop, visitor); });
    out.output = from_cgal(m);
    out.extra = ",\"collapses\":" + std::to_string(collapses);
    return out;
}

run_result run_cgal_sec(const surface& in, std::int64_t target) {
    return run_cgal(in, target, [](cgal_mesh& m, const auto& stop, const auto& visitor) {
        const SMS::Edge_length_cost<cgal_mesh> cost;
        const SMS::Midpoint_placement<cgal_mesh> placement;
        const SMS::Bounded_normal_change_filter<> filter;
        SMS::edge_collapse(
            m, stop,
            CGAL::parameters::get_cost(cost).get_placement(placement).filter(filter).visitor(
                visitor));
    });
}

run_result run_cgal_gh(const surface& in, std::int64_t target) {
    return run_cgal(in, target, [](cgal_mesh& m, const auto& stop, const auto& visitor) {
        // Creating the policies allocates their per-vertex quadric map; CGAL fills it
        // inside edge_collapse.
        SMS::GarlandHeckbert_plane_policies<cgal_mesh, kernel> gh(m);
        const SMS::Bounded_normal_change_filter<> filter;
        SMS::edge_collapse(m, stop,
                           CGAL::parameters::get_cost(gh.get_cost())
                               .get_placement(gh.get_placement())
                               .filter(filter)
                               .visitor(visitor));
    });
}

struct om_traits : OpenMesh::DefaultTraits {
    using Point = OpenMesh::Vec3d;
    using Normal = OpenMesh::Vec3d;
};
using om_mesh = OpenMesh::TriMesh_ArrayKernelT<om_traits>;

run_result run_openmesh(const surface& in, std::int64_t target) {
    om_mesh m;
    m.reserve(in.vertices.size(), 3 * in.faces.size() / 2, in.faces.size());
    std::vector<om_mesh::VertexHandle> v;
    v.reserve(in.vertices.size());
    for (const vec3& p : in.vertices) v.push_back(m.add_vertex(om_mesh::Point(p.x, p.y, p.z)));
    for (const tri_indices& f : in.faces)
        if (!m.add_face(v[f[0]], v[f[1]], v[f[2]]).is_valid())
            throw std::runtime_error("OpenMesh refused a face of the input");
    run_result out;
    std::size_t collapses = 0;
    // Includes the status and face-normal properties the decimater and the flip check
    // need, module set-up and the quadrics (initialize).
    out.seconds = timed([&] {
        // Requested here as well as by the decimater, so that they outlive it: the
        // decimater releases its requests, and garbage collection needs the status.
        m.request_vertex_status();
        m.request_edge_status();
        m.request_face_status();
        m.request_face_normals();
        m.update_face_normals();
        OpenMesh::Decimater::DecimaterT<om_mesh> decimater(m);
        OpenMesh::Decimater::ModQuadricT<om_mesh>::Handle quadric;
        OpenMesh::Decimater::ModNormalFlippingT<om_mesh>::Handle flip;
        decimater.add(quadric);
        decimater.add(flip);
        decimater.initialize();
        collapses = decimater.decimate_to_faces(0, static_cast<std::size_t>(target));
    });
    m.garbage_collection();
    out.output.vertices.reserve(m.n_vertices());
    for (auto vh : m.vertices()) {
        const auto& p = m.point(vh);
        out.output.vertices.push_back({p[0], p[1], p[2]});
    }
    for (auto fh : m.faces()) {
        tri_indices t{};
        int k = 0;
        for (auto vh : m.fv_range(fh)) t[k++] = static_cast<index_t>(vh.idx());
        out.output.faces.push_back(t);
    }
    out.extra = ",\"collapses\":" + std::to_string(collapses);
    return out;
}

// ---- driver ------------------------------------------------------------------------------

struct options {
    std::string peer, input = "x4", data = std::string(IDAS_DATA_DIR) + "/armadillo.obj";
    double ratio = 0.1;
    unsigned threads = 1;
    double samples = 1e6;       // face samples per base surface area
    unsigned shuffle = 0;       // 0: the input as made; else the seed of a random renumbering
    long long serial_tail = -1; // faces per part left to the final serial pass (-1: library's)
};

/// The same surface with its vertices and faces renumbered at random and each face's
/// corners rotated (orientation kept).
surface shuffled(const surface& s, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::vector<index_t> order(s.vertices.size()), id(s.vertices.size());
    std::iota(order.begin(), order.end(), index_t{0});
    std::shuffle(order.begin(), order.end(), rng);
    surface out;
    out.vertices.reserve(s.vertices.size());
    for (index_t v : order)
        id[v] = static_cast<index_t>(out.vertices.size()), out.vertices.push_back(s.vertices[v]);
    out.faces = s.faces;
    std::shuffle(out.faces.begin(), out.faces.end(), rng);
    for (tri_indices& f : out.faces) {
        const auto k = rng() % 3;
        f = {id[f[k]], id[f[(k + 1) % 3]], id[f[(k + 2) % 3]]};
    }
    return out;
}

[[noreturn]] void usage(const std::string& message) {
    std::fprintf(stderr,
                 "bench_decimation: %s\n"
                 "usage: bench_decimation --peer idas-sec|idas-sec-det|cgal-sec|idas-qslim|"
                 "idas-qslim-det|idas-sec-attr|idas-qslim-attr|cgal-gh|openmesh-quadric\n"
                 "         [--input x1|x4|x16|bunny|box] [--ratio R] [--threads T] [--samples N]"
                 " [--data FILE.obj] [--shuffle SEED] [--serial-tail N]\n"
                 "         [--serial-tail-share F] [--self-intersections]\n",
                 message.c_str());
    std::exit(2);
}

options parse(int argc, char** argv) {
    options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--self-intersections") {
            refuse_self_intersections = true;
            continue;
        }
        if (i + 1 >= argc) usage("missing value after " + a);
        const std::string v = argv[++i];
        if (a == "--peer")
            o.peer = v;
        else if (a == "--input")
            o.input = v;
        else if (a == "--ratio")
            o.ratio = std::stod(v);
        else if (a == "--threads")
            o.threads = static_cast<unsigned>(std::stoul(v));
        else if (a == "--samples")
            o.samples = std::stod(v);
        else if (a == "--data")
            o.data = v;
        else if (a == "--shuffle")
            o.shuffle = static_cast<unsigned>(std::stoul(v));
        else if (a == "--serial-tail")
            o.serial_tail = std::stoll(v);
        else if (a == "--serial-tail-share")
            serial_tail_share = std::stod(v);
        else
            usage("unknown option " + a);
    }
    if (o.peer.empty()) usage("--peer is required");
    if (!(o.ratio > 0 && o.ratio <= 1)) usage("--ratio must be in (0, 1]");
    if (o.threads == 0) usage("--threads must be at least 1");
    if (o.input != "x1" && o.input != "x4" && o.input != "x16" && o.input != "bunny" &&
        o.input != "box")
        usage("--input must be x1, x4, x16, bunny or box");
    if (o.threads != 1 && o.peer.rfind("idas", 0) != 0) usage("only idas peers take --threads");
    return o;
}

int run(const options& o) {
    // The subdivided inputs lie exactly on armadillo's surface (midpoints of its edges, flat
    // splits of its faces), so distances to the input are measured to armadillo itself:
    // the same surface, with a 16x smaller search tree for the x16 input. bunny and box are
    // their own base.
    const surface base =
        o.input == "box" ? subdivided_cube(32)
        : o.input == "bunny"
            ? drop_unreferenced(idas::io::read_surface(std::string(IDAS_DATA_DIR) + "/bunny.off"))
            : idas::io::read_surface(o.data);
    const double area = surface_area(base);
    const int levels = o.input == "x4" ? 1 : (o.input == "x16" ? 2 : 0);
    surface in = base;
    for (int l = 0; l < levels; ++l) in = subdivide(in);
    if (o.shuffle != 0) in = shuffled(in, o.shuffle);
    serial_tail_per_part = o.serial_tail;
    const double diagonal = bbox_diagonal(in);
    const auto input_faces = static_cast<std::int64_t>(in.faces.size());
    const auto target = static_cast<std::int64_t>(std::llround(o.ratio * double(input_faces)));

    malloc_trim(0);
    const bool peak_reset = reset_peak_rss();
    const double rss_loaded = current_rss_mb();

    run_result r;
    std::string algorithm;
    if (o.peer == "idas-sec") {
        using namespace idas::algorithms;
        r = run_idas<shortest_edge_collapse<true, idas_mesh>, shortest_edge_collapse_spec<true>>(
            in, target, o.threads);
        algorithm = "shortest-edge";
    } else if (o.peer == "idas-qslim") {
        using namespace idas::algorithms;
        r = run_idas<qslim<idas_mesh>, qslim_spec>(in, target, o.threads);
        algorithm = "qslim";
    } else if (o.peer == "idas-sec-attr") {
        using namespace idas::algorithms;
        r = run_idas<shortest_edge_collapse<true, idas_mesh>, shortest_edge_collapse_spec<true>>(
            in, target, o.threads, true);
        algorithm = "shortest-edge";
    } else if (o.peer == "idas-qslim-attr") {
        using namespace idas::algorithms;
        r = run_idas<qslim<idas_mesh>, qslim_spec>(in, target, o.threads, true);
        algorithm = "qslim";
    } else if (o.peer == "idas-sec-det") {
        using namespace idas::algorithms;
        r = run_idas<shortest_edge_collapse<true, idas_mesh, idas::lock::deterministic_rounds>,
                     shortest_edge_collapse_spec<true>>(in, target, o.threads);
        algorithm = "shortest-edge";
    } else if (o.peer == "idas-qslim-det") {
        using namespace idas::algorithms;
        r = run_idas<qslim<idas_mesh, idas::lock::deterministic_rounds>, qslim_spec>(in, target,
                                                                                     o.threads);
        algorithm = "qslim";
    } else if (o.peer == "cgal-sec") {
        r = run_cgal_sec(in, target);
        algorithm = "shortest-edge";
    } else if (o.peer == "cgal-gh") {
        r = run_cgal_gh(in, target);
        algorithm = "qslim";
    } else if (o.peer == "openmesh-quadric") {
        r = run_openmesh(in, target);
        algorithm = "qslim";
    } else {
        usage("unknown peer " + o.peer);
    }
    const double peak = peak_rss_mb();

    const idas::topology_report topo =
        idas::diagnose_topology(r.output.vertices.size(), r.output.faces);
    const auto output_faces = static_cast<std::int64_t>(r.output.faces.size());

    // Face pairs of the output that meet (exact), for every peer.
    const std::size_t crossings =
        idas::count_self_intersections(idas_mesh(r.output.vertices, r.output.faces));

    double h_out_in = -1, h_in_out = -1, mean_out_in = -1, mean_in_out = -1, h_seconds = 0;
    if (o.samples > 0 && output_faces > 0) {
        const stopwatch clock;
        const cgal_mesh a = to_cgal(base), b = to_cgal(r.output);
        const double per_area = o.samples / area;
        h_out_in = hausdorff(b, a, per_area) / diagonal;
        h_in_out = hausdorff(a, b, per_area) / diagonal;
        mean_out_in = mean_distance(b, a, per_area) / diagonal;
        mean_in_out = mean_distance(a, b, per_area) / diagonal;
        h_seconds = clock.seconds();
    }

    std::printf(
        "{\"peer\":\"%s\",\"algorithm\":\"%s\",\"input\":\"%s\",\"input_faces\":%lld,"
        "\"ratio\":%g,\"target_faces\":%lld,\"threads\":%u,\"seconds_algorithm\":%.6f,"
        "\"output_faces\":%lld,\"output_vertices\":%zu,\"face_error\":%.6g,"
        "\"hausdorff_out_in\":%.6g,\"hausdorff_symmetric\":%.6g,\"hausdorff_samples_per_area\":%g,"
        "\"mean_distance_out_in\":%.6g,\"mean_distance_in_out\":%.6g,"
        "\"seconds_hausdorff\":%.3f,\"rss_loaded_mb\":%.1f,\"peak_rss_mb\":%.1f,"
        "\"peak_rss_delta_mb\":%.1f,\"peak_reset\":%s,\"manifold\":%s,\"euler\":%ld,"
        "\"shuffle\":%u,\"serial_tail_per_part\":%lld,\"serial_tail_share\":%g,"
        "\"refuse_self_intersections\":%s,"
        "\"self_intersections\":%zu%s}\n",
        o.peer.c_str(), algorithm.c_str(), o.input.c_str(), (long long)input_faces, o.ratio,
        (long long)target, o.threads, r.seconds, (long long)output_faces, r.output.vertices.size(),
        double(output_faces - target) / double(target), h_out_in, std::max(h_out_in, h_in_out),
        o.samples, mean_out_in, mean_in_out, h_seconds, rss_loaded, peak, peak - rss_loaded,
        peak_reset ? "true" : "false", topo.editable() ? "true" : "false",
        static_cast<long>(topo.euler_characteristic), o.shuffle, o.serial_tail, serial_tail_share,
        refuse_self_intersections ? "true" : "false", crossings, r.extra.c_str());
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    try {
        return run(parse(argc, argv));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_decimation: error: %s\n", e.what());
        return 1;
    }
}
