// libFuzzer harness for the Gmsh MSH reader (parse_msh: 2.2 and 4.1, ASCII and binary).
#include "fuzz_support.hpp"
#include "idas/io/msh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return idas::fuzz::run(data, size, [](std::string_view bytes) {
        const idas::io::volume v = idas::io::parse_msh(bytes, idas::fuzz::source);
        idas::fuzz::check_volume(v);
    });
}
