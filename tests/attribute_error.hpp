// How far an edited surface's attributes and shape are from the input's, for the attribute
// tests and bench/bench_attribute_quadric.cpp.
#pragma once

#include <idas/core/aabb_tree.hpp>
#include <idas/io/surface.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace idas::test {

struct error_summary {
    double median = 0, p90 = 0, max = 0;
};

inline error_summary summarize(std::vector<double> errors) {
    if (errors.empty()) return {};
    std::sort(errors.begin(), errors.end());
    return {errors[errors.size() / 2], errors[errors.size() * 9 / 10], errors.back()};
}

/// Attribute `name` (per vertex or per corner): at each output face's centroid, its value
/// (the mean of the face's corners') against the input's at the nearest input point,
/// relative to the attribute's extent in the input (the length of the vector of its
/// components' ranges). Where the nearest input face lies in another chart (across a
/// seam) the values are not comparable; the median and 90th percentile are unmoved by
/// those few faces.
inline error_summary attribute_error(const io::surface& in, const io::surface& out,
                                     const std::string& name) {
    const auto find = [&](const io::surface& s) {
        for (const auto& a : s.attributes)
            if (a.name == name && a.domain != io::attribute_domain::face) return &a;
        return static_cast<const io::attribute_column*>(nullptr);
    };
    const io::attribute_column *a = find(in), *b = find(out);
    if (!a || !b || a->width != b->width) return {1e300, 1e300, 1e300};
    const std::size_t w = a->width;
    // Component k of corner c of face f.
    const auto corner = [w](const io::attribute_column& x, const io::surface& s, std::size_t f,
                            int c, std::size_t k) {
        return x.domain == io::attribute_domain::corner ? x.values[(3 * f + c) * w + k]
                                                        : x.values[s.faces[f][c] * w + k];
    };
    std::vector<double> lo(w, 1e300), hi(w, -1e300);
    for (std::size_t i = 0; i < a->values.size(); ++i)
        lo[i % w] = std::min(lo[i % w], a->values[i]),
               hi[i % w] = std::max(hi[i % w], a->values[i]);
    double extent = 0;
    for (std::size_t k = 0; k < w; ++k) extent += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    extent = std::sqrt(extent);
    if (!(extent > 0)) return {};
    const triangle_aabb_tree tree(in.vertices, in.faces);
    std::vector<double> errors;
    for (std::size_t f = 0; f < out.faces.size(); ++f) {
        const auto& fv = out.faces[f];
        const vec3 c = (out.vertices[fv[0]] + out.vertices[fv[1]] + out.vertices[fv[2]]) / 3.0;
        const auto hit = tree.closest_point(c);
        const auto& gv = in.faces[hit.face];
        // Barycentric coordinates of the hit in the input face.
        const vec3 x = in.vertices[gv[0]], y = in.vertices[gv[1]], z = in.vertices[gv[2]];
        const vec3 e0 = y - x, e1 = z - x, d = hit.point - x;
        const double p = dot(e0, e0), q = dot(e0, e1), r = dot(e1, e1);
        const double det = p * r - q * q;
        if (!(det > 0)) continue;
        const double wy = (r * dot(d, e0) - q * dot(d, e1)) / det,
                     wz = (p * dot(d, e1) - q * dot(d, e0)) / det, wx = 1 - wy - wz;
        double squared = 0;
        for (std::size_t k = 0; k < w; ++k) {
            const double mine =
                (corner(*b, out, f, 0, k) + corner(*b, out, f, 1, k) + corner(*b, out, f, 2, k)) /
                3;
            const double theirs = wx * corner(*a, in, hit.face, 0, k) +
                                  wy * corner(*a, in, hit.face, 1, k) +
                                  wz * corner(*a, in, hit.face, 2, k);
            squared += (mine - theirs) * (mine - theirs);
        }
        errors.push_back(std::sqrt(squared) / extent);
    }
    return summarize(std::move(errors));
}

/// Distance from the output's vertices and face centroids to the input surface, relative to
/// the input's bounding-box diagonal.
inline error_summary distance_to_input(const io::surface& in, const io::surface& out) {
    vec3 lo = in.vertices[0], hi = lo;
    for (const vec3& p : in.vertices)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    const double diagonal = norm(hi - lo);
    const triangle_aabb_tree tree(in.vertices, in.faces);
    std::vector<double> d;
    for (const vec3& p : out.vertices) d.push_back(std::sqrt(tree.squared_distance(p)) / diagonal);
    for (const auto& f : out.faces)
        d.push_back(std::sqrt(tree.squared_distance(
                        (out.vertices[f[0]] + out.vertices[f[1]] + out.vertices[f[2]]) / 3.0)) /
                    diagonal);
    return summarize(std::move(d));
}

} // namespace idas::test
