// The error quadric of Garland and Heckbert 1997: the sum of squared distances to planes,
// a symmetric 4x4 matrix over homogeneous positions.
#pragma once

#include <idas/core/attribute.hpp>
#include <idas/core/geometry.hpp>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <optional>

namespace idas::algorithms {

/// A symmetric 4x4 error quadric stored as its 10 distinct entries. Trivially
/// copyable, so it is a journaled attribute like any other.
struct quadric {
    // | a00 a01 a02 b0 |
    // |     a11 a12 b1 |
    // |         a22 b2 |
    // |             c  |
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, b0 = 0, b1 = 0, b2 = 0, c = 0;

    /// w * (n·x + d)^2 for the plane n·x + d = 0.
    static quadric plane(const vec3& n, double d, double w) {
        return {w * n.x * n.x, w * n.x * n.y, w * n.x * n.z, w * n.y * n.y, w * n.y * n.z,
                w * n.z * n.z, w * n.x * d,   w * n.y * d,   w * n.z * d,   w * d * d};
    }
    quadric& operator+=(const quadric& o) {
        a00 += o.a00, a01 += o.a01, a02 += o.a02, a11 += o.a11, a12 += o.a12, a22 += o.a22;
        b0 += o.b0, b1 += o.b1, b2 += o.b2, c += o.c;
        return *this;
    }
    friend quadric operator+(quadric a, const quadric& b) { return a += b; }

    double error(const vec3& p) const {
        const double x = p.x, y = p.y, z = p.z;
        const double e = a00 * x * x + 2 * a01 * x * y + 2 * a02 * x * z + a11 * y * y +
                         2 * a12 * y * z + a22 * z * z + 2 * (b0 * x + b1 * y + b2 * z) + c;
        return std::max(e, 0.0); // rounding can dip below zero
    }

    /// The minimiser nearest to `near`. Where the quadric is flat in some
    /// direction (a plane, a crease: the 3x3 block is singular there) the error
    /// does not change along it and the exact minimiser runs off or does not
    /// exist; so the point stays where `near` is along directions whose
    /// eigenvalue is below 1e-3 of the largest (a truncated pseudo-inverse, as in
    /// Lindstrom 2000). Measured against the plain inverse with a fallback to the
    /// best of a, b and the midpoint: half the refused collapses on subdivided
    /// inputs, 5-35% smaller Hausdorff distance, twice the cost of a priority.
    vec3 minimizer_near(const vec3& near) const {
        Eigen::Matrix3d a;
        a << a00, a01, a02, a01, a11, a12, a02, a12, a22;
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
        eigen.computeDirect(a);
        const Eigen::Vector3d x0(near.x, near.y, near.z);
        const Eigen::Vector3d residual = -(a * x0 + Eigen::Vector3d(b0, b1, b2));
        const auto& lambda = eigen.eigenvalues(); // ascending
        Eigen::Vector3d x = x0;
        for (int i = 0; i < 3; ++i)
            if (lambda[i] > 1e-3 * lambda[2]) {
                const auto u = eigen.eigenvectors().col(i);
                x += u * (u.dot(residual) / lambda[i]);
            }
        const vec3 p{x[0], x[1], x[2]};
        return is_finite(p) ? p : near;
    }

    /// The minimiser, if the 3x3 block is well conditioned.
    std::optional<vec3> minimizer() const {
        const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22,
                     c02 = a01 * a12 - a02 * a11;
        const double det = a00 * c00 + a01 * c01 + a02 * c02;
        const double scale = std::max({std::abs(a00), std::abs(a11), std::abs(a22)});
        if (!(std::abs(det) > 1e-10 * scale * scale * scale)) return std::nullopt;
        const double c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12,
                     c22 = a00 * a11 - a01 * a01;
        const double inv = -1.0 / det;
        vec3 p{(c00 * b0 + c01 * b1 + c02 * b2) * inv, (c01 * b0 + c11 * b1 + c12 * b2) * inv,
               (c02 * b0 + c12 * b1 + c22 * b2) * inv};
        if (!is_finite(p)) return std::nullopt;
        return p;
    }
};

static_assert(attribute_value<quadric>);

} // namespace idas::algorithms
