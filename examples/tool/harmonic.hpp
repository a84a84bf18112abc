// `idas harmonic` and the Python module's idas.harmonic: the options, their checks, the
// run on a point set (CGAL's Delaunay tetrahedralization, then the harmonic flips) and its
// result check. The run needs CGAL (IDAS_CLI_HAVE_CGAL); the options and the check do not.
#pragma once

#include "common.hpp"

#include <idas/algorithms/harmonic_triangulation.hpp>
#include <idas/io/volume.hpp>
#include <idas/mesh/tet_mesh.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

namespace idas::tool {

struct harmonic_options {
    std::string mode = "complete";   // or "reduced"
    std::string backend = "indexed"; // or "adjacency"
    unsigned threads = 1, rounds = idas::algorithms::harmonic_options{}.rounds;
    bool deterministic = false; // lock::deterministic_rounds
};

/// Every option that needs no input is checked before any work.
inline void check_harmonic_options(const harmonic_options& o) {
    if (o.mode != "reduced" && o.mode != "complete")
        throw idas::input_error("--mode must be reduced or complete (got '" + o.mode + "')");
    if (o.backend != "indexed" && o.backend != "adjacency")
        throw idas::input_error("--backend must be indexed or adjacency (got '" + o.backend + "')");
    check_threads(o.threads);
}

/// The result check of harmonic: every tet positively oriented (exact orient3d), every
/// face shared by at most two tets, and the boundary a closed oriented 2-manifold with
/// `boundary_chi` (the input hull's). One parallel sort of the faces.
inline std::optional<std::string> check_harmonic_result(const idas::io::volume& v,
                                                        long boundary_chi) {
    const auto& V = v.vertices;
    const auto& T = v.tets;
    using range = tbb::blocked_range<std::size_t>;
    // Each tet on its own, in parallel; the lowest bad tet is reported.
    const auto tet_problem = [&](std::size_t t) -> std::optional<std::string> {
        const auto& tv = T[t];
        for (index_t x : tv)
            if (x >= V.size()) return "tet " + std::to_string(t) + " references a missing vertex";
        if (idas::orient3d(V[tv[0]], V[tv[1]], V[tv[2]], V[tv[3]]) <= 0)
            return "tet " + std::to_string(t) + " is flat or inverted";
        return std::nullopt;
    };
    const std::size_t first_bad = tbb::parallel_reduce(
        range(0, T.size(), 4096), T.size(),
        [&](const range& r, std::size_t bad) {
            for (std::size_t t = r.begin(); t != r.end() && t < bad; ++t)
                if (tet_problem(t)) return t;
            return bad;
        },
        [](std::size_t a, std::size_t b) { return std::min(a, b); });
    if (first_bad < T.size()) return tet_problem(first_bad);
    // Every face (sorted key, as its tet sees it from outside), sorted so that copies of a
    // face are adjacent: a face seen once is on the boundary, more than twice is an error.
    // Sorted in buckets by the key's smallest vertex (counted, placed, each bucket sorted
    // on its own): the same order as one sort of all 4 |T| faces, without its log factor.
    struct face_use {
        std::array<index_t, 3> key;
        idas::tri_indices outward;
        bool operator<(const face_use& o) const {
            return std::tie(key, outward) < std::tie(o.key, o.outward);
        }
    };
    const auto face_of = [&](std::size_t t, std::size_t k) {
        const auto& lf = idas::tet_local::face_vertices[k];
        const idas::tri_indices f = {T[t][lf[0]], T[t][lf[1]], T[t][lf[2]]};
        std::array<index_t, 3> key = f;
        std::sort(key.begin(), key.end());
        return face_use{key, f};
    };
    std::vector<std::size_t> start(V.size() + 1, 0); // counts, then where buckets start
    tbb::parallel_for(range(0, T.size(), 4096), [&](const range& r) {
        for (std::size_t t = r.begin(); t != r.end(); ++t)
            for (std::size_t k = 0; k < 4; ++k)
                std::atomic_ref<std::size_t>(start[face_of(t, k).key[0] + 1])
                    .fetch_add(1, std::memory_order_relaxed);
    });
    for (std::size_t v = 0; v < V.size(); ++v) start[v + 1] += start[v];
    const std::size_t n = 4 * T.size();
    const std::unique_ptr<face_use[]> faces(new face_use[n]); // written once below
    {
        std::vector<std::size_t> cursor(start.begin(), start.end() - 1);
        tbb::parallel_for(range(0, T.size(), 4096), [&](const range& r) {
            for (std::size_t t = r.begin(); t != r.end(); ++t)
                for (std::size_t k = 0; k < 4; ++k) {
                    const face_use f = face_of(t, k);
                    faces[std::atomic_ref<std::size_t>(cursor[f.key[0]])
                              .fetch_add(1, std::memory_order_relaxed)] = f;
                }
        });
    }
    tbb::parallel_for(range(0, V.size(), 1024), [&](const range& r) {
        for (std::size_t v = r.begin(); v != r.end(); ++v)
            std::sort(faces.get() + start[v], faces.get() + start[v + 1]);
    });
    std::vector<idas::tri_indices> boundary;
    for (std::size_t i = 0; i < n;) {
        std::size_t j = i + 1;
        while (j < n && faces[j].key == faces[i].key) ++j;
        if (j - i > 2) {
            const auto& k = faces[i].key;
            return "face (" + std::to_string(k[0]) + ", " + std::to_string(k[1]) + ", " +
                   std::to_string(k[2]) + ") is shared by more than two tets";
        }
        if (j - i == 1) boundary.push_back(faces[i].outward);
        i = j;
    }
    const auto b = idas::summarize_surface(V.size(), boundary);
    if (b.problem) return "the boundary is not an oriented 2-manifold: " + *b.problem;
    if (b.boundary_edges > 0) return "the boundary surface is not closed";
    if (b.euler_characteristic != boundary_chi)
        return "the boundary has Euler characteristic " + std::to_string(b.euler_characteristic) +
               ", the input's has " + std::to_string(boundary_chi);
    return std::nullopt;
}

#if IDAS_CLI_HAVE_CGAL
struct harmonic_result {
    idas::io::volume mesh;
    std::size_t duplicate_points = 0;
    idas::algorithms::harmonic_stats before, after;
    idas::algorithms::harmonic_report report;
    double delaunay_seconds = 0, check_seconds = 0;
};

/// The harmonic triangulation of `points` (from `source`, which error messages name);
/// `progress` (may be null) hears (fraction done, note) after every phase. Laps "delaunay"
/// ... "check" on `phases`. Compiled once, in harmonic.cpp.
harmonic_result harmonic_volume(const std::vector<idas::vec3>& points, const std::string& source,
                                const harmonic_options& a, phase_times& phases,
                                const phase_progress* progress);
#endif

} // namespace idas::tool
