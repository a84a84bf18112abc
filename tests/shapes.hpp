// Meshes made at run time, shared by the test suite and the benchmarks (no doctest here).
#pragma once

#include <idas/core/types.hpp>

#include <array>
#include <map>
#include <utility>
#include <vector>

namespace idas::test {

/// A unit cube, each side an n x n grid of right triangles, vertices shared, outward: a
/// CAD-like input (flat sides, sharp edges), as positions and faces.
inline std::pair<std::vector<vec3>, std::vector<tri_indices>> subdivided_cube_arrays(int n) {
    std::vector<vec3> V;
    std::vector<tri_indices> F;
    std::map<std::array<int, 3>, index_t> id;
    auto at = [&](const std::array<int, 3>& c) {
        const auto [it, fresh] = id.try_emplace(c, index_t(V.size()));
        if (fresh) V.push_back({double(c[0]) / n, double(c[1]) / n, double(c[2]) / n});
        return it->second;
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side)
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    auto p = [&](int u, int w) {
                        std::array<int, 3> c{};
                        c[axis] = side * n, c[(axis + 1) % 3] = u, c[(axis + 2) % 3] = w;
                        return at(c);
                    };
                    const index_t a = p(i, j), b = p(i + 1, j), c = p(i + 1, j + 1),
                                  d = p(i, j + 1);
                    if (side == 1)
                        F.push_back({a, b, c}), F.push_back({a, c, d});
                    else
                        F.push_back({a, c, b}), F.push_back({a, d, c});
                }
    return {std::move(V), std::move(F)};
}

} // namespace idas::test
