// Object File Format (Geomview OFF): an "OFF" header, a line of vertex / face / edge
// counts, then one line per vertex and one per face ("n i0 ... i(n-1) [colour]").
// '#' starts a comment. The header's prefixes say what follows a vertex's position, in
// this order: N a normal (vertex attribute "normal"), C a colour of 3 or 4 values (vertex
// attribute "color"), ST a texture coordinate (vertex attribute "uv"). A face's optional
// colour (3 or 4 values: face attribute "color", NaN on faces without one; 1 value: a
// colour-map index, face attribute "color_index") is kept whatever the header says.
// Colours whose values are all integers in 0..255 are typed uint8, others float64. The
// writer emits the same columns back; binary OFF and 4D / nD OFF are refused.
#pragma once

#include "idas/io/atomic_file.hpp"
#include "idas/io/surface.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace idas::io {

namespace detail {

/// Lines of an OFF file with comments removed and blank lines skipped.
class off_lines {
public:
    explicit off_lines(std::string_view text)
        : lines_(text) {}

    bool next(std::string_view& content) noexcept {
        std::string_view line;
        while (lines_.next(line)) {
            const auto hash = line.find('#');
            if (hash != std::string_view::npos) line = line.substr(0, hash);
            if (!is_blank(line)) {
                content = line;
                return true;
            }
        }
        return false;
    }

    std::size_t line_number() const noexcept { return lines_.line_number(); }
    std::size_t position() const noexcept { return lines_.position(); }

private:
    line_reader lines_;
};

/// Whether OFF can hold a column: the vertex and face columns named in the file comment,
/// and vertex columns only without NaN (a vertex line cannot leave a value out).
inline bool off_stores(const attribute_column& a) noexcept {
    const bool colour = a.name == "color" && (a.width == 3 || a.width == 4);
    if (a.domain == attribute_domain::face)
        return colour || (a.name == "color_index" && a.width == 1);
    if (a.domain != attribute_domain::vertex) return false;
    if (!colour && !(a.name == "normal" && a.width == 3) && !(a.name == "uv" && a.width == 2))
        return false;
    return std::none_of(a.values.begin(), a.values.end(), [](double x) { return std::isnan(x); });
}

inline const attribute_column* off_column(const surface& s, std::string_view name,
                                          attribute_domain domain) noexcept {
    const attribute_column* a = find_attribute(s, name, domain);
    return a && off_stores(*a) ? a : nullptr;
}

inline void write_off_unchecked(std::ostream& os, const surface& s) {
    using enum attribute_domain;
    const attribute_column* normal = off_column(s, "normal", vertex);
    const attribute_column* colour = off_column(s, "color", vertex);
    const attribute_column* uv = off_column(s, "uv", vertex);
    const attribute_column* face_colour = off_column(s, "color", face);
    if (!face_colour) face_colour = off_column(s, "color_index", face);
    text_sink out(os);
    out << (uv ? "ST" : "") << (colour ? "C" : "") << (normal ? "N" : "") << "OFF\n"
        << std::uint64_t{s.vertices.size()} << ' ' << std::uint64_t{s.faces.size()} << " 0\n";
    const auto values = [](text_sink& to, const attribute_column* a, std::size_t i) {
        if (!a) return;
        for (std::uint32_t k = 0; k < a->width; ++k) {
            const double x = a->values[i * a->width + k];
            to << ' ' << (a->type == scalar_type::float64 ? x : representable(a->type, x));
        }
    };
    write_items(out, s.vertices.size(), [&](text_sink& to, std::size_t v) {
        const vec3& p = s.vertices[v];
        to << p.x << ' ' << p.y << ' ' << p.z;
        values(to, normal, v), values(to, colour, v), values(to, uv, v);
        to << '\n';
    });
    write_items(out, s.faces.size(), [&](text_sink& to, std::size_t f) {
        const tri_indices& t = s.faces[f];
        to << "3 " << t[0] << ' ' << t[1] << ' ' << t[2];
        if (face_colour && !std::isnan(face_colour->values[f * face_colour->width]))
            values(to, face_colour, f);
        to << '\n';
    });
    out.flush();
}

/// The optional values after a vertex's position or a face's indices, gathered while the
/// faces are read so that polygons and faces without a colour line up.
struct off_extras {
    std::vector<double> normals, colours, uvs, face_colours;
    std::uint32_t colour_width = 0, face_colour_width = 0;
};

/// Colours read as integers 0..255 are stored back as such; anything else as doubles.
inline scalar_type colour_type(const std::vector<double>& values) noexcept {
    const bool bytes = std::all_of(values.begin(), values.end(), [](double x) {
        return std::isnan(x) || (x >= 0 && x <= 255 && x == std::floor(x));
    });
    return bytes ? scalar_type::uint8 : scalar_type::float64;
}

inline void add_off_columns(surface& s, off_extras& e) {
    using enum attribute_domain;
    if (!e.normals.empty())
        s.attributes.push_back(
            {"normal", vertex, scalar_type::float64, 3, std::move(e.normals), {}});
    if (!e.colours.empty()) {
        const scalar_type t = colour_type(e.colours);
        s.attributes.push_back({"color", vertex, t, e.colour_width, std::move(e.colours), {}});
    }
    if (!e.uvs.empty())
        s.attributes.push_back({"uv", vertex, scalar_type::float64, 2, std::move(e.uvs), {}});
    if (e.face_colour_width == 1)
        s.attributes.push_back(
            {"color_index", face, scalar_type::int32, 1, std::move(e.face_colours), {}});
    else if (e.face_colour_width != 0) {
        const scalar_type t = colour_type(e.face_colours);
        s.attributes.push_back(
            {"color", face, t, e.face_colour_width, std::move(e.face_colours), {}});
    }
}

/// Parses the numbers left on a line into `out`; a token that is not a finite number is
/// refused. Returns how many there were.
template <class Fail>
std::size_t off_numbers(std::string_view& rest, std::vector<double>& out, Fail&& fail,
                        const char* what, std::uint64_t number) {
    out.clear();
    for (std::string_view token = next_token(rest); !token.empty(); token = next_token(rest)) {
        double x = 0;
        if (out.size() == 64)
            fail(std::string(what) + ' ' + std::to_string(number) + " has over 64 values");
        if (parse_double(token, x) != parse_status::ok || !std::isfinite(x))
            fail(std::string(what) + ' ' + std::to_string(number) + ": " + quoted(token) +
                 " is not a finite number");
        out.push_back(x);
    }
    return out.size();
}

/// What a vertex line holds under a header, for messages.
inline std::string off_vertex_layout(bool normal, bool colour, bool uv, std::uint32_t width) {
    std::string s = "3 (position)";
    if (normal) s += " + 3 (normal)";
    if (colour)
        s += width ? " + " + std::to_string(width) + " (colour, as earlier vertices)"
                   : std::string(" + 3 or 4 (colour)");
    if (uv) s += " + 2 (texture coordinate)";
    return s;
}

} // namespace detail

/// Parses OFF text; `source` names it in error messages. Vertex and face numbers in
/// messages are 0-based, as OFF counts them.
inline surface parse_off(std::string_view text, std::string_view source,
                         const read_options& options = {}) {
    text = detail::strip_utf8_bom(text);
    if (detail::is_blank(text)) detail::fail(source, "file is empty");

    detail::off_lines lines(text);
    const auto fail_here = [&](const std::string& what) {
        detail::fail_at_line(source, lines.line_number(), what);
    };
    std::string_view rest;
    if (!lines.next(rest)) detail::fail(source, "file is empty (only comments)");

    // Header keyword: optional ST / C / N prefixes, then "OFF".
    const std::string_view keyword = detail::next_token(rest);
    if (!keyword.ends_with("OFF"))
        fail_here("missing OFF header (found " + detail::quoted(keyword) + ")");
    const std::string_view prefix = keyword.substr(0, keyword.size() - 3);
    if (prefix.find_first_of("4n") != std::string_view::npos)
        fail_here("4D and n-dimensional OFF (" + std::string(keyword) + ") are not supported");
    if (prefix.find_first_not_of("STCN") != std::string_view::npos)
        fail_here("unknown OFF header variant " + detail::quoted(keyword));
    const bool with_normal = prefix.find('N') != std::string_view::npos;
    const bool with_colour = prefix.find('C') != std::string_view::npos;
    const bool with_uv = prefix.find_first_of("ST") != std::string_view::npos;

    // The counts usually sit on their own line but may follow the keyword.
    std::string_view token = detail::next_token(rest);
    if (token == "BINARY") fail_here("binary OFF is not supported");
    if (token.empty()) {
        if (!lines.next(rest)) detail::fail(source, "file ends before the vertex and face counts");
        token = detail::next_token(rest);
    }
    std::int64_t counts[3] = {0, 0, 0};
    const char* count_names[3] = {"vertex", "face", "edge"};
    for (int i = 0; i < 3; ++i) {
        if (i > 0) token = detail::next_token(rest);
        if (token.empty() && i == 2) break; // the edge count is often left out
        if (token.empty()) fail_here("expected vertex, face and edge counts");
        if (!detail::parse_int(token, counts[i]) || counts[i] < 0)
            fail_here(std::string(count_names[i]) + " count " + detail::quoted(token) +
                      " is not a non-negative integer");
    }
    if (!detail::next_token(rest).empty())
        fail_here("unexpected data after the vertex, face and edge counts");
    const auto vertex_count = static_cast<std::uint64_t>(counts[0]);
    const auto face_count = static_cast<std::uint64_t>(counts[1]);
    if (vertex_count >= invalid_index)
        fail_here("header says " + std::to_string(vertex_count) + " vertices, more than supported");

    surface s;
    detail::off_extras extras;
    std::vector<double> extra;
    // The shortest vertex line "0 0 0\n" has 6 bytes: never reserve more than the file holds.
    s.vertices.reserve(detail::capped_reserve(vertex_count, text.size() - lines.position(), 6));
    for (std::uint64_t v = 0; v < vertex_count; ++v) {
        if (!lines.next(rest))
            detail::fail(source, "truncated: header says " + std::to_string(vertex_count) +
                                     " vertices, found " + std::to_string(v));
        vec3 p;
        for (int axis = 0; axis < 3; ++axis) {
            token = detail::next_token(rest);
            if (token.empty())
                fail_here("vertex " + std::to_string(v) + " has fewer than 3 coordinates");
            const auto status = detail::parse_double(token, p[axis]);
            if (status == detail::parse_status::not_a_number)
                fail_here("vertex " + std::to_string(v) + ": " + detail::quoted(token) +
                          " is not a number");
            if (status == detail::parse_status::out_of_range || !std::isfinite(p[axis]))
                fail_here("vertex " + std::to_string(v) + " has a non-finite coordinate " +
                          detail::quoted(token));
        }
        // The header fixes how many values follow the position; a mismatch usually means the
        // header's vertex count is wrong and we are reading a face line.
        const std::size_t count = detail::off_numbers(rest, extra, fail_here, "vertex", v);
        const std::size_t fixed = (with_normal ? 3 : 0) + (with_uv ? 2 : 0);
        const std::size_t colour_width = count >= fixed ? count - fixed : 0;
        const bool fits = with_colour
                              ? (colour_width == 3 || colour_width == 4) &&
                                    (!extras.colour_width || colour_width == extras.colour_width)
                              : count == fixed;
        if (!fits)
            fail_here(
                "vertex " + std::to_string(v) + " has " + std::to_string(3 + count) +
                " values, but " + std::string(keyword) + " gives a vertex " +
                detail::off_vertex_layout(with_normal, with_colour, with_uv, extras.colour_width) +
                " (does the header's vertex count of " + std::to_string(vertex_count) +
                " match the file?)");
        s.vertices.push_back(p);
        if (!options.attributes) continue;
        const double* next = extra.data();
        if (with_normal) extras.normals.insert(extras.normals.end(), next, next + 3), next += 3;
        if (with_colour) {
            extras.colour_width = std::uint32_t(colour_width);
            extras.colours.insert(extras.colours.end(), next, next + colour_width);
            next += colour_width;
        }
        if (with_uv) extras.uvs.insert(extras.uvs.end(), next, next + 2);
    }

    // The shortest triangle line "3 0 1 2\n" has 8 bytes.
    s.faces.reserve(detail::capped_reserve(face_count, text.size() - lines.position(), 8));
    std::vector<index_t> poly;
    for (std::uint64_t f = 0; f < face_count; ++f) {
        if (!lines.next(rest))
            detail::fail(source, "truncated: header says " + std::to_string(face_count) +
                                     " faces, found " + std::to_string(f));
        const std::string face_name = "face " + std::to_string(f);
        std::int64_t corners = 0;
        token = detail::next_token(rest);
        if (!detail::parse_int(token, corners) || corners < 0)
            fail_here(face_name + ": " + detail::quoted(token) + " is not a vertex count");
        poly.clear();
        // Indices are taken while the line has tokens, so a huge count cannot run away.
        for (std::int64_t k = 0; k < corners; ++k) {
            token = detail::next_token(rest);
            if (token.empty())
                fail_here(face_name + " announces " + std::to_string(corners) +
                          " vertices but lists " + std::to_string(k));
            std::int64_t index = 0;
            if (!detail::parse_int(token, index))
                fail_here(face_name + ": " + detail::quoted(token) + " is not a vertex index");
            if (index < 0 || static_cast<std::uint64_t>(index) >= vertex_count)
                fail_here(face_name + " references vertex " + std::to_string(index) +
                          " but there are only " + std::to_string(vertex_count) + " vertices");
            poly.push_back(static_cast<index_t>(index));
        }
        const std::size_t first_triangle = s.faces.size();
        detail::add_polygon(s.faces, poly, f, options, 0, fail_here);
        // What follows the indices is a colour: a colour-map index, or 3 or 4 values.
        const std::size_t width = detail::off_numbers(rest, extra, fail_here, "face", f);
        if (width != 0 && width != 1 && width != 3 && width != 4)
            fail_here(face_name + " has " + std::to_string(width) +
                      " values after its indices; a face colour has 1, 3 or 4");
        if (width != 0 && extras.face_colour_width != 0 && width != extras.face_colour_width)
            fail_here(face_name + " has a colour of " + std::to_string(width) +
                      " values, earlier faces of " + std::to_string(extras.face_colour_width));
        if (!options.attributes) continue;
        if (width != 0 && extras.face_colour_width == 0) {
            extras.face_colour_width = std::uint32_t(width);
            extras.face_colours.assign(first_triangle * width,
                                       std::numeric_limits<double>::quiet_NaN());
        }
        if (extras.face_colour_width == 0) continue;
        for (std::size_t t = first_triangle; t < s.faces.size(); ++t)
            for (std::size_t k = 0; k < extras.face_colour_width; ++k)
                extras.face_colours.push_back(width ? extra[k]
                                                    : std::numeric_limits<double>::quiet_NaN());
    }

    if (lines.next(rest))
        fail_here("header says " + std::to_string(face_count) +
                  " faces but the file has more data after them");
    detail::add_off_columns(s, extras);
    return s;
}

/// The attributes of `s` that OFF cannot store (see the file comment).
inline std::vector<std::string> off_unstored_attributes(const surface& s) {
    return detail::unstored_attributes(s, detail::off_stores);
}

inline surface read_off(const std::filesystem::path& path, const read_options& options = {}) {
    return parse_off(detail::read_file(path), path.string(), options);
}

/// Writes positions with the shortest text that reads back to the same doubles.
inline void write_off(std::ostream& os, const surface& s) {
    detail::check_writable(s, "OFF output");
    detail::write_off_unchecked(os, s);
}

inline void write_off(const std::filesystem::path& path, const surface& s) {
    detail::check_writable(s, path.string());
    write_atomically(path, [&](std::ostream& os) { detail::write_off_unchecked(os, s); });
}

} // namespace idas::io
