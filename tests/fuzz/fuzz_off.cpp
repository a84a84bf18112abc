// libFuzzer harness for the OFF reader (parse_off).
#include "fuzz_support.hpp"
#include "idas/io/off.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return idas::fuzz::run(data, size, [](std::string_view bytes) {
        const idas::io::surface s = idas::io::parse_off(bytes, idas::fuzz::source);
        idas::fuzz::check_surface(s);
    });
}
