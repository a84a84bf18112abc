// Small geometric helpers shared by algorithms, tests and benchmarks.
#pragma once

#include <idas/core/types.hpp>

#include <algorithm>
#include <cmath>

namespace idas {

/// Squared distance from p to triangle (a, b, c), by the Voronoi regions of the
/// triangle's features (vertices, edges, interior).
inline double point_triangle_squared_distance(const vec3& p, const vec3& a, const vec3& b,
                                              const vec3& c) {
    const vec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return squared_norm(ap);
    const vec3 bp = p - b;
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return squared_norm(bp);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return squared_norm(ap - ab * (d1 / (d1 - d3)));
    const vec3 cp = p - c;
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return squared_norm(cp);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return squared_norm(ap - ac * (d2 / (d2 - d6)));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return squared_norm(bp - (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    const double denom = 1.0 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    return squared_norm(ap - ab * v - ac * w);
}

/// Interior angles of triangle (a, b, c) in radians, at a, b and c.
inline std::array<double, 3> triangle_angles(const vec3& a, const vec3& b, const vec3& c) {
    auto angle = [](const vec3& u, const vec3& v) {
        return std::atan2(norm(cross(u, v)), dot(u, v));
    };
    return {angle(b - a, c - a), angle(a - b, c - b), angle(a - c, b - c)};
}

} // namespace idas
