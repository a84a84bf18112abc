// Wavefront OBJ: "v x y z [r g b]", "vt u [v [w]]", "vn x y z" and "f" statements with
// corners written as v, v/vt, v//vn or v/vt/vn (negative indices count back from the
// latest definition). Texture coordinates and normals become corner attributes "uv" and
// "normal" (a vertex on a seam has a value per face), vertex colours the vertex attribute
// "color", `usemtl` and `g` names the face tags "material" and "group"; `mtllib` lines are
// kept. Other statements (`s`, `o`, curves) are skipped.
#pragma once

#include "idas/io/atomic_file.hpp"
#include "idas/io/surface.hpp"

#include <array>
#include <bit>
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <string_view>
#include <unordered_map>

namespace idas::io {

namespace detail {

inline bool is_obj_keyword(std::string_view token) noexcept {
    const auto letter = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); };
    if (token.empty() || !(letter(token[0]) || token[0] == '_')) return false;
    return std::all_of(token.begin(), token.end(),
                       [&](char c) { return letter(c) || c == '_' || (c >= '0' && c <= '9'); });
}

/// A tag column's label table while reading: names to values, first come first numbered.
struct obj_labels {
    std::vector<std::string> names;
    std::unordered_map<std::string, std::uint32_t> index;
    std::int64_t current = -1; // -1 until the first statement naming one

    void use(std::string_view name) {
        const auto [it, added] =
            index.try_emplace(std::string(name), static_cast<std::uint32_t>(names.size()));
        if (added) names.emplace_back(name);
        current = it->second;
    }
};

/// Distinct values of a corner attribute, numbered in order of first use: OBJ's vt and
/// vn lists, rebuilt by the writer (equal values share an index, bit for bit).
class obj_value_table {
public:
    explicit obj_value_table(std::uint32_t width)
        : width_(width) {}

    /// The 1-based index of the value at `v` (width doubles), added if new.
    std::uint64_t index_of(const double* v) {
        std::array<std::uint64_t, 3> key{};
        for (std::uint32_t k = 0; k < width_; ++k) key[k] = std::bit_cast<std::uint64_t>(v[k]);
        const auto [it, added] = map_.try_emplace(key, map_.size() + 1);
        if (added) order_.push_back(v);
        return it->second;
    }
    const std::vector<const double*>& values() const noexcept { return order_; }

private:
    struct key_hash {
        std::size_t operator()(const std::array<std::uint64_t, 3>& k) const noexcept {
            std::uint64_t h = 0x9e3779b97f4a7c15ull;
            for (std::uint64_t x : k) h = (h ^ x) * 0xff51afd7ed558ccdull, h ^= h >> 32;
            return static_cast<std::size_t>(h);
        }
    };
    std::uint32_t width_;
    std::unordered_map<std::array<std::uint64_t, 3>, std::uint64_t, key_hash> map_;
    std::vector<const double*> order_;
};

inline bool obj_stores(const attribute_column& a) noexcept {
    return (a.domain == attribute_domain::corner && a.name == "uv" && a.width <= 3) ||
           (a.domain == attribute_domain::corner && a.name == "normal" && a.width == 3) ||
           (a.domain == attribute_domain::vertex && a.name == "color" && a.width == 3) ||
           (a.domain == attribute_domain::face && (a.name == "material" || a.name == "group") &&
            a.width == 1);
}

inline void write_obj_unchecked(std::ostream& os, const surface& s) {
    text_sink out(os);
    for (const std::string& line : s.header_lines) out << line << '\n';
    const auto* color = find_attribute(s, "color", attribute_domain::vertex);
    if (color && color->width != 3) color = nullptr;
    for (std::size_t v = 0; v < s.vertices.size(); ++v) {
        const vec3& p = s.vertices[v];
        out << "v " << p.x << ' ' << p.y << ' ' << p.z;
        if (color)
            for (int k = 0; k < 3; ++k) out << ' ' << color->values[3 * v + k];
        out << '\n';
    }
    // Corner streams: the distinct values, then per corner an index (0: none).
    const auto corner_stream = [&](const char* name, const char* keyword,
                                   std::vector<std::uint64_t>& index) {
        const auto* a = find_attribute(s, name, attribute_domain::corner);
        if (!a || !obj_stores(*a)) return;
        obj_value_table table(a->width);
        index.resize(3 * s.faces.size());
        for (std::size_t c = 0; c < index.size(); ++c) {
            const double* v = a->values.data() + c * a->width;
            index[c] = std::isnan(v[0]) ? 0 : table.index_of(v);
        }
        for (const double* v : table.values()) {
            out << keyword;
            for (std::uint32_t k = 0; k < a->width; ++k) out << ' ' << v[k];
            out << '\n';
        }
    };
    std::vector<std::uint64_t> uv, normal;
    corner_stream("uv", "vt", uv);
    corner_stream("normal", "vn", normal);
    const auto tag = [&](const char* name) {
        const auto* a = find_attribute(s, name, attribute_domain::face);
        return a && obj_stores(*a) ? a : nullptr;
    };
    const attribute_column *material = tag("material"), *group = tag("group");
    double last_material = -1, last_group = -1;
    const auto switch_tag = [&](const attribute_column* a, const char* keyword, double& last,
                                std::size_t f) {
        if (!a || a->values[f] == last) return;
        last = a->values[f];
        const auto i = static_cast<std::size_t>(last);
        const std::string label = i < a->labels.size() ? a->labels[i] : std::to_string(i);
        if (!label.empty()) out << keyword << ' ' << label << '\n';
    };
    for (std::size_t f = 0; f < s.faces.size(); ++f) {
        switch_tag(group, "g", last_group, f);
        switch_tag(material, "usemtl", last_material, f);
        out << 'f';
        for (std::size_t c = 0; c < 3; ++c) {
            out << ' ' << (s.faces[f][c] + 1);
            const std::uint64_t t = uv.empty() ? 0 : uv[3 * f + c];
            const std::uint64_t n = normal.empty() ? 0 : normal[3 * f + c];
            if (t || n) out << '/';
            if (t) out << t;
            if (n) out << '/' << n;
        }
        out << '\n';
    }
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
    // Per polygon corner: its vt and vn numbers (0-based, -1 for none).
    std::vector<std::int64_t> poly_uv, poly_normal;
    std::uint64_t face_number = 0;
    // Texture coordinates and normals as listed, and per triangle corner the one it uses.
    std::vector<std::array<double, 3>> uvs, normals, colors;
    std::uint32_t uv_width = 0;
    std::vector<std::int64_t> corner_uv, corner_normal;
    bool any_color = false;
    detail::obj_labels materials, groups;
    std::vector<std::int64_t> face_material, face_group;
    // Positive indices may point at vertices (or vt, vn) defined further down; remember the
    // largest such reference of each list and check it once all are known.
    struct forward_reference {
        std::int64_t index = 0;
        std::size_t line = 0;
        std::uint64_t face = 0;
    } forward, forward_uv, forward_normal;

    // Reads the numbers of a v, vt or vn line (at most `max` kept); `what` names the
    // statement in messages, `noun` its values.
    const auto read_numbers = [&](std::string_view& rest, double* out, int min, int max,
                                  const std::string& what, const char* noun, auto&& fail_here) {
        int n = 0;
        for (std::string_view token = detail::next_token(rest); !token.empty() && token[0] != '#';
             token = detail::next_token(rest)) {
            double x = 0;
            const auto status = detail::parse_double(token, x);
            if (status == detail::parse_status::not_a_number)
                fail_here(what + ": " + detail::quoted(token) + " is not a number");
            if (status == detail::parse_status::out_of_range || !std::isfinite(x))
                fail_here(what + " has a non-finite " + noun + " " + detail::quoted(token));
            if (n < max) out[n] = x;
            ++n;
        }
        if (n < min) fail_here(what + " has fewer than " + std::to_string(min) + " " + noun + "s");
        return n;
    };

    std::string_view line;
    while (lines.next(line)) {
        const auto fail_here = [&](const std::string& what) {
            detail::fail_at_line(source, lines.line_number(), what);
        };
        std::string_view rest = line;
        const std::string_view keyword = detail::next_token(rest);
        if (keyword.empty() || keyword[0] == '#') continue;

        if (keyword == "v") {
            const std::string name = "vertex " + std::to_string(s.vertices.size() + 1);
            double x[7] = {};
            // x y z, optionally w (ignored) or a colour r g b.
            const int n = read_numbers(rest, x, 3, 7, name, "coordinate", fail_here);
            s.vertices.push_back({x[0], x[1], x[2]});
            if (n == 6 && options.attributes) {
                colors.resize(s.vertices.size(), {0, 0, 0});
                colors.back() = {x[3], x[4], x[5]};
                any_color = true;
            }
        } else if (keyword == "vt") {
            std::array<double, 3> t{};
            const int n = read_numbers(rest, t.data(), 1, 3,
                                       "texture coordinate " + std::to_string(uvs.size() + 1),
                                       "value", fail_here);
            uv_width =
                std::max<std::uint32_t>(uv_width, static_cast<std::uint32_t>(std::min(n, 3)));
            uvs.push_back(t);
        } else if (keyword == "vn") {
            std::array<double, 3> nv{};
            read_numbers(rest, nv.data(), 3, 3, "normal " + std::to_string(normals.size() + 1),
                         "value", fail_here);
            normals.push_back(nv);
        } else if (keyword == "f") {
            ++face_number;
            poly.clear(), poly_uv.clear(), poly_normal.clear();
            const std::string face_name = "face " + std::to_string(face_number);
            // Resolves one index of a corner: `what` names the list, `count` its length so far.
            const auto resolve = [&](std::string_view text, const char* what, std::int64_t count,
                                     forward_reference& fwd) -> std::int64_t {
                std::int64_t index = 0;
                const char* last = text.data() + text.size();
                const auto [end, ec] = std::from_chars(text.data(), last, index);
                if (ec != std::errc() || end != last)
                    fail_here(face_name + ": " + detail::quoted(text) + " is not a " + what +
                              " index");
                if (index == 0)
                    fail_here(face_name + " references " + what + " 0; OBJ indices start at 1");
                if (index < 0) {
                    // Compare without negating: -INT64_MIN overflows.
                    if (index < -count)
                        fail_here(face_name + ": relative index " + std::to_string(index) +
                                  " points before the first " + what + " (" +
                                  std::to_string(count) + " defined so far)");
                    index += count + 1;
                } else if (index > count) {
                    if (index >= static_cast<std::int64_t>(invalid_index))
                        fail_here(face_name + " references " + what + " " + std::to_string(index) +
                                  ", beyond any possible count");
                    if (index > fwd.index) fwd = {index, lines.line_number(), face_number};
                }
                return index - 1;
            };
            for (std::string_view token = detail::next_token(rest);
                 !token.empty() && token[0] != '#'; token = detail::next_token(rest)) {
                const std::size_t slash = token.find('/');
                const std::string_view v_text = token.substr(0, slash);
                std::string_view t_text, n_text;
                if (slash != std::string_view::npos) {
                    const std::string_view tail = token.substr(slash + 1);
                    const std::size_t slash2 = tail.find('/');
                    t_text = tail.substr(0, slash2);
                    if (slash2 != std::string_view::npos) n_text = tail.substr(slash2 + 1);
                }
                if (v_text.empty())
                    fail_here(face_name + ": " + detail::quoted(token) + " is not a vertex index");
                poly.push_back(static_cast<index_t>(resolve(
                    v_text, "vertex", static_cast<std::int64_t>(s.vertices.size()), forward)));
                poly_uv.push_back(t_text.empty()
                                      ? -1
                                      : resolve(t_text, "texture coordinate",
                                                static_cast<std::int64_t>(uvs.size()), forward_uv));
                poly_normal.push_back(n_text.empty()
                                          ? -1
                                          : resolve(n_text, "normal",
                                                    static_cast<std::int64_t>(normals.size()),
                                                    forward_normal));
            }
            detail::add_polygon(s.faces, poly, face_number, options, 1, fail_here);
            // The same fan for the corner streams and the tags.
            for (std::size_t i = 1; i + 1 < poly.size(); ++i)
                for (std::size_t c : {std::size_t{0}, i, i + 1})
                    corner_uv.push_back(poly_uv[c]), corner_normal.push_back(poly_normal[c]);
            face_material.resize(s.faces.size(), materials.current);
            face_group.resize(s.faces.size(), groups.current);
        } else if (keyword == "usemtl" || keyword == "g") {
            // The rest of the line is the name (g may list several: kept as one label).
            std::string_view name = rest;
            while (!name.empty() && detail::is_space(name.front())) name.remove_prefix(1);
            while (!name.empty() && detail::is_space(name.back())) name.remove_suffix(1);
            (keyword == "g" ? groups : materials).use(name);
        } else if (keyword == "mtllib") {
            s.header_lines.emplace_back(line);
        } else if (!detail::is_obj_keyword(keyword)) {
            // Statements we do not use are skipped, but a line that is not a statement at
            // all means this is not an OBJ file (or it is corrupted).
            fail_here("unexpected " + detail::quoted(keyword) + ", expected an OBJ statement");
        }
    }

    const auto check_forward = [&](const forward_reference& fwd, std::size_t count,
                                   const char* what, const char* plural) {
        if (fwd.index > static_cast<std::int64_t>(count))
            detail::fail_at_line(source, fwd.line,
                                 "face " + std::to_string(fwd.face) + " references " + what + " " +
                                     std::to_string(fwd.index) + " but there are only " +
                                     std::to_string(count) + " " + plural);
    };
    check_forward(forward, s.vertices.size(), "vertex", "vertices");
    check_forward(forward_uv, uvs.size(), "texture coordinate", "texture coordinates");
    check_forward(forward_normal, normals.size(), "normal", "normals");
    if (s.vertices.empty()) detail::fail(source, "no vertices ('v' lines) found");
    if (!options.attributes) return s;

    const auto corner_column = [&](const char* name, const std::vector<std::array<double, 3>>& list,
                                   std::uint32_t width, const std::vector<std::int64_t>& use) {
        if (std::none_of(use.begin(), use.end(), [](std::int64_t i) { return i >= 0; })) return;
        attribute_column a{name, attribute_domain::corner, scalar_type::float64, width, {}, {}};
        a.values.reserve(use.size() * width);
        for (std::int64_t i : use)
            for (std::uint32_t k = 0; k < width; ++k)
                a.values.push_back(i >= 0 ? list[static_cast<std::size_t>(i)][k]
                                          : std::numeric_limits<double>::quiet_NaN());
        s.attributes.push_back(std::move(a));
    };
    corner_column("uv", uvs, uv_width, corner_uv);
    corner_column("normal", normals, 3, corner_normal);
    if (any_color) {
        colors.resize(s.vertices.size(), {0, 0, 0});
        attribute_column a{"color", attribute_domain::vertex, scalar_type::float64, 3, {}, {}};
        for (const auto& c : colors) a.values.insert(a.values.end(), c.begin(), c.end());
        s.attributes.push_back(std::move(a));
    }
    const auto tag_column = [&](const char* name, detail::obj_labels& labels,
                                const std::vector<std::int64_t>& tags) {
        if (labels.names.empty()) return;
        attribute_column a{name, attribute_domain::face, scalar_type::uint32, 1, {}, {}};
        // Faces before the first statement get an unnamed tag of their own.
        std::uint32_t unnamed = 0;
        if (std::find(tags.begin(), tags.end(), -1) != tags.end()) {
            unnamed = static_cast<std::uint32_t>(labels.names.size());
            labels.names.emplace_back();
        }
        a.values.reserve(tags.size());
        for (std::int64_t t : tags) a.values.push_back(t < 0 ? unnamed : static_cast<double>(t));
        a.labels = std::move(labels.names);
        s.attributes.push_back(std::move(a));
    };
    tag_column("material", materials, face_material);
    tag_column("group", groups, face_group);
    return s;
}

inline surface read_obj(const std::filesystem::path& path, const read_options& options = {}) {
    return parse_obj(detail::read_file(path), path.string(), options);
}

/// Attributes that OBJ output cannot hold (a writer's warning lists them).
inline std::vector<std::string> obj_unstored_attributes(const surface& s) {
    return detail::unstored_attributes(s, detail::obj_stores);
}

/// Writes positions with the shortest text that reads back to the same doubles, and the
/// attributes OBJ holds (see the file comment).
inline void write_obj(std::ostream& os, const surface& s) {
    detail::check_writable(s, "OBJ output");
    detail::write_obj_unchecked(os, s);
}

inline void write_obj(const std::filesystem::path& path, const surface& s) {
    detail::check_writable(s, path.string());
    write_atomically(path, [&](std::ostream& os) { detail::write_obj_unchecked(os, s); });
}

} // namespace idas::io
