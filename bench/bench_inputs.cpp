// Writes the large inputs the scaling benchmark reads (bench/run_scaling.sh): a mesh after
// L levels of 1-to-4 midpoint subdivision (armadillo x16 is armadillo after two: 1,383,712
// faces on the same surface).
//
//   bench_inputs IN OUT [--levels L]
#include "bench_support.hpp"

#include <idas/io/io.hpp>

#include <cstdio>
#include <exception>
#include <string>

int main(int argc, char** argv) {
    if (argc != 3 && !(argc == 5 && std::string(argv[3]) == "--levels")) {
        std::fprintf(stderr, "usage: bench_inputs IN OUT [--levels L]\n");
        return 2;
    }
    try {
        const int levels = argc == 5 ? std::stoi(argv[4]) : 2;
        if (levels < 0 || levels > 6) throw std::invalid_argument("--levels must be 0 to 6");
        auto s = idas::io::read_surface(argv[1]);
        for (int l = 0; l < levels; ++l) s = idas_bench::subdivide(s);
        idas::io::write_surface(argv[2], s);
        std::printf("%s: %zu vertices, %zu faces\n", argv[2], s.vertices.size(), s.faces.size());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_inputs: %s\n", e.what());
        return 2;
    }
    return 0;
}
