// The Python module `idas`: the tool's commands (examples/tool/) on NumPy arrays. Reading,
// writing and every algorithm run with the GIL released; bad input raises idas.InputError
// (a ValueError) naming the file or argument, as the tool's exit-2 messages do.
//
//   idas.read(path) -> (vertices, faces or tets, attributes)
//   idas.write(path, vertices, faces or tets, attributes=None, *, ascii, msh_version)
//   idas.info(path or vertices, faces or tets=None, attributes=None, *, self_intersections)
//   idas.decimate / remesh (surface_algorithms.cpp), harmonic / tetmesh (tet_algorithms.cpp)
#include "module.hpp"

#include "tool/surface_stats.hpp"
#include "tool/tet_stats.hpp"

#include <idas/io/msh.hpp>

#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <regex>
#include <string>

namespace idas::python {
namespace {

/// The tool's messages name its options (--edge-length); Python callers know keywords.
std::string python_message(const std::string& message) {
    static const std::regex option(R"((^|[\s(])--([a-z][a-z-]*))");
    std::string out;
    auto last = message.cbegin();
    for (std::sregex_iterator it(message.begin(), message.end(), option), end; it != end; ++it) {
        const auto& match = *it;
        out.append(last, match[0].first).append(match[1].str());
        std::string name = match[2].str();
        for (char& c : name) c = c == '-' ? '_' : c;
        out += name == "faces" ? "target_faces" : name;
        last = match[0].second;
    }
    return out.append(last, message.cend());
}

std::string path_string(const std::filesystem::path& path) {
    return path.string();
}

void warn(const std::string& message) {
    if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0) throw py::error_already_set();
}

py::tuple read(const std::filesystem::path& file, bool attributes) {
    const std::string path = path_string(file);
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) {
        PyErr_SetString(PyExc_FileNotFoundError, (path + ": no such file").c_str());
        throw py::error_already_set();
    }
    if (tool::is_tet_path(path)) {
        io::volume v;
        {
            py::gil_scoped_release nogil;
            v = tool::load_tets(path);
        }
        return volume_to(v);
    }
    io::surface s;
    {
        py::gil_scoped_release nogil;
        s = tool::read_usable(path, attributes);
    }
    if (s.dropped_faces > 0) warn(tool::dropped_faces_warning(path, s.dropped_faces));
    return surface_to(s);
}

void write(const std::filesystem::path& file, const py::object& vertices, const py::object& cells,
           const py::object& attributes, bool ascii, const std::string& msh_version) {
    const std::string path = path_string(file);
    const auto enc = ascii ? io::encoding::ascii : io::encoding::binary;
    if (tool::is_tet_path(path)) {
        if (msh_version != "2.2" && msh_version != "4.1")
            refuse("msh_version must be \"2.2\" or \"4.1\" (got \"" + msh_version + "\")");
        const io::volume v = volume_from(vertices, cells, attributes);
        if (!tool::is_vtu_path(path)) {
            py::gil_scoped_release nogil;
            io::write_msh(
                path, v, msh_version == "4.1" ? io::msh_version::v4_1 : io::msh_version::v2_2, enc);
            return;
        }
        // VTU holds the vertex fields, as `idas convert` writes it.
        std::vector<std::string> lost;
        if (!v.tags.empty()) lost.push_back("tag (tet)");
        for (const auto& f : v.tet_fields) lost.push_back(f.name + " (tet)");
        if (!v.triangles.empty()) lost.push_back("triangles");
        {
            py::gil_scoped_release nogil;
            tool::write_vtu_file(path, v, enc);
        }
        if (!lost.empty()) warn(tool::unstored_warning(path, lost));
        return;
    }
    io::format_of(path); // an unknown extension fails before any conversion
    const io::surface s = surface_from(vertices, cells, attributes);
    std::vector<std::string> lost;
    {
        py::gil_scoped_release nogil;
        lost = tool::write_surface_file(path, s, ascii);
    }
    if (!lost.empty()) warn(tool::unstored_warning(path, lost));
}

/// `idas info --json` of a mesh file or arrays, without the times.
py::object info(const py::object& mesh, const py::object& cells, const py::object& attributes,
                bool self_intersections) {
    std::string file;
    const bool arrays = !cells.is_none();
    if (!arrays) file = path_string(mesh.cast<std::filesystem::path>());
    bool tets = tool::is_tet_path(file); // by the extension, as the tool; arrays by shape
    if (arrays) {
        const py::array a = py::array::ensure(cells);
        tets = a && a.ndim() == 2 && a.shape(1) == 4;
    }
    std::string text;
    if (tets) {
        io::volume v;
        if (arrays) {
            v = volume_from(mesh, cells, attributes);
            if (v.tets.empty()) refuse("tets is empty: there is no tet to work on");
            if (const auto problem = idas::check_geometry_range(v.vertices))
                refuse("vertices: " + *problem);
        }
        py::gil_scoped_release nogil;
        if (!arrays) v = tool::load_tets(file);
        tool::json j;
        j["file"] = file;
        j.update(tool::tet_stats_json(tool::compute_tet_stats(v)));
        text = j.dump();
    } else {
        io::surface s;
        if (arrays) {
            s = surface_from(mesh, cells, attributes);
            check_input_surface(s);
        }
        py::gil_scoped_release nogil;
        if (!arrays) s = tool::read_usable(file);
        tool::phase_times phases;
        const tool::surface_info result = tool::inspect_surface(s, self_intersections, phases);
        text = tool::surface_info_json(file, s, result).dump();
    }
    py::dict d = py::module_::import("json").attr("loads")(text);
    if (arrays) d["file"] = py::none();
    return d;
}

} // namespace

void check_input_surface(const io::surface& s) {
    if (s.faces.empty()) refuse("faces is empty: there is no triangle to work on");
    if (const auto problem = idas::check_geometry_range(s.vertices))
        refuse("vertices: " + *problem);
}

void bind_io(py::module_& m) {
    m.def("read", &read, py::arg("path"), py::arg("attributes") = true,
          R"(Reads a mesh file: (vertices (n, 3) float64, faces (m, 3) int64, attributes).

.obj, .off, .ply, .stl are triangle surfaces; .msh files tet meshes, returned as
(vertices, tets (m, 4) int64, attributes) with "tag" (MSH physical tags) and $NodeData
fields. attributes=False skips a surface file's attributes. Refuses (idas.InputError) what
the idas tool refuses: unreadable files, no triangles, coordinates beyond 1e50.)");
    m.def("write", &write, py::arg("path"), py::arg("vertices"), py::arg("faces"),
          py::arg("attributes") = py::none(), py::kw_only(), py::arg("ascii") = false,
          py::arg("msh_version") = "4.1",
          R"(Writes a mesh file; the extension picks the format (as `idas convert`).

faces is (m, 3) for a surface, (m, 4) tets for .msh and .vtu. PLY, STL and MSH are binary
unless ascii=True. Attributes the format cannot store are left out with a warning.)");
    m.def("info", &info, py::arg("mesh"), py::arg("faces") = py::none(),
          py::arg("attributes") = py::none(), py::kw_only(), py::arg("self_intersections") = false,
          R"(Statistics and topology of a mesh: what `idas info --json` prints, without times.

mesh is a file path (.msh: a tet mesh), or the vertices array with faces (m, 3) or tets
(m, 4) (and attributes) given. self_intersections: count the face pairs of a surface that
meet (exact).)");
}

} // namespace idas::python

PYBIND11_MODULE(idas, m) {
    namespace py = pybind11;
    m.doc() = "idas: declarative, parallel editing of triangle and tetrahedral meshes. The idas "
              "tool's commands on NumPy arrays, with the GIL released while they run.";
    m.attr("__version__") = IDAS_VERSION_STRING;
    static py::exception<idas::input_error> input_error(m, "InputError", PyExc_ValueError);
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const idas::input_error& e) {
            input_error(idas::python::python_message(e.what()).c_str());
        }
    });
    idas::python::bind_io(m);
    idas::python::bind_surface_algorithms(m);
    idas::python::bind_tet_algorithms(m);
}
