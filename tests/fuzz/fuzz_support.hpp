// Shared by the libFuzzer harnesses (scripts/fuzz.sh builds and runs them). A reader may
// refuse any input with idas::input_error naming the source; everything else is a
// finding: a sanitizer report, another exception type (std::bad_alloc from a lying
// header included), a hang, or a result that breaks the readers' documented guarantees.
#pragma once

#include "idas/core/types.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <span>
#include <string>
#include <string_view>
#include <typeinfo>

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

} // namespace idas::fuzz
