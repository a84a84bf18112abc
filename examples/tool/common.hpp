// What every command of the `idas` tool and the Python module share: thread and range
// checks, reading and writing surfaces, the result check of the editing commands, the
// phase clock, and the carrying of a file's attributes. Both front ends call these, so the
// same options give the same files.
#pragma once

#include <idas/algorithms/attribute_transfer.hpp>
#include <idas/exec/report.hpp>
#include <idas/idas.hpp>
#include <idas/io/io.hpp>
#include <idas/io/msh.hpp>
#include <idas/io/vtu.hpp>
#include <idas/mesh/geometry_range.hpp>
#include <idas/mesh/surface_check.hpp>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace idas::tool {

using json = nlohmann::ordered_json;

// ---- connectivity backends ------------------------------------------------------------------

/// `--backend`: the editing commands (demo, decimate, remesh) run on either triangle backend;
/// each is a separate instantiation of the same code.
inline const std::vector<std::string> backend_names = {"indexed", "corner-table"};

/// Calls fn(std::type_identity<Mesh>{}) with the mesh type the backend name selects.
template <class Fn>
decltype(auto) with_backend(const std::string& backend, Fn&& fn) {
    if (backend == "corner-table")
        return fn(std::type_identity<idas::tri_mesh<idas::backend::corner_table_tri>>{});
    return fn(std::type_identity<idas::tri_mesh<idas::backend::indexed_tri>>{});
}

inline void check_backend(const std::string& backend) {
    if (std::find(backend_names.begin(), backend_names.end(), backend) == backend_names.end())
        throw idas::input_error("--backend must be indexed or corner-table (got '" + backend +
                                "')");
}

/// `--threads` above this is refused: every worker is an OS thread with its own stack and
/// queue, and far more of them than cores only adds contention (tens of thousands made
/// thread creation fail). 1024 is well above the cores of any machine idas runs on.
inline constexpr unsigned max_threads = 1024;

inline void check_threads(unsigned threads) {
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

// ---- progress -------------------------------------------------------------------------------

/// A front end's progress callback: a function pointer and the front end's object. The
/// commands' runs (decimate.cpp, remesh.cpp, harmonic.cpp, tetmesh.cpp) are compiled once,
/// in the library idas_tool, for the tool and the Python module, so they take this rather
/// than the callable's own type. It is called after a phase or every 256th operation,
/// never on an operation's path.
template <class... Args>
class callback {
public:
    callback() = default;
    template <class F>
    requires std::invocable<F&, Args...>
    explicit callback(F& f) noexcept
        : call_([](void* object, Args... args) { (*static_cast<F*>(object))(args...); })
        , object_(const_cast<void*>(static_cast<const void*>(std::addressof(f)))) {}
    explicit operator bool() const noexcept { return call_ != nullptr; }
    void operator()(Args... args) const { call_(object_, args...); }

private:
    void (*call_)(void*, Args...) = nullptr;
    void* object_ = nullptr;
};
/// Decimation: (fraction done, faces left).
using face_progress = callback<double, std::int64_t>;
/// Remeshing and harmonic triangulation: (fraction done, a note on the phase).
using phase_progress = callback<double, const std::string&>;

// ---- input and output ----------------------------------------------------------------------

/// Refuses points outside idas::geometry_range (coordinates that would overflow or
/// underflow lengths and areas), naming the source.
inline void check_range(const std::string& source, const std::vector<vec3>& points) {
    if (const auto problem = idas::check_geometry_range(points))
        throw idas::input_error(source + ": " + *problem);
}

/// The lower-case extension of a path (".msh").
inline std::string lowercase_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    return ext;
}

/// Refuses a surface no command can use: no triangles at all, or coordinates outside the
/// supported range.
inline void check_usable(const std::string& source, const idas::io::surface& s) {
    if (s.faces.empty()) throw idas::input_error(source + ": the file contains no triangles");
    check_range(source, s.vertices);
}

/// Reads a mesh file and refuses what no subcommand can use: no triangles at all, or
/// coordinates outside the supported range.
inline idas::io::surface read_usable(const std::string& path, bool attributes = true) {
    idas::io::read_options options;
    options.attributes = attributes;
    idas::io::surface s = idas::io::read_surface(path, options);
    check_usable(path, s);
    return s;
}

/// What the tool says when STL facets were dropped.
inline std::string dropped_faces_warning(const std::string& path, std::size_t dropped) {
    return path + ": dropped " + std::to_string(dropped) +
           " faces whose corners share a position (STL stores positions only, so they weld "
           "into a degenerate face)";
}

/// read_usable, with warnings on stderr for dropped STL facets and for what the reader
/// read past (PLY lists and elements it cannot keep).
inline idas::io::surface load(const std::string& path, bool attributes = true) {
    idas::io::surface s = read_usable(path, attributes);
    if (s.dropped_faces > 0)
        std::fprintf(stderr, "idas: warning: %s\n",
                     dropped_faces_warning(path, s.dropped_faces).c_str());
    if (!s.skipped.empty()) {
        std::string names;
        for (const auto& n : s.skipped) names += (names.empty() ? "" : ", ") + n;
        std::fprintf(stderr, "idas: warning: %s: not kept (idas cannot hold them): %s\n",
                     path.c_str(), names.c_str());
    }
    return s;
}

/// Builds the editable mesh of `s` into `built`; a refusal (non-manifold, misoriented ...)
/// names `source`.
template <class Mesh>
Mesh& build_mesh(std::optional<Mesh>& built, const idas::io::surface& s,
                 const std::string& source) {
    try {
        built.emplace(s.vertices, s.faces);
    } catch (const idas::input_error& e) {
        throw idas::input_error(source + ": " + e.what());
    }
    return *built;
}

/// Writes a tet mesh as VTU the way `idas convert` does: its vertex fields as point data
/// (NaN where an MSH file gives no value stays NaN).
inline void write_vtu_file(const std::string& path, const idas::io::volume& v,
                           idas::io::encoding enc) {
    idas::io::vtu_options options;
    options.enc = enc;
    for (const auto& f : v.vertex_fields)
        options.point_data.push_back({f.name, f.components, f.values});
    idas::io::write_vtu(path, v, options);
}

/// True for the extensions of tet mesh files (.msh, .vtu; any case).
inline bool is_tet_path(const std::string& path) {
    const std::string ext = lowercase_extension(path);
    return ext == ".msh" || ext == ".vtu";
}

inline bool is_vtu_path(const std::string& path) {
    return lowercase_extension(path) == ".vtu";
}

/// Reads a tet mesh and refuses what no subcommand can use: no tets, or coordinates
/// outside the supported range.
inline idas::io::volume load_tets(const std::string& path) {
    if (is_vtu_path(path))
        throw idas::input_error(path + ": VTU is an output format only; read tets from .msh");
    idas::io::volume v = idas::io::read_msh(path);
    if (v.tets.empty())
        throw idas::input_error(path + ": the file contains no tetrahedra (" +
                                std::to_string(v.skipped_elements) +
                                " other elements skipped; surfaces are read from .obj, .off, "
                                ".ply or .stl)");
    check_range(path, v.vertices);
    return v;
}

/// The result check of the editing commands: what they write must be an oriented
/// 2-manifold with the input's Euler characteristic and boundary loops. A failure is a bug
/// in idas, not in the user's file: exit 1, naming the command and the check.
inline void check_result(const char* command, const idas::surface_summary& input,
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
inline void check_result(const char* command, const idas::surface_summary& input,
                         const idas::io::surface& result) {
    check_result(command, input, idas::summarize_surface(result.vertices.size(), result.faces));
}

/// The same numbers from a full diagnosis, for commands that report statistics anyway
/// (so the result is not walked twice).
inline idas::surface_summary summary_of(const idas::topology_report& t) {
    idas::surface_summary s;
    if (!t.editable()) s.problem = t.problems.empty() ? "not editable" : t.problems.front();
    s.euler_characteristic = t.euler_characteristic;
    s.boundary_edges = t.boundary_edges, s.boundary_loops = t.boundary_loops;
    return s;
}

/// Writes a surface (PLY and STL binary unless `ascii`); returns the names of the
/// attributes the format cannot store, which were not written.
inline std::vector<std::string> write_surface_file(const std::string& path,
                                                   const idas::io::surface& s, bool ascii) {
    idas::io::format_options options;
    options.encoding = ascii ? idas::io::encoding::ascii : idas::io::encoding::binary;
    idas::io::write_surface(path, s, options);
    return idas::io::unstored_attributes(path, s, options);
}

/// "OUT cannot store these attributes, not written: a, b"
inline std::string unstored_warning(const std::string& path, const std::vector<std::string>& lost) {
    std::string names;
    for (const auto& n : lost) names += (names.empty() ? "" : ", ") + n;
    return path + " cannot store these attributes, not written: " + names;
}

/// write_surface_file, with a warning on stderr for attributes not written.
inline void save(const std::string& path, const idas::io::surface& s, bool ascii) {
    // Said after the write, so it is not said when the write fails.
    if (const auto lost = write_surface_file(path, s, ascii); !lost.empty())
        std::fprintf(stderr, "idas: warning: %s\n", unstored_warning(path, lost).c_str());
}

inline json attributes_json(const idas::io::surface& s) {
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

} // namespace idas::tool
