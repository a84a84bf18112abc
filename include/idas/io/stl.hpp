// STL, ASCII and binary. STL stores each triangle's corners separately in single
// precision (ASCII values are rounded to float too); the reader welds corners with exactly
// equal coordinates into shared vertices (read_options::weld_stl), giving an indexed mesh.
// A facet whose corners weld together is dropped and counted (surface::dropped_faces):
// an indexed mesh may hold a face of distinct vertices at one position, which STL can
// only store as such a facet, so refusing it would refuse what idas itself wrote.
#pragma once

#include "idas/io/atomic_file.hpp"
#include "idas/io/surface.hpp"

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace idas::io {

namespace detail {

inline constexpr std::size_t stl_header_size = 84; // 80-byte comment + uint32 triangle count
inline constexpr std::size_t stl_facet_size = 50;  // 12 floats + uint16 attribute

/// Maps positions to vertex indices, creating a vertex the first time a position appears
/// (or always, when welding is off).
class stl_vertices {
public:
    stl_vertices(std::vector<vec3>& out, std::string_view source, bool weld, std::size_t expected)
        : out_(out)
        , source_(source)
        , weld_(weld) {
        if (weld_) map_.reserve(expected);
    }

    index_t add(const vec3& p) {
        if (out_.size() >= invalid_index) fail(source_, "too many vertices");
        const auto next = static_cast<index_t>(out_.size());
        if (weld_) {
            // Adding 0.0 turns -0.0 into +0.0, so positions that compare equal share a key.
            const key k{std::bit_cast<std::uint64_t>(p.x + 0.0),
                        std::bit_cast<std::uint64_t>(p.y + 0.0),
                        std::bit_cast<std::uint64_t>(p.z + 0.0)};
            const auto [it, inserted] = map_.try_emplace(k, next);
            if (!inserted) return it->second;
        }
        out_.push_back(p);
        return next;
    }

private:
    using key = std::array<std::uint64_t, 3>;
    struct key_hash {
        std::size_t operator()(const key& k) const noexcept {
            // Mix each word (splitmix64 finaliser) so nearby floats spread over buckets.
            std::uint64_t h = 0x9e3779b97f4a7c15ull;
            for (std::uint64_t w : k) {
                w ^= h;
                w = (w ^ (w >> 30)) * 0xbf58476d1ce4e5b9ull;
                w = (w ^ (w >> 27)) * 0x94d049bb133111ebull;
                h = w ^ (w >> 31);
            }
            return static_cast<std::size_t>(h);
        }
    };

    std::vector<vec3>& out_;
    std::string_view source_;
    bool weld_;
    std::unordered_map<key, index_t, key_hash> map_;
};

inline std::uint32_t stl_load_u32(const char* p) noexcept {
    unsigned char b[4];
    std::memcpy(b, p, 4);
    return std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 | std::uint32_t{b[2]} << 16 |
           std::uint32_t{b[3]} << 24;
}

inline float stl_load_float(const char* p) noexcept {
    return std::bit_cast<float>(stl_load_u32(p));
}

/// The reliable test for binary STL: its size is exactly 84 + 50 * (triangle count).
/// The "solid" prefix is not: many binary exporters start their header with it.
inline bool stl_size_matches(std::string_view data) noexcept {
    if (data.size() < stl_header_size) return false;
    const std::uint64_t count = stl_load_u32(data.data() + 80);
    return stl_header_size + stl_facet_size * count == data.size();
}

/// Control bytes other than whitespace never occur in ASCII STL but almost always in
/// binary float data: tells a damaged binary file from a damaged ASCII one.
inline bool has_binary_bytes(std::string_view data) noexcept {
    return std::any_of(data.begin(), data.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return u < 0x20 && !is_space(c);
    });
}

inline bool iequals(std::string_view a, std::string_view b) noexcept {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const char ca = (a[i] >= 'A' && a[i] <= 'Z') ? static_cast<char>(a[i] - 'A' + 'a') : a[i];
        if (ca != b[i]) return false;
    }
    return true;
}

/// True if welding made the facet repeat a vertex: it is dropped (see the file comment).
inline bool drop_welded_facet(surface& s, std::span<const index_t> poly,
                              const read_options& options) {
    if (!options.weld_stl) return false;
    for (std::size_t i = 0; i < poly.size(); ++i)
        for (std::size_t j = i + 1; j < poly.size(); ++j)
            if (poly[i] == poly[j]) return ++s.dropped_faces, true;
    return false;
}

/// Removes the vertices only dropped facets used (welded STL vertices come from corners,
/// so every other vertex is referenced), keeping the order of the rest.
inline void remove_unreferenced_vertices(surface& s) {
    if (s.dropped_faces == 0) return;
    std::vector<index_t> remap(s.vertices.size(), invalid_index);
    for (const tri_indices& f : s.faces)
        for (index_t v : f) remap[v] = 0;
    index_t next = 0;
    for (std::size_t v = 0; v < s.vertices.size(); ++v)
        if (remap[v] == 0) s.vertices[next] = s.vertices[v], remap[v] = next++;
    s.vertices.resize(next);
    for (tri_indices& f : s.faces)
        for (index_t& v : f) v = remap[v];
}

inline surface parse_binary_stl(std::string_view data, std::string_view source,
                                const read_options& options) {
    const std::size_t count = stl_load_u32(data.data() + 80);
    surface s;
    s.faces.reserve(count);
    // A closed mesh has about half as many vertices as triangles.
    stl_vertices vertices(s.vertices, source, options.weld_stl, count / 2 + 8);
    s.vertices.reserve(options.weld_stl ? count / 2 + 8 : 3 * count);
    std::array<index_t, 3> poly;
    // The facets' attribute words (colour, part number: exporters differ), per kept face.
    std::vector<double> words;
    bool any_word = false;
    for (std::size_t f = 0; f < count; ++f) {
        const char* facet = data.data() + stl_header_size + f * stl_facet_size;
        const auto fail_here = [&](const std::string& what) {
            fail(source, "byte " + std::to_string(facet - data.data()) + ": " + what);
        };
        for (int c = 0; c < 3; ++c) {
            const char* corner = facet + 12 * (c + 1); // skip the normal
            const vec3 p{stl_load_float(corner), stl_load_float(corner + 4),
                         stl_load_float(corner + 8)};
            if (!is_finite(p))
                fail_here("facet " + std::to_string(f) + ", corner " + std::to_string(c) +
                          " has a non-finite coordinate");
            poly[static_cast<std::size_t>(c)] = vertices.add(p);
        }
        if (!drop_welded_facet(s, poly, options)) {
            add_polygon(s.faces, poly, f, options, 0, fail_here);
            const std::uint16_t word = static_cast<std::uint16_t>(
                static_cast<unsigned char>(facet[48]) | static_cast<unsigned char>(facet[49]) << 8);
            words.push_back(word);
            any_word = any_word || word != 0;
        }
    }
    remove_unreferenced_vertices(s);
    // All zero is what nearly every exporter writes, and what the writer writes anyway.
    if (any_word && options.attributes)
        s.attributes.push_back({"stl_attribute",
                                attribute_domain::face,
                                scalar_type::uint16,
                                1,
                                std::move(words),
                                {}});
    return s;
}

inline surface parse_ascii_stl(std::string_view data, std::string_view source,
                               const read_options& options) {
    token_reader tokens(data);
    surface s;
    stl_vertices vertices(s.vertices, source, options.weld_stl, 0);
    std::vector<index_t> poly;
    std::uint64_t facet = 0;

    const auto fail_here = [&](const std::string& what) {
        fail_at_line(source, tokens.line(), what);
    };
    const auto expect = [&](std::string_view keyword) {
        const std::string_view token = tokens.next();
        if (token.empty())
            fail(source, "truncated: file ends in facet " + std::to_string(facet) + " where '" +
                             std::string(keyword) + "' was expected");
        if (!iequals(token, keyword))
            fail_here("facet " + std::to_string(facet) + ": expected '" + std::string(keyword) +
                      "', found " + quoted(token));
    };
    // Reads one number, rounded to single precision like binary STL so both encodings of
    // a mesh read (and weld) identically. Returns false for infinity, NaN or overflow.
    const auto number = [&](double& value) {
        const std::string_view token = tokens.next();
        if (token.empty()) fail(source, "truncated: file ends in facet " + std::to_string(facet));
        float single = 0;
        const auto status = parse_real(token, single);
        value = single;
        if (status == parse_status::not_a_number)
            fail_here("facet " + std::to_string(facet) + ": " + quoted(token) + " is not a number");
        return status == parse_status::ok && std::isfinite(value);
    };

    expect("solid");
    tokens.skip_line(); // the solid's name
    for (;;) {
        const std::string_view token = tokens.next();
        if (token.empty()) fail(source, "truncated: file ends without 'endsolid'");
        if (iequals(token, "endsolid")) {
            tokens.skip_line();
            if (tokens.at_end()) break;
            expect("solid"); // several solids in one file
            tokens.skip_line();
            continue;
        }
        if (!iequals(token, "facet"))
            fail_here("expected 'facet' or 'endsolid', found " + quoted(token));
        expect("normal");
        // The normal is ignored (some exporters write NaN for slivers): the corners define it.
        vec3 normal;
        for (int axis = 0; axis < 3; ++axis) number(normal[axis]);
        expect("outer");
        expect("loop");
        poly.clear();
        std::string_view next = tokens.next();
        while (iequals(next, "vertex")) {
            vec3 p;
            bool finite = true;
            for (int axis = 0; axis < 3; ++axis) finite = number(p[axis]) && finite;
            if (!finite)
                fail_here("facet " + std::to_string(facet) + ", corner " +
                          std::to_string(poly.size()) + " has a non-finite coordinate");
            poly.push_back(vertices.add(p));
            next = tokens.next();
        }
        if (next.empty()) fail(source, "truncated: file ends in facet " + std::to_string(facet));
        if (!iequals(next, "endloop"))
            fail_here("facet " + std::to_string(facet) +
                      ": expected 'vertex' or 'endloop', found " + quoted(next));
        expect("endfacet");
        if (poly.size() < 3 || !drop_welded_facet(s, poly, options))
            add_polygon(s.faces, poly, facet, options, 0, fail_here);
        ++facet;
    }
    remove_unreferenced_vertices(s);
    return s;
}

/// STL stores single precision: every coordinate must survive the conversion.
inline void check_stl_writable(const surface& s, std::string_view target) {
    check_writable(s, target);
    if (s.faces.size() > std::numeric_limits<std::uint32_t>::max())
        fail(target, "too many faces for STL");
    for (std::size_t v = 0; v < s.vertices.size(); ++v) {
        const vec3& p = s.vertices[v];
        if (!std::isfinite(static_cast<float>(p.x)) || !std::isfinite(static_cast<float>(p.y)) ||
            !std::isfinite(static_cast<float>(p.z)))
            fail(target, "vertex " + std::to_string(v) + " does not fit in single precision");
    }
}

struct stl_facet {
    std::array<std::array<float, 3>, 3> corners;
    std::array<float, 3> normal;
};

inline stl_facet make_stl_facet(const surface& s, const tri_indices& t) {
    stl_facet out{};
    vec3 rounded[3];
    for (int c = 0; c < 3; ++c) {
        const vec3& p = s.vertices[t[static_cast<std::size_t>(c)]];
        for (int axis = 0; axis < 3; ++axis) {
            const float value = static_cast<float>(p[axis]);
            out.corners[static_cast<std::size_t>(c)][static_cast<std::size_t>(axis)] = value;
            rounded[c][axis] = value;
        }
    }
    // Normal of the triangle as stored; zero for a sliver with no defined direction.
    const vec3 n = cross(rounded[1] - rounded[0], rounded[2] - rounded[0]);
    const double length = norm(n);
    for (int axis = 0; axis < 3; ++axis)
        out.normal[static_cast<std::size_t>(axis)] =
            length > 0 ? static_cast<float>(n[axis] / length) : 0.0f;
    return out;
}

inline void write_stl_unchecked(std::ostream& os, const surface& s, encoding enc) {
    if (enc == encoding::ascii) {
        // Shortest text that reads back to the same float (the reader parses as float).
        const auto put = [](text_sink& out, const std::array<float, 3>& v) {
            out << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
        };
        text_sink out(os);
        out << "solid idas\n";
        for (const tri_indices& t : s.faces) {
            const stl_facet facet = make_stl_facet(s, t);
            out << "  facet normal ";
            put(out, facet.normal);
            out << "    outer loop\n";
            for (const auto& corner : facet.corners) {
                out << "      vertex ";
                put(out, corner);
            }
            out << "    endloop\n  endfacet\n";
        }
        out << "endsolid idas\n";
        out.flush();
        return;
    }

    const auto put_u32 = [](std::string& buf, std::uint32_t v) {
        for (int shift = 0; shift < 32; shift += 8)
            buf.push_back(static_cast<char>((v >> shift) & 0xff));
    };
    std::string buf;
    // The header must not start with "solid", or naive readers would take it for ASCII.
    buf = "binary STL written by idas";
    buf.resize(80, ' ');
    put_u32(buf, static_cast<std::uint32_t>(s.faces.size()));
    constexpr std::size_t chunk = 1 << 16;
    const attribute_column* words = find_attribute(s, "stl_attribute", attribute_domain::face);
    if (words && words->width != 1) words = nullptr;
    for (std::size_t f = 0; f < s.faces.size(); ++f) {
        const stl_facet facet = make_stl_facet(s, s.faces[f]);
        for (float v : facet.normal) put_u32(buf, std::bit_cast<std::uint32_t>(v));
        for (const auto& corner : facet.corners)
            for (float v : corner) put_u32(buf, std::bit_cast<std::uint32_t>(v));
        const auto word = static_cast<std::uint16_t>(
            words ? representable(scalar_type::uint16, words->values[f]) : 0.0);
        buf.push_back(static_cast<char>(word & 0xff));
        buf.push_back(static_cast<char>(word >> 8));
        if (buf.size() >= chunk) {
            os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
            buf.clear();
        }
    }
    os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

} // namespace detail

/// Parses STL held in memory; `source` names it in error messages. Facets are numbered
/// from 0; binary errors give the byte offset.
inline surface parse_stl(std::string_view data, std::string_view source,
                         const read_options& options = {}) {
    if (detail::is_blank(data)) detail::fail(source, "file is empty");
    if (detail::stl_size_matches(data)) return detail::parse_binary_stl(data, source, options);

    std::string_view text = data;
    while (!text.empty() && detail::is_space(text.front())) text.remove_prefix(1);
    if (detail::iequals(text.substr(0, 5), "solid") && !detail::has_binary_bytes(data))
        return detail::parse_ascii_stl(data, source, options);

    if (data.size() < detail::stl_header_size)
        detail::fail(source, "truncated: a binary STL needs at least 84 bytes, the file has " +
                                 std::to_string(data.size()));
    const std::uint64_t count = detail::stl_load_u32(data.data() + 80);
    detail::fail(source,
                 "binary STL header says " + std::to_string(count) + " triangles (" +
                     std::to_string(detail::stl_header_size + detail::stl_facet_size * count) +
                     " bytes) but the file has " + std::to_string(data.size()) +
                     " bytes (truncated or corrupt)");
}

inline surface read_stl(const std::filesystem::path& path, const read_options& options = {}) {
    return parse_stl(detail::read_file(path), path.string(), options);
}

/// Attributes that STL output cannot hold: all but the facets' attribute word (binary).
inline std::vector<std::string> stl_unstored_attributes(const surface& s, encoding enc) {
    return detail::unstored_attributes(s, [&](const attribute_column& a) {
        return enc == encoding::binary && a.name == "stl_attribute" &&
               a.domain == attribute_domain::face && a.width == 1;
    });
}

/// Writes single-precision STL with per-facet normals computed from the corners.
inline void write_stl(std::ostream& os, const surface& s, encoding enc = encoding::binary) {
    detail::check_stl_writable(s, "STL output");
    detail::write_stl_unchecked(os, s, enc);
}

inline void write_stl(const std::filesystem::path& path, const surface& s,
                      encoding enc = encoding::binary) {
    detail::check_stl_writable(s, path.string());
    write_atomically(path, [&](std::ostream& os) { detail::write_stl_unchecked(os, s, enc); });
}

} // namespace idas::io
