// The range of coordinates idas computes with. Editing and inspecting a mesh takes powers
// of its lengths: squared lengths, squared areas and quadric errors (4th powers), exact
// orient3d products (3rd), sums of those (6th at most). Input is accepted only if every
// such quantity stays a finite, normal double, so nothing downstream sees an infinite
// diagonal, a zero bounding box or a subnormal length:
//
//   every coordinate        |x| <= max_coordinate = 1e50    (6th powers <= ~1e303)
//   the bounding box        largest side >= min_extent = 1e-50   (6th powers >= ~1e-300)
//
// Single edges or faces far below the extent are not refused: they are as harmless as
// the exactly zero-length edges and zero-area faces real meshes contain.
#pragma once

#include <idas/core/types.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <span>
#include <string>

namespace idas {

struct geometry_range {
    static constexpr double max_coordinate = 1e50;
    static constexpr double min_extent = 1e-50;
};

namespace detail {
inline std::string shortest(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", x);
    return buf;
}
} // namespace detail

/// Why the points fall outside geometry_range (non-finite or too large coordinates, a
/// zero, subnormal or too small bounding box), or nothing if they are inside. Linear time.
inline std::optional<std::string> check_geometry_range(std::span<const vec3> points) {
    if (points.empty()) return std::nullopt;
    vec3 lo = points[0], hi = points[0];
    for (std::size_t v = 0; v < points.size(); ++v) {
        const vec3& p = points[v];
        for (int k = 0; k < 3; ++k) {
            if (!std::isfinite(p[k]))
                return "vertex " + std::to_string(v) + " has a non-finite coordinate";
            if (std::abs(p[k]) > geometry_range::max_coordinate)
                return "vertex " + std::to_string(v) + " has coordinate " + detail::shortest(p[k]) +
                       ", beyond the supported range of +-1e50 (lengths and areas would "
                       "overflow in double precision)";
            lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
        }
    }
    // The largest side, not the diagonal: squaring a subnormal side would round it to 0.
    const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
    if (extent == 0)
        return "all " + std::to_string(points.size()) +
               " vertices are at one point (an empty bounding box; the supported minimum "
               "width is 1e-50)";
    if (extent < geometry_range::min_extent)
        return "the bounding box is only " + detail::shortest(extent) +
               " wide, below the supported minimum of 1e-50 (lengths and areas would underflow "
               "in double precision)";
    return std::nullopt;
}

} // namespace idas
