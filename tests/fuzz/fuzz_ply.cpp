// libFuzzer harness for the PLY reader (parse_ply).
#include "fuzz_support.hpp"
#include "idas/io/ply.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return idas::fuzz::run(data, size, [](std::string_view bytes) {
        const idas::io::surface s = idas::io::parse_ply(bytes, idas::fuzz::source);
        idas::fuzz::check_surface(s);
    });
}
