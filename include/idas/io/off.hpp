// Object File Format (Geomview OFF): an "OFF" header, a line of vertex / face / edge
// counts, then one line per vertex and one per face ("n i0 ... i(n-1) [colour]").
// '#' starts a comment. The header variants COFF, NOFF, CNOFF, STOFF etc. are accepted and
// their extra vertex columns ignored; binary OFF and 4D / nD OFF are refused.
#pragma once

#include "idas/io/atomic_file.hpp"
#include "idas/io/surface.hpp"

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <string_view>

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

inline void write_off_unchecked(std::ostream& os, const surface& s) {
    text_sink out(os);
    out << "OFF\n"
        << std::uint64_t{s.vertices.size()} << ' ' << std::uint64_t{s.faces.size()} << " 0\n";
    write_items(out, s.vertices.size(), [&](text_sink& to, std::size_t v) {
        const vec3& p = s.vertices[v];
        to << p.x << ' ' << p.y << ' ' << p.z << '\n';
    });
    write_items(out, s.faces.size(), [&](text_sink& to, std::size_t f) {
        const tri_indices& t = s.faces[f];
        to << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
    });
    out.flush();
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
    const bool extra_vertex_columns = !prefix.empty();

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
        // Plain OFF has exactly three columns; anything more usually means the header's
        // vertex count is wrong and we are reading a face line.
        if (!extra_vertex_columns && !detail::next_token(rest).empty())
            fail_here("vertex " + std::to_string(v) +
                      " has more than 3 values (does the header's vertex count of " +
                      std::to_string(vertex_count) + " match the file?)");
        s.vertices.push_back(p);
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
        // Whatever follows the indices is a face colour, which we do not keep.
        detail::add_polygon(s.faces, poly, f, options, 0, fail_here);
    }

    if (lines.next(rest))
        fail_here("header says " + std::to_string(face_count) +
                  " faces but the file has more data after them");
    return s;
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
