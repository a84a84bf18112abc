// bench_attribute_quadric: QSlim carrying a file's attributes at given attribute weights
// (algorithms/attribute_quadric.hpp), against QSlim without the attributes: time, and how
// far the result's attributes and shape are from the input (tests/attribute_error.hpp).
// A plain program (no Google Benchmark): one JSON line per configuration.
//
//   bench_attribute_quadric IN [--ratio R] [--weights W,W,...] [--repeat N]
//       runs "drop" (no attributes) and each weight N times, alternated, serially;
//       seconds = median wall time of qslim<>::run (the quadrics' set-up included, as the
//       tool's seconds_algorithm; attaching the attributes to the mesh is not)
//   bench_attribute_quadric --coloured IN OUT.ply
//       writes IN with an area-weighted float normal and an 8-bit colour (position scaled
//       to 0-255) per vertex: the coloured armadillo of bench/RESULTS.md
#include "../tests/attribute_error.hpp"

#include <idas/algorithms/qslim.hpp>
#include <idas/exec/report.hpp>
#include <idas/io/io.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace idas;
using namespace idas::algorithms;

namespace {

io::surface coloured(io::surface s) {
    vec3 lo = s.vertices[0], hi = lo;
    for (const vec3& p : s.vertices)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    std::vector<vec3> normal(s.vertices.size());
    for (const auto& f : s.faces) {
        const vec3 n =
            cross(s.vertices[f[1]] - s.vertices[f[0]], s.vertices[f[2]] - s.vertices[f[0]]);
        for (index_t v : f) normal[v] += n;
    }
    io::attribute_column normals{
        "normal", io::attribute_domain::vertex, io::scalar_type::float32, 3, {}, {}},
        colour{"color", io::attribute_domain::vertex, io::scalar_type::uint8, 3, {}, {}};
    for (std::size_t v = 0; v < s.vertices.size(); ++v) {
        const double l = norm(normal[v]);
        for (int k = 0; k < 3; ++k) {
            normals.values.push_back(double(float(l > 0 ? normal[v][k] / l : 0)));
            colour.values.push_back(std::round(255 * (s.vertices[v][k] - lo[k]) / (hi[k] - lo[k])));
        }
    }
    s.attributes = {std::move(normals), std::move(colour)};
    return s;
}

struct run_result {
    double seconds = 0;
    io::surface out;
    run_report report;
};

/// One QSlim run to `target` faces; weight < 0: without the attributes.
run_result decimate(const io::surface& in, std::int64_t target, double weight) {
    tri_mesh<> m(in.vertices, in.faces);
    attribute_transfer transfer;
    qslim_spec spec;
    spec.target_faces = target;
    if (weight >= 0) {
        transfer.attach(m, in);
        spec.transfer = &transfer;
        spec.attribute_weight = weight;
    }
    const detail::stopwatch clock;
    run_result r;
    r.report = qslim<>::run(m, spec, {.threads = 1});
    r.seconds = clock.seconds();
    std::tie(r.out.vertices, r.out.faces) = m.to_arrays();
    if (weight >= 0) r.out.attributes = transfer.exported(m);
    return r;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

} // namespace

int main(int argc, char** argv) {
    if (argc == 4 && std::string(argv[1]) == "--coloured") {
        io::write_surface(argv[3], coloured(io::read_surface(argv[2])),
                          {.encoding = io::encoding::ascii});
        return 0;
    }
    if (argc < 2) {
        std::fprintf(stderr, "usage: bench_attribute_quadric IN [--ratio R] [--weights W,W,...] "
                             "[--repeat N] | --coloured IN OUT.ply\n");
        return 2;
    }
    const io::surface in = io::read_surface(argv[1]);
    double ratio = 0.1;
    int repeat = 3;
    std::vector<double> weights{0, qslim_spec::default_attribute_weight};
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string arg = argv[i], value = argv[i + 1];
        if (arg == "--ratio") ratio = std::atof(value.c_str());
        if (arg == "--repeat") repeat = std::max(1, std::atoi(value.c_str()));
        if (arg == "--weights") {
            weights.clear();
            for (std::size_t a = 0; a < value.size();) {
                std::size_t b = value.find(',', a);
                if (b == std::string::npos) b = value.size();
                weights.push_back(std::atof(value.substr(a, b - a).c_str()));
                a = b + 1;
            }
        }
    }
    const auto target = static_cast<std::int64_t>(std::llround(ratio * double(in.faces.size())));
    std::vector<double> configs{-1};
    configs.insert(configs.end(), weights.begin(), weights.end());
    std::vector<std::vector<double>> seconds(configs.size());
    std::vector<io::surface> outputs(configs.size());
    std::vector<run_report> reports(configs.size());
    for (int r = 0; r < repeat; ++r)
        for (std::size_t c = 0; c < configs.size(); ++c) {
            run_result x = decimate(in, target, configs[c]);
            seconds[c].push_back(x.seconds);
            outputs[c] = std::move(x.out);
            reports[c] = x.report;
        }
    for (std::size_t c = 0; c < configs.size(); ++c) {
        const auto d = test::distance_to_input(in, outputs[c]);
        std::printf(
            "{\"input\":\"%s\",\"config\":\"%s\",\"output_faces\":%zu,"
            "\"collapses\":%llu,\"refused\":%llu,\"pushed\":%llu,\"seconds\":%.4f,"
            "\"seconds_vs_drop\":%.3f,\"distance_median\":%.3e,\"distance_p90\":%.3e,"
            "\"distance_max\":%.3e",
            argv[1], configs[c] < 0 ? "drop" : ("weight " + std::to_string(configs[c])).c_str(),
            outputs[c].faces.size(), (unsigned long long)reports[c].succeeded,
            (unsigned long long)reports[c].refused, (unsigned long long)reports[c].pushed,
            median(seconds[c]), median(seconds[c]) / median(seconds[0]), d.median, d.p90, d.max);
        for (const auto& a : outputs[c].attributes) {
            if (a.domain == io::attribute_domain::face) continue;
            const auto e = test::attribute_error(in, outputs[c], a.name);
            std::printf(",\"%s_error_median\":%.3e,\"%s_error_p90\":%.3e", a.name.c_str(), e.median,
                        a.name.c_str(), e.p90);
        }
        std::printf("}\n");
    }
    return 0;
}
