// Basic vocabulary of idas: indices, simplex kinds, small geometry types, errors.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

/// For the few small functions on every operation's path (tuple checks, the heap's steps,
/// the face across an edge): g++ stops inlining them into the executor's loop once that
/// loop's body grows, which cost a serial decimation several percent more instructions
/// (bench/RESULTS.md, "Executor refactoring (issue 15)", session 19).
#if defined(__GNUC__)
#define IDAS_ALWAYS_INLINE [[gnu::always_inline]] inline
#define IDAS_ALWAYS_INLINE_LAMBDA __attribute__((always_inline))
#else
#define IDAS_ALWAYS_INLINE inline
#define IDAS_ALWAYS_INLINE_LAMBDA
#endif

namespace idas {

/// Index of a vertex, edge, face or tet slot.
using index_t = std::uint32_t;
inline constexpr index_t invalid_index = std::numeric_limits<index_t>::max();

/// Version tag of a top simplex slot; bumped whenever the slot changes, so a tuple
/// that carries an older version is known to be stale.
using version_t = std::uint32_t;

enum class simplex_kind : std::uint8_t { vertex = 0, edge = 1, face = 2, tet = 3 };

/// A point or vector in 3D. Deliberately trivially copyable (unlike Eigen's fixed-size
/// matrices) so attribute journals can save and restore it with memcpy.
struct vec3 {
    double x = 0, y = 0, z = 0;

    constexpr double& operator[](int i) noexcept { return i == 0 ? x : (i == 1 ? y : z); }
    constexpr double operator[](int i) const noexcept { return i == 0 ? x : (i == 1 ? y : z); }

    constexpr vec3& operator+=(const vec3& o) noexcept {
        x += o.x, y += o.y, z += o.z;
        return *this;
    }
    constexpr vec3& operator-=(const vec3& o) noexcept {
        x -= o.x, y -= o.y, z -= o.z;
        return *this;
    }
    constexpr vec3& operator*=(double s) noexcept {
        x *= s, y *= s, z *= s;
        return *this;
    }
    constexpr vec3& operator/=(double s) noexcept {
        x /= s, y /= s, z /= s;
        return *this;
    }
    friend constexpr vec3 operator+(vec3 a, const vec3& b) noexcept { return a += b; }
    friend constexpr vec3 operator-(vec3 a, const vec3& b) noexcept { return a -= b; }
    friend constexpr vec3 operator-(const vec3& a) noexcept { return {-a.x, -a.y, -a.z}; }
    friend constexpr vec3 operator*(vec3 a, double s) noexcept { return a *= s; }
    friend constexpr vec3 operator*(double s, vec3 a) noexcept { return a *= s; }
    friend constexpr vec3 operator/(vec3 a, double s) noexcept { return a /= s; }
    friend constexpr bool operator==(const vec3&, const vec3&) = default;
};

constexpr double dot(const vec3& a, const vec3& b) noexcept {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
constexpr vec3 cross(const vec3& a, const vec3& b) noexcept {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double squared_norm(const vec3& a) noexcept {
    return dot(a, a);
}
inline double norm(const vec3& a) noexcept {
    return std::sqrt(dot(a, a));
}
inline bool is_finite(const vec3& a) noexcept {
    return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

using tri_indices = std::array<index_t, 3>;
using tet_indices = std::array<index_t, 4>;

/// Raised for input the library refuses: malformed files, non-manifold meshes,
/// out-of-range indices. The message says where the problem is.
class input_error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

} // namespace idas
