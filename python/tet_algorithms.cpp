// idas.harmonic and idas.tetmesh: `idas harmonic` and `idas tetmesh` (tool/harmonic.hpp,
// tool/tetmesh.hpp) on arrays, with the same options, defaults and checks. Both need CGAL
// (IDAS_CLI_HAVE_CGAL); without it they raise idas.InputError.
#include "module.hpp"

#include "tool/harmonic.hpp"
#include "tool/tetmesh.hpp"

#include <pybind11/stl/filesystem.h>

#include <filesystem>

#include <optional>
#include <string>
#include <variant>

namespace idas::python {
namespace {

py::tuple harmonic(const py::object& points, const std::string& mode, unsigned threads,
                   unsigned rounds, bool deterministic, const std::string& backend) {
    tool::harmonic_options o;
    o.mode = mode, o.threads = threads, o.rounds = rounds, o.deterministic = deterministic;
    o.backend = backend;
    tool::check_harmonic_options(o);
    const std::vector<vec3> p = vertices_from(points);
    if (p.size() < 4) refuse("points: a tet mesh needs at least 4 points");
#if IDAS_CLI_HAVE_CGAL
    const tool::harmonic_result r = without_gil(threads, [&](tool::phase_times& phases) {
        return tool::harmonic_volume(p, "points", o, phases, nullptr);
    });
    return volume_to(r.mesh);
#else
    throw idas::input_error("idas.harmonic needs a build with CGAL (for the Delaunay input)");
#endif
}

py::tuple tetmesh(const py::object& vertices, const py::object& faces, double epsilon,
                  double edge_length, bool absolute,
                  std::optional<std::variant<double, std::filesystem::path>> sizing,
                  double stop_energy, unsigned max_iterations, bool keep_outside, bool simplify,
                  unsigned threads, bool deterministic) {
    tool::tetmesh_options o;
    o.epsilon = epsilon, o.edge_length = edge_length, o.absolute = absolute;
    o.stop_energy = stop_energy, o.max_iterations = max_iterations;
    o.keep_outside = keep_outside, o.no_simplify = !simplify, o.threads = threads;
    o.deterministic = deterministic;
    if (sizing) {
        // A number goes as its shortest round-trip text, which the tool parses back exactly.
        if (const double* x = std::get_if<double>(&*sizing))
            o.sizing = py::repr(py::float_(*x)).cast<std::string>();
        else
            o.sizing = std::get<std::filesystem::path>(*sizing).string();
    }
    const std::optional<double> constant_sizing = tool::check_tetmesh_options(o);
    const io::surface s = surface_from(vertices, faces, py::none());
    check_input_surface(s);
#if IDAS_CLI_HAVE_CGAL
    const tool::tetmeshed r = without_gil(threads, [&](tool::phase_times&) {
        const tool::tetmesh_setup setup = tool::prepare_tetmesh(o, s, constant_sizing);
        return tool::tetmesh_volume(s, "mesh", o, setup, nullptr);
    });
    return volume_to(r.mesh);
#else
    (void)constant_sizing;
    throw idas::input_error("idas.tetmesh needs a build with CGAL (Delaunay background mesh)");
#endif
}

} // namespace

void bind_tet_algorithms(py::module_& m) {
    const tool::harmonic_options h;
    m.def("harmonic", &harmonic, py::arg("points"), py::kw_only(), py::arg("mode") = h.mode,
          py::arg("threads") = h.threads, py::arg("rounds") = h.rounds,
          py::arg("deterministic") = h.deterministic, py::arg("backend") = h.backend,
          R"(Harmonic triangulation of points (n, 3) as `idas harmonic`: returns
(vertices, tets, attributes).

mode: "complete" (2-3, 3-2, 4-4 swaps and smoothing, `rounds` rounds) or "reduced" (3-2
swaps only); backend: "indexed" or "adjacency". Duplicate points are dropped. The GIL is
released while it runs.)");
    const tool::tetmesh_options t;
    m.def("tetmesh", &tetmesh, py::arg("vertices"), py::arg("faces"), py::kw_only(),
          py::arg("epsilon") = t.epsilon, py::arg("edge_length") = t.edge_length,
          py::arg("absolute") = t.absolute, py::arg("sizing") = py::none(),
          py::arg("stop_energy") = t.stop_energy, py::arg("max_iterations") = t.max_iterations,
          py::arg("keep_outside") = t.keep_outside, py::arg("simplify") = !t.no_simplify,
          py::arg("threads") = t.threads, py::arg("deterministic") = t.deterministic,
          R"(Tet mesh of a triangle soup as `idas tetmesh`: returns (vertices, tets,
attributes), attributes["tag"] 1 inside and 2 outside.

epsilon: envelope half-width and edge_length: target length, both relative to the
diagonal unless absolute=True; sizing: a constant length or a .msh sizing mesh;
stop_energy, max_iterations: when the optimization stops; keep_outside: every tet, not
only the inside; simplify=False inserts every input triangle as it is; deterministic=True:
the same mesh at any thread count. The GIL is released while it runs.)");
}

} // namespace idas::python
