// Point sets: XYZ text files and the vertex element of PLY files (other elements, such
// as the dummy face some point-cloud PLYs carry, are ignored), and seeded Gaussian points.
#pragma once

#include <idas/io/ply.hpp>
#include <idas/io/surface.hpp>

#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <vector>

namespace idas::io {

namespace detail {

/// XYZ: one point per line, three coordinates first (further columns, such as normals,
/// are ignored); blank lines and lines starting with '#' are skipped.
inline std::vector<vec3> parse_xyz(std::string_view data, std::string_view source) {
    std::vector<vec3> points;
    line_reader lines(strip_utf8_bom(data));
    std::string_view line;
    while (lines.next(line)) {
        std::string_view rest = line;
        const std::string_view first = next_token(rest);
        if (first.empty() || first.front() == '#') continue;
        vec3 p;
        std::string_view token = first;
        for (int k = 0; k < 3; ++k) {
            if (k > 0) token = next_token(rest);
            if (token.empty())
                fail_at_line(source, lines.line_number(), "expected three coordinates");
            if (parse_double(token, p[k]) != parse_status::ok || !std::isfinite(p[k]))
                fail_at_line(source, lines.line_number(),
                             "coordinate " + io::detail::quoted(token) + " is not a finite number");
        }
        points.push_back(p);
    }
    return points;
}

/// The x, y, z of a PLY file's vertex element. Elements before it must have fixed-size
/// records in binary files (lists there would need decoding to skip).
inline std::vector<vec3> parse_ply_points(std::string_view data, std::string_view source) {
    const ply_header h = parse_ply_header(data, source);
    std::size_t pos = h.body_offset;
    std::size_t first_line = h.body_line;
    token_reader ascii_tokens(h.format == ply_format::ascii ? data.substr(pos) : std::string_view{},
                              first_line);
    const bool swap =
        (h.format == ply_format::binary_big_endian) != (std::endian::native == std::endian::big);
    const auto* base = reinterpret_cast<const unsigned char*>(data.data());
    for (const ply_element& e : h.elements) {
        const bool is_vertex = e.name == "vertex";
        int axis_of[64];
        std::size_t record = 0;
        bool has_list = false;
        if (e.properties.size() > 64) fail(source, "too many properties in element " + e.name);
        unsigned found = 0; // bit per axis: x, y and z each exactly once
        for (std::size_t i = 0; i < e.properties.size(); ++i) {
            const auto& p = e.properties[i];
            axis_of[i] = -1;
            if (p.is_list) {
                has_list = true;
                continue;
            }
            record += ply_size(p.type);
            if (is_vertex && (p.name == "x" || p.name == "y" || p.name == "z")) {
                const int axis = p.name[0] - 'x';
                if (found & (1u << axis))
                    fail(source, "the vertex element declares property " + p.name + " twice");
                axis_of[i] = axis, found |= 1u << axis;
            }
        }
        const auto truncated = [&](std::uint64_t done) {
            fail(source, "truncated: header says " + std::to_string(e.count) + " " + ply_plural(e) +
                             ", found " + std::to_string(done));
        };
        if (!is_vertex) {
            if (h.format == ply_format::ascii) {
                // ASCII elements before the vertices: one line per record. A record
                // needs a token, so a huge count stops at the end of the data.
                if (e.properties.empty()) continue;
                for (std::uint64_t i = 0; i < e.count; ++i) {
                    if (ascii_tokens.next().empty()) truncated(i);
                    ascii_tokens.skip_line();
                }
            } else {
                if (has_list)
                    fail(source, "element " + io::detail::quoted(e.name) +
                                     " before the vertices has list properties; not supported");
                // Compare by division: record * count can overflow and wrap pos around.
                if (record > 0 && e.count > (data.size() - pos) / record)
                    truncated((data.size() - pos) / record);
                pos += record * e.count;
            }
            continue;
        }
        if (found != 7 || has_list)
            fail(source, "the vertex element needs scalar properties x, y and z");
        if (e.count >= invalid_index) fail(source, "too many vertices");
        // Reserve only what the remaining bytes can hold: the count may be a lie. An ASCII
        // value takes at least a character and a separator.
        const bool ascii = h.format == ply_format::ascii;
        std::vector<vec3> points;
        points.reserve(
            capped_reserve(e.count, data.size() - pos, ascii ? 2 * e.properties.size() : record));
        for (std::uint64_t i = 0; i < e.count; ++i) {
            vec3 q;
            for (std::size_t k = 0; k < e.properties.size(); ++k) {
                const auto& p = e.properties[k];
                double value = 0;
                if (h.format == ply_format::ascii) {
                    const std::string_view token = ascii_tokens.next();
                    if (token.empty()) truncated(i);
                    if (parse_double(token, value) != parse_status::ok)
                        fail_at_line(source, ascii_tokens.line(),
                                     io::detail::quoted(token) + " is not a number");
                } else {
                    const std::size_t n = ply_size(p.type);
                    if (data.size() - pos < n) truncated(i);
                    value = ply_load_double(p.type, base + pos, swap);
                    pos += n;
                }
                if (axis_of[k] >= 0) q[axis_of[k]] = value;
            }
            if (!is_finite(q))
                fail(source, "vertex " + std::to_string(i) + " has a non-finite coordinate");
            points.push_back(q);
        }
        return points;
    }
    fail(source, "the PLY header declares no vertex element");
}

} // namespace detail

/// Parses a point set held in memory, in the format its `extension` names (".xyz",
/// ".txt" or ".ply", any case); `source` names it in error messages.
inline std::vector<vec3> parse_points(std::string_view data, std::string_view source,
                                      std::string_view extension) {
    std::string ext(extension);
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (data.empty()) detail::fail(source, "file is empty");
    if (ext == ".ply") return detail::parse_ply_points(data, source);
    if (ext == ".xyz" || ext == ".txt") return detail::parse_xyz(data, source);
    detail::fail(source, "unknown point-set extension (expected .xyz or .ply)");
}

/// Reads a point set from .xyz or .ply (by extension). Throws input_error naming the file
/// and the problem.
inline std::vector<vec3> read_points(const std::filesystem::path& path) {
    return parse_points(detail::read_file(path), path.string(), path.extension().string());
}

/// N points of the standard normal distribution in 3D, reproducible across platforms for a
/// given seed: 64-bit Mersenne Twister words through a Box-Muller transform written out here
/// (std::normal_distribution differs between standard libraries).
inline std::vector<vec3> gaussian_points(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const auto uniform = [&] { // in (0, 1]
        return (static_cast<double>(rng() >> 11) + 1.0) * (1.0 / 9007199254740992.0);
    };
    std::vector<vec3> points(n);
    double spare = 0;
    bool have_spare = false;
    const auto normal = [&] {
        if (have_spare) {
            have_spare = false;
            return spare;
        }
        const double r = std::sqrt(-2.0 * std::log(uniform()));
        const double t = 2.0 * std::numbers::pi * uniform();
        spare = r * std::sin(t), have_spare = true;
        return r * std::cos(t);
    };
    for (auto& p : points) p = {normal(), normal(), normal()};
    return points;
}

} // namespace idas::io
