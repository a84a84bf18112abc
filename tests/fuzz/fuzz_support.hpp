// Shared by the libFuzzer harnesses (scripts/fuzz.sh builds and runs them). A reader may
// refuse any input with idas::input_error naming the source; everything else is a
// finding: a sanitizer report, another exception type (std::bad_alloc from a lying
// header included), a hang, or a result that breaks the readers' documented guarantees.
#pragma once

#include "idas/core/types.hpp"
#include "idas/io/surface.hpp"
#include "idas/io/volume.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <span>
#include <string>
#include <string_view>
#include <typeinfo>
#include <vector>

namespace idas::fuzz {

/// Errors name this source first, as they would name the file.
inline constexpr std::string_view source = "fuzz-input";

[[noreturn]] inline void finding(const std::string& what) {
    std::fprintf(stderr, "idas fuzz finding: %s\n", what.c_str());
    std::abort();
}

/// Runs `parse` on the bytes: input_error is the documented refusal, anything else aborts
/// so libFuzzer records the input.
template <class Parse>
int run(const std::uint8_t* data, std::size_t size, Parse&& parse) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    try {
        parse(bytes);
    } catch (const input_error& e) {
        const std::string_view msg = e.what();
        if (!msg.starts_with(std::string(source) + ": "))
            finding("input_error does not name the source: " + std::string(msg));
    } catch (const std::exception& e) {
        finding(std::string("uncaught ") + typeid(e).name() + ": " + e.what());
    }
    return 0;
}

inline void check_points(std::span<const vec3> points) {
    for (const vec3& p : points)
        if (!is_finite(p)) finding("a reader returned a non-finite position");
}

/// Readers promise every corner index is in range and no cell repeats a vertex.
template <class Cells>
void check_cells(std::size_t vertex_count, const Cells& cells) {
    for (const auto& c : cells) {
        for (std::size_t i = 0; i < c.size(); ++i) {
            if (c[i] >= vertex_count) finding("a reader returned an out-of-range index");
            for (std::size_t j = 0; j < i; ++j)
                if (c[i] == c[j]) finding("a reader returned a cell that repeats a vertex");
        }
    }
}

/// Attribute columns hold `width` values per element: one element per vertex, per face or
/// (corner columns) three per face; a tag column's values index its labels.
inline void check_attributes(const io::surface& s) {
    for (const io::attribute_column& a : s.attributes) {
        std::size_t elements = s.vertices.size();
        if (a.domain == io::attribute_domain::face) elements = s.faces.size();
        if (a.domain == io::attribute_domain::corner) elements = 3 * s.faces.size();
        if (a.width == 0 || a.values.size() != elements * a.width)
            finding("attribute \"" + a.name + "\" has " + std::to_string(a.values.size()) +
                    " values for " + std::to_string(elements) + " elements of width " +
                    std::to_string(a.width));
        if (!a.labels.empty())
            for (double v : a.values)
                if (!(v >= 0 && v < static_cast<double>(a.labels.size())))
                    finding("tag column \"" + a.name + "\" holds a value without a label");
    }
}

inline void check_surface(const io::surface& s) {
    check_points(s.vertices);
    check_cells(s.vertices.size(), s.faces);
    check_attributes(s);
}

/// Tets in range, one tag per tet (or none), each field `components` values per vertex.
inline void check_volume(const io::volume& v) {
    check_points(v.vertices);
    check_cells(v.vertices.size(), v.tets);
    if (!v.tags.empty() && v.tags.size() != v.tets.size())
        finding("a reader returned " + std::to_string(v.tags.size()) + " tags for " +
                std::to_string(v.tets.size()) + " tets");
    check_cells(v.vertices.size(), v.triangles);
    if (!v.triangle_tags.empty() && v.triangle_tags.size() != v.triangles.size())
        finding("a reader returned " + std::to_string(v.triangle_tags.size()) + " tags for " +
                std::to_string(v.triangles.size()) + " triangles");
    for (const io::vertex_field& f : v.vertex_fields)
        if (f.components < 1 || f.values.size() != v.vertices.size() * std::size_t(f.components))
            finding("vertex field \"" + f.name + "\" has " + std::to_string(f.values.size()) +
                    " values for " + std::to_string(v.vertices.size()) + " vertices");
    for (const io::tet_field& f : v.tet_fields)
        if (f.components < 1 || f.values.size() != v.tets.size() * std::size_t(f.components))
            finding("tet field \"" + f.name + "\" has " + std::to_string(f.values.size()) +
                    " values for " + std::to_string(v.tets.size()) + " tets");
}

} // namespace idas::fuzz
