// VTK XML unstructured grid (.vtu) output of tet meshes, for ParaView and friends:
// ASCII, or binary (base64-encoded inline data with 64-bit headers), with optional
// per-point and per-cell fields.
#pragma once

#include "idas/io/atomic_file.hpp"
#include "idas/io/surface.hpp"
#include "idas/io/volume.hpp"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace idas::io {

/// A named field: `components` values per point (or per cell), point after point.
struct vtu_field {
    std::string name;
    int components = 1;
    std::vector<double> values;
};

struct vtu_options {
    encoding enc = encoding::binary;
    std::vector<vtu_field> point_data;
    std::vector<vtu_field> cell_data;
};

namespace detail {

inline std::string xml_escaped(std::string_view s) {
    std::string out;
    for (char c : s) {
        switch (c) {
        case '&':
            out += "&amp;";
            break;
        case '<':
            out += "&lt;";
            break;
        case '>':
            out += "&gt;";
            break;
        case '"':
            out += "&quot;";
            break;
        default:
            out += c;
        }
    }
    return out;
}

inline void base64_append(std::string& out, const unsigned char* p, std::size_t n) {
    static constexpr char alphabet[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::size_t i = 0;
    for (; i + 3 <= n; i += 3) {
        const std::uint32_t w = std::uint32_t{p[i]} << 16 | std::uint32_t{p[i + 1]} << 8 | p[i + 2];
        for (int s = 18; s >= 0; s -= 6) out += alphabet[(w >> s) & 63];
    }
    if (i < n) {
        const std::uint32_t w =
            std::uint32_t{p[i]} << 16 | (i + 1 < n ? std::uint32_t{p[i + 1]} << 8 : 0u);
        out += alphabet[(w >> 18) & 63];
        out += alphabet[(w >> 12) & 63];
        out += i + 1 < n ? alphabet[(w >> 6) & 63] : '=';
        out += '=';
    }
}

/// One DataArray: `values` of type T, written as text or as base64 of (UInt64 byte
/// count, raw little-endian bytes) — VTK's "binary" inline format with header_type UInt64.
template <class T>
void vtu_array(std::ostream& os, const char* type, std::string_view name, int components,
               const std::vector<T>& values, encoding enc) {
    std::string head = "        <DataArray type=\"" + std::string(type) + "\"";
    if (!name.empty()) head += " Name=\"" + xml_escaped(name) + "\"";
    if (components != 1) head += " NumberOfComponents=\"" + std::to_string(components) + "\"";
    head += enc == encoding::ascii ? " format=\"ascii\">\n" : " format=\"binary\">\n";
    os << head;
    if (enc == encoding::ascii) {
        text_sink out(os);
        for (std::size_t i = 0; i < values.size(); ++i) {
            if constexpr (std::is_floating_point_v<T>)
                out << static_cast<double>(values[i]);
            else
                out << static_cast<std::uint64_t>(values[i]);
            out << ((i + 1) % 12 == 0 || i + 1 == values.size() ? '\n' : ' ');
        }
        out.flush();
    } else {
        std::vector<unsigned char> raw(8 + values.size() * sizeof(T));
        const std::uint64_t bytes = values.size() * sizeof(T);
        std::memcpy(raw.data(), &bytes, 8);
        if (!values.empty()) std::memcpy(raw.data() + 8, values.data(), bytes);
        std::string text;
        text.reserve(raw.size() / 3 * 4 + 8);
        base64_append(text, raw.data(), raw.size());
        os << text << '\n';
    }
    os << "        </DataArray>\n";
}

inline void check_fields(const std::vector<vtu_field>& fields, std::size_t count, const char* what,
                         std::string_view target) {
    for (const auto& f : fields) {
        if (f.components < 1)
            fail(target, std::string(what) + " field " + quoted(std::string_view(f.name)) +
                             " has no components");
        if (f.values.size() != count * static_cast<std::size_t>(f.components))
            fail(target, std::string(what) + " field " + quoted(std::string_view(f.name)) +
                             " has " + std::to_string(f.values.size()) + " values, expected " +
                             std::to_string(count * static_cast<std::size_t>(f.components)));
    }
}

inline void check_vtu_writable(const volume& v, const vtu_options& options,
                               std::string_view target) {
    check_writable(v, target);
    check_fields(options.point_data, v.vertices.size(), "point", target);
    check_fields(options.cell_data, v.tets.size(), "cell", target);
}

inline void write_vtu_unchecked(std::ostream& os, const volume& v, const vtu_options& options) {
    static_assert(std::endian::native == std::endian::little,
                  "the binary VTU writer assumes little-endian");
    const encoding enc = options.enc;
    os << "<?xml version=\"1.0\"?>\n"
          "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
          "header_type=\"UInt64\">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\""
       << v.vertices.size() << "\" NumberOfCells=\"" << v.tets.size() << "\">\n";
    const auto fields = [&](const char* tag, const std::vector<vtu_field>& list) {
        if (list.empty()) return;
        os << "      <" << tag << ">\n";
        for (const auto& f : list) vtu_array(os, "Float64", f.name, f.components, f.values, enc);
        os << "      </" << tag << ">\n";
    };
    fields("PointData", options.point_data);
    fields("CellData", options.cell_data);
    std::vector<double> points;
    points.reserve(3 * v.vertices.size());
    for (const vec3& p : v.vertices) points.insert(points.end(), {p.x, p.y, p.z});
    os << "      <Points>\n";
    vtu_array(os, "Float64", "Points", 3, points, enc);
    os << "      </Points>\n      <Cells>\n";
    std::vector<std::int64_t> connectivity, offsets;
    connectivity.reserve(4 * v.tets.size()), offsets.reserve(v.tets.size());
    for (const auto& t : v.tets) {
        for (index_t x : t) connectivity.push_back(x);
        offsets.push_back(static_cast<std::int64_t>(connectivity.size()));
    }
    vtu_array(os, "Int64", "connectivity", 1, connectivity, enc);
    vtu_array(os, "Int64", "offsets", 1, offsets, enc);
    const std::vector<std::uint8_t> types(v.tets.size(), 10); // VTK_TETRA
    vtu_array(os, "UInt8", "types", 1, types, enc);
    os << "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
}

} // namespace detail

inline void write_vtu(std::ostream& os, const volume& v, const vtu_options& options = {}) {
    detail::check_vtu_writable(v, options, "VTU output");
    detail::write_vtu_unchecked(os, v, options);
}

/// Writes atomically: the target is either fully replaced or untouched.
inline void write_vtu(const std::filesystem::path& path, const volume& v,
                      const vtu_options& options = {}) {
    detail::check_vtu_writable(v, options, path.string());
    write_atomically(path, [&](std::ostream& os) { detail::write_vtu_unchecked(os, v, options); });
}

} // namespace idas::io
