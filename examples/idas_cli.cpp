// idas: the command-line tool.
//
//   idas info IN [--json] [--self-intersections] [--reference REF [--samples N]]
//                                              statistics and topology of a mesh file
//   idas convert IN OUT [--ascii] [--msh-version V]
//                                              any supported format to any other
//   idas demo IN OUT [--json] [--seed S] [--ops N] [--ascii] [--backend B]
//                                              random local operations guarded by invariants
//   idas decimate IN OUT (--ratio R | --faces N) [--algorithm A] [--threads T] [--backend B]
//                 [--deterministic] [--allow-self-intersections] [--attribute-weight W]
//                                              shortest edge collapse or QSlim
//   idas remesh IN OUT --edge-length L [--absolute] [--iterations K] [--threads T]
//               [--envelope EPS] [--backend B] [--deterministic] [--allow-self-intersections]
//                                              isotropic remeshing (cli_remesh.hpp)
//   idas harmonic OUT (--points IN | --gaussian N [--seed S]) [--mode M] [--threads T]
//                                              harmonic triangulation of points (cli_harmonic.hpp)
//   idas tetmesh IN OUT.msh [--epsilon E] [--edge-length L] [--absolute] [--threads T]
//                                              tet mesh of a triangle soup (cli_tetmesh.hpp)
// --deterministic (decimate, remesh, harmonic): lock::deterministic_rounds, the same
// output file at every thread count. decimate and remesh refuse operations that would make
// faces meet (no_self_intersection) unless --allow-self-intersections is given.
// B is the triangle connectivity backend, indexed (default) or corner-table (harmonic:
// tet backend, indexed or adjacency).
// Surface or tets is decided by the extension: .msh is a tet mesh (MSH 2.2/4.1, read and
// write), .vtu a tet mesh (write only), the rest triangle surfaces (see cli_tet.hpp).
//
// Exit codes: 0 success; 2 bad input or usage; 1 any other failure. Errors go to stderr
// and start with "idas: error: "; with --json, stdout holds exactly one JSON object.
// Every input must lie in idas::geometry_range (mesh/geometry_range.hpp); every edited
// mesh passes a result check (mesh/surface_check.hpp) before it is written; SIGINT and
// SIGTERM remove a half-written output (io/atomic_file.hpp).
// The options, checks and runs of the commands and info's statistics are in tool/ (shared
// with the Python module, python/); this file parses options, reads, writes and reports.
#include <idas/algorithms/attribute_transfer.hpp>
#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/idas.hpp>
#include <idas/invariants/no_self_intersection.hpp>
#include <idas/io/io.hpp>
#include <idas/io/msh.hpp>
#include <idas/io/vtu.hpp>
#include <idas/mesh/geometry_range.hpp>
#include <idas/mesh/surface_check.hpp>
#include <idas/mesh/tet_mesh.hpp>
#include <idas/mesh/tet_quality.hpp>
#if IDAS_CLI_HAVE_CGAL
#include <idas/algorithms/harmonic_triangulation.hpp>
#include <idas/cgal/delaunay.hpp>
#include <idas/cgal/tetmesh.hpp>
#include <idas/invariants/envelope.hpp>
#include <idas/io/msh.hpp>
#include <idas/io/points.hpp>
#include <idas/io/vtu.hpp>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#endif

#include "tool/common.hpp"
#include "tool/decimate.hpp"
#include "tool/harmonic.hpp"
#include "tool/reference_distance.hpp"
#include "tool/remesh.hpp"
#include "tool/surface_stats.hpp"
#include "tool/tet_stats.hpp"
#include "tool/tetmesh.hpp"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <limits>
#include <new>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include <unistd.h> // isatty: the progress bar is drawn on terminals only

namespace {

// The commands' options, checks and runs, shared with the Python module (python/).
using namespace idas::tool;
using tuple_t = idas::tri_tuple;
using result_t = idas::op_result<tuple_t>;
using idas::index_t;
using idas::vec3;

// ---- statistics of a face list (tool/surface_stats.hpp) -------------------------------

void print_stats(const mesh_stats& st) {
    const auto& t = st.topo;
    fmt::print("  vertices              {} ({} referenced)\n", t.vertices, t.referenced_vertices);
    fmt::print("  faces                 {}\n", t.faces);
    fmt::print("  edges                 {}\n", t.edges);
    if (t.manifold()) {
        fmt::print("  manifold              yes\n");
    } else {
        fmt::print("  manifold              NO: {} non-manifold edges, {} non-manifold vertices",
                   t.nonmanifold_edges, t.nonmanifold_vertices);
        if (t.degenerate_faces > 0) fmt::print(", {} degenerate faces", t.degenerate_faces);
        fmt::print("\n");
    }
    if (t.oriented() && !t.manifold())
        fmt::print("  oriented              consistently across its manifold edges\n");
    else if (t.oriented())
        fmt::print("  oriented              consistently\n");
    else
        fmt::print("  oriented              NO: {} edges used twice in one direction\n",
                   t.misoriented_edges);
    if (t.closed())
        fmt::print("  closed                yes\n");
    else
        fmt::print("  closed                no: {} boundary edges, {} boundary loops\n",
                   t.boundary_edges, t.boundary_loops);
    fmt::print("  components            {}\n", t.components);
    fmt::print("  Euler characteristic  {}", t.euler_characteristic);
    if (st.genus) fmt::print(" (genus {})", *st.genus);
    fmt::print("\n");
    fmt::print("  editable              {}\n",
               t.editable() ? "yes" : "no (not a consistently oriented 2-manifold)");
    for (const auto& p : t.problems) fmt::print("    - {}\n", p);
    fmt::print("  bounding box          [{:.6g}, {:.6g}, {:.6g}] .. [{:.6g}, {:.6g}, {:.6g}]\n",
               st.bbox_min.x, st.bbox_min.y, st.bbox_min.z, st.bbox_max.x, st.bbox_max.y,
               st.bbox_max.z);
    fmt::print("  diagonal              {:.6g}\n", st.diagonal);
    fmt::print("  edge length           min {:.6g}, mean {:.6g}, max {:.6g}\n", st.edge_length.min,
               st.edge_length.mean, st.edge_length.max);
    fmt::print("  valence               min {}, mean {:.3f}, max {}; valence 6: {:.1f}% of {} "
               "interior vertices\n",
               st.min_valence, st.mean_valence, st.max_valence, 100 * st.valence6_fraction,
               st.interior_vertices);
    fmt::print("  angles                min {:.3f} deg, mean per-face min {:.3f} deg\n",
               st.min_angle_deg, st.mean_min_angle_deg);
    if (st.zero_area_faces > 0) fmt::print("  zero-area faces       {}\n", st.zero_area_faces);
}

// ---- input and output (tool/common.hpp) -----------------------------------------------

/// "uv (corner, float64 x2), material (face, uint32, 3 names)"
std::string describe_attributes(const idas::io::surface& s) {
    std::string out;
    for (const auto& a : s.attributes) {
        out += out.empty() ? "" : ", ";
        out += fmt::format(
            "{} ({}, {}{}{})", a.name, idas::io::to_string(a.domain), idas::io::to_string(a.type),
            a.width > 1 ? " x" + std::to_string(a.width) : std::string(),
            a.labels.empty() ? std::string() : ", " + std::to_string(a.labels.size()) + " names");
    }
    return out;
}

// ---- info ----------------------------------------------------------------------------------

/// `--reference FILE` and `--samples N` of info.
struct info_reference {
    std::string file;
    int samples = 16;
};

std::optional<reference_distance> measure_reference(const std::vector<vec3>& V,
                                                    const std::vector<idas::tri_indices>& F,
                                                    const info_reference& r) {
    if (r.file.empty()) return std::nullopt;
    if (r.samples < 0 || r.samples > max_samples_per_face)
        throw idas::input_error("--samples must be 0 to " + std::to_string(max_samples_per_face));
    if (is_tet_path(r.file))
        throw idas::input_error(r.file + ": the reference must be a triangle surface, not a "
                                         "tet mesh (convert it to its boundary first)");
    return measure_against_reference(V, F, load(r.file, false), r.file, r.samples);
}

int run_info(const std::string& in, bool as_json, bool self_intersections,
             const info_reference& ref) {
    phase_times phases;
    const idas::io::surface s = load(in);
    phases.lap("read");
    const surface_info info = inspect_surface(s, self_intersections, phases);
    const auto distance = measure_reference(s.vertices, s.faces, ref);
    if (distance) phases.lap("reference");
    if (as_json) {
        json j = surface_info_json(in, s, info);
        if (distance) j["reference"] = reference_distance_json(*distance);
        j["seconds"] = phases.total();
        j["phases"] = phases.to_json();
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}\n", in);
        print_stats(info.stats);
        if (info.self_intersections)
            fmt::print("self-intersecting face pairs: {}\n", *info.self_intersections);
        fmt::print("attributes: {}\n", s.attributes.empty() ? "none" : describe_attributes(s));
        if (distance) print_reference_distance(*distance, "surface");
    }
    return 0;
}

// ---- convert -------------------------------------------------------------------------------

int run_convert(const std::string& in, const std::string& out, bool ascii, bool drop_attributes) {
    idas::io::format_of(out); // an unknown output extension fails before any reading
    const idas::io::surface s = load(in, !drop_attributes);
    save(out, s, ascii);
    fmt::print("{}: {} vertices, {} faces written to {}\n", in, s.vertices.size(), s.faces.size(),
               out);
    return 0;
}

// ---- demo ----------------------------------------------------------------------------------

template <class Mesh>
std::size_t ring_size(const Mesh& m, index_t v) {
    boost::container::small_vector<index_t, 24> ring;
    m.one_ring_vertices(v, ring);
    return ring.size();
}

/// The demo's spec: every operation is checked by the link condition and by
/// no_normal_flip; the hooks below add each kind's own acceptance rule and place the
/// vertices it moves or creates.
struct demo_spec {
    double collapse_below = 0; // collapse only edges shorter than this

    auto invariants() const {
        return idas::invariant_set<idas::link_condition, idas::no_normal_flip>{};
    }

    // Split at the midpoint (computed on the old mesh, placed on the new vertex).
    template <class Mesh>
    std::optional<vec3> before(idas::op::split_edge, const Mesh& m, const tuple_t& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Mesh>
    bool after(idas::op::split_edge, Mesh& m, const result_t& r, const vec3& mid) const {
        m.positions(r).set(r.anchor.vid, mid);
        return true;
    }

    // Collapse short edges to their midpoint; a boundary vertex keeps its place so the
    // boundary does not move inwards.
    template <class Mesh>
    std::optional<vec3> before(idas::op::collapse_edge, const Mesh& m, const tuple_t& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const vec3 pa = m.position(a), pb = m.position(b);
        if (!(idas::norm(pa - pb) < collapse_below)) return std::nullopt;
        const bool ba = m.is_boundary_vertex(a), bb = m.is_boundary_vertex(b);
        if (ba && !bb) return pa;
        if (bb && !ba) return pb;
        return (pa + pb) * 0.5;
    }
    template <class Mesh>
    bool after(idas::op::collapse_edge, Mesh& m, const result_t& r, const vec3& p) const {
        m.positions(r).set(r.anchor.vid, p);
        return true;
    }

    // Swap only when the valences of the four vertices get closer to their ideal
    // (6 inside, 4 on the boundary).
    template <class Mesh>
    bool before(idas::op::swap_edge, const Mesh& m, const tuple_t& t) const {
        const auto [a, b] = m.edge_vertices(t);
        const auto g = m.switch_face(t);
        if (!g) return false;
        const index_t c = m.opposite_vertex(t), d = m.opposite_vertex(*g);
        auto deviation = [&](index_t v, long change) {
            const long target = m.is_boundary_vertex(v) ? 4 : 6;
            return std::abs(static_cast<long>(ring_size(m, v)) + change - target);
        };
        const long now = deviation(a, 0) + deviation(b, 0) + deviation(c, 0) + deviation(d, 0);
        const long then = deviation(a, -1) + deviation(b, -1) + deviation(c, 1) + deviation(d, 1);
        return then < now;
    }

    // Tangential smoothing: move an interior vertex towards the average of its one-ring,
    // removing the component along the vertex normal so the surface keeps its shape.
    template <class Mesh>
    std::optional<vec3> before(idas::op::smooth_vertex, const Mesh& m, const tuple_t& t) const {
        const index_t v = t.vid;
        if (m.is_boundary_vertex(v)) return std::nullopt;
        boost::container::small_vector<index_t, 24> ring;
        m.one_ring_vertices(v, ring);
        if (ring.empty()) return std::nullopt;
        vec3 avg;
        for (index_t w : ring) avg += m.position(w);
        avg /= static_cast<double>(ring.size());
        vec3 n;
        for (index_t f : m.vertex_faces(v)) n += idas::face_normal_unnormalised(m, f);
        const vec3 p = m.position(v);
        vec3 step = avg - p;
        if (const double nn = idas::squared_norm(n); nn > 0) step -= n * (idas::dot(step, n) / nn);
        return p + step;
    }
    template <class Mesh>
    bool after(idas::op::smooth_vertex, Mesh& m, const result_t& r, const vec3& p) const {
        m.positions(r).set(r.anchor.vid, p);
        return true;
    }
};

/// A uniformly random live face; a few random probes, then a scan, so a mesh with many
/// dead slots (or none alive) cannot stall the demo.
template <class Mesh>
std::optional<index_t> random_live_face(const Mesh& m, std::mt19937_64& rng) {
    const index_t slots = m.face_slots();
    if (slots == 0) return std::nullopt;
    for (int probe = 0; probe < 64; ++probe)
        if (const auto f = static_cast<index_t>(rng() % slots); m.face_alive(f)) return f;
    const auto start = static_cast<index_t>(rng() % slots);
    for (index_t i = 0; i < slots; ++i)
        if (const auto f = static_cast<index_t>((std::uint64_t{start} + i) % slots);
            m.face_alive(f))
            return f;
    return std::nullopt;
}

struct op_counts {
    std::size_t attempted = 0, accepted = 0;
    std::size_t rejected() const { return attempted - accepted; }
};

template <class Mesh>
int run_demo(const std::string& in, const std::string& out, bool as_json, std::uint64_t seed,
             std::size_t n_ops, bool ascii, const std::string& backend) {
    using mesh_t = Mesh;
    const stopwatch total;
    json j;
    j["input"] = in;
    j["output"] = out;
    j["seed"] = seed;
    j["ops"] = n_ops;
    j["backend"] = backend;

    stopwatch clock;
    const idas::io::surface s = load(in);
    const double t_read = clock.seconds();
    const mesh_stats in_stats = compute_stats(s);

    clock = {};
    std::optional<mesh_t> built;
    mesh_t& m = build_mesh(built, s, in);
    const double t_build = clock.seconds();

    if (!as_json) {
        fmt::print("{}\n", in);
        print_stats(in_stats);
        fmt::print("running {} random operations (seed {}) on the {} backend\n", n_ops, seed,
                   backend);
    }

    // Random operations: pick a kind, then a random live face and a corner or edge of it.
    clock = {};
    demo_spec spec{in_stats.edge_length.mean};
    std::mt19937_64 rng(seed);
    op_counts counts[4];
    auto& ctx = idas::thread_context<mesh_t>();
    for (std::size_t i = 0; i < n_ops; ++i) {
        const auto kind = static_cast<int>(rng() % 4);
        const std::optional<index_t> f = random_live_face(m, rng);
        if (!f) break; // nothing left to edit
        const auto le = static_cast<std::uint8_t>(rng() % 3);
        const tuple_t t = m.tuple_from_edge(*f, le);
        bool ok = false;
        switch (kind) {
        case 0:
            ok = idas::split_edge(m, t, spec, ctx).has_value();
            break;
        case 1:
            ok = idas::collapse_edge(m, t, spec, ctx).has_value();
            break;
        case 2:
            ok = idas::swap_edge(m, t, spec, ctx).has_value();
            break;
        default:
            ok = idas::smooth_vertex(m, t, spec, ctx).has_value();
            break;
        }
        ++counts[kind].attempted;
        counts[kind].accepted += ok ? 1 : 0;
    }
    const double t_ops = clock.seconds();

    // A broken mesh here would be a library bug, not bad input: report it as a failure.
    clock = {};
    if (const auto problem = idas::find_inconsistency(m))
        throw std::runtime_error("the edited mesh is inconsistent: " + *problem);
    idas::io::surface result;
    std::tie(result.vertices, result.faces) = m.to_arrays();
    const mesh_stats out_stats = compute_stats(result);
    check_result("demo", summary_of(in_stats.topo), summary_of(out_stats.topo));
    const double t_validate = clock.seconds();

    clock = {};
    save(out, result, ascii);
    const double t_write = clock.seconds();

    static constexpr const char* names[4] = {"split", "collapse", "swap", "smooth"};
    if (as_json) {
        j["input_stats"] = stats_json(in_stats);
        j["output_stats"] = stats_json(out_stats);
        json ops = json::object();
        for (int k = 0; k < 4; ++k)
            ops[names[k]] = {{"attempted", counts[k].attempted},
                             {"accepted", counts[k].accepted},
                             {"rejected", counts[k].rejected()}};
        j["operations"] = ops;
        j["seconds"] = {{"read", t_read},         {"build", t_build}, {"operations", t_ops},
                        {"validate", t_validate}, {"write", t_write}, {"total", total.seconds()}};
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("operations              attempted  accepted  rejected\n");
        for (int k = 0; k < 4; ++k)
            fmt::print("  {:<20} {:>9} {:>9} {:>9}\n", names[k], counts[k].attempted,
                       counts[k].accepted, counts[k].rejected());
        fmt::print("{}\n", out);
        print_stats(out_stats);
        fmt::print("time: read {:.3f} s, build {:.3f} s, operations {:.3f} s, validate {:.3f} s, "
                   "write {:.3f} s, total {:.3f} s\n",
                   t_read, t_build, t_ops, t_validate, t_write, total.seconds());
    }
    return 0;
}

// ---- decimate (tool/decimate.hpp) ---------------------------------------------------------

#include "cli_progress.hpp"

int run_decimate(const std::string& in, const std::string& out, const decimate_options& o,
                 bool as_json, bool ascii, bool drop_attributes) {
    phase_times phases;
    idas::io::format_of(out); // an unknown output extension fails before any work
    check_decimate_options(o);
    if (o.attribute_weight && drop_attributes)
        throw idas::input_error("--attribute-weight has no attributes to weigh with "
                                "--drop-attributes");
    // Reading, checking and writing use oneTBB: on as many threads as the algorithm.
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, o.threads);
    const idas::io::surface s = load(in, !drop_attributes);
    phases.lap("read");
    terminal_progress bar("decimate");
    const auto draw = [&bar](double done, std::int64_t faces) {
        bar.draw(done, std::to_string(faces) + " faces");
    };
    const face_progress progress(draw);
    const decimated d = decimate_surface(s, in, o, phases, bar.enabled() ? &progress : nullptr);
    bar.end_line();
    const idas::io::surface& result = d.mesh;
    const idas::run_report& r = d.report;
    save(out, result, ascii);
    phases.lap("write");
    const auto output_faces = static_cast<std::int64_t>(result.faces.size());
    if (as_json) {
        json j;
        j["input"] = in;
        j["output"] = out;
        j["algorithm"] = o.algorithm;
        j["backend"] = o.backend;
        j["input_faces"] = d.input_faces;
        j["target_faces"] = d.target_faces;
        j["output_faces"] = output_faces;
        j["output_vertices"] = result.vertices.size();
        j["threads"] = o.threads;
        j["deterministic"] = o.deterministic;
        j["self_intersections_refused"] = !o.allow_self_intersections;
        j["rounds"] = r.rounds;
        j["grouped"] = r.grouped;
        j["attributes"] = attributes_json(result);
        j["constrained_vertices"] = d.constrained_vertices;
        if (o.algorithm == "qslim")
            j["attribute_weight"] =
                o.attribute_weight.value_or(idas::algorithms::qslim_spec::default_attribute_weight);
        j["seconds_algorithm"] = r.seconds;
        j["seconds_check"] = d.check_seconds;
        j["seconds_total"] = phases.total();
        j["phases"] = phases.to_json();
        j["collapses"] = r.succeeded;
        j["refused"] = r.refused;
        j["stale_entries"] = r.stale;
        j["lock_failures"] = r.lock_failures;
        j["deferred_to_serial"] = r.deferred_to_serial;
        j["retaken"] = r.retaken;
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} -> {} faces (target {}) by {} on {} thread{}{} ({} backend) in {:.3f} s "
                   "(result check {:.3f} s, {:.3f} s total)\n",
                   in, d.input_faces, output_faces, d.target_faces, o.algorithm, o.threads,
                   o.threads == 1 ? "" : "s", o.deterministic ? ", deterministic" : "", o.backend,
                   r.seconds, d.check_seconds, phases.total());
        fmt::print("  collapses {}, refused {}, stale queue entries {}, lock failures {}\n",
                   r.succeeded, r.refused, r.stale, r.lock_failures);
        fmt::print("  seconds: {}\n", phases.to_text());
        fmt::print("  written to {}\n", out);
    }
    return 0;
}

#include "cli_harmonic.hpp"
#include "cli_remesh.hpp"
#include "cli_tet.hpp"
#include "cli_tetmesh.hpp"

// ---- main ----------------------------------------------------------------------------------

int error(int code, const std::string& message) {
    std::fflush(stdout);
    std::fprintf(stderr, "idas: error: %s\n", message.c_str());
    return code;
}

/// Unsigned options would silently wrap "-1" around; accept plain digits only.
const CLI::Validator unsigned_integer(
    [](std::string& text) -> std::string {
        std::uint64_t value = 0;
        const char* last = text.data() + text.size();
        const auto [end, ec] = std::from_chars(text.data(), last, value);
        if (text.empty() || ec != std::errc() || end != last)
            return "'" + text + "' is not a non-negative integer";
        return {};
    },
    "");

int run(int argc, char** argv) {
    CLI::App app{"idas: inspect, convert and edit triangle meshes (OBJ, OFF, PLY, STL); inspect "
                 "and convert tetrahedral meshes (MSH 2.2/4.1 in and out, VTU out)",
                 "idas"};
    app.footer("The file extension decides: .msh and .vtu files are tetrahedral meshes, all "
               "others triangle surfaces. Converting tets to .obj/.off/.ply/.stl writes the "
               "boundary surface.");
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("idas ") + IDAS_VERSION_STRING);

    std::string in, out;
    bool as_json = false, ascii = false;
    std::uint64_t seed = 1;
    std::size_t n_ops = 2000;

    auto* info = app.add_subcommand("info", "Print statistics and topology of a mesh");
    info->add_option("IN", in, "input mesh file (.msh: tetrahedral mesh)")->required();
    info->add_flag("--json", as_json, "print one JSON object instead of text");
    bool self_intersections = false;
    info->add_flag("--self-intersections", self_intersections,
                   "count the pairs of faces that meet other than at shared vertices and edges "
                   "(exact)");
    info_reference reference;
    auto* reference_option = info->add_option(
        "--reference", reference.file,
        "a triangle surface to measure against: the farthest sample of the mesh's "
        "surface (a tet mesh's boundary) from it and of it from that surface, also "
        "relative to its bounding-box diagonal");
    info->add_option("--samples", reference.samples,
                     "samples per face for --reference, besides corners, edge midpoints and "
                     "centroid (0 to 10000)")
        ->needs(reference_option)
        ->capture_default_str();

    auto* convert = app.add_subcommand("convert", "Convert a mesh between file formats");
    convert->add_option("IN", in, "input mesh file")->required();
    convert->add_option("OUT", out, "output mesh file; the extension picks the format")->required();
    convert->add_flag("--ascii", ascii, "write PLY, STL, MSH and VTU as text instead of binary");
    bool drop_attributes = false;
    convert->add_flag("--drop-attributes", drop_attributes,
                      "write positions and triangles only (no UVs, normals, colours, tags)");
    tet_convert_arguments tet_convert;
    add_tet_convert_options(convert, tet_convert);

    auto* demo = app.add_subcommand(
        "demo", "Run random splits, collapses, swaps and smoothing guarded by invariants");
    demo->add_option("IN", in, "input mesh file (an orientable 2-manifold)")->required();
    demo->add_option("OUT", out, "output mesh file")->required();
    demo->add_flag("--json", as_json, "print one JSON object instead of text");
    demo->add_option("--seed", seed, "random seed")->check(unsigned_integer)->capture_default_str();
    demo->add_option("--ops", n_ops, "number of operations to attempt")
        ->check(unsigned_integer)
        ->capture_default_str();
    demo->add_flag("--ascii", ascii, "write PLY and STL as text instead of binary");
    std::string backend = "indexed";
    demo->add_option("--backend", backend, "connectivity backend: indexed or corner-table")
        ->check(CLI::IsMember(backend_names))
        ->capture_default_str();

    decimate_options dec;
    double ratio = -1, feature_angle = -1;
    bool decimate_drop_attributes = false;
    auto* decimate = app.add_subcommand("decimate", "Decimate by shortest edge collapse or QSlim");
    decimate->add_option("IN", in, "input mesh file (an orientable 2-manifold)")->required();
    decimate->add_option("OUT", out, "output mesh file")->required();
    decimate->add_option("--algorithm", dec.algorithm, "shortest-edge or qslim")
        ->check(CLI::IsMember({"shortest-edge", "qslim"}))
        ->capture_default_str();
    auto* ratio_opt =
        decimate->add_option("--ratio", ratio, "target face count as a fraction of the input's");
    auto* faces_opt = decimate->add_option("--faces", dec.faces, "target face count");
    ratio_opt->excludes(faces_opt);
    decimate->add_option("--threads", dec.threads, "worker threads")
        ->check(unsigned_integer)
        ->capture_default_str();
    decimate->add_flag("--deterministic", dec.deterministic,
                       "the same output at every thread count (deterministic rounds)");
    decimate->add_flag("--json", as_json, "print one JSON object instead of text");
    decimate->add_flag("--ascii", ascii, "write PLY and STL as text instead of binary");
    decimate->add_option("--backend", dec.backend, "connectivity backend: indexed or corner-table")
        ->check(CLI::IsMember(backend_names))
        ->capture_default_str();
    decimate->add_flag("--drop-attributes", decimate_drop_attributes,
                       "do not read, carry or write the file's attributes (UVs, normals, colours, "
                       "tags)");
    decimate->add_flag("--keep-boundary", dec.keep_boundary,
                       "no boundary vertex moves or disappears");
    decimate->add_flag("--allow-self-intersections", dec.allow_self_intersections,
                       "do not refuse collapses that make faces meet (faster)");
    auto* feature_angle_opt = decimate->add_option(
        "--feature-angle", feature_angle,
        "no vertex on an edge sharper than this dihedral angle (degrees) moves or disappears");
    double attribute_weight = idas::algorithms::qslim_spec::default_attribute_weight;
    auto* attribute_weight_opt =
        decimate
            ->add_option("--attribute-weight", attribute_weight,
                         "QSlim: how much texture coordinates, colours and other attributes "
                         "(not normals) weigh against the shape; 0: the shape alone")
            ->capture_default_str();
    decimate->callback([&] {
        if (ratio_opt->count() + faces_opt->count() != 1)
            throw CLI::ValidationError("decimate", "give exactly one of --ratio R or --faces N");
        if (ratio_opt->count() > 0) dec.ratio = ratio;
        if (feature_angle_opt->count() > 0) dec.feature_angle = feature_angle;
        if (attribute_weight_opt->count() > 0) dec.attribute_weight = attribute_weight;
    });

    remesh_arguments ra;
    auto* remesh = app.add_subcommand(
        "remesh", "Isotropic remeshing (Botsch-Kobbelt) to a target edge length");
    remesh->add_option("IN", ra.in, "input mesh file (an orientable 2-manifold)")->required();
    remesh->add_option("OUT", ra.out, "output mesh file")->required();
    remesh
        ->add_option("--edge-length", ra.options.edge_length,
                     "target edge length, relative to the bounding-box diagonal")
        ->capture_default_str();
    remesh->add_flag("--absolute", ra.options.absolute, "--edge-length is absolute, not relative");
    remesh->add_option("--iterations", ra.options.iterations, "iterations")
        ->check(unsigned_integer)
        ->capture_default_str();
    remesh->add_option("--threads", ra.options.threads, "worker threads")
        ->check(unsigned_integer)
        ->capture_default_str();
    ra.envelope_option = remesh->add_option(
        "--envelope", ra.envelope,
        "keep every new triangle within EPS (relative to the diagonal) of the input, exactly");
    ra.feature_angle_option =
        remesh->add_option("--feature-angle", ra.feature_angle,
                           "keep edges sharper than this dihedral angle (degrees, 0 to 180)");
    remesh
        ->add_option("--max-faces", ra.options.max_faces,
                     "refuse a target edge length whose output would need more faces than this "
                     "(estimated from the surface area)")
        ->check(unsigned_integer)
        ->capture_default_str();
    remesh->add_flag("!--free-boundary", ra.options.keep_boundary,
                     "let boundary vertices move and vanish");
    remesh->add_flag("--allow-self-intersections", ra.options.allow_self_intersections,
                     "do not refuse operations that make faces meet (faster)");
    remesh->add_flag("--deterministic", ra.options.deterministic,
                     "the same output at every thread count (deterministic rounds)");
    remesh->add_flag("--json", ra.as_json, "print one JSON object instead of text");
    remesh->add_flag("--trace", ra.options.trace,
                     "report the smallest angle and the valences after every phase");
    remesh
        ->add_option("--backend", ra.options.backend,
                     "connectivity backend: indexed or corner-table")
        ->check(CLI::IsMember(backend_names))
        ->capture_default_str();
    remesh->add_flag("--ascii", ra.ascii, "write PLY and STL as text instead of binary");
    remesh->add_flag("--drop-attributes", ra.drop_attributes,
                     "do not read, carry or write the file's attributes (UVs, normals, colours, "
                     "tags)");
    remesh->callback([&ra] {
        if (ra.envelope_option->count() > 0) ra.options.envelope = ra.envelope;
        if (ra.feature_angle_option->count() > 0) ra.options.feature_angle = ra.feature_angle;
    });

    harmonic_arguments ha;
    auto* harmonic = add_harmonic_command(app, ha, unsigned_integer);

    tetmesh_arguments ta;
    auto* tetmesh = add_tetmesh_command(app, ta, unsigned_integer);

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::string message = e.what();
        if (app.get_subcommands().empty() && !app.remaining().empty())
            message = "unknown subcommand '" + app.remaining().front() + "'";
        return error(2, message + " (run 'idas --help' for usage)");
    }

    if (info->parsed())
        return is_tet_path(in) ? run_tet_info(in, as_json, reference)
                               : run_info(in, as_json, self_intersections, reference);
    if (remesh->parsed()) return run_remesh(ra);
    if (harmonic->parsed()) return run_harmonic(ha);
    if (tetmesh->parsed()) return run_tetmesh(ta);
    if (decimate->parsed())
        return run_decimate(in, out, dec, as_json, ascii, decimate_drop_attributes);
    if (convert->parsed() && is_tet_convert(in, out))
        return run_tet_convert(in, out, ascii, tet_convert);
    if (convert->parsed()) return run_convert(in, out, ascii, drop_attributes);
    return with_backend(backend, [&]<class Mesh>(std::type_identity<Mesh>) {
        return run_demo<Mesh>(in, out, as_json, seed, n_ops, ascii, backend);
    });
}

} // namespace

int main(int argc, char** argv) {
    // An interrupted run removes its half-written output (the final path is never partial).
    idas::io::remove_temporary_files_on_signals();
    int code = 0;
    try {
        code = run(argc, argv);
    } catch (const idas::input_error& e) {
        return error(2, e.what());
    } catch (const std::bad_alloc&) {
        return error(1, "out of memory");
    } catch (const std::exception& e) {
        return error(1, e.what());
    } catch (...) {
        return error(1, "unknown failure");
    }
    // Output that never reached stdout (closed pipe, full disk) is a failure too.
    if (std::fflush(stdout) != 0 || std::ferror(stdout)) return error(1, "cannot write to stdout");
    return code;
}
