// Harmonic triangulations of Gaussian points (the IDAS paper's Fig. 7): one run per
// process, printed as one JSON line. Seconds of CGAL's Delaunay tetrahedralization, of
// building the tet_mesh, and of flipping; tets and mean harmonic index before and after.
//
//   bench_harmonic [--points N] [--seed S] [--input FILE] [--mode reduced|complete]
//                  [--threads T] [--rounds R] [--seed-above X] [--no-keep-max]
//                  [--delaunay-only] [--cgal-only] [--lock try|own-part] [--parts-per-thread K]
//
// --delaunay-only: idas::cgal::delaunay_tetrahedralization (CGAL's triangulation, duplicates
// merged, numbered by the points) on --threads threads; --cgal-only: CGAL's triangulation
// alone (its Parallel_tag insertion when --threads > 1), the peer of the scaling targets.
#if IDAS_BENCH_WITH_CGAL
#include <idas/algorithms/harmonic_triangulation.hpp>
#include <idas/cgal/delaunay.hpp>
#include <idas/io/points.hpp>

#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <numeric>
#include <string>

namespace {
double seconds_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
/// CPU seconds of the whole process (all threads): on a loaded machine, parallel
/// overhead shows as CPU time above the serial run's even when wall time says nothing.
double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}
} // namespace

int main(int argc, char** argv) {
    std::size_t n = 1000000;
    std::uint64_t seed = 1;
    std::string input, mode = "complete";
    unsigned threads = 1, rounds = idas::algorithms::harmonic_options{}.rounds;
    double seed_above = idas::algorithms::harmonic_options{}.seed_above;
    bool keep_max = true, delaunay_only = false, cgal_only = false;
    std::string lock = "own-part";
    unsigned parts_per_thread = 1;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto value = [&] {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "missing value after %s\n", a.c_str());
                std::exit(2);
            }
            return std::string(argv[++i]);
        };
        if (a == "--points")
            n = std::stoull(value());
        else if (a == "--seed")
            seed = std::stoull(value());
        else if (a == "--input")
            input = value();
        else if (a == "--mode")
            mode = value();
        else if (a == "--threads")
            threads = static_cast<unsigned>(std::stoul(value()));
        else if (a == "--rounds")
            rounds = static_cast<unsigned>(std::stoul(value()));
        else if (a == "--seed-above")
            seed_above = std::stod(value());
        else if (a == "--lock")
            lock = value();
        else if (a == "--parts-per-thread")
            parts_per_thread = static_cast<unsigned>(std::stoul(value()));
        else if (a == "--no-keep-max")
            keep_max = false;
        else if (a == "--delaunay-only")
            delaunay_only = true;
        else if (a == "--cgal-only")
            cgal_only = true;
        else {
            std::fprintf(stderr, "unknown argument %s\n", a.c_str());
            return 2;
        }
    }
    if (lock != "try" && lock != "own-part" && lock != "det") {
        std::fprintf(stderr, "--lock must be try, own-part or det\n");
        return 2;
    }
    if (mode != "reduced" && mode != "complete") {
        std::fprintf(stderr, "--mode must be reduced or complete\n");
        return 2;
    }
    // CGAL's parallel insertion runs on oneTBB: as many threads as asked for, even more
    // than the cores (a contention run).
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism,
                                          std::max(1u, threads));
    try {
        const std::vector<idas::vec3> points =
            input.empty() ? idas::io::gaussian_points(n, seed) : idas::io::read_points(input);

        auto t0 = std::chrono::steady_clock::now();
        if (cgal_only) { // CGAL's triangulation alone: parallel (Parallel_tag) when T > 1
            std::vector<idas::index_t> all(points.size());
            std::iota(all.begin(), all.end(), idas::index_t{0});
            const double cpu0 = cpu_seconds();
            std::size_t tets = 0;
            idas::cgal::detail::triangulate(
                points, all, threads, [&](const auto& dt) { tets = dt.number_of_finite_cells(); });
            std::printf("{\"points\":%zu,\"threads\":%u,\"cgal_delaunay_seconds\":%.3f,"
                        "\"cgal_delaunay_cpu_seconds\":%.3f,\"tets\":%zu}\n",
                        points.size(), threads, seconds_since(t0), cpu_seconds() - cpu0, tets);
            return 0;
        }
        const double delaunay_cpu0 = cpu_seconds();
        auto dt = idas::cgal::delaunay_tetrahedralization(points, threads);
        const double delaunay_seconds = seconds_since(t0);
        const double delaunay_cpu = cpu_seconds() - delaunay_cpu0;
        if (delaunay_only) {
            std::printf("{\"points\":%zu,\"delaunay_seconds\":%.3f,\"delaunay_cpu_seconds\":%.3f,"
                        "\"tets\":%zu}\n",
                        points.size(), delaunay_seconds, delaunay_cpu, dt.tets.size());
            return 0;
        }
        t0 = std::chrono::steady_clock::now();
        idas::tet_mesh<> m(dt.vertices, dt.tets);
        const double build_seconds = seconds_since(t0);
        const auto before = idas::algorithms::harmonic_statistics(m);

        idas::algorithms::harmonic_options o;
        o.mode = mode == "reduced" ? idas::algorithms::harmonic_mode::reduced
                                   : idas::algorithms::harmonic_mode::complete;
        o.rounds = rounds;
        o.seed_above = seed_above;
        o.keep_max = keep_max;
        o.exec.threads = threads;
        o.exec.parts_per_thread = parts_per_thread;
        const double cpu0 = cpu_seconds();
        using idas::algorithms::harmonic_triangulation;
        const auto rep =
            lock == "try"
                ? harmonic_triangulation<idas::tet_mesh<>, idas::lock::vertex_try_lock>::run(m, o)
            : lock == "det"
                ? harmonic_triangulation<idas::tet_mesh<>, idas::lock::deterministic_rounds>::run(m,
                                                                                                  o)
                : harmonic_triangulation<idas::tet_mesh<>, idas::lock::own_part_first>::run(m, o);
        const double flip_cpu = cpu_seconds() - cpu0;
        const auto after = idas::algorithms::harmonic_statistics(m);
        std::printf(
            "{\"points\":%zu,\"mode\":\"%s\",\"threads\":%u,\"rounds\":%u,\"seed_above\":%g,"
            "\"keep_max\":%s,"
            "\"delaunay_seconds\":%.3f,\"delaunay_cpu_seconds\":%.3f,\"build_seconds\":%.3f,"
            "\"flip_seconds\":%.3f,"
            "\"flips_only_seconds\":%.3f,\"smooth_seconds\":%.3f,\"flip_cpu_seconds\":%.3f,"
            "\"tets_before\":%zu,\"tets_after\":%zu,\"mean_index_before\":%.4f,"
            "\"mean_index_after\":%.4f,\"max_energy_before\":%.4g,\"max_energy_after\":%.4g,"
            "\"flips\":%llu,\"smoothed\":%llu,\"attempted\":%llu,\"lock_failures\":%llu,"
            "\"deferred_to_serial\":%llu,\"crossed_parts\":%llu,\"owner_seconds\":%.3f,\"lock\":\"%"
            "s\"}\n",
            points.size(), mode.c_str(), threads, rounds, seed_above, keep_max ? "true" : "false",
            delaunay_seconds, delaunay_cpu, build_seconds, rep.seconds, rep.flip_seconds,
            rep.smooth_seconds, flip_cpu, before.tets, after.tets, before.mean_index,
            after.mean_index, before.max_energy, after.max_energy,
            static_cast<unsigned long long>(rep.flips),
            static_cast<unsigned long long>(rep.smoothed),
            static_cast<unsigned long long>(rep.attempted),
            static_cast<unsigned long long>(rep.lock_failures),
            static_cast<unsigned long long>(rep.deferred_to_serial),
            static_cast<unsigned long long>(rep.crossed_parts), rep.owner_seconds, lock.c_str());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 2;
    }
    return 0;
}
#else
#include <cstdio>
int main() {
    std::puts("bench_harmonic needs CGAL (for the Delaunay input)");
    return 0;
}
#endif
