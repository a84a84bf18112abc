// idas.decimate and idas.remesh: `idas decimate` and `idas remesh` (tool/decimate.hpp,
// tool/remesh.hpp) on arrays, with the same options, defaults and checks, so the same
// input and options give the same mesh as the tool (with deterministic=True, or on one
// thread, the same file).
#include "module.hpp"

#include "tool/decimate.hpp"
#include "tool/remesh.hpp"

#include <optional>
#include <string>

namespace idas::python {
namespace {

/// The arrays as a surface the tool would take, then edit(surface, phases) without the GIL
/// (the tool library's run, on the backend its options name); returns its result.
template <class Edit>
py::tuple edit_surface(const py::object& vertices, const py::object& faces,
                       const py::object& attributes, unsigned threads, Edit&& edit) {
    const io::surface s = surface_from(vertices, faces, attributes);
    check_input_surface(s);
    const io::surface result =
        without_gil(threads, [&](tool::phase_times& phases) { return edit(s, phases); });
    return surface_to(result);
}

py::tuple decimate(const py::object& vertices, const py::object& faces,
                   const py::object& attributes, std::optional<double> ratio,
                   std::optional<std::int64_t> target_faces, const std::string& algorithm,
                   unsigned threads, bool deterministic, bool keep_boundary,
                   std::optional<double> feature_angle, bool allow_self_intersections,
                   const std::string& backend, std::optional<double> attribute_weight) {
    if (ratio.has_value() == target_faces.has_value())
        refuse("give exactly one of ratio or target_faces");
    tool::decimate_options o;
    o.algorithm = algorithm, o.ratio = ratio, o.faces = target_faces.value_or(-1);
    o.threads = threads, o.deterministic = deterministic, o.keep_boundary = keep_boundary;
    o.feature_angle = feature_angle, o.allow_self_intersections = allow_self_intersections;
    o.backend = backend, o.attribute_weight = attribute_weight;
    tool::check_decimate_options(o);
    return edit_surface(vertices, faces, attributes, threads,
                        [&](const io::surface& s, tool::phase_times& phases) {
                            return tool::decimate_surface(s, "mesh", o, phases, nullptr).mesh;
                        });
}

py::tuple remesh(const py::object& vertices, const py::object& faces, const py::object& attributes,
                 double edge_length, bool absolute, unsigned iterations, unsigned threads,
                 bool deterministic, std::optional<double> envelope,
                 std::optional<double> feature_angle, bool keep_boundary,
                 bool allow_self_intersections, const std::string& backend,
                 std::uint64_t max_faces) {
    tool::remesh_options o;
    o.edge_length = edge_length, o.absolute = absolute, o.iterations = iterations;
    o.threads = threads, o.deterministic = deterministic, o.envelope = envelope;
    o.feature_angle = feature_angle, o.keep_boundary = keep_boundary;
    o.allow_self_intersections = allow_self_intersections, o.backend = backend;
    o.max_faces = max_faces;
    tool::check_remesh_options(o);
    return edit_surface(vertices, faces, attributes, threads,
                        [&](const io::surface& s, tool::phase_times& phases) {
                            return tool::remesh_surface(s, "mesh", o, phases, nullptr).mesh;
                        });
}

} // namespace

void bind_surface_algorithms(py::module_& m) {
    const tool::decimate_options d;
    m.def("decimate", &decimate, py::arg("vertices"), py::arg("faces"),
          py::arg("attributes") = py::none(), py::kw_only(), py::arg("ratio") = py::none(),
          py::arg("target_faces") = py::none(), py::arg("algorithm") = d.algorithm,
          py::arg("threads") = d.threads, py::arg("deterministic") = d.deterministic,
          py::arg("keep_boundary") = d.keep_boundary, py::arg("feature_angle") = py::none(),
          py::arg("allow_self_intersections") = d.allow_self_intersections,
          py::arg("backend") = d.backend, py::arg("attribute_weight") = py::none(),
          R"(Decimates a surface as `idas decimate`: returns (vertices, faces, attributes).

Give exactly one of ratio (of the input's faces, in (0, 1]) and target_faces.
algorithm: "qslim" or "shortest-edge"; threads: worker threads (1 to 1024);
deterministic: the same mesh at every thread count; keep_boundary, feature_angle (degrees):
vertices that never move nor vanish; allow_self_intersections: do not refuse collapses that
make faces meet; backend: "indexed" or "corner-table"; attribute_weight (QSlim): how much
texture coordinates, colours and other attributes weigh against the shape (None: the
tool's default, 0: the shape alone). Attributes (see idas.read) are carried through every
collapse. The GIL is released while it runs.)");
    const tool::remesh_options r;
    m.def("remesh", &remesh, py::arg("vertices"), py::arg("faces"),
          py::arg("attributes") = py::none(), py::kw_only(), py::arg("edge_length") = r.edge_length,
          py::arg("absolute") = r.absolute, py::arg("iterations") = r.iterations,
          py::arg("threads") = r.threads, py::arg("deterministic") = r.deterministic,
          py::arg("envelope") = py::none(), py::arg("feature_angle") = py::none(),
          py::arg("keep_boundary") = r.keep_boundary,
          py::arg("allow_self_intersections") = r.allow_self_intersections,
          py::arg("backend") = r.backend, py::arg("max_faces") = r.max_faces,
          R"(Isotropic remeshing as `idas remesh`: returns (vertices, faces, attributes).

edge_length: the target, relative to the bounding-box diagonal unless absolute=True;
envelope: keep every new triangle within this distance (relative) of the input, exactly;
feature_angle: keep edges sharper than this (degrees); keep_boundary=False lets boundary
vertices move; max_faces: refuse a target that would make more faces. The other options
are decimate's. The GIL is released while it runs.)");
}

} // namespace idas::python
