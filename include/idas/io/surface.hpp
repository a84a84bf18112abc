// The in-memory triangle surface that every file reader produces and every writer consumes,
// plus the small parsing toolkit the format readers share (namespace detail).
#pragma once

#include "idas/core/types.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace idas::io {

/// How a file stores a value; attributes are written back with the type they were read with.
enum class scalar_type : std::uint8_t {
    int8,
    uint8,
    int16,
    uint16,
    int32,
    uint32,
    float32,
    float64
};

/// What an attribute's values belong to. A corner value belongs to one face's use of a
/// vertex (OBJ `vt`/`vn` indices, PLY `texcoord` lists), so a vertex on a texture seam can
/// carry a different value in each face around it.
enum class attribute_domain : std::uint8_t { vertex, face, corner };

/// One attribute column read from a file. Values are stored as doubles, which hold every
/// value of every scalar_type exactly, element after element (`width` values each; a corner
/// column holds 3 elements per face, in the face's corner order). A corner value may be
/// NaN where the file gives none (an OBJ face without `vt` among faces with them).
struct attribute_column {
    std::string name;
    attribute_domain domain = attribute_domain::vertex;
    scalar_type type = scalar_type::float64;
    std::uint32_t width = 1;
    std::vector<double> values;
    /// Names of the values of a tag column (OBJ `usemtl` and `g` names): value i is labels[i].
    std::vector<std::string> labels;

    std::size_t elements() const noexcept { return width == 0 ? 0 : values.size() / width; }
};

/// A triangle soup as stored in a file: positions and 0-based corner indices. Readers
/// guarantee every index is in range and no face repeats a vertex; they do not check
/// manifoldness (the mesh layer does).
struct surface {
    surface() = default;
    /// Positions and faces only, as the editing algorithms hand them back (to_arrays()).
    surface(std::vector<vec3> v, std::vector<tri_indices> f)
        : vertices(std::move(v))
        , faces(std::move(f)) {}

    std::vector<vec3> vertices;
    std::vector<tri_indices> faces;
    /// Everything else the file carries per vertex, face or corner (read_options::attributes).
    std::vector<attribute_column> attributes;
    /// Lines a writer of the same format repeats verbatim (OBJ `mtllib`).
    std::vector<std::string> header_lines;
    /// What the reader read past without keeping it, as "name (what)": PLY list properties
    /// other than texcoord and PLY elements other than vertex and face. Callers warn.
    std::vector<std::string> skipped;
    /// Faces the reader left out: STL facets whose corners weld into fewer than three
    /// vertices (STL stores positions only, so such a facet cannot be told apart from a
    /// degenerate one). Other readers refuse degenerate faces instead.
    std::size_t dropped_faces = 0;
};

struct read_options {
    /// Split polygons with more than three corners into a fan of triangles around their
    /// first corner; when false such polygons are refused.
    bool triangulate_polygons = true;
    /// STL stores every triangle corner separately; merge corners with exactly equal
    /// coordinates into one vertex so the result is an indexed mesh.
    bool weld_stl = true;
    /// Read texture coordinates, normals, colours, tags and other properties into
    /// surface::attributes; when false they are skipped (positions and faces only).
    bool attributes = true;
};

/// The attribute called `name` in `domain`, or nullptr.
inline attribute_column* find_attribute(surface& s, std::string_view name,
                                        attribute_domain domain) noexcept {
    for (auto& a : s.attributes)
        if (a.name == name && a.domain == domain) return &a;
    return nullptr;
}
inline const attribute_column* find_attribute(const surface& s, std::string_view name,
                                              attribute_domain domain) noexcept {
    return find_attribute(const_cast<surface&>(s), name, domain);
}

inline const char* to_string(scalar_type t) noexcept {
    constexpr const char* names[] = {"int8",  "uint8",  "int16",   "uint16",
                                     "int32", "uint32", "float32", "float64"};
    return names[static_cast<int>(t)];
}
inline const char* to_string(attribute_domain d) noexcept {
    constexpr const char* names[] = {"vertex", "face", "corner"};
    return names[static_cast<int>(d)];
}

/// The nearest value of type t to x (integers rounded and clamped, float32 rounded), as a
/// double: what interpolated values become before they are stored or written.
inline double representable(scalar_type t, double x) noexcept {
    const auto clamp_round = [&](double lo, double hi) {
        if (std::isnan(x)) return 0.0;
        return std::clamp(std::nearbyint(x), lo, hi);
    };
    switch (t) {
    case scalar_type::int8:
        return clamp_round(-128, 127);
    case scalar_type::uint8:
        return clamp_round(0, 255);
    case scalar_type::int16:
        return clamp_round(-32768, 32767);
    case scalar_type::uint16:
        return clamp_round(0, 65535);
    case scalar_type::int32:
        return clamp_round(-2147483648.0, 2147483647.0);
    case scalar_type::uint32:
        return clamp_round(0, 4294967295.0);
    case scalar_type::float32:
        return std::isfinite(x) ? static_cast<double>(static_cast<float>(x)) : x;
    case scalar_type::float64:
        return x;
    }
    return x;
}

/// Encoding for the formats that have both (PLY, STL).
enum class encoding { ascii, binary };

namespace detail {

// ---- errors ---------------------------------------------------------------------------

// Every reader error reads "<source>: [line N: ]<what>", so the user sees the file first.
[[noreturn]] inline void fail(std::string_view source, std::string_view what) {
    std::string msg;
    msg.reserve(source.size() + what.size() + 2);
    msg.append(source).append(": ").append(what);
    throw input_error(msg);
}

[[noreturn]] inline void fail_at_line(std::string_view source, std::size_t line,
                                      std::string_view what) {
    fail(source, "line " + std::to_string(line) + ": " + std::string(what));
}

// Quotes a token for an error message, shortened so a megabyte of garbage on one line
// does not end up in the exception text.
inline std::string quoted(std::string_view token) {
    constexpr std::size_t max_shown = 40;
    std::string out = "'";
    for (char c : token.substr(0, max_shown)) {
        const auto u = static_cast<unsigned char>(c);
        out += (u >= 0x20 && u < 0x7f) ? c : '?';
    }
    if (token.size() > max_shown) out += "...";
    return out + "'";
}

// ---- whole-file input -----------------------------------------------------------------

/// Reads the whole file into memory: one system call for typical files, and parsing from a
/// contiguous buffer is much faster than going through a stream.
inline std::string read_file(const std::filesystem::path& path) {
    const std::string name = path.string();
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) fail(name, "cannot open: is a directory");
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(name, "cannot open file");
    std::string data;
    const auto size = std::filesystem::file_size(path, ec);
    if (!ec) {
        data.resize(static_cast<std::size_t>(size));
        in.read(data.data(), static_cast<std::streamsize>(data.size()));
        data.resize(static_cast<std::size_t>(in.gcount()));
    }
    // Pick up anything the size did not report (pipes, files that grew meanwhile).
    char chunk[1 << 14];
    while (in.read(chunk, sizeof chunk) || in.gcount() > 0)
        data.append(chunk, static_cast<std::size_t>(in.gcount()));
    if (in.bad()) fail(name, "read error");
    return data;
}

inline bool is_space(char c) noexcept {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

inline bool is_blank(std::string_view text) noexcept {
    return std::all_of(text.begin(), text.end(), is_space);
}

/// Text written by some Windows tools starts with a UTF-8 byte order mark; skip it.
inline std::string_view strip_utf8_bom(std::string_view text) noexcept {
    return text.starts_with("\xEF\xBB\xBF") ? text.substr(3) : text;
}

// ---- number parsing -------------------------------------------------------------------

enum class parse_status { ok, not_a_number, out_of_range };

/// Parses a whole token as a float or double, rounding correctly from the decimal text.
/// Accepts a leading '+', which std::from_chars rejects but printf-style writers may
/// produce. Values too small for the type become zero (like strtod); values too large
/// report out_of_range.
template <class Real>
parse_status parse_real(std::string_view token, Real& out) noexcept {
    const char* first = token.data();
    const char* last = first + token.size();
    if (first != last && *first == '+') {
        ++first;
        if (first != last && (*first == '+' || *first == '-')) return parse_status::not_a_number;
    }
    const auto [end, ec] = std::from_chars(first, last, out);
    if (end != last || first == last) return parse_status::not_a_number;
    if (ec == std::errc::result_out_of_range) {
        // from_chars reports underflow and overflow alike; tell them apart by the exponent.
        const auto e = token.find_last_of("eE");
        if (e != std::string_view::npos && e + 1 < token.size() && token[e + 1] == '-') {
            out = (token.find('-') < e) ? -Real(0) : Real(0);
            return parse_status::ok;
        }
        return parse_status::out_of_range;
    }
    return ec == std::errc() ? parse_status::ok : parse_status::not_a_number;
}

inline parse_status parse_double(std::string_view token, double& out) noexcept {
    return parse_real(token, out);
}

/// Parses a whole token as a signed integer.
inline bool parse_int(std::string_view token, std::int64_t& out) noexcept {
    const char* first = token.data();
    const char* last = first + token.size();
    if (first != last && *first == '+') ++first;
    const auto [end, ec] = std::from_chars(first, last, out);
    return ec == std::errc() && end == last && first != last;
}

// ---- text scanning ----------------------------------------------------------------------

/// Splits a buffer into lines ("\n" or "\r\n"), counting them for error messages.
class line_reader {
public:
    explicit line_reader(std::string_view text)
        : text_(text) {}

    bool next(std::string_view& line) noexcept {
        if (pos_ >= text_.size()) return false;
        const char* start = text_.data() + pos_;
        const auto* nl = static_cast<const char*>(std::memchr(start, '\n', text_.size() - pos_));
        std::size_t len = nl ? static_cast<std::size_t>(nl - start) : text_.size() - pos_;
        pos_ += len + (nl ? 1 : 0);
        ++line_no_;
        if (len > 0 && start[len - 1] == '\r') --len;
        line = std::string_view(start, len);
        return true;
    }

    std::size_t line_number() const noexcept { return line_no_; }
    std::size_t position() const noexcept { return pos_; }

private:
    std::string_view text_;
    std::size_t pos_ = 0;
    std::size_t line_no_ = 0;
};

/// Takes the next whitespace-separated token off the front of `rest` (empty at the end).
inline std::string_view next_token(std::string_view& rest) noexcept {
    std::size_t i = 0;
    while (i < rest.size() && is_space(rest[i])) ++i;
    std::size_t j = i;
    while (j < rest.size() && !is_space(rest[j])) ++j;
    const std::string_view token = rest.substr(i, j - i);
    rest.remove_prefix(j);
    return token;
}

/// Token stream over a whole buffer, ignoring line structure but tracking the line number
/// (ASCII PLY and ASCII STL are whitespace-separated streams).
class token_reader {
public:
    explicit token_reader(std::string_view text, std::size_t first_line = 1)
        : text_(text)
        , line_(first_line) {}

    /// Next token, or an empty view at the end of the text.
    std::string_view next() noexcept {
        skip_space();
        const std::size_t start = pos_;
        while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
        return text_.substr(start, pos_ - start);
    }

    /// Skips the remainder of the current line (e.g. an STL solid name).
    void skip_line() noexcept {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    }

    bool at_end() noexcept {
        skip_space();
        return pos_ >= text_.size();
    }

    /// Line of the next token (after skipping whitespace) or of the last one read.
    std::size_t line() const noexcept { return line_; }

private:
    void skip_space() noexcept {
        while (pos_ < text_.size() && is_space(text_[pos_])) {
            if (text_[pos_] == '\n') ++line_;
            ++pos_;
        }
    }

    std::string_view text_;
    std::size_t pos_ = 0;
    std::size_t line_;
};

// ---- faces ----------------------------------------------------------------------------

/// Capacity to reserve for `count` records when each needs at least `min_bytes` of the
/// `available` input: a header claiming four billion faces must not allocate for them.
inline std::size_t capped_reserve(std::uint64_t count, std::size_t available,
                                  std::size_t min_bytes) noexcept {
    return static_cast<std::size_t>(
        std::min<std::uint64_t>(count, available / std::max<std::size_t>(min_bytes, 1)));
}

/// Validates one polygon (indices already resolved and range-checked) and appends it as
/// triangles. `fail` receives the reason and must throw; `number_base` is 1 for OBJ so
/// messages show vertex numbers the way the file writes them.
template <class Fail>
void add_polygon(std::vector<tri_indices>& faces, std::span<const index_t> poly,
                 std::uint64_t face_number, const read_options& options, index_t number_base,
                 Fail&& fail) {
    const auto face_name = [&] { return "face " + std::to_string(face_number); };
    if (poly.size() < 3) {
        fail(face_name() + " has " + std::to_string(poly.size()) +
             " vertices; a face needs at least 3");
    }
    if (poly.size() > 3 && !options.triangulate_polygons) {
        fail(face_name() + " is a polygon with " + std::to_string(poly.size()) +
             " vertices and triangulate_polygons is off");
    }
    // A repeated vertex makes a degenerate face; quadratic search is fine for the small
    // polygons files hold, long ones are checked on a sorted copy.
    const auto degenerate = [&](index_t v) {
        fail(face_name() + " is degenerate: it uses vertex " + std::to_string(v + number_base) +
             " more than once");
    };
    if (poly.size() <= 32) {
        for (std::size_t i = 0; i < poly.size(); ++i)
            for (std::size_t j = i + 1; j < poly.size(); ++j)
                if (poly[i] == poly[j]) degenerate(poly[i]);
    } else {
        std::vector<index_t> sorted(poly.begin(), poly.end());
        std::sort(sorted.begin(), sorted.end());
        const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
        if (dup != sorted.end()) degenerate(*dup);
    }
    for (std::size_t i = 1; i + 1 < poly.size(); ++i)
        faces.push_back({poly[0], poly[i], poly[i + 1]});
}

// ---- writer support -------------------------------------------------------------------

/// Writers refuse what readers would refuse, so every file idas writes reads back.
inline void check_writable(const surface& s, std::string_view target) {
    if (s.vertices.size() >= invalid_index) fail(target, "too many vertices to write");
    for (std::size_t v = 0; v < s.vertices.size(); ++v)
        if (!is_finite(s.vertices[v]))
            fail(target, "vertex " + std::to_string(v) + " has a non-finite coordinate");
    for (std::size_t f = 0; f < s.faces.size(); ++f) {
        const tri_indices& t = s.faces[f];
        for (index_t v : t)
            if (v >= s.vertices.size())
                fail(target, "face " + std::to_string(f) + " references vertex " +
                                 std::to_string(v) + " but there are only " +
                                 std::to_string(s.vertices.size()) + " vertices");
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            fail(target, "face " + std::to_string(f) + " is degenerate (repeats a vertex)");
    }
    for (const attribute_column& a : s.attributes) {
        const std::size_t expected = a.domain == attribute_domain::vertex ? s.vertices.size()
                                     : a.domain == attribute_domain::face ? s.faces.size()
                                                                          : 3 * s.faces.size();
        if (a.width == 0 || a.values.size() != expected * a.width)
            fail(target, std::string(to_string(a.domain)) + " attribute \"" + a.name + "\" has " +
                             std::to_string(a.values.size()) + " values, expected " +
                             std::to_string(expected) + " x " + std::to_string(a.width));
        if (a.name.empty() || a.name.find_first_of(" \t\r\n\"") != std::string::npos)
            fail(target,
                 "attribute name " + io::detail::quoted(a.name) + " is empty or holds white space");
    }
}

/// The names of the attributes that `kept(column)` says a format cannot store, for the
/// writers' warnings ("name (domain)").
template <class Kept>
std::vector<std::string> unstored_attributes(const surface& s, Kept&& kept) {
    std::vector<std::string> out;
    for (const attribute_column& a : s.attributes)
        if (!kept(a)) out.push_back(a.name + " (" + to_string(a.domain) + ")");
    return out;
}

/// Buffered text output: formats numbers with std::to_chars into a local buffer and
/// hands the stream large blocks, which is several times faster than operator<<. Without
/// a stream it only collects the text (a block formatted by one task of a parallel write).
class text_sink {
public:
    // Callers flush() explicitly: a destructor that writes could throw during unwinding.
    explicit text_sink(std::ostream& os)
        : os_(&os) {
        buf_.reserve(capacity + 64);
    }
    text_sink() = default;
    text_sink(const text_sink&) = delete;
    text_sink& operator=(const text_sink&) = delete;

    text_sink& operator<<(std::string_view s) {
        buf_.append(s);
        maybe_flush();
        return *this;
    }
    text_sink& operator<<(char c) {
        buf_.push_back(c);
        maybe_flush();
        return *this;
    }
    /// Shortest representation that reads back to exactly the same double.
    text_sink& operator<<(double v) { return put_number(v); }
    /// Shortest representation that reads back to exactly the same float.
    text_sink& operator<<(float v) { return put_number(v); }
    text_sink& operator<<(std::uint64_t v) { return put_number(v); }
    text_sink& operator<<(index_t v) { return put_number(v); }

    void flush() {
        if (!os_) return;
        os_->write(buf_.data(), static_cast<std::streamsize>(buf_.size()));
        buf_.clear();
    }
    /// The text collected so far (all of it, without a stream).
    const std::string& text() const noexcept { return buf_; }
    void clear() noexcept { buf_.clear(); }

private:
    static constexpr std::size_t capacity = 1 << 16;

    template <class T>
    text_sink& put_number(T v) {
        char tmp[32];
        const auto res = std::to_chars(tmp, tmp + sizeof tmp, v);
        buf_.append(tmp, res.ptr);
        maybe_flush();
        return *this;
    }
    void maybe_flush() {
        if (os_ && buf_.size() >= capacity) flush();
    }

    std::ostream* os_ = nullptr;
    std::string buf_;
};

/// Writes `format(sink, i)` for i = 0 .. n - 1 to `out` in order. Blocks of items are
/// formatted in parallel (oneTBB) into their own buffers, a bounded number at a time, and
/// written in order: number formatting, not the disk, is what a large text file waits for.
template <class Format>
void write_items(text_sink& out, std::size_t n, Format&& format) {
    constexpr std::size_t block = 1 << 14;
    const std::size_t blocks = (n + block - 1) / block;
    if (blocks <= 1) {
        for (std::size_t i = 0; i < n; ++i) format(out, i);
        return;
    }
    const auto in_flight = 4 * static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
    std::vector<text_sink> texts(std::min(blocks, in_flight));
    for (std::size_t first = 0; first < blocks; first += texts.size()) {
        const std::size_t count = std::min(texts.size(), blocks - first);
        tbb::parallel_for(std::size_t{0}, count, [&](std::size_t k) {
            const std::size_t b = first + k;
            for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i)
                format(texts[k], i);
        });
        for (std::size_t k = 0; k < count; ++k) {
            out << std::string_view(texts[k].text());
            texts[k].clear();
        }
    }
}

} // namespace detail
} // namespace idas::io
