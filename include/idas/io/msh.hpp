// Gmsh MSH files, versions 2.2 and 4.1, ASCII and binary: tetrahedra and triangles
// (boundary and interface faces) are read with their physical tags (2.2: the first element
// tag; 4.1: the first physical tag of the element's entity in $Entities), every other
// element type is skipped (and counted). Node tags may be any non-negative integers in any
// order; they are mapped to 0-based indices in file order. $NodeData blocks (per-vertex
// fields: a sizing field, a solution) and $ElementData blocks on tets (TetWild's per-tet
// quality) are read and written back; other sections ($PhysicalNames...) are skipped.
//
// Like the surface readers, every problem with a file is an input_error that starts with
// the path ("<path>: line N: ..." for ASCII, "<path>: byte N: ..." for binary). Counts
// in headers are checked against the bytes that are actually there before anything is
// reserved or looped over, so lying headers and truncated files fail fast.
#pragma once

#include "idas/io/atomic_file.hpp"
#include "idas/io/surface.hpp"
#include "idas/io/volume.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace idas::io {

enum class msh_version { v2_2, v4_1 };

namespace detail {

/// Nodes per element of Gmsh's element types; 0 for types this table does not know.
inline int msh_nodes_per_element(std::int64_t type) noexcept {
    static constexpr int table[] = {0, 2,  3,  4,  4, 8,  6,  5,  3,  6,  9, 10, 27, 18, 14, 1,
                                    8, 20, 15, 13, 9, 10, 12, 15, 15, 21, 4, 5,  6,  20, 35, 56};
    if (type >= 1 && type <= 31) return table[type];
    if (type == 92) return 64;
    if (type == 93) return 125;
    return 0;
}
inline constexpr std::int64_t msh_tet4 = 4;
inline constexpr std::int64_t msh_tri3 = 2;

template <class T>
T byte_swapped(T v) noexcept {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    std::reverse(b, b + sizeof(T));
    std::memcpy(&v, b, sizeof(T));
    return v;
}

class msh_parser {
public:
    msh_parser(std::string_view data, std::string_view source)
        : data_(data)
        , source_(source) {}

    volume run() {
        if (data_.starts_with("\xEF\xBB\xBF")) pos_ = 3;
        if (is_blank(data_.substr(pos_))) fail(source_, "file is empty");
        if (token() != "$MeshFormat")
            fail(source_, "not a Gmsh MSH file: it does not start with $MeshFormat");
        parse_format();
        for (;;) {
            const std::string_view t = token();
            if (t.empty()) break;
            if (t.size() < 2 || t[0] != '$' || t.starts_with("$End"))
                fail_here("expected a section such as $Nodes or $Elements, found " + quoted(t));
            const std::string_view name = t.substr(1);
            if (name == "MeshFormat") fail_here("a second $MeshFormat section");
            if (name == "Nodes") {
                if (have_nodes_) fail_here("a second $Nodes section");
                have_nodes_ = true;
                v41_ ? nodes_41() : nodes_22();
                expect_end("Nodes");
            } else if (name == "Elements") {
                if (have_elements_) fail_here("a second $Elements section");
                have_elements_ = true;
                v41_ ? elements_41() : elements_22();
                expect_end("Elements");
            } else if (name == "NodeData") {
                fields_.push_back(field_block("$NodeData", "node"));
                expect_end("NodeData");
            } else if (name == "ElementData") {
                element_fields_.push_back(field_block("$ElementData", "element"));
                expect_end("ElementData");
            } else if (name == "Entities" && v41_) {
                entities_41();
                expect_end("Entities");
            } else {
                skip_section(name);
            }
        }
        if (!have_nodes_) fail(source_, "no $Nodes section");
        if (!have_elements_) fail(source_, "no $Elements section");
        return resolve();
    }

private:
    // ---- errors ----
    [[noreturn]] void fail_here(const std::string& what) const {
        if (binary_) fail(source_, "byte " + std::to_string(pos_) + ": " + what);
        const auto line =
            1 + std::count(data_.begin(), data_.begin() + static_cast<std::ptrdiff_t>(pos_), '\n');
        fail_at_line(source_, static_cast<std::size_t>(line), what);
    }
    [[noreturn]] void truncated(const std::string& where) const {
        fail(source_, "truncated: the file ends " + where);
    }

    // ---- text ----
    void skip_space() noexcept {
        while (pos_ < data_.size() && is_space(data_[pos_])) ++pos_;
    }
    std::string_view token() noexcept {
        skip_space();
        const std::size_t start = pos_;
        while (pos_ < data_.size() && !is_space(data_[pos_])) ++pos_;
        return data_.substr(start, pos_ - start);
    }
    /// The rest of the current line; moves past its end.
    std::string_view rest_of_line() noexcept {
        const std::size_t start = pos_;
        while (pos_ < data_.size() && data_[pos_] != '\n') ++pos_;
        std::string_view l = data_.substr(start, pos_ - start);
        if (pos_ < data_.size()) ++pos_;
        if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
        return l;
    }
    std::int64_t integer(const char* what) {
        const std::string_view t = token();
        if (t.empty()) truncated(std::string("where ") + what + " was expected");
        std::int64_t v = 0;
        if (!parse_int(t, v)) fail_here(std::string(what) + " " + quoted(t) + " is not an integer");
        return v;
    }
    std::uint64_t count(const char* what) {
        const std::int64_t v = integer(what);
        if (v < 0) fail_here(std::string(what) + " is negative (" + std::to_string(v) + ")");
        return static_cast<std::uint64_t>(v);
    }
    double real(const char* what) {
        const std::string_view t = token();
        if (t.empty()) truncated(std::string("where ") + what + " was expected");
        double v = 0;
        switch (parse_double(t, v)) {
        case parse_status::ok:
            return v;
        case parse_status::out_of_range:
            fail_here(std::string(what) + " " + quoted(t) + " is out of range");
        case parse_status::not_a_number:
            break;
        }
        fail_here(std::string(what) + " " + quoted(t) + " is not a number");
    }
    void expect_end(std::string_view name) {
        const std::string_view t = token();
        const std::string want = "$End" + std::string(name);
        if (t.empty()) truncated("before " + want);
        if (t != want) fail_here("expected " + want + ", found " + quoted(t));
    }
    void skip_section(std::string_view name) {
        const std::string want = "$End" + std::string(name);
        const std::size_t at = data_.find(want, pos_);
        if (at == std::string_view::npos)
            truncated("inside section $" + std::string(name) + " (no " + want + ")");
        pos_ = at + want.size();
    }
    /// Tokens of one element line (ASCII files keep one element per line).
    template <class Out>
    void line_tokens(Out& out, std::uint64_t done, std::uint64_t total) {
        skip_space();
        if (pos_ >= data_.size())
            truncated("after " + std::to_string(done) + " of " + std::to_string(total) +
                      " elements");
        if (data_[pos_] == '$')
            fail_here("the $Elements header announces " + std::to_string(total) +
                      " elements but only " + std::to_string(done) + " are listed");
        out.clear();
        std::string_view l = rest_of_line();
        for (std::string_view t = next_token(l); !t.empty(); t = next_token(l)) {
            std::int64_t v = 0;
            if (!parse_int(t, v)) {
                --pos_; // report the element's own line
                fail_here("element value " + quoted(t) + " is not an integer");
            }
            out.push_back(v);
        }
    }

    // ---- binary ----
    template <class T>
    T bin(const char* what) {
        if (data_.size() - pos_ < sizeof(T)) truncated(std::string("inside ") + what);
        T v;
        std::memcpy(&v, data_.data() + pos_, sizeof(T));
        pos_ += sizeof(T);
        return swap_ ? byte_swapped(v) : v;
    }
    /// Binary payloads start right after one line break (the payload itself may begin
    /// with bytes that look like white space).
    void line_break_before_binary() {
        while (pos_ < data_.size() &&
               (data_[pos_] == ' ' || data_[pos_] == '\t' || data_[pos_] == '\r'))
            ++pos_;
        if (pos_ >= data_.size()) truncated("before binary data");
        if (data_[pos_] != '\n') fail_here("expected a line break before binary data");
        ++pos_;
    }
    /// Refuses counts the remaining bytes cannot hold, before anything is allocated.
    void need(std::uint64_t n, std::size_t bytes_each, const char* what) const {
        const std::size_t left = data_.size() - pos_;
        if (n > left / bytes_each)
            fail(source_, "byte " + std::to_string(pos_) +
                              ": truncated or corrupt: the header announces " + std::to_string(n) +
                              " " + what + " (" + std::to_string(bytes_each) +
                              " bytes each) but only " + std::to_string(left) + " bytes remain");
    }

    /// A string tag: "quoted" (on one line) or a bare token.
    std::string string_tag() {
        skip_space();
        if (pos_ < data_.size() && data_[pos_] == '"') {
            const std::size_t end = data_.find_first_of("\"\n", pos_ + 1);
            if (end == std::string_view::npos || data_[end] != '"')
                fail_here("a string tag's closing quote is missing");
            std::string out(data_.substr(pos_ + 1, end - pos_ - 1));
            pos_ = end + 1;
            return out;
        }
        const std::string_view t = token();
        if (t.empty()) truncated("where a string tag was expected");
        return std::string(t);
    }

    // ---- sections ----
    /// $NodeData and $ElementData: string, real and integer tags (name; time; time step,
    /// components, count), then per node or element its tag and its values. Binary files
    /// give the tag as a 4-byte int in both versions, as Gmsh writes it.
    struct raw_field {
        std::string name;
        int components = 1;
        std::vector<std::uint64_t> tags; // node or element tags, resolved at the end
        std::vector<double> values;
    };
    raw_field field_block(const std::string& section, const std::string& item) {
        raw_field f;
        const std::uint64_t strings = count("number of string tags");
        if (strings > 64)
            fail_here(section + " announces " + std::to_string(strings) + " string tags");
        for (std::uint64_t i = 0; i < strings; ++i) {
            std::string t = string_tag();
            if (i == 0) f.name = std::move(t);
        }
        const std::uint64_t reals = count("number of real tags");
        if (reals > 64) fail_here(section + " announces " + std::to_string(reals) + " real tags");
        for (std::uint64_t i = 0; i < reals; ++i) real("real tag");
        const std::uint64_t ints = count("number of integer tags");
        if (ints < 3 || ints > 64)
            fail_here(section + " needs 3 integer tags (time step, components, count), not " +
                      std::to_string(ints));
        std::uint64_t components = 0, n = 0;
        for (std::uint64_t i = 0; i < ints; ++i) {
            const std::uint64_t x = count("integer tag");
            if (i == 1) components = x;
            if (i == 2) n = x;
        }
        if (components < 1 || components > 9)
            fail_here(section + " has " + std::to_string(components) + " components per " + item +
                      " (1 to 9 are allowed)");
        f.components = int(components);
        if (binary_) {
            line_break_before_binary();
            need(n, 4 + 8 * components, (item + " values").c_str());
        } else {
            need(n, 2 * (1 + components), (item + " values").c_str());
        }
        f.tags.reserve(n), f.values.reserve(n * components);
        for (std::uint64_t i = 0; i < n; ++i) {
            if (binary_) {
                const auto tag = bin<std::int32_t>(section.c_str());
                if (tag < 0)
                    fail_here(section + " has negative " + item + " tag " + std::to_string(tag));
                f.tags.push_back(std::uint64_t(tag));
                for (std::uint64_t k = 0; k < components; ++k)
                    f.values.push_back(bin<double>(section.c_str()));
            } else {
                f.tags.push_back(count((item + " tag").c_str()));
                for (std::uint64_t k = 0; k < components; ++k) f.values.push_back(real("value"));
            }
        }
        return f;
    }

    /// $Entities (4.1 only): the first physical tag of every surface and volume, which the
    /// 4.1 elements take from the entity their block belongs to. Points and curves are read
    /// past.
    void entities_41() {
        std::uint64_t counts[4] = {};
        if (binary_) line_break_before_binary();
        for (auto& c : counts)
            c = binary_ ? bin<std::uint64_t>("$Entities") : count("number of entities");
        const auto number = [&](const char* what) -> std::int64_t {
            return binary_ ? bin<std::int32_t>(what) : integer(what);
        };
        const auto size = [&](const char* what) -> std::uint64_t {
            return binary_ ? bin<std::uint64_t>(what) : count(what);
        };
        for (int dim = 0; dim < 4; ++dim) {
            // An entity takes at least its tag, box and two counts: 4 + 24 + 8 bytes, or 6
            // tokens of text.
            need(counts[dim], binary_ ? 36 : 12, "entities");
            for (std::uint64_t i = 0; i < counts[dim]; ++i) {
                const std::int64_t tag = number("an entity tag");
                for (int k = 0; k < (dim == 0 ? 3 : 6); ++k)
                    binary_ ? void(bin<double>("an entity")) : void(real("an entity's bounds"));
                const std::uint64_t physicals = size("number of physical tags");
                need(physicals, binary_ ? 4 : 2, "physical tags");
                std::int64_t first = 0;
                for (std::uint64_t j = 0; j < physicals; ++j) {
                    const std::int64_t p = number("a physical tag");
                    if (j == 0) first = p;
                }
                if (dim > 0) {
                    const std::uint64_t bounding = size("number of bounding entities");
                    need(bounding, binary_ ? 4 : 2, "bounding entities");
                    for (std::uint64_t j = 0; j < bounding; ++j) number("a bounding entity tag");
                }
                if (dim >= 2 && physicals > 0) entity_physical_[dim - 2].push_back({tag, first});
            }
        }
        for (auto& e : entity_physical_) std::sort(e.begin(), e.end());
    }
    /// The physical tag of a 4.1 element block's entity; 0 when it has none.
    std::int64_t entity_physical(std::int64_t dim, std::int64_t tag) const noexcept {
        if (dim < 2 || dim > 3) return 0;
        const auto& e = entity_physical_[dim - 2];
        const auto it = std::lower_bound(
            e.begin(), e.end(),
            std::pair<std::int64_t, std::int64_t>{tag, std::numeric_limits<std::int64_t>::min()});
        return it != e.end() && it->first == tag ? it->second : 0;
    }

    void parse_format() {
        rest_of_line();
        const std::string_view version = token();
        const std::string_view type = token();
        const std::string_view size = token();
        if (size.empty()) truncated("inside $MeshFormat");
        if (version == "2.2" || version == "2.1" || version == "2.0" || version == "2")
            v41_ = false;
        else if (version == "4.1")
            v41_ = true;
        else if (version == "4" || version == "4.0")
            fail_here(
                "MSH version 4.0 is not supported (only 2.2 and 4.1); re-save the file as 4.1");
        else
            fail_here("MSH version " + quoted(version) + " is not supported (only 2.2 and 4.1)");
        if (type == "1")
            binary_ = true;
        else if (type != "0")
            fail_here("file type " + quoted(type) + " is neither 0 (ASCII) nor 1 (binary)");
        if (size != "8") fail_here("data size " + quoted(size) + " is not supported (only 8)");
        if (binary_) {
            line_break_before_binary();
            const auto one = bin<std::int32_t>("$MeshFormat");
            if (one != 1) {
                if (byte_swapped(one) != 1)
                    fail_here("the binary endianness marker is " + std::to_string(one) + ", not 1");
                swap_ = true;
            }
        }
        expect_end("MeshFormat");
    }

    void add_node(std::uint64_t tag, const vec3& p) {
        if (vertices_.size() >= invalid_index - 1) fail(source_, "too many nodes");
        if (!is_finite(p))
            fail_here("node " + std::to_string(tag) + " has a non-finite coordinate");
        tags_.push_back({tag, static_cast<index_t>(vertices_.size())});
        vertices_.push_back(p);
    }
    void reserve_nodes(std::uint64_t n, std::size_t min_bytes) {
        const std::size_t cap = capped_reserve(n, data_.size() - pos_, min_bytes);
        vertices_.reserve(cap), tags_.reserve(cap);
    }

    void nodes_22() {
        const std::uint64_t n = count("number of nodes");
        if (binary_) {
            line_break_before_binary();
            need(n, 4 + 24, "nodes");
            reserve_nodes(n, 28);
            for (std::uint64_t i = 0; i < n; ++i) {
                const auto tag = bin<std::int32_t>("$Nodes");
                if (tag < 0) fail_here("node tag " + std::to_string(tag) + " is negative");
                vec3 p;
                for (int k = 0; k < 3; ++k) p[k] = bin<double>("$Nodes");
                add_node(static_cast<std::uint64_t>(tag), p);
            }
            return;
        }
        reserve_nodes(n, 8);
        for (std::uint64_t i = 0; i < n; ++i) {
            skip_space();
            if (pos_ < data_.size() && data_[pos_] == '$')
                fail_here("the $Nodes header announces " + std::to_string(n) + " nodes but only " +
                          std::to_string(i) + " are listed");
            const std::uint64_t tag = count("node tag");
            vec3 p;
            for (int k = 0; k < 3; ++k) p[k] = real("coordinate");
            add_node(tag, p);
        }
    }

    void nodes_41() {
        std::uint64_t blocks = 0, total = 0;
        if (binary_) {
            line_break_before_binary();
            blocks = bin<std::uint64_t>("$Nodes"), total = bin<std::uint64_t>("$Nodes");
            bin<std::uint64_t>("$Nodes"), bin<std::uint64_t>("$Nodes"); // min and max tag
            need(total, 32, "nodes");
            need(blocks, 20, "node blocks");
        } else {
            blocks = count("number of node blocks"), total = count("number of nodes");
            count("minimum node tag"), count("maximum node tag");
        }
        reserve_nodes(total, binary_ ? 32 : 8);
        std::uint64_t read = 0;
        for (std::uint64_t b = 0; b < blocks; ++b) {
            std::int64_t dim = 0, parametric = 0;
            std::uint64_t n = 0;
            if (binary_) {
                dim = bin<std::int32_t>("a node block"), bin<std::int32_t>("a node block");
                parametric = bin<std::int32_t>("a node block"),
                n = bin<std::uint64_t>("a node block");
            } else {
                dim = integer("entity dimension"), integer("entity tag");
                parametric = integer("parametric flag"), n = count("number of nodes in block");
            }
            if (dim < 0 || dim > 3)
                fail_here("node block " + std::to_string(b) + " has dimension " +
                          std::to_string(dim));
            if (parametric != 0 && parametric != 1)
                fail_here("node block " + std::to_string(b) + " has parametric flag " +
                          std::to_string(parametric));
            if (n > total - read)
                fail_here("the $Nodes header announces " + std::to_string(total) +
                          " nodes but the blocks hold more");
            const std::size_t values = 3 + static_cast<std::size_t>(parametric ? dim : 0);
            // Tags first, then coordinates: remember where this block's tags start.
            const std::size_t first = tags_.size();
            if (binary_) need(n, 8 + 8 * values, "nodes");
            for (std::uint64_t i = 0; i < n; ++i) {
                std::uint64_t tag = binary_ ? bin<std::uint64_t>("node tags") : count("node tag");
                tags_.push_back({tag, 0});
            }
            for (std::uint64_t i = 0; i < n; ++i) {
                vec3 p;
                for (std::size_t k = 0; k < values; ++k) {
                    const double x = binary_ ? bin<double>("node coordinates") : real("coordinate");
                    if (k < 3) p[static_cast<int>(k)] = x;
                }
                const auto tag = tags_[first + i].first;
                if (vertices_.size() >= invalid_index - 1) fail(source_, "too many nodes");
                if (!is_finite(p))
                    fail_here("node " + std::to_string(tag) + " has a non-finite coordinate");
                tags_[first + i].second = static_cast<index_t>(vertices_.size());
                vertices_.push_back(p);
            }
            read += n;
        }
        if (read != total)
            fail_here("the $Nodes header announces " + std::to_string(total) +
                      " nodes but the blocks hold " + std::to_string(read));
    }

    /// A tet or a triangle (the first three nodes); `physical`: its physical tag, 0 if it
    /// has none.
    void add_element(std::int64_t type, std::uint64_t element,
                     const std::array<std::uint64_t, 4>& nodes, std::int64_t physical) {
        cells& c = type == msh_tet4 ? tets_ : triangles_;
        if (c.nodes.size() >= invalid_index - 1) fail(source_, "too many elements");
        c.nodes.push_back(nodes), c.elements.push_back(element), c.physical.push_back(physical);
    }
    static bool kept(std::int64_t type) noexcept { return type == msh_tet4 || type == msh_tri3; }

    void elements_22() {
        const std::uint64_t m = count("number of elements");
        if (binary_) {
            line_break_before_binary();
            std::uint64_t read = 0;
            while (read < m) {
                const auto type = bin<std::int32_t>("an element header");
                const auto n = bin<std::int32_t>("an element header");
                const auto ntags = bin<std::int32_t>("an element header");
                const int nn = msh_nodes_per_element(type);
                if (nn == 0)
                    fail_here("element type " + std::to_string(type) +
                              " is unknown, so it cannot be skipped");
                if (n <= 0 || static_cast<std::uint64_t>(n) > m - read)
                    fail_here("element block of " + std::to_string(n) +
                              " elements does not fit the header's " + std::to_string(m));
                if (ntags < 0 || ntags > 1000)
                    fail_here("element block has " + std::to_string(ntags) + " tags");
                const std::size_t each =
                    4 * (1 + static_cast<std::size_t>(ntags) + static_cast<std::size_t>(nn));
                need(static_cast<std::uint64_t>(n), each, "elements");
                for (std::int32_t i = 0; i < n; ++i) {
                    const auto number = bin<std::int32_t>("an element");
                    if (!kept(type)) {
                        pos_ += each - 4;
                        ++skipped_;
                        continue;
                    }
                    std::int64_t physical = 0;
                    if (ntags > 0) physical = bin<std::int32_t>("an element");
                    pos_ += 4 * static_cast<std::size_t>(std::max(ntags - 1, 0));
                    std::array<std::uint64_t, 4> nodes{};
                    for (int k = 0; k < nn; ++k) {
                        const auto tag = bin<std::int32_t>("an element");
                        if (tag < 0)
                            fail_here("element " + std::to_string(number) +
                                      " has negative node tag " + std::to_string(tag));
                        nodes[std::size_t(k)] = static_cast<std::uint64_t>(tag);
                    }
                    add_element(type, static_cast<std::uint64_t>(number), nodes, physical);
                }
                read += static_cast<std::uint64_t>(n);
            }
            return;
        }
        if (!is_blank(rest_of_line())) fail_here("unexpected text after the number of elements");
        element_values values;
        for (std::uint64_t k = 0; k < m; ++k) {
            line_tokens(values, k, m);
            if (values.size() < 3)
                fail_here("element line has " + std::to_string(values.size()) + " values");
            const std::int64_t number = values[0], type = values[1], ntags = values[2];
            const int nn = msh_nodes_per_element(type);
            if (ntags < 0 ||
                (nn && values.size() !=
                           3 + static_cast<std::size_t>(ntags) + static_cast<std::size_t>(nn)) ||
                (!nn && values.size() < 3 + static_cast<std::size_t>(ntags)))
                fail_line_of_element(number, "has " + std::to_string(values.size()) +
                                                 " values, which does not fit type " +
                                                 std::to_string(type) + " with " +
                                                 std::to_string(ntags) + " tags");
            if (!kept(type)) {
                ++skipped_;
                continue;
            }
            add_element_from(type, number, values, 3 + static_cast<std::size_t>(ntags),
                             ntags > 0 ? values[3] : 0);
        }
    }

    void elements_41() {
        std::uint64_t blocks = 0, total = 0;
        if (binary_) {
            line_break_before_binary();
            blocks = bin<std::uint64_t>("$Elements"), total = bin<std::uint64_t>("$Elements");
            bin<std::uint64_t>("$Elements"), bin<std::uint64_t>("$Elements");
            need(total, 16, "elements");
            need(blocks, 20, "element blocks");
        } else {
            blocks = count("number of element blocks"), total = count("number of elements");
            count("minimum element tag"), count("maximum element tag");
            if (!is_blank(rest_of_line())) fail_here("unexpected text after the $Elements header");
        }
        tets_.nodes.reserve(capped_reserve(total, data_.size() - pos_, binary_ ? 40 : 10));
        std::uint64_t read = 0;
        element_values values;
        for (std::uint64_t b = 0; b < blocks; ++b) {
            std::int64_t type = 0, dim = 0, entity = 0;
            std::uint64_t n = 0;
            if (binary_) {
                dim = bin<std::int32_t>("an element block");
                entity = bin<std::int32_t>("an element block");
                type = bin<std::int32_t>("an element block"),
                n = bin<std::uint64_t>("an element block");
            } else {
                dim = integer("entity dimension"), entity = integer("entity tag");
                type = integer("element type"), n = count("number of elements in block");
                if (!is_blank(rest_of_line()))
                    fail_here("unexpected text after an element block header");
            }
            if (n > total - read)
                fail_here("the $Elements header announces " + std::to_string(total) +
                          " elements but the blocks hold more");
            const int nn = msh_nodes_per_element(type);
            const std::int64_t physical = entity_physical(dim, entity);
            if (binary_) {
                if (nn == 0)
                    fail_here("element type " + std::to_string(type) +
                              " is unknown, so it cannot be skipped");
                const std::size_t each = 8 * (1 + static_cast<std::size_t>(nn));
                need(n, each, "elements");
                for (std::uint64_t i = 0; i < n; ++i) {
                    const auto number = bin<std::uint64_t>("an element");
                    if (!kept(type)) {
                        pos_ += each - 8;
                        ++skipped_;
                        continue;
                    }
                    std::array<std::uint64_t, 4> nodes{};
                    for (int k = 0; k < nn; ++k)
                        nodes[std::size_t(k)] = bin<std::uint64_t>("an element");
                    add_element(type, number, nodes, physical);
                }
            } else {
                for (std::uint64_t i = 0; i < n; ++i) {
                    line_tokens(values, read + i, total);
                    if (values.empty() || values[0] < 0 ||
                        (nn && values.size() != 1 + static_cast<std::size_t>(nn)))
                        fail_line_of_element(values.empty() ? -1 : values[0],
                                             "has " + std::to_string(values.size()) +
                                                 " values, which does not fit type " +
                                                 std::to_string(type));
                    if (!kept(type)) {
                        ++skipped_;
                        continue;
                    }
                    add_element_from(type, values[0], values, 1, physical);
                }
            }
            read += n;
        }
        if (read != total)
            fail_here("the $Elements header announces " + std::to_string(total) +
                      " elements but the blocks hold " + std::to_string(read));
    }

    // Element values are stored in a reused vector: one line at a time.
    using element_values = std::vector<std::int64_t>;

    [[noreturn]] void fail_line_of_element(std::int64_t number, const std::string& what) {
        --pos_; // back onto the element's line for the line number
        fail_here("element " + std::to_string(number) + " " + what);
    }
    void add_element_from(std::int64_t type, std::int64_t number, const element_values& values,
                          std::size_t first, std::int64_t physical) {
        std::array<std::uint64_t, 4> nodes{};
        for (std::size_t k = 0; k < std::size_t(msh_nodes_per_element(type)); ++k) {
            if (values[first + k] < 0)
                fail_line_of_element(number,
                                     "has negative node tag " + std::to_string(values[first + k]));
            nodes[k] = static_cast<std::uint64_t>(values[first + k]);
        }
        add_element(type, static_cast<std::uint64_t>(number), nodes, physical);
    }

    volume resolve() {
        volume out;
        out.skipped_elements = skipped_;
        auto sorted = tags_;
        std::sort(sorted.begin(), sorted.end());
        for (std::size_t i = 1; i < sorted.size(); ++i)
            if (sorted[i].first == sorted[i - 1].first)
                fail(source_, "node tag " + std::to_string(sorted[i].first) + " is defined twice");
        // Dense tags (the usual 1..n) get a direct table; sparse ones a binary search.
        std::vector<index_t> dense;
        if (!sorted.empty() && sorted.back().first < 2 * sorted.size() + 1024) {
            dense.assign(static_cast<std::size_t>(sorted.back().first) + 1, invalid_index);
            for (const auto& [tag, i] : sorted) dense[static_cast<std::size_t>(tag)] = i;
        }
        const auto lookup = [&](std::uint64_t tag) -> index_t {
            if (!dense.empty())
                return tag < dense.size() ? dense[static_cast<std::size_t>(tag)] : invalid_index;
            const auto it = std::lower_bound(sorted.begin(), sorted.end(),
                                             std::pair<std::uint64_t, index_t>{tag, 0});
            return it != sorted.end() && it->first == tag ? it->second : invalid_index;
        };
        // Corners to indices; an element naming an undefined node or one node twice is refused.
        const auto resolve_cells = [&](const cells& c, std::size_t corners, auto& into) {
            into.reserve(c.nodes.size());
            for (std::size_t t = 0; t < c.nodes.size(); ++t) {
                typename std::remove_reference_t<decltype(into)>::value_type tv{};
                for (std::size_t k = 0; k < corners; ++k) {
                    tv[k] = lookup(c.nodes[t][k]);
                    if (tv[k] == invalid_index)
                        fail(source_, "element " + std::to_string(c.elements[t]) +
                                          " references node " + std::to_string(c.nodes[t][k]) +
                                          ", which is not defined");
                    for (std::size_t j = 0; j < k; ++j)
                        if (tv[j] == tv[k])
                            fail(source_, "element " + std::to_string(c.elements[t]) +
                                              " is degenerate: it uses node " +
                                              std::to_string(c.nodes[t][k]) + " twice");
                }
                into.push_back(tv);
            }
        };
        resolve_cells(tets_, 4, out.tets);
        resolve_cells(triangles_, 3, out.triangles);
        // Values per tag, spread over what the tags name; NaN for what has no value.
        // `missing` hears of a tag that names nothing.
        const auto spread = [&](raw_field& f, std::size_t items, auto&& index_of, auto&& missing) {
            field out_field;
            out_field.name = std::move(f.name);
            out_field.components = f.components;
            const std::size_t c = std::size_t(f.components);
            out_field.values.assign(items * c, std::numeric_limits<double>::quiet_NaN());
            for (std::size_t i = 0; i < f.tags.size(); ++i) {
                const index_t v = index_of(f.tags[i]);
                if (v == invalid_index) {
                    missing(out_field.name, f.tags[i]);
                    continue;
                }
                std::copy_n(f.values.begin() + std::ptrdiff_t(i * c), c,
                            out_field.values.begin() + std::ptrdiff_t(std::size_t(v) * c));
            }
            return out_field;
        };
        for (auto& f : fields_)
            out.vertex_fields.push_back(spread(
                f, vertices_.size(), lookup, [&](const std::string& name, std::uint64_t tag) {
                    fail(source_, "$NodeData \"" + name + "\" gives a value for node " +
                                      std::to_string(tag) + ", which is not defined");
                }));
        // $ElementData keeps the tets' values; values for other elements (triangles, lines)
        // are left out.
        if (!element_fields_.empty()) {
            std::vector<std::pair<std::uint64_t, index_t>> by_number;
            by_number.reserve(tets_.elements.size());
            for (std::size_t t = 0; t < tets_.elements.size(); ++t)
                by_number.push_back({tets_.elements[t], static_cast<index_t>(t)});
            std::sort(by_number.begin(), by_number.end());
            const auto tet_of = [&](std::uint64_t number) -> index_t {
                const auto it = std::lower_bound(by_number.begin(), by_number.end(),
                                                 std::pair<std::uint64_t, index_t>{number, 0});
                return it != by_number.end() && it->first == number ? it->second : invalid_index;
            };
            for (auto& f : element_fields_)
                out.tet_fields.push_back(
                    spread(f, out.tets.size(), tet_of, [](const std::string&, std::uint64_t) {}));
        }
        // Physical tags become tags when every element has a positive one that fits an int
        // (what the writers store) and they are not all 1; otherwise none are kept.
        const auto tags_of = [](const std::vector<std::int64_t>& physical) {
            const bool usable =
                !physical.empty() &&
                std::all_of(
                    physical.begin(), physical.end(),
                    [](std::int64_t t) { return t > 0 && t <= std::numeric_limits<int>::max(); }) &&
                std::any_of(physical.begin(), physical.end(),
                            [](std::int64_t t) { return t != 1; });
            return usable ? std::vector<int>(physical.begin(), physical.end()) : std::vector<int>{};
        };
        out.tags = tags_of(tets_.physical);
        out.triangle_tags = tags_of(triangles_.physical);
        out.vertices = std::move(vertices_);
        return out;
    }

    std::string_view data_, source_;
    std::size_t pos_ = 0;
    bool binary_ = false, swap_ = false, v41_ = false;
    bool have_nodes_ = false, have_elements_ = false;
    std::vector<vec3> vertices_;
    std::vector<std::pair<std::uint64_t, index_t>> tags_; // (tag, index) in file order
    struct cells {
        std::vector<std::array<std::uint64_t, 4>> nodes; // node tags, resolved at the end
        std::vector<std::uint64_t> elements;             // element tags
        std::vector<std::int64_t> physical;              // physical tags, 0 for none
    };
    cells tets_, triangles_;
    std::size_t skipped_ = 0;
    std::vector<raw_field> fields_, element_fields_;
    // (entity tag, physical tag) of 4.1 surfaces and volumes, sorted.
    std::vector<std::pair<std::int64_t, std::int64_t>> entity_physical_[2];
};

// ---- writing ----

template <class T>
void put_binary(std::string& out, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    out.append(b, sizeof(T));
}

inline void flush_if_large(std::ostream& os, std::string& buf) {
    if (buf.size() >= (1u << 20)) {
        os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
        buf.clear();
    }
}

/// The items (vertices or tets) a field has values for (all finite): the others read back
/// as NaN.
inline std::vector<std::uint64_t> valued_items(const field& f) {
    std::vector<std::uint64_t> out;
    const std::size_t c = std::size_t(f.components);
    for (std::size_t i = 0; i * c < f.values.size(); ++i)
        if (std::all_of(f.values.begin() + std::ptrdiff_t(i * c),
                        f.values.begin() + std::ptrdiff_t((i + 1) * c),
                        [](double x) { return std::isfinite(x); }))
            out.push_back(i);
    return out;
}

/// "$NodeData" or "$ElementData" up to the count: one string tag (the name), one real tag
/// (time 0), three integer tags (time step 0, components, count).
inline std::string field_header(std::string_view section, const field& f, std::size_t count) {
    return std::string(section) + "\n1\n\"" + f.name + "\"\n1\n0\n3\n0\n" +
           std::to_string(f.components) + "\n" + std::to_string(count) + "\n";
}

/// The distinct tags, ascending ({1} when there are none): one MSH 4.1 entity, with the
/// same physical tag, per tag.
inline std::vector<int> distinct_tags(const std::vector<int>& tags) {
    std::vector<int> t = tags.empty() ? std::vector<int>{1} : tags;
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end()), t.end());
    return t;
}
inline int tag_of(const std::vector<int>& tags, std::size_t i) {
    return tags.empty() ? 1 : tags[i];
}

/// What the writer numbers and groups: tets are elements 1..m, triangles m+1..m+k.
struct msh_layout {
    const volume& v;
    std::uint64_t n = v.vertices.size(), m = v.tets.size(), k = v.triangles.size();
    std::vector<int> volumes = distinct_tags(v.tags);
    std::vector<int> surfaces = k ? distinct_tags(v.triangle_tags) : std::vector<int>{};
    vec3 lo{}, hi{};

    explicit msh_layout(const volume& vol)
        : v(vol) {
        if (n) lo = hi = v.vertices[0];
        for (const vec3& p : v.vertices)
            for (int a = 0; a < 3; ++a)
                lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
    }
    /// Calls visit(element number, element type, tag, corners) for every element in the
    /// order 2.2 writes them.
    template <class Visit>
    void elements_in_order(Visit&& visit) const {
        for (std::uint64_t t = 0; t < m; ++t)
            visit(t + 1, msh_tet4, tag_of(v.tags, t), std::span<const index_t>(v.tets[t]));
        for (std::uint64_t t = 0; t < k; ++t)
            visit(m + 1 + t, msh_tri3, tag_of(v.triangle_tags, t),
                  std::span<const index_t>(v.triangles[t]));
    }
    /// Calls block(dimension, entity, type, count) and then element(number, corners) for
    /// each of its elements: 4.1's blocks, one per entity.
    template <class Block, class Element>
    void blocks(Block&& block, Element&& element) const {
        const auto one_dimension = [&](int dim, const std::vector<int>& entities,
                                       const std::vector<int>& tags, std::uint64_t count,
                                       std::uint64_t first, std::int64_t type, auto corners) {
            for (int e : entities) {
                std::uint64_t in = 0;
                for (std::uint64_t i = 0; i < count; ++i) in += tag_of(tags, i) == e;
                block(dim, e, type, in);
                for (std::uint64_t i = 0; i < count; ++i)
                    if (tag_of(tags, i) == e) element(first + i, corners(i));
            }
        };
        one_dimension(3, volumes, v.tags, m, 1, msh_tet4,
                      [&](std::uint64_t t) { return std::span<const index_t>(v.tets[t]); });
        one_dimension(2, surfaces, v.triangle_tags, k, m + 1, msh_tri3,
                      [&](std::uint64_t t) { return std::span<const index_t>(v.triangles[t]); });
    }
};

inline void write_msh_unchecked(std::ostream& os, const volume& v, msh_version version,
                                encoding enc) {
    const msh_layout l(v);
    const std::uint64_t n = l.n, m = l.m, k = l.k;
    const std::uint64_t blocks = l.volumes.size() + l.surfaces.size();
    if (enc == encoding::ascii) {
        text_sink out(os);
        if (version == msh_version::v2_2) {
            out << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n" << n << '\n';
            for (std::uint64_t i = 0; i < n; ++i) {
                const vec3& p = v.vertices[i];
                out << (i + 1) << ' ' << p.x << ' ' << p.y << ' ' << p.z << '\n';
            }
            out << "$EndNodes\n$Elements\n" << (m + k) << '\n';
            l.elements_in_order(
                [&](std::uint64_t number, std::int64_t type, int tag, std::span<const index_t> c) {
                    out << number << ' ' << std::uint64_t(type) << " 2 " << std::uint64_t(tag)
                        << ' ' << std::uint64_t(tag);
                    for (index_t x : c) out << ' ' << std::uint64_t{x} + 1;
                    out << '\n';
                });
            out << "$EndElements\n";
        } else {
            out << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
            // One entity per tag, with that tag as its physical tag.
            out << "$Entities\n0 0 " << std::uint64_t(l.surfaces.size()) << ' '
                << std::uint64_t(l.volumes.size()) << '\n';
            for (const auto* entities : {&l.surfaces, &l.volumes})
                for (int e : *entities)
                    out << std::uint64_t(e) << ' ' << l.lo.x << ' ' << l.lo.y << ' ' << l.lo.z
                        << ' ' << l.hi.x << ' ' << l.hi.y << ' ' << l.hi.z << " 1 "
                        << std::uint64_t(e) << " 0\n";
            out << "$EndEntities\n";
            out << "$Nodes\n1 " << n << ' ' << std::uint64_t{n ? 1u : 0u} << ' ' << n << "\n3 1 0 "
                << n << '\n';
            for (std::uint64_t i = 0; i < n; ++i) out << (i + 1) << '\n';
            for (const vec3& p : v.vertices) out << p.x << ' ' << p.y << ' ' << p.z << '\n';
            out << "$EndNodes\n$Elements\n"
                << blocks << ' ' << (m + k) << ' ' << std::uint64_t{m + k ? 1u : 0u} << ' '
                << (m + k) << '\n';
            l.blocks(
                [&](int dim, int entity, std::int64_t type, std::uint64_t count) {
                    out << std::uint64_t(dim) << ' ' << std::uint64_t(entity) << ' '
                        << std::uint64_t(type) << ' ' << count << '\n';
                },
                [&](std::uint64_t number, std::span<const index_t> c) {
                    out << number;
                    for (index_t x : c) out << ' ' << std::uint64_t{x} + 1;
                    out << '\n';
                });
            out << "$EndElements\n";
        }
        const auto fields = [&](std::string_view section, const std::vector<field>& all) {
            for (const auto& f : all) {
                const auto valued = valued_items(f);
                out << field_header(section, f, valued.size());
                const std::size_t c = std::size_t(f.components);
                for (std::uint64_t i : valued) {
                    out << (i + 1);
                    for (std::size_t j = 0; j < c; ++j) out << ' ' << f.values[i * c + j];
                    out << '\n';
                }
                out << "$End" << section.substr(1) << '\n';
            }
        };
        fields("$NodeData", v.vertex_fields);
        fields("$ElementData", v.tet_fields);
        out.flush();
        return;
    }

    std::string buf;
    if (version == msh_version::v2_2) {
        buf = "$MeshFormat\n2.2 1 8\n";
        put_binary<std::int32_t>(buf, 1);
        buf += "\n$EndMeshFormat\n$Nodes\n" + std::to_string(n) + "\n";
        for (std::uint64_t i = 0; i < n; ++i) {
            put_binary(buf, static_cast<std::int32_t>(i + 1));
            put_binary(buf, v.vertices[i].x), put_binary(buf, v.vertices[i].y),
                put_binary(buf, v.vertices[i].z);
            flush_if_large(os, buf);
        }
        buf += "\n$EndNodes\n$Elements\n" + std::to_string(m + k) + "\n";
        std::int64_t block_type = 0;
        l.elements_in_order(
            [&](std::uint64_t number, std::int64_t type, int tag, std::span<const index_t> c) {
                if (type != block_type) { // a block header: type, count, number of tags
                    block_type = type;
                    put_binary<std::int32_t>(buf, std::int32_t(type));
                    put_binary(buf, static_cast<std::int32_t>(type == msh_tet4 ? m : k));
                    put_binary<std::int32_t>(buf, 2);
                }
                put_binary(buf, static_cast<std::int32_t>(number));
                put_binary<std::int32_t>(buf, tag), put_binary<std::int32_t>(buf, tag);
                for (index_t x : c) put_binary(buf, static_cast<std::int32_t>(x + 1));
                flush_if_large(os, buf);
            });
        buf += "\n$EndElements\n";
    } else {
        buf = "$MeshFormat\n4.1 1 8\n";
        put_binary<std::int32_t>(buf, 1);
        buf += "\n$EndMeshFormat\n$Entities\n";
        for (std::uint64_t c : {std::uint64_t{0}, std::uint64_t{0},
                                std::uint64_t(l.surfaces.size()), std::uint64_t(l.volumes.size())})
            put_binary(buf, c);
        for (const auto* entities : {&l.surfaces, &l.volumes})
            for (int e : *entities) {
                put_binary<std::int32_t>(buf, e);
                for (double x : {l.lo.x, l.lo.y, l.lo.z, l.hi.x, l.hi.y, l.hi.z})
                    put_binary(buf, x);
                put_binary<std::uint64_t>(buf, 1), put_binary<std::int32_t>(buf, e);
                put_binary<std::uint64_t>(buf, 0);
            }
        buf += "\n$EndEntities\n$Nodes\n";
        for (std::uint64_t c : {std::uint64_t{1}, n, std::uint64_t{n ? 1u : 0u}, n})
            put_binary(buf, c);
        put_binary<std::int32_t>(buf, 3), put_binary<std::int32_t>(buf, 1),
            put_binary<std::int32_t>(buf, 0);
        put_binary(buf, n);
        for (std::uint64_t i = 0; i < n; ++i) {
            put_binary(buf, i + 1);
            flush_if_large(os, buf);
        }
        for (const vec3& p : v.vertices) {
            put_binary(buf, p.x), put_binary(buf, p.y), put_binary(buf, p.z);
            flush_if_large(os, buf);
        }
        buf += "\n$EndNodes\n$Elements\n";
        for (std::uint64_t c : {blocks, m + k, std::uint64_t{m + k ? 1u : 0u}, m + k})
            put_binary(buf, c);
        l.blocks(
            [&](int dim, int entity, std::int64_t type, std::uint64_t count) {
                put_binary<std::int32_t>(buf, dim), put_binary<std::int32_t>(buf, entity),
                    put_binary<std::int32_t>(buf, std::int32_t(type));
                put_binary(buf, count);
            },
            [&](std::uint64_t number, std::span<const index_t> c) {
                put_binary(buf, number);
                for (index_t x : c) put_binary(buf, std::uint64_t{x} + 1);
                flush_if_large(os, buf);
            });
        buf += "\n$EndElements\n";
    }
    const auto fields = [&](std::string_view section, const std::vector<field>& all) {
        for (const auto& f : all) {
            const auto valued = valued_items(f);
            buf += field_header(section, f, valued.size());
            const std::size_t c = std::size_t(f.components);
            for (std::uint64_t i : valued) {
                put_binary(buf, static_cast<std::int32_t>(i + 1));
                for (std::size_t j = 0; j < c; ++j) put_binary(buf, f.values[i * c + j]);
                flush_if_large(os, buf);
            }
            buf += "\n$End" + std::string(section.substr(1)) + "\n";
        }
    };
    fields("$NodeData", v.vertex_fields);
    fields("$ElementData", v.tet_fields);
    os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

} // namespace detail

/// Parses MSH held in memory; `source` names it in error messages.
inline volume parse_msh(std::string_view data, std::string_view source) {
    return detail::msh_parser(data, source).run();
}

inline volume read_msh(const std::filesystem::path& path) {
    return parse_msh(detail::read_file(path), path.string());
}

/// Writes tets (element type 4) with node tags 1..n and element tags 1..m, then the
/// triangles (type 2) as elements m+1..m+k, each with its physical tag (4.1: one entity
/// per tag), then the vertex and tet fields. Binary files use this machine's byte order
/// (the format's marker records it).
inline void write_msh(std::ostream& os, const volume& v, msh_version version = msh_version::v4_1,
                      encoding enc = encoding::binary) {
    detail::check_writable(v, "MSH output");
    detail::write_msh_unchecked(os, v, version, enc);
}

/// Writes atomically: the target is either fully replaced or untouched.
inline void write_msh(const std::filesystem::path& path, const volume& v,
                      msh_version version = msh_version::v4_1, encoding enc = encoding::binary) {
    detail::check_writable(v, path.string());
    write_atomically(path,
                     [&](std::ostream& os) { detail::write_msh_unchecked(os, v, version, enc); });
}

} // namespace idas::io
