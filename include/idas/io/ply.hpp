// Stanford PLY in its three encodings (ascii, binary_little_endian, binary_big_endian).
// The reader takes x, y, z from the "vertex" element and the "vertex_indices" (or
// "vertex_index") list from the "face" element. Every other scalar property of those two
// elements (normals, colours, quality, custom) becomes a vertex or face attribute of the
// same name and type, and a face's "texcoord" list (u v per corner, as MeshLab writes it)
// the corner attribute "texcoord"; other lists and elements are skipped and named in
// surface::skipped. The writer emits double coordinates, int32 indices and the attributes
// with their types.
#pragma once

#include "idas/io/atomic_file.hpp"
#include "idas/io/surface.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace idas::io {

namespace detail {

// The same numbering as io::scalar_type, so a property's type is the attribute's.
enum class ply_type : std::uint8_t { int8, uint8, int16, uint16, int32, uint32, float32, float64 };
static_assert(static_cast<int>(ply_type::float64) == static_cast<int>(scalar_type::float64));

inline bool parse_ply_type(std::string_view name, ply_type& type) noexcept {
    // PLY has two spellings for every type: the original ("uchar") and sized ("uint8").
    static constexpr struct {
        std::string_view name;
        ply_type type;
    } names[] = {
        {"char", ply_type::int8},      {"int8", ply_type::int8},
        {"uchar", ply_type::uint8},    {"uint8", ply_type::uint8},
        {"short", ply_type::int16},    {"int16", ply_type::int16},
        {"ushort", ply_type::uint16},  {"uint16", ply_type::uint16},
        {"int", ply_type::int32},      {"int32", ply_type::int32},
        {"uint", ply_type::uint32},    {"uint32", ply_type::uint32},
        {"float", ply_type::float32},  {"float32", ply_type::float32},
        {"double", ply_type::float64}, {"float64", ply_type::float64},
    };
    for (const auto& entry : names) {
        if (entry.name == name) {
            type = entry.type;
            return true;
        }
    }
    return false;
}

constexpr std::size_t ply_size(ply_type t) noexcept {
    constexpr std::size_t sizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
    return sizes[static_cast<int>(t)];
}

inline const char* ply_type_name(scalar_type t) noexcept {
    constexpr const char* names[] = {"char", "uchar", "short", "ushort",
                                     "int",  "uint",  "float", "double"};
    return names[static_cast<int>(t)];
}

constexpr bool ply_is_integer(ply_type t) noexcept {
    return t < ply_type::float32;
}

struct ply_property {
    std::string name;
    ply_type type = ply_type::float32; // item type for lists
    bool is_list = false;
    ply_type count_type = ply_type::uint8;
};

struct ply_element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<ply_property> properties;
};

enum class ply_format { ascii, binary_little_endian, binary_big_endian };

struct ply_header {
    ply_format format = ply_format::ascii;
    std::vector<ply_element> elements;
    std::size_t body_offset = 0; // first byte after the "end_header" line
    std::size_t body_line = 1;   // line number of that byte, for ASCII messages
};

inline ply_header parse_ply_header(std::string_view data, std::string_view source) {
    line_reader lines(data);
    std::string_view line;
    const auto fail_here = [&](const std::string& what) {
        fail_at_line(source, lines.line_number(), what);
    };
    if (!lines.next(line) || next_token(line) != "ply" || !next_token(line).empty())
        fail(source, "not a PLY file (the first line is not 'ply')");

    ply_header header;
    bool have_format = false;
    while (lines.next(line)) {
        std::string_view rest = line;
        const std::string_view keyword = next_token(rest);
        if (keyword == "end_header") {
            if (!have_format) fail_here("the header has no 'format' line");
            header.body_offset = lines.position();
            header.body_line = lines.line_number() + 1;
            return header;
        }
        if (keyword == "comment" || keyword == "obj_info" || keyword.empty()) continue;
        if (keyword == "format") {
            const std::string_view name = next_token(rest);
            if (name == "ascii")
                header.format = ply_format::ascii;
            else if (name == "binary_little_endian")
                header.format = ply_format::binary_little_endian;
            else if (name == "binary_big_endian")
                header.format = ply_format::binary_big_endian;
            else
                fail_here("unknown PLY format " + quoted(name));
            if (next_token(rest) != "1.0") fail_here("unsupported PLY version (expected 1.0)");
            have_format = true;
        } else if (keyword == "element") {
            ply_element element;
            element.name = std::string(next_token(rest));
            const std::string_view count = next_token(rest);
            std::int64_t n = 0;
            if (element.name.empty() || !parse_int(count, n) || n < 0 || !next_token(rest).empty())
                fail_here("malformed element line (expected 'element <name> <count>')");
            element.count = static_cast<std::uint64_t>(n);
            header.elements.push_back(std::move(element));
        } else if (keyword == "property") {
            if (header.elements.empty()) fail_here("property declared before any element");
            ply_property property;
            std::string_view type = next_token(rest);
            if (type == "list") {
                property.is_list = true;
                const std::string_view count_type = next_token(rest);
                if (!parse_ply_type(count_type, property.count_type))
                    fail_here("unknown PLY type " + quoted(count_type));
                if (!ply_is_integer(property.count_type))
                    fail_here("list count type " + quoted(count_type) + " is not an integer type");
                type = next_token(rest);
            }
            if (!parse_ply_type(type, property.type)) fail_here("unknown PLY type " + quoted(type));
            property.name = std::string(next_token(rest));
            if (property.name.empty() || !next_token(rest).empty())
                fail_here("malformed property line");
            header.elements.back().properties.push_back(std::move(property));
        } else {
            fail_here("unexpected header line starting with " + quoted(keyword));
        }
    }
    fail(source, "the PLY header has no 'end_header' line");
}

/// Loads a T stored with the given byte order from possibly unaligned memory.
template <class T>
T ply_load(const unsigned char* p, bool swap) noexcept {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, p, sizeof(T));
    if (swap) std::reverse(bytes, bytes + sizeof(T));
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return value;
}

inline double ply_load_double(ply_type t, const unsigned char* p, bool swap) noexcept {
    switch (t) {
    case ply_type::int8:
        return ply_load<std::int8_t>(p, swap);
    case ply_type::uint8:
        return ply_load<std::uint8_t>(p, swap);
    case ply_type::int16:
        return ply_load<std::int16_t>(p, swap);
    case ply_type::uint16:
        return ply_load<std::uint16_t>(p, swap);
    case ply_type::int32:
        return ply_load<std::int32_t>(p, swap);
    case ply_type::uint32:
        return ply_load<std::uint32_t>(p, swap);
    case ply_type::float32:
        return ply_load<float>(p, swap);
    case ply_type::float64:
        return ply_load<double>(p, swap);
    }
    return 0;
}

/// Only for integer types (checked when the header is interpreted).
inline std::int64_t ply_load_int(ply_type t, const unsigned char* p, bool swap) noexcept {
    switch (t) {
    case ply_type::int8:
        return ply_load<std::int8_t>(p, swap);
    case ply_type::uint8:
        return ply_load<std::uint8_t>(p, swap);
    case ply_type::int16:
        return ply_load<std::int16_t>(p, swap);
    case ply_type::uint16:
        return ply_load<std::uint16_t>(p, swap);
    case ply_type::int32:
        return ply_load<std::int32_t>(p, swap);
    case ply_type::uint32:
        return ply_load<std::uint32_t>(p, swap);
    default:
        return 0;
    }
}

inline std::string ply_plural(const ply_element& e) {
    if (e.name == "vertex") return "vertices";
    if (e.name == "face") return "faces";
    return "'" + e.name + "' elements";
}

/// What the reader does with a property: keep it as a coordinate, as the face's corner
/// list, or skip it.
enum class ply_role : std::uint8_t { skip, x, y, z, corners, attribute, texcoord };

/// Reads the element bodies described by the header. The two encodings differ only in how
/// values are fetched; validation and assembly are shared.
class ply_reader {
public:
    ply_reader(std::string_view data, std::string_view source, const read_options& options)
        : data_(data)
        , source_(source)
        , options_(options)
        , header_(parse_ply_header(data, source)) {
        interpret_header();
    }

    surface read() {
        if (header_.format == ply_format::ascii)
            read_ascii();
        else
            read_binary();
        return std::move(surface_);
    }

private:
    void interpret_header() {
        const ply_element* vertex = nullptr;
        for (const ply_element& e : header_.elements) {
            if (e.name == "vertex") {
                if (vertex) fail(source_, "the PLY header declares two vertex elements");
                vertex = &e;
            }
        }
        if (!vertex) fail(source_, "the PLY header declares no vertex element");
        if (vertex->count >= invalid_index)
            fail(source_,
                 "header says " + std::to_string(vertex->count) + " vertices, more than supported");
        vertex_count_ = vertex->count;

        bool face_seen = false;
        for (const ply_element& e : header_.elements) {
            std::vector<ply_role>& roles = roles_.emplace_back(e.properties.size(), ply_role::skip);
            columns_.emplace_back(e.properties.size(), npos);
            if (&e == vertex) {
                const char* axes[3] = {"x", "y", "z"};
                for (int axis = 0; axis < 3; ++axis) {
                    const auto it =
                        std::find_if(e.properties.begin(), e.properties.end(),
                                     [&](const auto& p) { return p.name == axes[axis]; });
                    if (it == e.properties.end() || it->is_list)
                        fail(source_, std::string("the vertex element has no scalar property ") +
                                          axes[axis]);
                    roles[static_cast<std::size_t>(it - e.properties.begin())] =
                        static_cast<ply_role>(static_cast<int>(ply_role::x) + axis);
                }
                add_attribute_roles(e, roles, columns_.back(), attribute_domain::vertex);
            } else if (e.name == "face") {
                if (face_seen) fail(source_, "the PLY header declares two face elements");
                face_seen = true;
                const auto it =
                    std::find_if(e.properties.begin(), e.properties.end(), [](const auto& p) {
                        return p.name == "vertex_indices" || p.name == "vertex_index";
                    });
                if (it == e.properties.end() || !it->is_list)
                    fail(source_, "the face element has no vertex_indices list");
                if (!ply_is_integer(it->type))
                    fail(source_, "the face vertex_indices list does not have an integer type");
                roles[static_cast<std::size_t>(it - e.properties.begin())] = ply_role::corners;
                add_attribute_roles(e, roles, columns_.back(), attribute_domain::face);
            } else if (options_.attributes) {
                surface_.skipped.push_back(e.name + " (PLY element of " + std::to_string(e.count) +
                                           (e.count == 1 ? " item)" : " items)"));
            }
        }
    }

    /// Every other scalar property of the vertex or face element becomes an attribute
    /// column (its index kept in `columns`), and a face texcoord list the corner attribute
    /// "texcoord".
    void add_attribute_roles(const ply_element& e, std::vector<ply_role>& roles,
                             std::vector<std::size_t>& columns, attribute_domain domain) {
        if (!options_.attributes) return;
        bool texcoord_seen = false;
        for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
            const ply_property& p = e.properties[pi];
            if (roles[pi] != ply_role::skip) continue;
            if (!p.is_list) {
                roles[pi] = ply_role::attribute;
                columns[pi] = surface_.attributes.size();
                surface_.attributes.push_back(
                    {p.name, domain, static_cast<scalar_type>(p.type), 1, {}, {}});
            } else if (domain == attribute_domain::face && p.name == "texcoord" &&
                       !ply_is_integer(p.type)) {
                // A face keeps the values of one texcoord list per corner.
                if (texcoord_seen) fail(source_, "the face element has two texcoord lists");
                texcoord_seen = true;
                roles[pi] = ply_role::texcoord;
                columns[pi] = surface_.attributes.size();
                surface_.attributes.push_back({p.name,
                                               attribute_domain::corner,
                                               static_cast<scalar_type>(p.type),
                                               2,
                                               {},
                                               {}});
            } else {
                surface_.skipped.push_back(p.name + " (" + e.name + " list property)");
            }
        }
    }

    bool is_vertex(const ply_element& e) const noexcept { return e.name == "vertex"; }
    bool is_face(const ply_element& e) const noexcept { return e.name == "face"; }

    /// Checks a corner index and appends it to the current polygon.
    template <class Fail>
    void add_corner(std::int64_t index, std::uint64_t face, Fail&& fail_here) {
        if (index < 0 || static_cast<std::uint64_t>(index) >= vertex_count_)
            fail_here("face " + std::to_string(face) + " references vertex " +
                      std::to_string(index) + " but there are only " +
                      std::to_string(vertex_count_) + " vertices");
        poly_.push_back(static_cast<index_t>(index));
    }

    /// Keeps the current instance's value of an attribute column.
    void keep_value(std::size_t column, double value) { pending_.push_back({column, value}); }

    template <class Fail>
    void finish_instance(const ply_element& e, std::uint64_t i, const vec3& p, Fail&& fail_here) {
        if (is_vertex(e)) {
            if (!is_finite(p))
                fail_here("vertex " + std::to_string(i) + " has a non-finite coordinate");
            surface_.vertices.push_back(p);
            for (const auto& [column, value] : pending_)
                surface_.attributes[column].values.push_back(value);
        } else if (is_face(e)) {
            const std::size_t first = surface_.faces.size();
            add_polygon(surface_.faces, poly_, i, options_, 0, fail_here);
            const std::size_t triangles = surface_.faces.size() - first;
            for (const auto& [column, value] : pending_)
                surface_.attributes[column].values.insert(surface_.attributes[column].values.end(),
                                                          triangles, value);
            if (texcoord_column_ != npos) {
                if (texcoords_.size() != 2 * poly_.size())
                    fail_here("face " + std::to_string(i) + " has " +
                              std::to_string(texcoords_.size()) + " texcoord values for " +
                              std::to_string(poly_.size()) + " corners");
                auto& values = surface_.attributes[texcoord_column_].values;
                for (std::size_t k = 1; k + 1 < poly_.size(); ++k)
                    for (std::size_t c : {std::size_t{0}, k, k + 1})
                        values.push_back(texcoords_[2 * c]),
                            values.push_back(texcoords_[2 * c + 1]);
            }
        }
        pending_.clear();
        texcoords_.clear();
        texcoord_column_ = npos;
    }

    /// An attribute value read from text: float32 properties are parsed as float, so
    /// they read back to the same bits as a binary file would give.
    template <class Fail>
    double attribute_from_text(ply_type type, std::string_view token, Fail&& fail_here) {
        double value = 0;
        parse_status status;
        if (type == ply_type::float32) {
            float single = 0;
            status = parse_real(token, single);
            value = single;
        } else {
            status = parse_double(token, value);
        }
        if (status == parse_status::not_a_number) fail_here(quoted(token) + " is not a number");
        // NaN is a float value like any other; every other value must be one of its type's.
        const bool fits = std::isnan(value) ? !ply_is_integer(type)
                                            : representable(scalar_type(type), value) == value;
        if (status == parse_status::out_of_range || !fits)
            fail_here(quoted(token) + " does not fit in a PLY " + ply_type_name(scalar_type(type)));
        return value;
    }

    void reserve(const ply_element& e, std::size_t min_bytes) {
        const std::size_t available = data_.size() - header_.body_offset;
        if (is_vertex(e)) surface_.vertices.reserve(capped_reserve(e.count, available, min_bytes));
        if (is_face(e)) surface_.faces.reserve(capped_reserve(e.count, available, min_bytes));
    }

    void read_binary() {
        const bool swap = (header_.format == ply_format::binary_big_endian) !=
                          (std::endian::native == std::endian::big);
        const auto* const base = reinterpret_cast<const unsigned char*>(data_.data());
        std::size_t pos = header_.body_offset;
        const std::size_t size = data_.size();

        for (std::size_t ei = 0; ei < header_.elements.size(); ++ei) {
            const ply_element& e = header_.elements[ei];
            const std::vector<ply_role>& roles = roles_[ei];
            // An element without properties occupies no bytes, however large its count.
            if (e.properties.empty()) continue;
            std::size_t min_bytes = 0;
            for (const ply_property& p : e.properties)
                min_bytes += p.is_list ? ply_size(p.count_type) : ply_size(p.type);
            reserve(e, min_bytes);

            for (std::uint64_t i = 0; i < e.count; ++i) {
                const auto truncated = [&] {
                    fail(source_, "truncated: header says " + std::to_string(e.count) + " " +
                                      ply_plural(e) + ", found " + std::to_string(i));
                };
                const auto fail_here = [&](const std::string& what) {
                    fail(source_, "byte " + std::to_string(pos) + ": " + what);
                };
                if (size - pos < min_bytes) truncated();
                vec3 point;
                poly_.clear();
                for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
                    const ply_property& prop = e.properties[pi];
                    if (!prop.is_list) {
                        const std::size_t n = ply_size(prop.type);
                        if (size - pos < n) truncated();
                        const ply_role role = roles[pi];
                        if (role >= ply_role::x && role <= ply_role::z)
                            point[static_cast<int>(role) - 1] =
                                ply_load_double(prop.type, base + pos, swap);
                        else if (role == ply_role::attribute)
                            keep_value(columns_[ei][pi],
                                       ply_load_double(prop.type, base + pos, swap));
                        pos += n;
                        continue;
                    }
                    const std::size_t count_size = ply_size(prop.count_type);
                    if (size - pos < count_size) truncated();
                    const std::int64_t length = ply_load_int(prop.count_type, base + pos, swap);
                    if (length < 0)
                        fail_here("negative list length " + std::to_string(length) + " in " +
                                  e.name + " " + std::to_string(i));
                    pos += count_size;
                    const std::size_t item_size = ply_size(prop.type);
                    // Compare by division: length * item_size could overflow.
                    if (static_cast<std::uint64_t>(length) > (size - pos) / item_size) truncated();
                    if (roles[pi] == ply_role::corners) {
                        for (std::int64_t k = 0; k < length; ++k)
                            add_corner(
                                ply_load_int(prop.type,
                                             base + pos + static_cast<std::size_t>(k) * item_size,
                                             swap),
                                i, fail_here);
                    } else if (roles[pi] == ply_role::texcoord) {
                        texcoord_column_ = columns_[ei][pi];
                        for (std::int64_t k = 0; k < length; ++k)
                            texcoords_.push_back(ply_load_double(
                                prop.type, base + pos + static_cast<std::size_t>(k) * item_size,
                                swap));
                    }
                    pos += static_cast<std::size_t>(length) * item_size;
                }
                finish_instance(e, i, point, fail_here);
            }
        }
        if (!is_blank(data_.substr(pos)))
            fail(source_, "the header's element counts leave " + std::to_string(size - pos) +
                              " bytes of data unread at the end of the file");
    }

    void read_ascii() {
        token_reader tokens(data_.substr(header_.body_offset), header_.body_line);
        for (std::size_t ei = 0; ei < header_.elements.size(); ++ei) {
            const ply_element& e = header_.elements[ei];
            const std::vector<ply_role>& roles = roles_[ei];
            if (e.properties.empty()) continue;
            // Every value takes at least one character and one separator.
            reserve(e, 2 * e.properties.size());

            for (std::uint64_t i = 0; i < e.count; ++i) {
                const auto fail_here = [&](const std::string& what) {
                    fail_at_line(source_, tokens.line(), what);
                };
                const auto next = [&] {
                    const std::string_view token = tokens.next();
                    if (token.empty())
                        fail(source_, "truncated: header says " + std::to_string(e.count) + " " +
                                          ply_plural(e) + ", found " + std::to_string(i));
                    return token;
                };
                // Values we skip must still be numbers: that is how garbage gets noticed.
                const auto skip_number = [&](std::string_view token) {
                    double ignored;
                    if (parse_double(token, ignored) == parse_status::not_a_number)
                        fail_here(quoted(token) + " is not a number");
                };
                vec3 point;
                poly_.clear();
                for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
                    const ply_property& prop = e.properties[pi];
                    const ply_role role = roles[pi];
                    std::string_view token = next();
                    if (!prop.is_list) {
                        if (role == ply_role::skip) {
                            skip_number(token);
                            continue;
                        }
                        if (role == ply_role::attribute) {
                            keep_value(columns_[ei][pi],
                                       attribute_from_text(prop.type, token, fail_here));
                            continue;
                        }
                        double& value = point[static_cast<int>(role) - 1];
                        const auto status = parse_double(token, value);
                        if (status == parse_status::not_a_number)
                            fail_here(quoted(token) + " is not a number");
                        if (status == parse_status::out_of_range || !std::isfinite(value))
                            fail_here("vertex " + std::to_string(i) +
                                      " has a non-finite coordinate " + quoted(token));
                        continue;
                    }
                    std::int64_t length = 0;
                    if (!parse_int(token, length) || length < 0)
                        fail_here(quoted(token) + " is not a list length");
                    // Items are consumed one token at a time, so a huge length simply runs
                    // into the end of the data.
                    if (role == ply_role::texcoord) texcoord_column_ = columns_[ei][pi];
                    for (std::int64_t k = 0; k < length; ++k) {
                        token = next();
                        if (role == ply_role::texcoord) {
                            texcoords_.push_back(attribute_from_text(prop.type, token, fail_here));
                            continue;
                        }
                        if (role != ply_role::corners) {
                            skip_number(token);
                            continue;
                        }
                        std::int64_t index = 0;
                        if (!parse_int(token, index))
                            fail_here("face " + std::to_string(i) + ": " + quoted(token) +
                                      " is not a vertex index");
                        add_corner(index, i, fail_here);
                    }
                }
                finish_instance(e, i, point, fail_here);
            }
        }
        if (!tokens.at_end())
            fail_at_line(source_, tokens.line(),
                         "data continues after all elements the header declares");
    }

    std::string_view data_;
    std::string_view source_;
    const read_options& options_;
    ply_header header_;
    static constexpr std::size_t npos = ~std::size_t{0};
    std::vector<std::vector<ply_role>> roles_;      // per element, per property
    std::vector<std::vector<std::size_t>> columns_; // attribute column, or npos
    std::uint64_t vertex_count_ = 0;
    std::vector<index_t> poly_;
    surface surface_;
    // The current instance's attribute values.
    std::vector<std::pair<std::size_t, double>> pending_;
    std::vector<double> texcoords_;
    std::size_t texcoord_column_ = npos;
};

/// Appends a value in little-endian byte order, whatever the host's order.
template <class T>
void put_little_endian(std::string& out, T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
    out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

/// The property names of an attribute column: its own name for one component, the usual
/// PLY names for normals, colours and texture coordinates, name_0, name_1... otherwise.
inline std::vector<std::string> ply_property_names(const attribute_column& a) {
    if (a.width == 1) return {a.name};
    if (a.width == 3 && a.name == "normal") return {"nx", "ny", "nz"};
    if (a.width == 3 && a.name == "color") return {"red", "green", "blue"};
    if (a.width == 2 && a.name == "uv") return {"s", "t"};
    std::vector<std::string> names;
    for (std::uint32_t k = 0; k < a.width; ++k) names.push_back(a.name + "_" + std::to_string(k));
    return names;
}

inline bool ply_stores(const attribute_column& a) noexcept {
    return a.domain != attribute_domain::corner || a.width == 2;
}

/// Appends x in type t, little-endian (x is first made representable: rounded, clamped).
inline void put_scalar(std::string& out, scalar_type t, double x) {
    x = representable(t, x);
    switch (t) {
    case scalar_type::int8:
        return put_little_endian(out, static_cast<std::int8_t>(x));
    case scalar_type::uint8:
        return put_little_endian(out, static_cast<std::uint8_t>(x));
    case scalar_type::int16:
        return put_little_endian(out, static_cast<std::int16_t>(x));
    case scalar_type::uint16:
        return put_little_endian(out, static_cast<std::uint16_t>(x));
    case scalar_type::int32:
        return put_little_endian(out, static_cast<std::int32_t>(x));
    case scalar_type::uint32:
        return put_little_endian(out, static_cast<std::uint32_t>(x));
    case scalar_type::float32:
        return put_little_endian(out, static_cast<float>(x));
    case scalar_type::float64:
        return put_little_endian(out, x);
    }
}

/// Writes x as text, with the shortest digits that read back to the same value of type t.
inline void put_scalar(text_sink& out, scalar_type t, double x) {
    x = representable(t, x);
    if (t == scalar_type::float32)
        out << static_cast<float>(x);
    else
        out << x;
}

inline void write_ply_unchecked(std::ostream& os, const surface& s, encoding enc) {
    // int32 indices as promised, unless the mesh is too large for them.
    const bool wide =
        s.vertices.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max());
    std::vector<const attribute_column*> vertex_columns, face_columns, corner_columns;
    for (const attribute_column& a : s.attributes) {
        if (!ply_stores(a)) continue;
        (a.domain == attribute_domain::vertex ? vertex_columns
         : a.domain == attribute_domain::face ? face_columns
                                              : corner_columns)
            .push_back(&a);
    }
    text_sink header(os);
    header << "ply\nformat " << (enc == encoding::ascii ? "ascii" : "binary_little_endian")
           << " 1.0\ncomment written by idas\nelement vertex " << std::uint64_t{s.vertices.size()}
           << "\nproperty double x\nproperty double y\nproperty double z\n";
    for (const attribute_column* a : vertex_columns)
        for (const std::string& name : ply_property_names(*a))
            header << "property " << ply_type_name(a->type) << ' ' << name << '\n';
    header << "element face " << std::uint64_t{s.faces.size()} << "\nproperty list uchar "
           << (wide ? "uint" : "int") << " vertex_indices\n";
    for (const attribute_column* a : face_columns)
        for (const std::string& name : ply_property_names(*a))
            header << "property " << ply_type_name(a->type) << ' ' << name << '\n';
    for (const attribute_column* a : corner_columns)
        header << "property list uchar " << ply_type_name(a->type) << ' '
               << (a->name == "uv" ? std::string("texcoord") : a->name) << '\n';
    header << "end_header\n";
    if (enc == encoding::ascii) {
        write_items(header, s.vertices.size(), [&](text_sink& out, std::size_t v) {
            const vec3& p = s.vertices[v];
            out << p.x << ' ' << p.y << ' ' << p.z;
            for (const attribute_column* a : vertex_columns)
                for (std::uint32_t k = 0; k < a->width; ++k)
                    out << ' ', put_scalar(out, a->type, a->values[v * a->width + k]);
            out << '\n';
        });
        write_items(header, s.faces.size(), [&](text_sink& out, std::size_t f) {
            const tri_indices& t = s.faces[f];
            out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2];
            for (const attribute_column* a : face_columns)
                for (std::uint32_t k = 0; k < a->width; ++k)
                    out << ' ', put_scalar(out, a->type, a->values[f * a->width + k]);
            for (const attribute_column* a : corner_columns) {
                out << " 6";
                for (std::size_t k = 0; k < 6; ++k)
                    out << ' ', put_scalar(out, a->type, a->values[6 * f + k]);
            }
            out << '\n';
        });
        header.flush();
        return;
    }
    header.flush();

    std::string buf;
    constexpr std::size_t chunk = 1 << 16;
    buf.reserve(chunk + 64);
    const auto drain = [&](bool force) {
        if (force || buf.size() >= chunk) {
            os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
            buf.clear();
        }
    };
    for (std::size_t v = 0; v < s.vertices.size(); ++v) {
        const vec3& p = s.vertices[v];
        put_little_endian(buf, p.x);
        put_little_endian(buf, p.y);
        put_little_endian(buf, p.z);
        for (const attribute_column* a : vertex_columns)
            for (std::uint32_t k = 0; k < a->width; ++k)
                put_scalar(buf, a->type, a->values[v * a->width + k]);
        drain(false);
    }
    for (std::size_t f = 0; f < s.faces.size(); ++f) {
        buf.push_back(3);
        for (index_t v : s.faces[f]) {
            if (wide)
                put_little_endian(buf, std::uint32_t{v});
            else
                put_little_endian(buf, static_cast<std::int32_t>(v));
        }
        for (const attribute_column* a : face_columns)
            for (std::uint32_t k = 0; k < a->width; ++k)
                put_scalar(buf, a->type, a->values[f * a->width + k]);
        for (const attribute_column* a : corner_columns) {
            buf.push_back(6);
            for (std::size_t k = 0; k < 6; ++k) put_scalar(buf, a->type, a->values[6 * f + k]);
        }
        drain(false);
    }
    drain(true);
}

} // namespace detail

/// Parses a PLY file held in memory; `source` names it in error messages. Vertex and face
/// numbers in messages are 0-based; binary errors give the byte offset.
inline surface parse_ply(std::string_view data, std::string_view source,
                         const read_options& options = {}) {
    if (data.empty()) detail::fail(source, "file is empty");
    return detail::ply_reader(data, source, options).read();
}

inline surface read_ply(const std::filesystem::path& path, const read_options& options = {}) {
    return parse_ply(detail::read_file(path), path.string(), options);
}

/// Attributes that PLY output cannot hold (corner attributes other than 2-component
/// texture coordinates).
inline std::vector<std::string> ply_unstored_attributes(const surface& s) {
    return detail::unstored_attributes(s, detail::ply_stores);
}

/// Binary output stores coordinates as double and indices as int32 (uint32 beyond 2^31
/// vertices); ASCII output uses the shortest text that reads back to the same doubles.
inline void write_ply(std::ostream& os, const surface& s, encoding enc = encoding::binary) {
    detail::check_writable(s, "PLY output");
    detail::write_ply_unchecked(os, s, enc);
}

inline void write_ply(const std::filesystem::path& path, const surface& s,
                      encoding enc = encoding::binary) {
    detail::check_writable(s, path.string());
    write_atomically(path, [&](std::ostream& os) { detail::write_ply_unchecked(os, s, enc); });
}

} // namespace idas::io
