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
#include <exception>
#include <filesystem>
#include <ostream>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

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
    write_items(out, s.vertices.size(), [&](text_sink& to, std::size_t v) {
        const vec3& p = s.vertices[v];
        to << "v " << p.x << ' ' << p.y << ' ' << p.z;
        if (color)
            for (int k = 0; k < 3; ++k) to << ' ' << color->values[3 * v + k];
        to << '\n';
    });
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
    // A face whose tag differs from the previous face's starts with a g or usemtl line.
    const auto switch_tag = [&](text_sink& to, const attribute_column* a, const char* keyword,
                                std::size_t f) {
        if (!a || (f > 0 && a->values[f] == a->values[f - 1])) return;
        const auto i = static_cast<std::size_t>(a->values[f]);
        const std::string label = i < a->labels.size() ? a->labels[i] : std::to_string(i);
        if (!label.empty()) to << keyword << ' ' << label << '\n';
    };
    write_items(out, s.faces.size(), [&](text_sink& to, std::size_t f) {
        switch_tag(to, group, "g", f);
        switch_tag(to, material, "usemtl", f);
        to << 'f';
        for (std::size_t c = 0; c < 3; ++c) {
            to << ' ' << (s.faces[f][c] + 1);
            const std::uint64_t t = uv.empty() ? 0 : uv[3 * f + c];
            const std::uint64_t n = normal.empty() ? 0 : normal[3 * f + c];
            if (t || n) to << '/';
            if (t) to << t;
            if (n) to << '/' << n;
        }
        to << '\n';
    });
    out.flush();
}

} // namespace detail

// ---- reading ------------------------------------------------------------------------------
// Large files are read in parallel: the text is cut into stretches of whole lines; a first
// parallel pass counts each stretch's lines and statements, so that a second one parses
// every stretch knowing the line, vertex, texture coordinate, normal and face numbers it
// starts at (relative indices and error messages come out as in one serial pass); the
// stretches are then joined in order. The first problem in the file is the one reported.

namespace detail {

/// Lines and statements before a stretch of the file.
struct obj_counts {
    std::size_t lines = 0, vertices = 0, uvs = 0, normals = 0, faces = 0;

    obj_counts& operator+=(const obj_counts& o) noexcept {
        lines += o.lines, vertices += o.vertices, uvs += o.uvs, normals += o.normals;
        faces += o.faces;
        return *this;
    }
};

/// Counts what parse_obj_stretch will number: lines, and v, vt, vn and f statements.
inline obj_counts count_obj_statements(std::string_view text) noexcept {
    obj_counts c;
    line_reader lines(text);
    std::string_view line;
    while (lines.next(line)) {
        const std::string_view keyword = next_token(line);
        if (keyword == "v")
            ++c.vertices;
        else if (keyword == "vt")
            ++c.uvs;
        else if (keyword == "vn")
            ++c.normals;
        else if (keyword == "f")
            ++c.faces;
    }
    c.lines = lines.line_number();
    return c;
}

/// Positive indices may point at vertices (or vt, vn) defined further down; the largest
/// such reference of each list is checked once all are known.
struct obj_forward_reference {
    std::int64_t index = 0;
    std::size_t line = 0;
    std::uint64_t face = 0;

    void merge(const obj_forward_reference& later) noexcept {
        if (later.index > index) *this = later;
    }
};

/// What one stretch of lines holds. Tags are numbered by the stretch's own label tables;
/// faces before the stretch's first usemtl (g) carry `inherited`.
struct obj_stretch {
    static constexpr std::int64_t inherited = -2;
    std::vector<vec3> vertices;
    std::vector<std::array<double, 3>> colors, uvs, normals; // colors: per vertex when any
    bool any_color = false;
    std::uint32_t uv_width = 0;
    std::vector<tri_indices> faces;
    std::vector<std::int64_t> corner_uv, corner_normal; // per triangle corner, -1 for none
    obj_labels materials{{}, {}, inherited}, groups{{}, {}, inherited};
    std::vector<std::int64_t> face_material, face_group;
    obj_forward_reference forward, forward_uv, forward_normal;
    std::vector<std::string> header_lines;
};

/// Parses the whole lines of `text`, which start after the statements counted in `before`.
inline void parse_obj_stretch(std::string_view text, const obj_counts& before,
                              std::string_view source, const read_options& options,
                              obj_stretch& out) {
    line_reader lines(text);
    std::vector<index_t> poly;
    // Per polygon corner: its vt and vn numbers (0-based, -1 for none).
    std::vector<std::int64_t> poly_uv, poly_normal;
    std::uint64_t face_number = before.faces;
    const auto vertex_count = [&] { return before.vertices + out.vertices.size(); };

    // Reads the numbers of a v, vt or vn line (at most `max` kept); `what` names the
    // statement in messages, `noun` its values.
    const auto read_numbers = [&](std::string_view& rest, double* numbers, int min, int max,
                                  auto&& what, const char* noun, auto&& fail_here) {
        int n = 0;
        for (std::string_view token = next_token(rest); !token.empty() && token[0] != '#';
             token = next_token(rest)) {
            double x = 0;
            const auto status = parse_double(token, x);
            if (status == parse_status::not_a_number)
                fail_here(what() + ": " + quoted(token) + " is not a number");
            if (status == parse_status::out_of_range || !std::isfinite(x))
                fail_here(what() + " has a non-finite " + noun + " " + quoted(token));
            if (n < max) numbers[n] = x;
            ++n;
        }
        if (n < min)
            fail_here(what() + " has fewer than " + std::to_string(min) + " " + noun + "s");
        return n;
    };

    std::string_view line;
    while (lines.next(line)) {
        const auto fail_here = [&](const std::string& what) {
            fail_at_line(source, before.lines + lines.line_number(), what);
        };
        std::string_view rest = line;
        const std::string_view keyword = next_token(rest);
        if (keyword.empty() || keyword[0] == '#') continue;

        if (keyword == "v") {
            const auto name = [&] { return "vertex " + std::to_string(vertex_count() + 1); };
            double x[7] = {};
            // x y z, optionally w (ignored) or a colour r g b.
            const int n = read_numbers(rest, x, 3, 7, name, "coordinate", fail_here);
            out.vertices.push_back({x[0], x[1], x[2]});
            if (n == 6 && options.attributes) {
                out.colors.resize(out.vertices.size(), {0, 0, 0});
                out.colors.back() = {x[3], x[4], x[5]};
                out.any_color = true;
            }
        } else if (keyword == "vt") {
            std::array<double, 3> t{};
            const auto name = [&] {
                return "texture coordinate " + std::to_string(before.uvs + out.uvs.size() + 1);
            };
            const int n = read_numbers(rest, t.data(), 1, 3, name, "value", fail_here);
            out.uv_width =
                std::max<std::uint32_t>(out.uv_width, static_cast<std::uint32_t>(std::min(n, 3)));
            out.uvs.push_back(t);
        } else if (keyword == "vn") {
            std::array<double, 3> nv{};
            const auto name = [&] {
                return "normal " + std::to_string(before.normals + out.normals.size() + 1);
            };
            read_numbers(rest, nv.data(), 3, 3, name, "value", fail_here);
            out.normals.push_back(nv);
        } else if (keyword == "f") {
            ++face_number;
            poly.clear(), poly_uv.clear(), poly_normal.clear();
            const auto face_name = [&] { return "face " + std::to_string(face_number); };
            // Resolves one index of a corner: `what` names the list, `count` its length so far.
            const auto resolve = [&](std::string_view text, const char* what, std::int64_t count,
                                     obj_forward_reference& fwd) -> std::int64_t {
                std::int64_t index = 0;
                const char* last = text.data() + text.size();
                const auto [end, ec] = std::from_chars(text.data(), last, index);
                if (ec != std::errc() || end != last)
                    fail_here(face_name() + ": " + quoted(text) + " is not a " + what + " index");
                if (index == 0)
                    fail_here(face_name() + " references " + what + " 0; OBJ indices start at 1");
                if (index < 0) {
                    // Compare without negating: -INT64_MIN overflows.
                    if (index < -count)
                        fail_here(face_name() + ": relative index " + std::to_string(index) +
                                  " points before the first " + what + " (" +
                                  std::to_string(count) + " defined so far)");
                    index += count + 1;
                } else if (index > count) {
                    if (index >= static_cast<std::int64_t>(invalid_index))
                        fail_here(face_name() + " references " + what + " " +
                                  std::to_string(index) + ", beyond any possible count");
                    if (index > fwd.index)
                        fwd = {index, before.lines + lines.line_number(), face_number};
                }
                return index - 1;
            };
            for (std::string_view token = next_token(rest); !token.empty() && token[0] != '#';
                 token = next_token(rest)) {
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
                    fail_here(face_name() + ": " + quoted(token) + " is not a vertex index");
                poly.push_back(static_cast<index_t>(resolve(
                    v_text, "vertex", static_cast<std::int64_t>(vertex_count()), out.forward)));
                poly_uv.push_back(
                    t_text.empty() ? -1
                                   : resolve(t_text, "texture coordinate",
                                             static_cast<std::int64_t>(before.uvs + out.uvs.size()),
                                             out.forward_uv));
                poly_normal.push_back(
                    n_text.empty()
                        ? -1
                        : resolve(n_text, "normal",
                                  static_cast<std::int64_t>(before.normals + out.normals.size()),
                                  out.forward_normal));
            }
            add_polygon(out.faces, poly, face_number, options, 1, fail_here);
            // The same fan for the corner streams and the tags.
            for (std::size_t i = 1; i + 1 < poly.size(); ++i)
                for (std::size_t c : {std::size_t{0}, i, i + 1})
                    out.corner_uv.push_back(poly_uv[c]),
                        out.corner_normal.push_back(poly_normal[c]);
            out.face_material.resize(out.faces.size(), out.materials.current);
            out.face_group.resize(out.faces.size(), out.groups.current);
        } else if (keyword == "usemtl" || keyword == "g") {
            // The rest of the line is the name (g may list several: kept as one label).
            std::string_view name = rest;
            while (!name.empty() && is_space(name.front())) name.remove_prefix(1);
            while (!name.empty() && is_space(name.back())) name.remove_suffix(1);
            (keyword == "g" ? out.groups : out.materials).use(name);
        } else if (keyword == "mtllib") {
            out.header_lines.emplace_back(line);
        } else if (!is_obj_keyword(keyword)) {
            // Statements we do not use are skipped, but a line that is not a statement at
            // all means this is not an OBJ file (or it is corrupted).
            fail_here("unexpected " + quoted(keyword) + ", expected an OBJ statement");
        }
    }
}

/// Cuts `text` after line ends into about `n` stretches of whole lines.
inline std::vector<std::string_view> split_into_stretches(std::string_view text, std::size_t n) {
    std::vector<std::string_view> out;
    std::size_t begin = 0;
    for (std::size_t k = 1; k <= n && begin < text.size(); ++k) {
        std::size_t end = k == n ? text.size() : std::max(begin, text.size() / n * k);
        if (end < text.size()) {
            const std::size_t nl = text.find('\n', end);
            end = nl == std::string_view::npos ? text.size() : nl + 1;
        }
        if (end > begin) out.push_back(text.substr(begin, end - begin));
        begin = end;
    }
    return out;
}

/// Text below this size is parsed in one stretch: starting tasks would cost more.
inline constexpr std::size_t obj_stretch_bytes = std::size_t{1} << 20;

/// parse_obj in `stretches` stretches (tests compare any count with one).
inline surface parse_obj_in(std::string_view text, std::string_view source,
                            const read_options& options, std::size_t stretches) {
    text = detail::strip_utf8_bom(text);
    if (detail::is_blank(text)) detail::fail(source, "file is empty");
    const std::vector<std::string_view> pieces = detail::split_into_stretches(text, stretches);
    std::vector<detail::obj_counts> before(pieces.size() + 1);
    std::vector<detail::obj_stretch> parts(pieces.size());
    std::vector<std::exception_ptr> failures(pieces.size());
    const auto each_piece = [&](auto&& fn) {
        tbb::parallel_for(std::size_t{0}, pieces.size(), [&](std::size_t i) {
            try {
                fn(i);
            } catch (...) {
                failures[i] = std::current_exception();
            }
        });
        for (const auto& f : failures) // the first problem in the file
            if (f) std::rethrow_exception(f);
    };
    each_piece([&](std::size_t i) { before[i + 1] = detail::count_obj_statements(pieces[i]); });
    for (std::size_t i = 0; i < pieces.size(); ++i) before[i + 1] += before[i];
    each_piece([&](std::size_t i) {
        detail::parse_obj_stretch(pieces[i], before[i], source, options, parts[i]);
    });

    surface s;
    detail::obj_forward_reference forward, forward_uv, forward_normal;
    std::vector<std::size_t> face_start(parts.size() + 1, 0);
    for (std::size_t i = 0; i < parts.size(); ++i) {
        forward.merge(parts[i].forward), forward_uv.merge(parts[i].forward_uv);
        forward_normal.merge(parts[i].forward_normal);
        face_start[i + 1] = face_start[i] + parts[i].faces.size();
    }
    const std::size_t vertex_total = before.back().vertices;
    const auto check_forward = [&](const detail::obj_forward_reference& fwd, std::size_t count,
                                   const char* what, const char* plural) {
        if (fwd.index > static_cast<std::int64_t>(count))
            detail::fail_at_line(source, fwd.line,
                                 "face " + std::to_string(fwd.face) + " references " + what + " " +
                                     std::to_string(fwd.index) + " but there are only " +
                                     std::to_string(count) + " " + plural);
    };
    check_forward(forward, vertex_total, "vertex", "vertices");
    check_forward(forward_uv, before.back().uvs, "texture coordinate", "texture coordinates");
    check_forward(forward_normal, before.back().normals, "normal", "normals");
    if (vertex_total == 0) detail::fail(source, "no vertices ('v' lines) found");

    // Joined in order, each stretch copied to its place in parallel.
    s.vertices.resize(vertex_total);
    s.faces.resize(face_start.back());
    tbb::parallel_for(std::size_t{0}, parts.size(), [&](std::size_t i) {
        std::copy(parts[i].vertices.begin(), parts[i].vertices.end(),
                  s.vertices.begin() + std::ptrdiff_t(before[i].vertices));
        std::copy(parts[i].faces.begin(), parts[i].faces.end(),
                  s.faces.begin() + std::ptrdiff_t(face_start[i]));
    });
    for (auto& p : parts)
        for (auto& h : p.header_lines) s.header_lines.push_back(std::move(h));
    if (!options.attributes) return s;

    // Lists that attributes index, joined.
    const auto joined = [&](auto member) {
        std::vector<std::array<double, 3>> all;
        for (const auto& p : parts) all.insert(all.end(), (p.*member).begin(), (p.*member).end());
        return all;
    };
    const auto joined_corners = [&](auto member) {
        std::vector<std::int64_t> all;
        all.reserve(3 * s.faces.size());
        for (const auto& p : parts) all.insert(all.end(), (p.*member).begin(), (p.*member).end());
        return all;
    };
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
    std::uint32_t uv_width = 0;
    for (const auto& p : parts) uv_width = std::max(uv_width, p.uv_width);
    corner_column("uv", joined(&detail::obj_stretch::uvs), uv_width,
                  joined_corners(&detail::obj_stretch::corner_uv));
    corner_column("normal", joined(&detail::obj_stretch::normals), 3,
                  joined_corners(&detail::obj_stretch::corner_normal));
    if (std::any_of(parts.begin(), parts.end(), [](const auto& p) { return p.any_color; })) {
        attribute_column a{"color", attribute_domain::vertex, scalar_type::float64, 3, {}, {}};
        a.values.assign(3 * vertex_total, 0.0);
        for (std::size_t i = 0; i < parts.size(); ++i)
            for (std::size_t v = 0; v < parts[i].colors.size(); ++v)
                for (int k = 0; k < 3; ++k)
                    a.values[3 * (before[i].vertices + v) + std::size_t(k)] = parts[i].colors[v][k];
        s.attributes.push_back(std::move(a));
    }
    // Tags: each stretch's labels join the file's table in order of first use (as one
    // serial pass numbers them); its faces before its first statement take the tag in
    // force where it starts.
    const auto tag_column = [&](const char* name, detail::obj_labels detail::obj_stretch::*labels,
                                std::vector<std::int64_t> detail::obj_stretch::*local_tags) {
        detail::obj_labels all;
        std::vector<std::int64_t> tags;
        tags.reserve(s.faces.size());
        for (const auto& p : parts) {
            std::vector<std::int64_t> global((p.*labels).names.size());
            for (std::size_t k = 0; k < global.size(); ++k) {
                const std::int64_t current = all.current;
                all.use((p.*labels).names[k]);
                global[k] = all.current;
                all.current = current;
            }
            const std::int64_t start = all.current;
            for (std::int64_t t : p.*local_tags)
                tags.push_back(t == detail::obj_stretch::inherited ? start
                                                                   : global[std::size_t(t)]);
            if ((p.*labels).current != detail::obj_stretch::inherited)
                all.current = global[std::size_t((p.*labels).current)];
        }
        if (all.names.empty()) return;
        attribute_column a{name, attribute_domain::face, scalar_type::uint32, 1, {}, {}};
        // Faces before the first statement get an unnamed tag of their own.
        std::uint32_t unnamed = 0;
        if (std::find(tags.begin(), tags.end(), -1) != tags.end()) {
            unnamed = static_cast<std::uint32_t>(all.names.size());
            all.names.emplace_back();
        }
        a.values.reserve(tags.size());
        for (std::int64_t t : tags) a.values.push_back(t < 0 ? unnamed : static_cast<double>(t));
        a.labels = std::move(all.names);
        s.attributes.push_back(std::move(a));
    };
    tag_column("material", &detail::obj_stretch::materials, &detail::obj_stretch::face_material);
    tag_column("group", &detail::obj_stretch::groups, &detail::obj_stretch::face_group);
    return s;
}

} // namespace detail

/// Parses OBJ text; `source` names it in error messages. Vertex and face numbers in
/// messages are 1-based, as OBJ counts them.
inline surface parse_obj(std::string_view text, std::string_view source,
                         const read_options& options = {}) {
    // Stretches of about a megabyte, at most a few per thread (load balance).
    const auto threads = static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
    const std::size_t n = std::clamp<std::size_t>(text.size() / detail::obj_stretch_bytes, 1,
                                                  threads == 1 ? 1 : 4 * threads);
    return detail::parse_obj_in(text, source, options, n);
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
