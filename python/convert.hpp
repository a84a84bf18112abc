// NumPy arrays and Python dicts to and from the tool's surfaces and volumes: what the
// module's functions take and return. Arrays are checked (dtype, shape, index range) and
// refused with ValueError naming the argument; nothing here runs without the GIL.
//
// A surface is (vertices (n, 3) float64, faces (m, 3) int64, attributes); a volume the
// same with tets (m, 4). attributes is a dict: name -> {"domain": "vertex" | "face" |
// "corner", "values": array, "labels": [str, ...] (tag columns only)}, the array's dtype
// the column's type (int8 ... float64) and its rows the vertices, faces, or corners (three
// per face, in the face's corner order); one value per row is a 1-D array, more a 2-D one.
// Lines a writer repeats (OBJ mtllib) are {"domain": "file", "lines": [...]} under
// "header_lines". A volume has "tag" (the tets' physical tags, int32, domain "tet"), tet
// and vertex fields (float64) and "triangles" stored with the tets ({"domain": "triangles",
// "values": (k, 3)[, "tags"]}). A name used in two domains is keyed "domain:name", with its
// "name" in the entry.
#pragma once

#include <idas/io/surface.hpp>
#include <idas/io/volume.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace idas::python {

namespace py = pybind11;

[[noreturn]] inline void refuse(const std::string& what) {
    throw py::value_error(what);
}

/// A C-contiguous copy (or view) of `a` with dtype T, after checking that its kind fits.
template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> as_array(const py::handle& a,
                                                                   const char* name) {
    const py::array arr = py::array::ensure(a);
    if (!arr) refuse(std::string(name) + " must be a NumPy array (or convertible to one)");
    const char kind = arr.dtype().kind();
    if constexpr (std::is_floating_point_v<T>) {
        if (kind != 'f' && kind != 'i' && kind != 'u')
            refuse(std::string(name) + " must hold numbers (got dtype " +
                   std::string(py::str(arr.dtype())) + ")");
    } else if (kind != 'i' && kind != 'u') {
        refuse(std::string(name) + " must hold integers (got dtype " +
               std::string(py::str(arr.dtype())) + ")");
    }
    return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(arr);
}

inline std::string shape_of(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

inline std::vector<vec3> vertices_from(const py::handle& h) {
    const auto a = as_array<double>(h, "vertices");
    if (a.ndim() != 2 || a.shape(1) != 3)
        refuse("vertices must have shape (n, 3), got " + shape_of(a));
    std::vector<vec3> v(static_cast<std::size_t>(a.shape(0)));
    const double* p = a.data();
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
    return v;
}

/// Rows of N distinct vertex indices below `vertex_count`.
template <std::size_t N>
std::vector<std::array<index_t, N>> cells_from(const py::handle& h, std::size_t vertex_count,
                                               const char* name) {
    const auto a = as_array<std::int64_t>(h, name);
    if (a.ndim() != 2 || a.shape(1) != py::ssize_t(N))
        refuse(std::string(name) + " must have shape (m, " + std::to_string(N) + "), got " +
               shape_of(a));
    std::vector<std::array<index_t, N>> cells(static_cast<std::size_t>(a.shape(0)));
    const std::int64_t* p = a.data();
    for (std::size_t c = 0; c < cells.size(); ++c)
        for (std::size_t k = 0; k < N; ++k) {
            const std::int64_t x = p[N * c + k];
            if (x < 0 || std::uint64_t(x) >= vertex_count)
                refuse(std::string(name) + "[" + std::to_string(c) + "] references vertex " +
                       std::to_string(x) + " but there are " + std::to_string(vertex_count) +
                       " vertices");
            cells[c][k] = index_t(x);
            for (std::size_t j = 0; j < k; ++j)
                if (cells[c][j] == cells[c][k])
                    refuse(std::string(name) + "[" + std::to_string(c) + "] repeats vertex " +
                           std::to_string(x));
        }
    return cells;
}

/// (n, 3) float64.
inline py::array_t<double> vertices_to(const std::vector<vec3>& v) {
    py::array_t<double> a({py::ssize_t(v.size()), py::ssize_t(3)});
    double* p = a.mutable_data();
    for (std::size_t i = 0; i < v.size(); ++i)
        p[3 * i] = v[i].x, p[3 * i + 1] = v[i].y, p[3 * i + 2] = v[i].z;
    return a;
}

/// (m, N) int64.
template <std::size_t N>
py::array_t<std::int64_t> cells_to(const std::vector<std::array<index_t, N>>& cells) {
    py::array_t<std::int64_t> a({py::ssize_t(cells.size()), py::ssize_t(N)});
    std::int64_t* p = a.mutable_data();
    for (std::size_t c = 0; c < cells.size(); ++c)
        for (std::size_t k = 0; k < N; ++k) p[N * c + k] = cells[c][k];
    return a;
}

// ---- attribute columns ---------------------------------------------------------------------

inline std::optional<io::scalar_type> scalar_type_of(const py::dtype& d) {
    using io::scalar_type;
    const char kind = d.kind();
    const auto size = d.itemsize();
    if (kind == 'i' && size == 1) return scalar_type::int8;
    if (kind == 'u' && size == 1) return scalar_type::uint8;
    if (kind == 'i' && size == 2) return scalar_type::int16;
    if (kind == 'u' && size == 2) return scalar_type::uint16;
    if (kind == 'i' && size == 4) return scalar_type::int32;
    if (kind == 'u' && size == 4) return scalar_type::uint32;
    if (kind == 'f' && size == 4) return scalar_type::float32;
    if (kind == 'f' && size == 8) return scalar_type::float64;
    return std::nullopt;
}

inline py::dtype dtype_of(io::scalar_type t) {
    return py::dtype(io::to_string(t)); // the names are NumPy's
}

/// A column's values as an array of its own dtype: (rows,) or (rows, width).
inline py::array column_values(const io::attribute_column& a) {
    const auto rows = py::ssize_t(a.elements());
    std::vector<py::ssize_t> shape{rows};
    if (a.width != 1) shape.push_back(py::ssize_t(a.width));
    py::array_t<double> doubles(shape);
    double* p = doubles.mutable_data();
    // Stored values are representable in their type (NaN only in float columns), so the
    // cast below is exact.
    for (std::size_t i = 0; i < a.values.size(); ++i) p[i] = io::representable(a.type, a.values[i]);
    return doubles.attr("astype")(dtype_of(a.type));
}

/// One column from a dict entry {"domain", "values"[, "labels"][, "name"]}.
inline io::attribute_column column_from(const std::string& key, const py::handle& entry,
                                        std::size_t vertex_count, std::size_t face_count) {
    const std::string where = "attributes['" + key + "']";
    if (!py::isinstance<py::dict>(entry))
        refuse(where + " must be a dict with \"domain\" and \"values\"");
    const auto d = py::reinterpret_borrow<py::dict>(entry);
    io::attribute_column a;
    a.name = d.contains("name") ? py::str(d["name"]).cast<std::string>() : key;
    if (!d.contains("domain") || !d.contains("values"))
        refuse(where + " must have \"domain\" and \"values\"");
    const std::string domain = py::str(d["domain"]);
    std::size_t rows = 0;
    if (domain == "vertex")
        a.domain = io::attribute_domain::vertex, rows = vertex_count;
    else if (domain == "face")
        a.domain = io::attribute_domain::face, rows = face_count;
    else if (domain == "corner")
        a.domain = io::attribute_domain::corner, rows = 3 * face_count;
    else
        refuse(where + ": domain must be \"vertex\", \"face\" or \"corner\" (got \"" + domain +
               "\")");
    const py::array values = py::array::ensure(d["values"]);
    if (!values) refuse(where + ": values must be a NumPy array");
    const auto type = scalar_type_of(values.dtype());
    if (!type)
        refuse(where + ": values have dtype " + std::string(py::str(values.dtype())) +
               "; an attribute is int8, uint8, int16, uint16, int32, uint32, float32 or float64");
    a.type = *type;
    if (values.ndim() < 1 || values.ndim() > 2 || values.shape(0) != py::ssize_t(rows) ||
        (values.ndim() == 2 && values.shape(1) < 1))
        refuse(where + ": a " + domain + " attribute needs " + std::to_string(rows) +
               " rows (shape (" + std::to_string(rows) + ",) or (" + std::to_string(rows) +
               ", width)), got " + shape_of(values));
    a.width = values.ndim() == 2 ? std::uint32_t(values.shape(1)) : 1;
    const auto doubles = as_array<double>(values, where.c_str());
    a.values.assign(doubles.data(), doubles.data() + doubles.size());
    if (d.contains("labels")) {
        a.labels = d["labels"].cast<std::vector<std::string>>();
        if (a.domain != io::attribute_domain::face || a.width != 1 ||
            (a.type != io::scalar_type::uint8 && a.type != io::scalar_type::uint16 &&
             a.type != io::scalar_type::uint32))
            refuse(where + ": labels name the values of a face tag column (one unsigned "
                           "integer per face)");
    }
    return a;
}

/// Entries of an attributes dict, keyed by name, or by "domain:name" (with a "name" entry)
/// where one name stands in several domains.
class keyed_entries {
public:
    void add(const std::string& name, const char* domain, py::dict entry) {
        entries_.push_back({name, domain, std::move(entry)});
    }
    py::dict to_dict() const {
        std::map<std::string, int> uses;
        for (const auto& e : entries_) ++uses[e.name];
        py::dict out;
        for (const auto& e : entries_) {
            py::dict entry = e.entry;
            entry["domain"] = e.domain;
            std::string key = e.name;
            if (uses[e.name] > 1) {
                key = e.domain + ":" + e.name;
                entry["name"] = e.name;
            }
            out[py::str(key)] = entry;
        }
        return out;
    }

private:
    struct keyed {
        std::string name, domain;
        py::dict entry;
    };
    std::vector<keyed> entries_;
};

inline py::dict values_entry(const py::object& values) {
    py::dict entry;
    entry["values"] = values;
    return entry;
}

/// The attributes dict of a surface (see the top of this file).
inline py::dict attributes_to(const io::surface& s) {
    keyed_entries out;
    for (const auto& a : s.attributes) {
        py::dict entry = values_entry(column_values(a));
        if (!a.labels.empty()) entry["labels"] = a.labels;
        out.add(a.name, io::to_string(a.domain), entry);
    }
    if (!s.header_lines.empty()) {
        py::dict entry;
        entry["lines"] = s.header_lines;
        out.add("header_lines", "file", entry);
    }
    return out.to_dict();
}

/// The domain of an attributes dict entry; refuses anything but a dict with one.
inline std::string domain_of(const std::string& key, const py::handle& entry) {
    if (!py::isinstance<py::dict>(entry) || !entry.contains("domain"))
        refuse("attributes['" + key + "'] must be a dict with \"domain\" and \"values\"");
    return py::str(entry["domain"]);
}

/// A surface from arrays and an attributes dict (or None).
inline io::surface surface_from(const py::handle& vertices, const py::handle& faces,
                                const py::handle& attributes) {
    io::surface s;
    s.vertices = vertices_from(vertices);
    s.faces = cells_from<3>(faces, s.vertices.size(), "faces");
    if (attributes.is_none()) return s;
    if (!py::isinstance<py::dict>(attributes)) refuse("attributes must be a dict or None");
    for (const auto& [k, entry] : py::reinterpret_borrow<py::dict>(attributes)) {
        const std::string key = py::str(k);
        if (domain_of(key, entry) == "file") {
            if (!entry.contains("lines"))
                refuse("attributes['" + key + "']: a file entry needs \"lines\"");
            const auto lines = entry["lines"].cast<std::vector<std::string>>();
            s.header_lines.insert(s.header_lines.end(), lines.begin(), lines.end());
            continue;
        }
        s.attributes.push_back(column_from(key, entry, s.vertices.size(), s.faces.size()));
    }
    return s;
}

inline py::tuple surface_to(const io::surface& s) {
    return py::make_tuple(vertices_to(s.vertices), cells_to(s.faces), attributes_to(s));
}

// ---- volumes -------------------------------------------------------------------------------

inline py::array_t<std::int32_t> tags_to(const std::vector<int>& tags) {
    py::array_t<std::int32_t> a(py::ssize_t(tags.size()));
    std::copy(tags.begin(), tags.end(), a.mutable_data());
    return a;
}

/// Positive 32-bit tags, one per element (MSH physical tags).
inline std::vector<int> tags_from(const py::handle& h, std::size_t count,
                                  const std::string& where) {
    const auto a = as_array<std::int64_t>(h, where.c_str());
    if (a.ndim() != 1 || a.shape(0) != py::ssize_t(count))
        refuse(where + ": tags need shape (" + std::to_string(count) + ",), got " + shape_of(a));
    std::vector<int> tags(count);
    for (std::size_t t = 0; t < count; ++t) {
        if (a.data()[t] <= 0 || a.data()[t] > INT32_MAX)
            refuse(where + ": tags must be positive 32-bit integers (MSH physical tags)");
        tags[t] = int(a.data()[t]);
    }
    return tags;
}

/// A volume's attributes: "tag" (tets' physical tags, int32), tet fields ($ElementData)
/// and vertex fields ($NodeData) as float64 columns, and "triangles" stored with the tets
/// ({"domain": "triangles", "values": (k, 3) int64[, "tags": int32]}).
inline py::dict volume_attributes_to(const io::volume& v) {
    keyed_entries out;
    if (!v.tags.empty()) out.add("tag", "tet", values_entry(tags_to(v.tags)));
    const auto fields = [&](const std::vector<io::field>& list, const char* domain) {
        for (const auto& f : list) {
            io::attribute_column a;
            a.width = std::uint32_t(f.components);
            a.values = f.values;
            out.add(f.name, domain, values_entry(column_values(a)));
        }
    };
    fields(v.tet_fields, "tet");
    fields(v.vertex_fields, "vertex");
    if (!v.triangles.empty()) {
        py::dict entry = values_entry(cells_to(v.triangles));
        if (!v.triangle_tags.empty()) entry["tags"] = tags_to(v.triangle_tags);
        out.add("triangles", "triangles", entry);
    }
    return out.to_dict();
}

inline py::tuple volume_to(const io::volume& v) {
    return py::make_tuple(vertices_to(v.vertices), cells_to(v.tets), volume_attributes_to(v));
}

/// A field ($NodeData, $ElementData): numbers, (rows,) or (rows, components).
inline io::field field_from(const std::string& where, const std::string& name,
                            const py::handle& values, std::size_t rows) {
    const auto a = as_array<double>(values, where.c_str());
    if (a.ndim() < 1 || a.ndim() > 2 || a.shape(0) != py::ssize_t(rows) ||
        (a.ndim() == 2 && a.shape(1) < 1))
        refuse(where + ": a field needs shape (" + std::to_string(rows) + ",) or (" +
               std::to_string(rows) + ", components), got " + shape_of(a));
    return {name, a.ndim() == 2 ? int(a.shape(1)) : 1, {a.data(), a.data() + a.size()}};
}

/// A volume from arrays and an attributes dict as volume_attributes_to makes them (the
/// "tet" entry named "tag" holds the physical tags, other "tet" entries are fields).
inline io::volume volume_from(const py::handle& vertices, const py::handle& tets,
                              const py::handle& attributes) {
    io::volume v;
    v.vertices = vertices_from(vertices);
    v.tets = cells_from<4>(tets, v.vertices.size(), "tets");
    if (attributes.is_none()) return v;
    if (!py::isinstance<py::dict>(attributes)) refuse("attributes must be a dict or None");
    for (const auto& [k, entry] : py::reinterpret_borrow<py::dict>(attributes)) {
        const std::string key = py::str(k), where = "attributes['" + key + "']";
        const std::string domain = domain_of(key, entry);
        if (!entry.contains("values")) refuse(where + " must have \"values\"");
        const std::string name = entry.contains("name") ? std::string(py::str(entry["name"])) : key;
        if (domain == "tet" && name == "tag") {
            v.tags = tags_from(entry["values"], v.tets.size(), where);
        } else if (domain == "tet" || domain == "vertex") {
            const bool tet = domain == "tet";
            (tet ? v.tet_fields : v.vertex_fields)
                .push_back(field_from(where, name, entry["values"],
                                      tet ? v.tets.size() : v.vertices.size()));
        } else if (domain == "triangles") {
            v.triangles = cells_from<3>(entry["values"], v.vertices.size(), where.c_str());
            if (entry.contains("tags"))
                v.triangle_tags = tags_from(entry["tags"], v.triangles.size(), where + "[tags]");
        } else {
            refuse(where +
                   ": a tet mesh has \"tet\" tags and fields, \"vertex\" fields and "
                   "\"triangles\" (got \"" +
                   domain + "\")");
        }
    }
    return v;
}

} // namespace idas::python
