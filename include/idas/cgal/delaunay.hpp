// The Delaunay tetrahedralization of a point set, built by CGAL's Delaunay_triangulation_3
// (exact predicates, inexact constructions) and handed over as plain arrays for tet_mesh.
// Kept out of idas.hpp and every core header: only code that links CGAL includes it.
#pragma once

#include <idas/core/types.hpp>
#include <idas/exec/partition.hpp>
#include <idas/predicates/orient.hpp>

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace idas::cgal {

struct delaunay_result {
    std::vector<vec3> vertices;    // the distinct input points, in a spatially coherent order
    std::vector<tet_indices> tets; // positively oriented (exact orient3d > 0)
    std::size_t duplicates = 0;    // input points dropped because an earlier one equals them
    std::vector<index_t> index_of; // input point i is vertices[index_of[i]] (invalid: a duplicate)
};

namespace detail {

/// The distinct points along a Morton curve (`order`: their input indices, so that a
/// vertex's star and, in a parallel run, its lock words sit in a few cache lines) and each
/// input point's place in it (`index_of`; invalid for a copy of an earlier point: equal
/// points share a key, and the first copy, the lowest index, stays). One sort, whose ties
/// are broken by input index: the numbering depends on the points alone.
struct point_numbering {
    std::vector<index_t> order, index_of;
};
inline point_numbering number_points(const std::vector<vec3>& points) {
    auto keyed = partition::morton::keys(points);
    tbb::parallel_sort(keyed.begin(), keyed.end());
    point_numbering n;
    n.order.reserve(keyed.size());
    n.index_of.assign(points.size(), invalid_index);
    std::vector<char> copy;
    std::vector<index_t> by_position;
    for (std::size_t b = 0; b < keyed.size();) { // runs of equal keys
        std::size_t e = b + 1;
        while (e < keyed.size() && keyed[e].first == keyed[b].first) ++e;
        copy.assign(e - b, 0);
        if (e - b <= 16) {
            for (std::size_t i = b + 1; i < e; ++i)
                for (std::size_t j = b; j < i && !copy[i - b]; ++j)
                    copy[i - b] = points[keyed[j].second] == points[keyed[i].second];
        } else { // many points in one grid cell: sort them by position instead
            by_position.resize(e - b);
            std::iota(by_position.begin(), by_position.end(), index_t{0});
            const auto at = [&](index_t k) -> const vec3& { return points[keyed[b + k].second]; };
            std::sort(by_position.begin(), by_position.end(), [&](index_t x, index_t y) {
                return std::tie(at(x).x, at(x).y, at(x).z, x) <
                       std::tie(at(y).x, at(y).y, at(y).z, y);
            });
            for (std::size_t i = 1; i < by_position.size(); ++i)
                if (at(by_position[i]) == at(by_position[i - 1])) copy[by_position[i]] = 1;
        }
        for (std::size_t i = b; i < e; ++i)
            if (!copy[i - b]) {
                n.index_of[keyed[i].second] = index_t(n.order.size());
                n.order.push_back(keyed[i].second);
            }
        b = e;
    }
    return n;
}

/// No more threads than the processors this process may run on: CGAL's workers spin on
/// the cells they lock, and a descheduled holder stalls them all (on 2 cores, 100k Gaussian
/// points on 8 threads: 305 s against 0.5 s).
inline unsigned delaunay_threads(unsigned threads) {
    return std::min(threads, static_cast<unsigned>(std::max(1, tbb::info::default_concurrency())));
}

/// Fewer points than this are triangulated on one thread: the parallel insertion's lock
/// grid and task start cost more than they save (Gaussian points on 2 cores: 2,000 took
/// 0.019 s on 2 threads against 0.015 s on one, 8,000 broke even, 30,000 took 0.16 against
/// 0.20 s; bench/RESULTS.md, "Session 45").
inline constexpr std::size_t parallel_delaunay_min_points = 10'000;

/// CGAL's triangulation of the points `kept` (by index), on `threads` threads when CGAL
/// runs on oneTBB (CGAL_LINKED_WITH_TBB: its Parallel_tag insertion, which locks a grid of
/// cells over the bounding box). Calls `take(dt)` with the triangulation.
template <class Take>
void triangulate(const std::vector<vec3>& points, const std::vector<index_t>& kept,
                 unsigned threads, Take&& take) {
    using K = CGAL::Exact_predicates_inexact_constructions_kernel;
    using Vb = CGAL::Triangulation_vertex_base_with_info_3<index_t, K>;
    const auto input = [&] {
        std::vector<std::pair<K::Point_3, index_t>> in(kept.size());
        tbb::parallel_for(std::size_t{0}, kept.size(), [&](std::size_t i) {
            const vec3& p = points[kept[i]];
            in[i] = {K::Point_3(p.x, p.y, p.z), kept[i]};
        });
        return in;
    };
#ifdef CGAL_LINKED_WITH_TBB
    threads = kept.size() < parallel_delaunay_min_points ? 1 : delaunay_threads(threads);
    if (threads > 1) {
        using Cb = CGAL::Delaunay_triangulation_cell_base_3<K>;
        using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb, CGAL::Parallel_tag>;
        using DT = CGAL::Delaunay_triangulation_3<K, Tds>;
        CGAL::Bbox_3 box;
        for (index_t i : kept)
            box += CGAL::Bbox_3(points[i].x, points[i].y, points[i].z, points[i].x, points[i].y,
                                points[i].z);
        tbb::task_arena arena(static_cast<int>(threads));
        arena.execute([&] {
            const auto in = input();
            // 50 grid cells per side: CGAL's own examples' choice.
            typename DT::Lock_data_structure locks(box, 50);
            DT dt(in.begin(), in.end(), &locks);
            take(dt);
        });
        return;
    }
#endif
    (void)threads;
    using Tds = CGAL::Triangulation_data_structure_3<Vb>;
    using DT = CGAL::Delaunay_triangulation_3<K, Tds>;
    const auto in = input();
    // The range insertion sorts spatially (Hilbert order) first: the fast path.
    DT dt(in.begin(), in.end());
    take(dt);
}

/// The triangulation as arrays in the numbering `n`: each tet positively oriented and
/// written from its smallest vertex (an even permutation), the tets sorted (grouped by
/// that vertex with a counting sort, each group sorted). CGAL's storage order, which
/// depends on the insertion order and the threads, plays no part.
template <class DT>
delaunay_result numbered(const std::vector<vec3>& points, point_numbering n, const DT& dt) {
    delaunay_result r;
    r.vertices.resize(n.order.size());
    tbb::parallel_for(std::size_t{0}, n.order.size(),
                      [&](std::size_t i) { r.vertices[i] = points[n.order[i]]; });
    r.duplicates = points.size() - n.order.size();
    std::vector<tet_indices> cells;
    cells.reserve(dt.number_of_finite_cells());
    for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
        tet_indices t;
        for (int k = 0; k < 4; ++k) t[k] = n.index_of[c->vertex(k)->info()];
        cells.push_back(t);
    }
    const auto& p = r.vertices;
    tbb::parallel_for(std::size_t{0}, cells.size(), [&](std::size_t i) {
        tet_indices& t = cells[i];
        // CGAL orders cells positively in its own sense; check ours exactly once here.
        if (orient3d(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
        // The smallest vertex first by an even permutation (two swaps), then the other
        // three rotated to start at their smallest: the orientation stays.
        const auto lowest = std::min_element(t.begin(), t.end()) - t.begin();
        if (lowest == 1) t = {t[1], t[0], t[3], t[2]};
        if (lowest == 2) t = {t[2], t[3], t[0], t[1]};
        if (lowest == 3) t = {t[3], t[2], t[1], t[0]};
        while (t[1] > t[2] || t[1] > t[3]) t = {t[0], t[2], t[3], t[1]};
    });
    std::vector<std::size_t> first(r.vertices.size() + 1, 0);
    for (const auto& t : cells) ++first[t[0] + 1];
    for (std::size_t v = 0; v < r.vertices.size(); ++v) first[v + 1] += first[v];
    r.tets.resize(cells.size());
    {
        std::vector<std::size_t> fill(first.begin(), first.end() - 1);
        for (const auto& t : cells) r.tets[fill[t[0]]++] = t;
    }
    tbb::parallel_for(std::size_t{0}, r.vertices.size(), [&](std::size_t v) {
        std::sort(r.tets.begin() + std::ptrdiff_t(first[v]),
                  r.tets.begin() + std::ptrdiff_t(first[v + 1]));
    });
    r.index_of = std::move(n.index_of);
    return r;
}

} // namespace detail

/// Delaunay tetrahedralization of `points`. Exact duplicates are merged (the first copy
/// stays). Throws input_error if there are fewer than four distinct points or all are
/// coplanar (no tet at all). With `threads` > 1 CGAL inserts in parallel (when it runs on
/// oneTBB); the result does not depend on the thread count: the Delaunay tetrahedralization
/// is unique (CGAL perturbs cospherical points symbolically), and it is numbered here by
/// the points alone (vertices along a Morton curve, tets sorted).
inline delaunay_result delaunay_tetrahedralization(const std::vector<vec3>& points,
                                                   unsigned threads = 1) {
    for (std::size_t i = 0; i < points.size(); ++i)
        if (!is_finite(points[i]))
            throw input_error("point " + std::to_string(i) + " has a non-finite coordinate");
    if (points.size() >= invalid_index) throw input_error("too many points");
    detail::point_numbering n = detail::number_points(points);
    delaunay_result r;
    detail::triangulate(points, n.order, threads, [&](const auto& dt) {
        if (dt.dimension() < 3)
            throw input_error("the " + std::to_string(points.size()) +
                              " points span no volume (fewer than four distinct points, or "
                              "all coplanar): there is no tetrahedralization");
        r = detail::numbered(points, std::move(n), dt);
    });
    return r;
}

} // namespace idas::cgal
