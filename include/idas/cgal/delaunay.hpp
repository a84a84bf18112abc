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

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

namespace idas::cgal {

struct delaunay_result {
    std::vector<vec3> vertices;    // the distinct input points, in a spatially coherent order
    std::vector<tet_indices> tets; // positively oriented (exact orient3d > 0)
    std::size_t duplicates = 0;    // input points dropped because an earlier one equals them
    std::vector<index_t> index_of; // input point i is vertices[index_of[i]] (invalid: a duplicate)
};

/// Delaunay tetrahedralization of `points`. Exact duplicates are merged (the first copy
/// stays). Throws input_error if there are fewer than four distinct points or all are
/// coplanar (no tet at all).
inline delaunay_result delaunay_tetrahedralization(const std::vector<vec3>& points) {
    using K = CGAL::Exact_predicates_inexact_constructions_kernel;
    using Vb = CGAL::Triangulation_vertex_base_with_info_3<index_t, K>;
    using Tds = CGAL::Triangulation_data_structure_3<Vb>;
    using DT = CGAL::Delaunay_triangulation_3<K, Tds>;

    for (std::size_t i = 0; i < points.size(); ++i)
        if (!is_finite(points[i]))
            throw input_error("point " + std::to_string(i) + " has a non-finite coordinate");
    if (points.size() >= invalid_index) throw input_error("too many points");
    std::vector<std::pair<K::Point_3, index_t>> input;
    input.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
        input.emplace_back(K::Point_3(points[i].x, points[i].y, points[i].z),
                           static_cast<index_t>(i));
    // The range insertion sorts spatially (Hilbert order) first: the fast path.
    DT dt(input.begin(), input.end());
    if (dt.dimension() < 3)
        throw input_error("the " + std::to_string(points.size()) +
                          " points span no volume (fewer than four distinct points, or all "
                          "coplanar): there is no tetrahedralization");

    delaunay_result r;
    // Vertices are numbered in CGAL's storage order, which follows the spatial sort of
    // the insertion, so neighbours get nearby ids (cache locality for everything after);
    // tets are then grouped by their smallest vertex. Duplicates are not in the
    // triangulation and are counted.
    std::vector<index_t> new_id(points.size(), invalid_index);
    r.vertices.reserve(dt.number_of_vertices());
    for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v) {
        new_id[v->info()] = static_cast<index_t>(r.vertices.size());
        r.vertices.push_back(points[v->info()]);
    }
    r.duplicates = points.size() - r.vertices.size();
    // Then along a Morton curve: CGAL inserts in rounds of a randomised order (BRIO), each
    // round sorted, so neighbours in space came from different rounds, far apart in the
    // storage order. Along the curve a vertex's star, and its lock words in a parallel
    // run, sit in a few cache lines.
    {
        struct view { // what partition::morton::keys reads
            const std::vector<vec3>& p;
            index_t vertex_slots() const noexcept { return index_t(p.size()); }
            bool vertex_alive(index_t) const noexcept { return true; }
            const vec3& position(index_t v) const noexcept { return p[v]; }
        };
        auto keyed = partition::morton::keys(view{r.vertices});
        std::sort(keyed.begin(), keyed.end());
        std::vector<index_t> rank(keyed.size());
        std::vector<vec3> sorted(keyed.size());
        for (std::size_t i = 0; i < keyed.size(); ++i)
            rank[keyed[i].second] = index_t(i), sorted[i] = r.vertices[keyed[i].second];
        for (index_t& id : new_id)
            if (id != invalid_index) id = rank[id];
        r.vertices = std::move(sorted);
    }
    r.index_of = new_id;
    std::vector<tet_indices> cells;
    cells.reserve(dt.number_of_finite_cells());
    std::vector<std::size_t> first(r.vertices.size() + 1, 0);
    for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
        tet_indices t;
        for (int k = 0; k < 4; ++k) t[k] = new_id[c->vertex(k)->info()];
        // CGAL orders cells positively in its own sense; check ours exactly once here.
        const auto& p = r.vertices;
        if (orient3d(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
        cells.push_back(t);
        ++first[*std::min_element(t.begin(), t.end()) + 1];
    }
    for (std::size_t v = 0; v < r.vertices.size(); ++v) first[v + 1] += first[v];
    r.tets.resize(cells.size());
    for (const auto& t : cells) r.tets[first[*std::min_element(t.begin(), t.end())]++] = t;
    return r;
}

} // namespace idas::cgal
