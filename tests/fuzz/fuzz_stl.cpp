// libFuzzer harness for the STL reader (parse_stl, ASCII and binary), with and without
// welding: the two build the vertex list on different paths.
#include "fuzz_support.hpp"
#include "idas/io/stl.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    for (const bool weld : {true, false}) {
        idas::fuzz::run(data, size, [weld](std::string_view bytes) {
            const idas::io::surface s =
                idas::io::parse_stl(bytes, idas::fuzz::source, {.weld_stl = weld});
            idas::fuzz::check_surface(s);
        });
    }
    return 0;
}
