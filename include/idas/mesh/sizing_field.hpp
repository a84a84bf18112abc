// Sizing fields: the target edge length wanted at a point, for algorithms that refine or
// coarsen towards a local length (the tet optimization). A field is any type callable on
// a point that returns a positive, finite length:
//
//   uniform_sizing     one length everywhere
//   background_sizing  a tet mesh with a length per vertex, interpolated linearly inside
//                      its tets (fTetWild's --bg-mesh; a user's error estimate)
#pragma once

#include "idas/core/types.hpp"
#include "idas/mesh/geometry_range.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace idas {

/// The target edge length at a point: positive and finite wherever it is asked.
template <class F>
concept sizing_field = requires(const F& f, const vec3& p) {
    { f(p) } -> std::convertible_to<double>;
};

/// One length everywhere.
struct uniform_sizing {
    double length = 1;
    double operator()(const vec3&) const noexcept { return length; }
};
static_assert(sizing_field<uniform_sizing>);

/// A length per vertex of a background tet mesh, linear inside each tet. Points outside
/// every background tet take the value at the closest point of the nearest tet found in
/// their grid cell (constant extrapolation outwards), or `outside` where no tet is near.
class background_sizing {
public:
    /// Throws input_error (naming `source`) unless every value is positive and finite,
    /// every index is in range and there is a value per vertex.
    background_sizing(std::vector<vec3> vertices, std::vector<tet_indices> tets,
                      std::vector<double> values, double outside, const std::string& source)
        : vertices_(std::move(vertices))
        , tets_(std::move(tets))
        , values_(std::move(values))
        , outside_(outside) {
        if (values_.size() != vertices_.size())
            fail(source, "the sizing field has " + std::to_string(values_.size()) + " values for " +
                             std::to_string(vertices_.size()) + " vertices");
        if (tets_.empty()) fail(source, "the sizing field's background mesh has no tets");
        for (std::size_t i = 0; i < values_.size(); ++i)
            if (!(values_[i] > 0) || !std::isfinite(values_[i]))
                fail(source, "sizing value " + idas::detail::shortest(values_[i]) + " at node " +
                                 std::to_string(i + 1) + " is not a positive finite length");
        if (!(outside_ > 0) || !std::isfinite(outside_))
            fail(source, "the sizing field's value outside its mesh must be positive");
        for (const auto& t : tets_)
            for (index_t x : t)
                if (x >= vertices_.size())
                    fail(source, "a background tet's vertex is out of range");
        build_grid();
    }

    double operator()(const vec3& p) const noexcept {
        if (!is_finite(p)) return outside_;
        std::array<std::size_t, 3> c{};
        for (int k = 0; k < 3; ++k) {
            const double x = std::floor((p[k] - lo_[k]) / cell_[k]);
            c[k] = std::size_t(std::clamp(x, 0.0, double(n_[k] - 1)));
        }
        const std::size_t cell = (c[2] * n_[1] + c[1]) * n_[0] + c[0];
        double best = -std::numeric_limits<double>::infinity(), value = outside_;
        for (std::uint32_t i = start_[cell]; i < start_[cell + 1]; ++i) {
            const auto& t = tets_[members_[i]];
            std::array<double, 4> w = barycentric(p, t);
            const double least = std::min({w[0], w[1], w[2], w[3]});
            if (!(least > best)) continue; // also skips flat tets (NaN weights)
            best = least;
            // Outside the tet: the weights clamped to the tet, renormalized.
            double sum = 0;
            for (double& x : w) x = std::max(x, 0.0), sum += x;
            value = 0;
            for (int k = 0; k < 4; ++k) value += w[k] / sum * values_[t[k]];
            if (least >= 0) break; // inside: exact linear interpolation
        }
        return value;
    }

    std::size_t tets() const noexcept { return tets_.size(); }

private:
    [[noreturn]] static void fail(const std::string& source, const std::string& what) {
        throw input_error(source + ": " + what);
    }

    std::array<double, 4> barycentric(const vec3& p, const tet_indices& t) const noexcept {
        const vec3 &a = vertices_[t[0]], &b = vertices_[t[1]], &c = vertices_[t[2]],
                   &d = vertices_[t[3]];
        const double v = dot(b - a, cross(c - a, d - a));
        const double wb = dot(p - a, cross(c - a, d - a)) / v;
        const double wc = dot(b - a, cross(p - a, d - a)) / v;
        const double wd = dot(b - a, cross(c - a, p - a)) / v;
        return {1 - wb - wc - wd, wb, wc, wd};
    }

    /// A uniform grid of about one tet per cell; each tet listed in the cells its box
    /// overlaps (compressed rows).
    void build_grid() {
        lo_ = hi_ = vertices_[tets_[0][0]];
        for (const auto& t : tets_)
            for (index_t x : t)
                for (int k = 0; k < 3; ++k)
                    lo_[k] = std::min(lo_[k], vertices_[x][k]),
                    hi_[k] = std::max(hi_[k], vertices_[x][k]);
        const vec3 size = hi_ - lo_;
        const double volume_per_cell = std::max(size[0], 1e-300) * std::max(size[1], 1e-300) *
                                       std::max(size[2], 1e-300) / double(tets_.size());
        const double side = std::cbrt(volume_per_cell);
        for (int k = 0; k < 3; ++k) {
            n_[k] = std::size_t(std::clamp(std::ceil(size[k] / side), 1.0, 256.0));
            cell_[k] = size[k] > 0 ? size[k] / double(n_[k]) : 1.0;
        }
        const std::size_t cells = n_[0] * n_[1] * n_[2];
        auto range = [&](const tet_indices& t, int k) {
            double a = vertices_[t[0]][k], b = a;
            for (index_t x : t) a = std::min(a, vertices_[x][k]), b = std::max(b, vertices_[x][k]);
            const auto cell = [&](double x) {
                return std::size_t(
                    std::clamp(std::floor((x - lo_[k]) / cell_[k]), 0.0, double(n_[k] - 1)));
            };
            return std::array<std::size_t, 2>{cell(a), cell(b)};
        };
        start_.assign(cells + 1, 0);
        for (int pass = 0; pass < 2; ++pass) {
            std::vector<std::uint32_t> fill;
            if (pass == 1) {
                for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
                members_.resize(start_[cells]);
                fill.assign(start_.begin(), start_.end() - 1);
            }
            for (std::size_t i = 0; i < tets_.size(); ++i) {
                const auto x = range(tets_[i], 0), y = range(tets_[i], 1), z = range(tets_[i], 2);
                for (std::size_t cz = z[0]; cz <= z[1]; ++cz)
                    for (std::size_t cy = y[0]; cy <= y[1]; ++cy)
                        for (std::size_t cx = x[0]; cx <= x[1]; ++cx) {
                            const std::size_t c = (cz * n_[1] + cy) * n_[0] + cx;
                            if (pass == 0)
                                ++start_[c + 1];
                            else
                                members_[fill[c]++] = std::uint32_t(i);
                        }
            }
        }
    }

    std::vector<vec3> vertices_;
    std::vector<tet_indices> tets_;
    std::vector<double> values_;
    double outside_;
    vec3 lo_{}, hi_{}, cell_{};
    std::array<std::size_t, 3> n_{};
    std::vector<std::uint32_t> start_, members_;
};
static_assert(sizing_field<background_sizing>);

} // namespace idas
