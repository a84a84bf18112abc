// Wavefront OBJ: "v x y z" and "f i j k ..." statements. Texture coordinates, normals,
// groups, materials and other statements are ignored; face corners may be written as
// v, v/vt, v//vn or v/vt/vn, and negative indices count back from the latest vertex.
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

inline bool is_obj_keyword(std::string_view token) noexcept {
    const auto letter = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); };
    if (token.empty() || !(letter(token[0]) || token[0] == '_')) return false;
    return std::all_of(token.begin(), token.end(),
                       [&](char c) { return letter(c) || c == '_' || (c >= '0' && c <= '9'); });
}

inline void write_obj_unchecked(std::ostream& os, const surface& s) {
    text_sink out(os);
    for (const vec3& p : s.vertices) out << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
    for (const tri_indices& t : s.faces)
        out << "f " << (t[0] + 1) << ' ' << (t[1] + 1) << ' ' << (t[2] + 1) << '\n';
    out.flush();
}

} // namespace detail

/// Parses OBJ text; `source` names it in error messages. Vertex and face numbers in
/// messages are 1-based, as OBJ counts them.
inline surface parse_obj(std::string_view text, std::string_view source,
                         const read_options& options = {}) {
    text = detail::strip_utf8_bom(text);
    if (detail::is_blank(text)) detail::fail(source, "file is empty");

    surface s;
    detail::line_reader lines(text);
    std::vector<index_t> poly;
    std::uint64_t face_number = 0;
    // Positive indices may point at vertices defined further down; remember the largest
    // such reference and check it once all vertices are known.
    struct {
        std::int64_t index = 0;
        std::size_t line = 0;
        std::uint64_t face = 0;
    } forward;

    std::string_view line;
    while (lines.next(line)) {
        const auto fail_here = [&](const std::string& what) {
            detail::fail_at_line(source, lines.line_number(), what);
        };
        std::string_view rest = line;
        const std::string_view keyword = detail::next_token(rest);
        if (keyword.empty() || keyword[0] == '#') continue;

        if (keyword == "v") {
            const auto vertex_name = [&] {
                return "vertex " + std::to_string(s.vertices.size() + 1);
            };
            vec3 p;
            for (int axis = 0; axis < 3; ++axis) {
                const std::string_view token = detail::next_token(rest);
                if (token.empty()) fail_here(vertex_name() + " has fewer than 3 coordinates");
                const auto status = detail::parse_double(token, p[axis]);
                if (status == detail::parse_status::not_a_number)
                    fail_here(vertex_name() + ": " + detail::quoted(token) + " is not a number");
                if (status == detail::parse_status::out_of_range || !std::isfinite(p[axis]))
                    fail_here(vertex_name() + " has a non-finite coordinate " +
                              detail::quoted(token));
            }
            // Further columns (w or vertex colours) are ignored.
            s.vertices.push_back(p);
        } else if (keyword == "f") {
            ++face_number;
            poly.clear();
            const auto count = static_cast<std::int64_t>(s.vertices.size());
            for (std::string_view token = detail::next_token(rest);
                 !token.empty() && token[0] != '#'; token = detail::next_token(rest)) {
                // Only the position index before the first '/' matters here.
                std::int64_t index = 0;
                const char* last = token.data() + token.size();
                const auto [end, ec] = std::from_chars(token.data(), last, index);
                if (ec != std::errc() || (end != last && *end != '/'))
                    fail_here("face " + std::to_string(face_number) + ": " + detail::quoted(token) +
                              " is not a vertex index");
                if (index == 0)
                    fail_here("face " + std::to_string(face_number) +
                              " references vertex 0; OBJ indices start at 1");
                if (index < 0) {
                    // Compare without negating: -INT64_MIN overflows.
                    if (index < -count)
                        fail_here("face " + std::to_string(face_number) + ": relative index " +
                                  std::to_string(index) + " points before the first vertex (" +
                                  std::to_string(count) + " vertices defined so far)");
                    index += count + 1;
                } else if (index > count) {
                    if (index >= static_cast<std::int64_t>(invalid_index))
                        fail_here("face " + std::to_string(face_number) + " references vertex " +
                                  std::to_string(index) + ", beyond any possible vertex count");
                    if (index > forward.index) forward = {index, lines.line_number(), face_number};
                }
                poly.push_back(static_cast<index_t>(index - 1));
            }
            detail::add_polygon(s.faces, poly, face_number, options, 1, fail_here);
        } else if (!detail::is_obj_keyword(keyword)) {
            // Statements we do not use are skipped, but a line that is not a statement at
            // all means this is not an OBJ file (or it is corrupted).
            fail_here("unexpected " + detail::quoted(keyword) + ", expected an OBJ statement");
        }
    }

    if (forward.index > static_cast<std::int64_t>(s.vertices.size()))
        detail::fail_at_line(source, forward.line,
                             "face " + std::to_string(forward.face) + " references vertex " +
                                 std::to_string(forward.index) + " but there are only " +
                                 std::to_string(s.vertices.size()) + " vertices");
    if (s.vertices.empty()) detail::fail(source, "no vertices ('v' lines) found");
    return s;
}

inline surface read_obj(const std::filesystem::path& path, const read_options& options = {}) {
    return parse_obj(detail::read_file(path), path.string(), options);
}

/// Writes positions with the shortest text that reads back to the same doubles.
inline void write_obj(std::ostream& os, const surface& s) {
    detail::check_writable(s, "OBJ output");
    detail::write_obj_unchecked(os, s);
}

inline void write_obj(const std::filesystem::path& path, const surface& s) {
    detail::check_writable(s, path.string());
    write_atomically(path, [&](std::ostream& os) { detail::write_obj_unchecked(os, s); });
}

} // namespace idas::io
