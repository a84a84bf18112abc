// libFuzzer harness for the OBJ reader (parse_obj). Large files are parsed in stretches
// of whole lines in parallel, with the same results and messages as one serial pass; fuzz
// inputs are small, so each is also parsed in three stretches and the two compared.
#include "fuzz_support.hpp"
#include "idas/io/obj.hpp"

#include <optional>

namespace {

struct outcome {
    std::optional<idas::io::surface> surface;
    std::string error;
};

outcome parse_in(std::string_view bytes, std::size_t stretches) {
    outcome o;
    try {
        o.surface = idas::io::detail::parse_obj_in(bytes, idas::fuzz::source, {}, stretches);
    } catch (const idas::input_error& e) {
        o.error = e.what();
    }
    return o;
}

bool same_values(const std::vector<double>& a, const std::vector<double>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (!(a[i] == b[i] || (a[i] != a[i] && b[i] != b[i]))) return false; // NaN == NaN
    return true;
}

bool same(const idas::io::surface& a, const idas::io::surface& b) {
    if (a.vertices != b.vertices || a.faces != b.faces || a.header_lines != b.header_lines ||
        a.attributes.size() != b.attributes.size())
        return false;
    for (std::size_t i = 0; i < a.attributes.size(); ++i) {
        const auto &x = a.attributes[i], &y = b.attributes[i];
        if (x.name != y.name || x.domain != y.domain || x.type != y.type || x.width != y.width ||
            x.labels != y.labels || !same_values(x.values, y.values))
            return false;
    }
    return true;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return idas::fuzz::run(data, size, [](std::string_view bytes) {
        const outcome split = parse_in(bytes, 3);
        idas::io::surface s;
        try {
            s = idas::io::parse_obj(bytes, idas::fuzz::source);
        } catch (const idas::input_error& e) {
            if (split.surface)
                idas::fuzz::finding(std::string("only the serial parse refused: ") + e.what());
            if (split.error != e.what())
                idas::fuzz::finding("the split parse refused with another message: " + split.error +
                                    " / " + e.what());
            throw;
        }
        idas::fuzz::check_surface(s);
        if (!split.surface) idas::fuzz::finding("only the split parse refused: " + split.error);
        if (!same(s, *split.surface))
            idas::fuzz::finding("parsing in three stretches gives another result");
    });
}
