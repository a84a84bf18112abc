// Sampled distances between triangle surfaces, measured with a triangle_aabb_tree: the
// independent check of the envelope invariant (is every output point within eps of the
// input?), the Hausdorff distances benchmarks report, and mean distances.
//
// Each triangle is sampled at its vertices, edge midpoints and centroid, plus stratified
// interior samples: the triangle is cut into k x k congruent sub-triangles, k =
// ceil(sqrt(samples_per_face)), and each sub-triangle contributes its centroid. Distances
// are exact for the samples (up to rounding), so the answers are lower bounds of the true
// one-sided Hausdorff distance that tighten as samples_per_face grows. Deterministic, and
// computed in parallel with oneTBB.
#pragma once

#include <idas/core/aabb_tree.hpp>
#include <idas/core/types.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace idas {

/// The sample farthest from a reference surface: its distance (not squared), where it is
/// and on which face of the sampled surface. An empty sampled surface gives distance 0 and
/// face invalid_index; an empty reference gives an infinite distance.
struct farthest_sample {
    double distance = 0;
    vec3 point{};
    index_t face = invalid_index;
};

namespace detail {

/// Calls visit(point) for every sample of triangle (a, b, c).
template <class Visit>
void for_each_triangle_sample(const vec3& a, const vec3& b, const vec3& c, int samples_per_face,
                              Visit&& visit) {
    visit(a), visit(b), visit(c);
    visit((a + b) * 0.5), visit((b + c) * 0.5), visit((c + a) * 0.5);
    visit((a + b + c) / 3.0);
    if (samples_per_face <= 0) return;
    const int k = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(samples_per_face))));
    const double h = 1.0 / k;
    // Sub-triangles of the k x k grid in barycentric (u, v): "up" ones at (i, j), "down"
    // ones between them; centroids at offsets 1/3 and 2/3 of a cell.
    for (int i = 0; i < k; ++i)
        for (int j = 0; i + j < k; ++j) {
            const auto at = [&](double u, double v) { return a + (b - a) * u + (c - a) * v; };
            visit(at((i + 1.0 / 3) * h, (j + 1.0 / 3) * h));
            if (i + j + 1 < k) visit(at((i + 2.0 / 3) * h, (j + 2.0 / 3) * h));
        }
}

} // namespace detail

/// The sample of surface (V, F) farthest from `reference` (see the file comment for the
/// samples). Throws input_error for an out-of-range vertex index.
inline farthest_sample farthest_sampled_point(const std::vector<vec3>& V,
                                              const std::vector<tri_indices>& F,
                                              const triangle_aabb_tree& reference,
                                              int samples_per_face) {
    for (std::size_t f = 0; f < F.size(); ++f)
        for (index_t v : F[f])
            if (v >= V.size())
                throw input_error("face " + std::to_string(f) + " has vertex index " +
                                  std::to_string(v) + " beyond the " + std::to_string(V.size()) +
                                  " vertices");
    struct acc {
        double d2 = -1;
        vec3 p{};
        index_t face = invalid_index;
    };
    const auto better = [](const acc& x, const acc& y) {
        // Larger distance wins; ties go to the smaller face so the answer is deterministic.
        if (x.d2 != y.d2) return x.d2 > y.d2 ? x : y;
        return x.face <= y.face ? x : y;
    };
    const acc r = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, F.size(), 256), acc{},
        [&](const tbb::blocked_range<std::size_t>& range, acc best) {
            for (std::size_t f = range.begin(); f != range.end(); ++f) {
                const auto& t = F[f];
                detail::for_each_triangle_sample(
                    V[t[0]], V[t[1]], V[t[2]], samples_per_face, [&](const vec3& p) {
                        // Only a sample at least as far as the current maximum can change it (ties
                        // too: they are broken by face, whatever order the chunks run in).
                        if (best.d2 > 0 &&
                            reference.within_squared_distance(p, std::nextafter(best.d2, 0.0)))
                            return;
                        const double d2 = reference.squared_distance(p);
                        const acc cand{d2, p, static_cast<index_t>(f)};
                        best = better(best, cand);
                    });
            }
            return best;
        },
        better);
    if (r.face == invalid_index) return {};
    return {std::sqrt(r.d2), r.p, r.face};
}

/// Maximum distance from the samples of every triangle of (V, F) to `reference`.
inline double max_sampled_distance(const std::vector<vec3>& V, const std::vector<tri_indices>& F,
                                   const triangle_aabb_tree& reference, int samples_per_face) {
    return farthest_sampled_point(V, F, reference, samples_per_face).distance;
}

/// Area-weighted mean distance from the samples of every triangle of (V, F) to
/// `reference`: the steadier figure beside the Hausdorff distance, which one sample
/// decides. Deterministic (a fixed reduction order).
inline double mean_sampled_distance(const std::vector<vec3>& V, const std::vector<tri_indices>& F,
                                    const triangle_aabb_tree& reference, int samples_per_face) {
    struct acc {
        double weighted = 0, area = 0;
    };
    const acc r = tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, F.size(), 256), acc{},
        [&](const tbb::blocked_range<std::size_t>& range, acc sum) {
            for (std::size_t f = range.begin(); f != range.end(); ++f) {
                const auto& t = F[f];
                const double a = 0.5 * norm(cross(V[t[1]] - V[t[0]], V[t[2]] - V[t[0]]));
                double d = 0;
                int n = 0;
                detail::for_each_triangle_sample(V[t[0]], V[t[1]], V[t[2]], samples_per_face,
                                                 [&](const vec3& p) {
                                                     d += std::sqrt(reference.squared_distance(p));
                                                     ++n;
                                                 });
                sum.weighted += a * d / n, sum.area += a;
            }
            return sum;
        },
        [](acc x, const acc& y) {
            x.weighted += y.weighted, x.area += y.area;
            return x;
        });
    return r.area > 0 ? r.weighted / r.area : 0.0;
}

/// Sampled one-sided Hausdorff distance from surface A to surface B (absolute units).
inline double hausdorff_one_sided(const std::vector<vec3>& VA, const std::vector<tri_indices>& FA,
                                  const std::vector<vec3>& VB, const std::vector<tri_indices>& FB,
                                  int samples_per_face = 16) {
    return max_sampled_distance(VA, FA, triangle_aabb_tree(VB, FB), samples_per_face);
}

/// Sampled symmetric Hausdorff distance: the larger of both one-sided distances.
inline double hausdorff_symmetric(const std::vector<vec3>& VA, const std::vector<tri_indices>& FA,
                                  const std::vector<vec3>& VB, const std::vector<tri_indices>& FB,
                                  int samples_per_face = 16) {
    return std::max(hausdorff_one_sided(VA, FA, VB, FB, samples_per_face),
                    hausdorff_one_sided(VB, FB, VA, FA, samples_per_face));
}

/// The same, with trees already built over A and B.
inline double hausdorff_symmetric(const std::vector<vec3>& VA, const std::vector<tri_indices>& FA,
                                  const triangle_aabb_tree& A, const std::vector<vec3>& VB,
                                  const std::vector<tri_indices>& FB, const triangle_aabb_tree& B,
                                  int samples_per_face = 16) {
    return std::max(max_sampled_distance(VA, FA, B, samples_per_face),
                    max_sampled_distance(VB, FB, A, samples_per_face));
}

} // namespace idas
