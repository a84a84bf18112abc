// idas: the command-line tool.
//
//   idas info IN [--json] [--self-intersections]
//                                              statistics and topology of a mesh file
//   idas convert IN OUT [--ascii] [--msh-version V]
//                                              any supported format to any other
//   idas demo IN OUT [--json] [--seed S] [--ops N] [--ascii] [--backend B]
//                                              random local operations guarded by invariants
//   idas decimate IN OUT (--ratio R | --faces N) [--algorithm A] [--threads T] [--backend B]
//                 [--deterministic] [--allow-self-intersections]
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

using json = nlohmann::ordered_json;
using tuple_t = idas::tri_tuple;
using result_t = idas::op_result<tuple_t>;
using idas::index_t;
using idas::vec3;

// ---- connectivity backends ------------------------------------------------------------------

/// `--backend`: the editing commands (demo, decimate, remesh) run on either triangle backend;
/// each is a separate instantiation of the same code.
const std::vector<std::string> backend_names = {"indexed", "corner-table"};

/// Calls fn(std::type_identity<Mesh>{}) with the mesh type the backend name selects.
template <class Fn>
decltype(auto) with_backend(const std::string& backend, Fn&& fn) {
    if (backend == "corner-table")
        return fn(std::type_identity<idas::tri_mesh<idas::backend::corner_table_tri>>{});
    return fn(std::type_identity<idas::tri_mesh<idas::backend::indexed_tri>>{});
}

/// `--threads` above this is refused: every worker is an OS thread with its own stack and
/// queue, and far more of them than cores only adds contention (tens of thousands made
/// thread creation fail). 1024 is well above the cores of any machine idas runs on.
constexpr unsigned max_threads = 1024;

void check_threads(unsigned threads) {
    if (threads == 0 || threads > max_threads)
        throw idas::input_error("--threads must be between 1 and " + std::to_string(max_threads) +
                                " (got " + std::to_string(threads) + ")");
}

using idas::detail::stopwatch; // wall seconds since construction

/// Wall time per phase of a command, in the order they ran (read, build, the algorithm's
/// setup, main phase and serial tail, check, write, ...): `--json` reports them under
/// "phases", the text output on one line, so users and benchmarks see where the time goes.
class phase_times {
public:
    /// Ends the phase that is running under `name`.
    void lap(std::string name) {
        const double now = clock_.seconds();
        phases_.emplace_back(std::move(name), now - last_);
        last_ = now;
    }
    /// Ends a run of the executor, split as its report says: setup and serial tail on one
    /// thread, the rest its main phase (named `name`).
    void lap(const std::string& name, double setup_seconds, double tail_seconds) {
        const double now = clock_.seconds(), spent = now - last_;
        const double setup = std::min(setup_seconds, spent);
        const double tail = std::min(tail_seconds, spent - setup);
        phases_.emplace_back(name + "_setup", setup);
        phases_.emplace_back(name, spent - setup - tail);
        phases_.emplace_back(name + "_serial_tail", tail);
        last_ = now;
    }
    double total() const { return clock_.seconds(); }
    json to_json() const {
        json j = json::object();
        for (const auto& [name, seconds] : phases_) j[name] = seconds;
        j["total"] = total();
        return j;
    }
    std::string to_text() const {
        std::string text;
        for (const auto& [name, seconds] : phases_)
            text += fmt::format("{}{} {:.3f}", text.empty() ? "" : ", ", name, seconds);
        return text + fmt::format(" (total {:.3f} s)", total());
    }

private:
    stopwatch clock_;
    double last_ = 0;
    std::vector<std::pair<std::string, double>> phases_;
};

// ---- statistics of a face list -------------------------------------------------------------

struct min_mean_max {
    double min = 0, mean = 0, max = 0;
};

/// Everything `info` reports. Geometry is computed from the face list itself, so it is
/// available for non-manifold input too.
struct mesh_stats {
    idas::topology_report topo;
    std::optional<long> genus; // orientable manifolds only
    vec3 bbox_min, bbox_max;
    double diagonal = 0;
    min_mean_max edge_length;
    double min_valence = 0, mean_valence = 0, max_valence = 0;
    std::size_t interior_vertices = 0;
    double valence6_fraction = 0; // of interior vertices
    double min_angle_deg = 0, mean_min_angle_deg = 0;
    std::size_t zero_area_faces = 0;
};

mesh_stats compute_stats(const idas::io::surface& s) {
    mesh_stats st;
    st.topo = idas::diagnose_topology(s.vertices.size(), s.faces);
    const auto& t = st.topo;
    if (t.editable()) {
        // chi = 2C - 2g - b for an orientable surface with b boundary loops.
        const long twice_g = 2 * static_cast<long>(t.components) - t.euler_characteristic -
                             static_cast<long>(t.boundary_loops);
        if (twice_g >= 0 && twice_g % 2 == 0) st.genus = twice_g / 2;
    }

    const std::size_t nv = s.vertices.size();
    auto usable = [&](const idas::tri_indices& f) {
        return f[0] < nv && f[1] < nv && f[2] < nv && f[0] != f[1] && f[1] != f[2] && f[0] != f[2];
    };

    // Bounding box of the referenced vertices (of all of them if no face is usable).
    std::vector<char> used(nv, 0);
    for (const auto& f : s.faces)
        if (usable(f)) used[f[0]] = used[f[1]] = used[f[2]] = 1;
    const bool any_used = std::find(used.begin(), used.end(), 1) != used.end();
    constexpr double inf = std::numeric_limits<double>::infinity();
    vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
    for (std::size_t v = 0; v < nv; ++v) {
        if (any_used && !used[v]) continue;
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], s.vertices[v][k]);
            hi[k] = std::max(hi[k], s.vertices[v][k]);
        }
    }
    if (nv > 0) st.bbox_min = lo, st.bbox_max = hi, st.diagonal = idas::norm(hi - lo);

    // Undirected edges, each once, with the number of faces using it.
    std::vector<std::uint64_t> keys;
    keys.reserve(3 * s.faces.size());
    for (const auto& f : s.faces) {
        if (!usable(f)) continue;
        for (int i = 0; i < 3; ++i) {
            const index_t a = std::min(f[i], f[(i + 1) % 3]), b = std::max(f[i], f[(i + 1) % 3]);
            keys.push_back(std::uint64_t{a} << 32 | b);
        }
    }
    tbb::parallel_sort(keys.begin(), keys.end());
    std::vector<std::uint32_t> valence(nv, 0);
    std::vector<char> on_boundary(nv, 0);
    double sum_len = 0;
    std::size_t n_edges = 0;
    st.edge_length.min = inf;
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i;
        while (j < keys.size() && keys[j] == keys[i]) ++j;
        const auto a = static_cast<index_t>(keys[i] >> 32);
        const auto b = static_cast<index_t>(keys[i] & 0xffffffffu);
        const double len = idas::norm(s.vertices[a] - s.vertices[b]);
        st.edge_length.min = std::min(st.edge_length.min, len);
        st.edge_length.max = std::max(st.edge_length.max, len);
        sum_len += len, ++n_edges;
        ++valence[a], ++valence[b];
        if (j - i == 1) on_boundary[a] = on_boundary[b] = 1;
        i = j;
    }
    if (n_edges > 0)
        st.edge_length.mean = sum_len / static_cast<double>(n_edges);
    else
        st.edge_length.min = 0;

    std::size_t n_ref = 0, n_val6 = 0;
    double sum_val = 0;
    st.min_valence = inf;
    for (std::size_t v = 0; v < nv; ++v) {
        if (valence[v] == 0) continue;
        ++n_ref;
        sum_val += valence[v];
        st.min_valence = std::min(st.min_valence, double(valence[v]));
        st.max_valence = std::max(st.max_valence, double(valence[v]));
        if (!on_boundary[v]) {
            ++st.interior_vertices;
            n_val6 += valence[v] == 6 ? 1 : 0;
        }
    }
    if (n_ref > 0)
        st.mean_valence = sum_val / static_cast<double>(n_ref);
    else
        st.min_valence = 0;
    if (st.interior_vertices > 0)
        st.valence6_fraction = double(n_val6) / static_cast<double>(st.interior_vertices);

    // Angles: atan2(|u x v|, u . v) is accurate for tiny and near-straight angles and
    // gives 0 (not NaN) for zero-length edges.
    constexpr double to_deg = 180.0 / std::numbers::pi;
    struct angles {
        double sum_min = 0, min = inf;
        std::size_t faces = 0, zero_area = 0;
    };
    // Blocks of faces in parallel, summed in a fixed tree: the same sum on any thread count.
    using range = tbb::blocked_range<std::size_t>;
    const angles a = tbb::parallel_deterministic_reduce(
        range(0, s.faces.size(), 8192), angles{},
        [&](const range& r, angles acc) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                const auto& f = s.faces[i];
                if (!usable(f)) continue;
                double face_min = inf;
                for (int k = 0; k < 3; ++k) {
                    const vec3& p = s.vertices[f[k]];
                    const vec3 u = s.vertices[f[(k + 1) % 3]] - p,
                               w = s.vertices[f[(k + 2) % 3]] - p;
                    face_min = std::min(face_min,
                                        std::atan2(idas::norm(idas::cross(u, w)), idas::dot(u, w)));
                }
                const vec3 n = idas::cross(s.vertices[f[1]] - s.vertices[f[0]],
                                           s.vertices[f[2]] - s.vertices[f[0]]);
                if (idas::squared_norm(n) == 0) ++acc.zero_area;
                acc.min = std::min(acc.min, face_min * to_deg);
                acc.sum_min += face_min * to_deg, ++acc.faces;
            }
            return acc;
        },
        [](angles x, const angles& y) {
            x.sum_min += y.sum_min, x.min = std::min(x.min, y.min);
            x.faces += y.faces, x.zero_area += y.zero_area;
            return x;
        });
    st.zero_area_faces = a.zero_area;
    st.min_angle_deg = a.min;
    const double sum_min_angle = a.sum_min;
    const std::size_t n_faces = a.faces;
    if (n_faces > 0)
        st.mean_min_angle_deg = sum_min_angle / static_cast<double>(n_faces);
    else
        st.min_angle_deg = 0;
    return st;
}

json vec_json(const vec3& v) {
    return json::array({v.x, v.y, v.z});
}

json stats_json(const mesh_stats& st) {
    const auto& t = st.topo;
    json j;
    j["vertices"] = t.vertices;
    j["faces"] = t.faces;
    j["referenced_vertices"] = t.referenced_vertices;
    j["edges"] = t.edges;
    j["manifold"] = t.manifold();
    j["nonmanifold_edges"] = t.nonmanifold_edges;
    j["nonmanifold_vertices"] = t.nonmanifold_vertices;
    j["degenerate_faces"] = t.degenerate_faces;
    j["out_of_range_faces"] = t.out_of_range_faces;
    j["oriented"] = t.oriented();
    j["misoriented_edges"] = t.misoriented_edges;
    j["editable"] = t.editable();
    j["closed"] = t.closed();
    j["boundary_edges"] = t.boundary_edges;
    j["boundary_loops"] = t.boundary_loops;
    j["components"] = t.components;
    j["euler_characteristic"] = t.euler_characteristic;
    j["genus"] = st.genus ? json(*st.genus) : json(nullptr);
    j["problems"] = t.problems;
    j["bounding_box"] = {
        {"min", vec_json(st.bbox_min)}, {"max", vec_json(st.bbox_max)}, {"diagonal", st.diagonal}};
    j["edge_length"] = {
        {"min", st.edge_length.min}, {"mean", st.edge_length.mean}, {"max", st.edge_length.max}};
    j["valence"] = {{"min", st.min_valence},
                    {"mean", st.mean_valence},
                    {"max", st.max_valence},
                    {"interior_vertices", st.interior_vertices},
                    {"interior_valence6_fraction", st.valence6_fraction}};
    j["angles"] = {{"min_deg", st.min_angle_deg}, {"mean_min_deg", st.mean_min_angle_deg}};
    j["zero_area_faces"] = st.zero_area_faces;
    return j;
}

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

// ---- input and output ----------------------------------------------------------------------

/// Refuses points outside idas::geometry_range (coordinates that would overflow or
/// underflow lengths and areas), naming the source.
void check_range(const std::string& source, const std::vector<vec3>& points) {
    if (const auto problem = idas::check_geometry_range(points))
        throw idas::input_error(source + ": " + *problem);
}

/// The lower-case extension of a path (".msh").
std::string lowercase_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    return ext;
}

/// Reads a mesh file and refuses what no subcommand can use: no triangles at all, or
/// coordinates outside the supported range.
idas::io::surface load(const std::string& path, bool attributes = true) {
    idas::io::read_options options;
    options.attributes = attributes;
    idas::io::surface s = idas::io::read_surface(path, options);
    if (s.dropped_faces > 0)
        std::fprintf(stderr,
                     "idas: warning: %s: dropped %zu faces whose corners share a position (STL "
                     "stores positions only, so they weld into a degenerate face)\n",
                     path.c_str(), s.dropped_faces);
    if (s.faces.empty()) throw idas::input_error(path + ": the file contains no triangles");
    check_range(path, s.vertices);
    return s;
}

/// The result check of the editing commands: what they write must be an oriented
/// 2-manifold with the input's Euler characteristic and boundary loops. A failure is a bug
/// in idas, not in the user's file: exit 1, naming the command and the check.
void check_result(const char* command, const idas::surface_summary& input,
                  const idas::surface_summary& out) {
    std::string failed;
    if (out.problem)
        failed = "not an oriented 2-manifold: " + *out.problem;
    else if (out.euler_characteristic != input.euler_characteristic)
        failed = "Euler characteristic " + std::to_string(out.euler_characteristic) +
                 ", the input's is " + std::to_string(input.euler_characteristic);
    else if (out.boundary_loops != input.boundary_loops)
        failed = std::to_string(out.boundary_loops) + " boundary loops, the input has " +
                 std::to_string(input.boundary_loops);
    if (!failed.empty())
        throw std::runtime_error(std::string("internal error: ") + command +
                                 " produced an invalid mesh (result check: " + failed +
                                 "); nothing was written");
}
void check_result(const char* command, const idas::surface_summary& input,
                  const idas::io::surface& result) {
    check_result(command, input, idas::summarize_surface(result.vertices.size(), result.faces));
}

/// The same numbers from a full diagnosis, for commands that report statistics anyway
/// (so the result is not walked twice).
idas::surface_summary summary_of(const idas::topology_report& t) {
    idas::surface_summary s;
    if (!t.editable()) s.problem = t.problems.empty() ? "not editable" : t.problems.front();
    s.euler_characteristic = t.euler_characteristic;
    s.boundary_edges = t.boundary_edges, s.boundary_loops = t.boundary_loops;
    return s;
}

void save(const std::string& path, const idas::io::surface& s, bool ascii) {
    idas::io::format_options options;
    options.encoding = ascii ? idas::io::encoding::ascii : idas::io::encoding::binary;
    idas::io::write_surface(path, s, options);
    // Said after the write, so it is not said when the write fails.
    const auto lost = idas::io::unstored_attributes(path, s, options);
    if (!lost.empty()) {
        std::string names;
        for (const auto& n : lost) names += (names.empty() ? "" : ", ") + n;
        std::fprintf(stderr, "idas: warning: %s cannot store these attributes, not written: %s\n",
                     path.c_str(), names.c_str());
    }
}

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

json attributes_json(const idas::io::surface& s) {
    json list = json::array();
    for (const auto& a : s.attributes) {
        json j = {{"name", a.name},
                  {"domain", idas::io::to_string(a.domain)},
                  {"type", idas::io::to_string(a.type)},
                  {"width", a.width}};
        if (!a.labels.empty()) j["labels"] = a.labels;
        list.push_back(std::move(j));
    }
    return list;
}

/// The attribute carrying of decimate and remesh: the file's attributes (unless dropped)
/// and the vertices that must stay (kept boundary, sharp features).
struct carried_attributes {
    idas::algorithms::attribute_transfer transfer;
    bool dropped = false;

    template <class Mesh>
    const idas::algorithms::attribute_transfer*
    attach(Mesh& m, const idas::io::surface& s,
           const idas::algorithms::attribute_transfer_options& o) {
        if (s.attributes.empty() && !o.keep_boundary && o.feature_angle_deg < 0) return nullptr;
        transfer.attach(m, s, o);
        return &transfer;
    }
    template <class Mesh>
    void export_to(const Mesh& m, idas::io::surface& result, const idas::io::surface& input) const {
        if (!transfer.active()) return;
        result.attributes = transfer.exported(m);
        result.header_lines = input.header_lines;
    }
};

// ---- info ----------------------------------------------------------------------------------

/// A surface file's faces as idas::count_self_intersections reads a mesh: any soup.
struct soup_view {
    const idas::io::surface& s;
    idas::index_t face_slots() const noexcept { return idas::index_t(s.faces.size()); }
    static constexpr bool face_alive(idas::index_t) noexcept { return true; }
    const idas::tri_indices& face_vertices(idas::index_t f) const noexcept { return s.faces[f]; }
    const vec3& position(idas::index_t v) const noexcept { return s.vertices[v]; }
};

int run_info(const std::string& in, bool as_json, bool self_intersections) {
    phase_times phases;
    const idas::io::surface s = load(in);
    phases.lap("read");
    const mesh_stats st = compute_stats(s);
    phases.lap("statistics");
    std::optional<std::size_t> crossings;
    if (self_intersections) crossings = idas::count_self_intersections(soup_view{s});
    phases.lap("self_intersections");
    if (as_json) {
        json j;
        j["file"] = in;
        j.update(stats_json(st));
        if (crossings) j["self_intersections"] = *crossings;
        j["attributes"] = attributes_json(s);
        j["seconds"] = phases.total();
        j["phases"] = phases.to_json();
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}\n", in);
        print_stats(st);
        if (crossings) fmt::print("self-intersecting face pairs: {}\n", *crossings);
        fmt::print("attributes: {}\n", s.attributes.empty() ? "none" : describe_attributes(s));
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
        m.positions().set(r.anchor.vid, mid);
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
        m.positions().set(r.anchor.vid, p);
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
        m.positions().set(r.anchor.vid, p);
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
    try {
        built.emplace(s.vertices, s.faces);
    } catch (const idas::input_error& e) {
        throw idas::input_error(in + ": " + e.what());
    }
    mesh_t& m = *built;
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

// ---- decimate ------------------------------------------------------------------------------

#include "cli_progress.hpp"

/// Wraps a decimation spec to draw a progress bar: the executor calls `stop` after every
/// success (serial) or every few (parallel workers). The wrapped type is the executor's
/// spec (Algorithm::with_spec), so this `stop` is the one called.
template <class Base>
struct with_progress_bar : Base {
    std::int64_t start_faces = 0;
    terminal_progress* bar = nullptr;

    bool stop(const idas::progress& p) {
        if (bar && (p.successes & 255) == 0) {
            const double done = double(start_faces - p.faces) /
                                double(std::max<std::int64_t>(1, start_faces - this->target_faces));
            bar->draw(done, std::to_string(p.faces) + " faces");
        }
        return Base::stop(p);
    }
};

template <class Algorithm, class Spec, class Mesh>
idas::run_report decimate_with(Mesh& m, std::int64_t target, unsigned threads,
                               const idas::algorithms::attribute_transfer* transfer,
                               idas::no_self_intersection guard) {
    terminal_progress bar("decimate");
    with_progress_bar<Spec> spec;
    spec.target_faces = target;
    spec.transfer = transfer;
    spec.self_intersections = guard;
    spec.start_faces = static_cast<std::int64_t>(m.n_faces());
    spec.bar = bar.enabled() ? &bar : nullptr;
    idas::exec_options options;
    options.threads = threads;
    return Algorithm::template with_spec<with_progress_bar<Spec>>::run(m, spec, options);
}

/// What decimate keeps besides the shape.
struct decimate_keeping {
    bool drop_attributes = false;
    bool keep_boundary = false;
    bool allow_self_intersections = false;
    double feature_angle = -1;
    CLI::Option* feature_angle_option = nullptr;
};

template <class Mesh>
int run_decimate(const std::string& in, const std::string& out, const std::string& algorithm,
                 std::optional<double> ratio, std::int64_t faces, unsigned threads, bool as_json,
                 bool ascii, const std::string& backend, bool deterministic,
                 const decimate_keeping& keeping) {
    using namespace idas::algorithms;
    using mesh_t = Mesh;
    phase_times phases;
    idas::io::format_of(out); // an unknown output extension fails before any work
    check_threads(threads);
    // Reading, checking and writing use oneTBB: on as many threads as the algorithm.
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
    if (ratio && !(*ratio > 0 && *ratio <= 1)) throw idas::input_error("--ratio must be in (0, 1]");
    if (!ratio && faces < 0) throw idas::input_error("--faces must be non-negative");
    if (keeping.feature_angle_option && keeping.feature_angle_option->count() > 0 &&
        !(keeping.feature_angle >= 0 && keeping.feature_angle <= 180))
        throw idas::input_error("--feature-angle must be between 0 and 180 degrees");
    const idas::io::surface s = load(in, !keeping.drop_attributes);
    phases.lap("read");
    std::optional<mesh_t> built;
    try {
        built.emplace(s.vertices, s.faces);
    } catch (const idas::input_error& e) {
        throw idas::input_error(in + ": " + e.what());
    }
    mesh_t& m = *built;
    phases.lap("build");
    const auto input_faces = static_cast<std::int64_t>(m.n_faces());
    const std::int64_t target =
        ratio ? static_cast<std::int64_t>(std::llround(*ratio * double(input_faces))) : faces;

    carried_attributes carried;
    attribute_transfer_options keep;
    keep.keep_boundary = keeping.keep_boundary;
    keep.feature_angle_deg = keeping.feature_angle;
    const attribute_transfer* transfer = carried.attach(m, s, keep);
    phases.lap("attributes");

    // Collapses that make faces meet are refused unless asked otherwise.
    std::optional<idas::self_intersection_index> index;
    if (!keeping.allow_self_intersections) index.emplace(m);
    const idas::no_self_intersection guard =
        index ? idas::no_self_intersection(*index) : idas::no_self_intersection();
    phases.lap("self_intersection_index");

    idas::run_report r;
    const auto run = [&]<class Lock>(std::type_identity<Lock>) {
        if (algorithm == "qslim")
            r = decimate_with<qslim<mesh_t, Lock>, qslim_spec>(m, target, threads, transfer, guard);
        else
            r = decimate_with<shortest_edge_collapse<true, mesh_t, Lock>,
                              shortest_edge_collapse_spec<true>>(m, target, threads, transfer,
                                                                 guard);
    };
    if (deterministic)
        run(std::type_identity<idas::lock::deterministic_rounds>{});
    else
        run(std::type_identity<idas::lock::vertex_try_lock>{});
    phases.lap("decimation", r.setup_seconds, r.tail_seconds);

    idas::io::surface result;
    std::tie(result.vertices, result.faces) = m.to_arrays();
    carried.export_to(m, result, s);
    phases.lap("export");
    const stopwatch check_clock;
    check_result("decimate", idas::summarize_surface(s.vertices.size(), s.faces), result);
    const double t_check = check_clock.seconds();
    phases.lap("check");
    save(out, result, ascii);
    phases.lap("write");
    const auto output_faces = static_cast<std::int64_t>(result.faces.size());
    if (as_json) {
        json j;
        j["input"] = in;
        j["output"] = out;
        j["algorithm"] = algorithm;
        j["backend"] = backend;
        j["input_faces"] = input_faces;
        j["target_faces"] = target;
        j["output_faces"] = output_faces;
        j["output_vertices"] = result.vertices.size();
        j["threads"] = threads;
        j["deterministic"] = deterministic;
        j["self_intersections_refused"] = !keeping.allow_self_intersections;
        j["rounds"] = r.rounds;
        j["attributes"] = attributes_json(result);
        j["constrained_vertices"] = transfer ? carried.transfer.constrained_count(m) : 0;
        j["seconds_algorithm"] = r.seconds;
        j["seconds_check"] = t_check;
        j["seconds_total"] = phases.total();
        j["phases"] = phases.to_json();
        j["collapses"] = r.succeeded;
        j["refused"] = r.refused;
        j["stale_entries"] = r.stale;
        j["lock_failures"] = r.lock_failures;
        j["deferred_to_serial"] = r.deferred_to_serial;
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: {} -> {} faces (target {}) by {} on {} thread{}{} ({} backend) in {:.3f} s "
                   "(result check {:.3f} s, {:.3f} s total)\n",
                   in, input_faces, output_faces, target, algorithm, threads,
                   threads == 1 ? "" : "s", deterministic ? ", deterministic" : "", backend,
                   r.seconds, t_check, phases.total());
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

    std::string algorithm = "qslim";
    double ratio = -1;
    std::int64_t target_faces = -1;
    unsigned threads = 1;
    bool deterministic = false;
    auto* decimate = app.add_subcommand("decimate", "Decimate by shortest edge collapse or QSlim");
    decimate->add_option("IN", in, "input mesh file (an orientable 2-manifold)")->required();
    decimate->add_option("OUT", out, "output mesh file")->required();
    decimate->add_option("--algorithm", algorithm, "shortest-edge or qslim")
        ->check(CLI::IsMember({"shortest-edge", "qslim"}))
        ->capture_default_str();
    auto* ratio_opt =
        decimate->add_option("--ratio", ratio, "target face count as a fraction of the input's");
    auto* faces_opt = decimate->add_option("--faces", target_faces, "target face count");
    ratio_opt->excludes(faces_opt);
    decimate->add_option("--threads", threads, "worker threads")
        ->check(unsigned_integer)
        ->capture_default_str();
    decimate->add_flag("--deterministic", deterministic,
                       "the same output at every thread count (deterministic rounds)");
    decimate->add_flag("--json", as_json, "print one JSON object instead of text");
    decimate->add_flag("--ascii", ascii, "write PLY and STL as text instead of binary");
    decimate->add_option("--backend", backend, "connectivity backend: indexed or corner-table")
        ->check(CLI::IsMember(backend_names))
        ->capture_default_str();
    decimate_keeping keeping;
    decimate->add_flag("--drop-attributes", keeping.drop_attributes,
                       "do not read, carry or write the file's attributes (UVs, normals, colours, "
                       "tags)");
    decimate->add_flag("--keep-boundary", keeping.keep_boundary,
                       "no boundary vertex moves or disappears");
    decimate->add_flag("--allow-self-intersections", keeping.allow_self_intersections,
                       "do not refuse collapses that make faces meet (faster)");
    keeping.feature_angle_option = decimate->add_option(
        "--feature-angle", keeping.feature_angle,
        "no vertex on an edge sharper than this dihedral angle (degrees) moves or disappears");
    decimate->callback([&] {
        if (ratio_opt->count() + faces_opt->count() != 1)
            throw CLI::ValidationError("decimate", "give exactly one of --ratio R or --faces N");
    });

    remesh_arguments ra;
    auto* remesh = app.add_subcommand(
        "remesh", "Isotropic remeshing (Botsch-Kobbelt) to a target edge length");
    remesh->add_option("IN", ra.in, "input mesh file (an orientable 2-manifold)")->required();
    remesh->add_option("OUT", ra.out, "output mesh file")->required();
    remesh
        ->add_option("--edge-length", ra.edge_length,
                     "target edge length, relative to the bounding-box diagonal")
        ->capture_default_str();
    remesh->add_flag("--absolute", ra.absolute, "--edge-length is absolute, not relative");
    remesh->add_option("--iterations", ra.iterations, "iterations")
        ->check(unsigned_integer)
        ->capture_default_str();
    remesh->add_option("--threads", ra.threads, "worker threads")
        ->check(unsigned_integer)
        ->capture_default_str();
    ra.envelope_option = remesh->add_option(
        "--envelope", ra.envelope,
        "keep every new triangle within EPS (relative to the diagonal) of the input, exactly");
    ra.feature_angle_option =
        remesh->add_option("--feature-angle", ra.feature_angle,
                           "keep edges sharper than this dihedral angle (degrees, 0 to 180)");
    remesh
        ->add_option("--max-faces", ra.max_faces,
                     "refuse a target edge length whose output would need more faces than this "
                     "(estimated from the surface area)")
        ->check(unsigned_integer)
        ->capture_default_str();
    remesh->add_flag("!--free-boundary", ra.keep_boundary, "let boundary vertices move and vanish");
    remesh->add_flag("--allow-self-intersections", ra.allow_self_intersections,
                     "do not refuse operations that make faces meet (faster)");
    remesh->add_flag("--deterministic", ra.deterministic,
                     "the same output at every thread count (deterministic rounds)");
    remesh->add_flag("--json", ra.as_json, "print one JSON object instead of text");
    remesh->add_option("--backend", ra.backend, "connectivity backend: indexed or corner-table")
        ->check(CLI::IsMember(backend_names))
        ->capture_default_str();
    remesh->add_flag("--ascii", ra.ascii, "write PLY and STL as text instead of binary");
    remesh->add_flag("--drop-attributes", ra.drop_attributes,
                     "do not read, carry or write the file's attributes (UVs, normals, colours, "
                     "tags)");

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
        return is_tet_path(in) ? run_tet_info(in, as_json)
                               : run_info(in, as_json, self_intersections);
    if (remesh->parsed())
        return with_backend(
            ra.backend, [&]<class Mesh>(std::type_identity<Mesh>) { return run_remesh<Mesh>(ra); });
    if (harmonic->parsed()) return run_harmonic(ha);
    if (tetmesh->parsed()) return run_tetmesh(ta);
    if (decimate->parsed())
        return with_backend(backend, [&]<class Mesh>(std::type_identity<Mesh>) {
            return run_decimate<Mesh>(
                in, out, algorithm, ratio_opt->count() > 0 ? std::optional(ratio) : std::nullopt,
                target_faces, threads, as_json, ascii, backend, deterministic, keeping);
        });
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
