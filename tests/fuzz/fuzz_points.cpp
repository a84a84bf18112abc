// libFuzzer harness for the point-set reader (parse_points): input starting with "ply"
// goes to the PLY vertex reader, everything else to the XYZ reader, as the extension
// would decide for a file.
#include "fuzz_support.hpp"
#include "idas/io/points.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return idas::fuzz::run(data, size, [](std::string_view bytes) {
        const char* ext = bytes.starts_with("ply") ? ".ply" : ".xyz";
        idas::fuzz::check_points(idas::io::parse_points(bytes, idas::fuzz::source, ext));
    });
}
