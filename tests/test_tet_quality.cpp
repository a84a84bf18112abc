// Tet quality measures (mesh/tet_quality.hpp): values on tets whose answers are known in
// closed form, invariances, and inverted / flat tets.
#include <idas/mesh/tet_quality.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

using namespace idas;

namespace {

constexpr double deg = 180.0 / std::numbers::pi;

// The regular tet with unit edges, positively oriented.
const std::array<vec3, 4> regular = {vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{0.5, std::sqrt(3.0) / 2, 0},
                                     vec3{0.5, std::sqrt(3.0) / 6, std::sqrt(2.0 / 3.0)}};
// The corner of the unit cube.
const std::array<vec3, 4> corner = {vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{0, 1, 0}, vec3{0, 0, 1}};

double amips(const std::array<vec3, 4>& p) {
    return tet_amips(p[0], p[1], p[2], p[3]);
}

/// Rotation about a unit axis (Rodrigues), then scale and shift.
vec3 transform(const vec3& p, const vec3& axis, double angle, double scale, const vec3& shift) {
    const double c = std::cos(angle), s = std::sin(angle);
    const vec3 r = p * c + cross(axis, p) * s + axis * (dot(axis, p) * (1 - c));
    return r * scale + shift;
}

} // namespace

TEST_CASE("tet quality: the regular tet") {
    REQUIRE(orient3d(regular[0], regular[1], regular[2], regular[3]) > 0);
    CHECK(amips(regular) == doctest::Approx(3).epsilon(1e-14));
    CHECK(tet_quality(regular[0], regular[1], regular[2], regular[3]) ==
          doctest::Approx(1).epsilon(1e-14));
    CHECK(tet_signed_volume(regular[0], regular[1], regular[2], regular[3]) ==
          doctest::Approx(1 / (6 * std::sqrt(2.0))).epsilon(1e-14));
    for (double a : tet_dihedral_angles(regular[0], regular[1], regular[2], regular[3]))
        CHECK(a == doctest::Approx(std::acos(1.0 / 3)).epsilon(1e-14)); // 70.53 degrees

    // Any similar copy is just as good: AMIPS is invariant under rotation, uniform
    // scaling and translation, and its minimum 3 is reached by every regular tet.
    const vec3 axis = vec3{1, 2, 3} / norm(vec3{1, 2, 3});
    for (double scale : {1e-6, 0.3, 7.0, 1e5}) {
        std::array<vec3, 4> q;
        for (int i = 0; i < 4; ++i) q[i] = transform(regular[i], axis, 0.7, scale, {5, -3, 2});
        CHECK(amips(q) == doctest::Approx(3).epsilon(1e-9));
        CHECK(tet_quality(q[0], q[1], q[2], q[3]) == doctest::Approx(1).epsilon(1e-9));
    }
}

TEST_CASE("tet quality: dihedral angles and AMIPS of the cube corner") {
    const auto a = tet_dihedral_angles(corner[0], corner[1], corner[2], corner[3]);
    // Edges along the axes (0-1, 0-2, 0-3) meet at right angles; the edges of the slanted
    // face meet the coordinate planes at acos(1/sqrt(3)) = 54.7356 degrees.
    static_assert(tet_edge_corners[0] == std::array<int, 2>{0, 1});
    for (int e = 0; e < 3; ++e) CHECK(a[e] * deg == doctest::Approx(90).epsilon(1e-13));
    for (int e = 3; e < 6; ++e)
        CHECK(a[e] == doctest::Approx(std::acos(1 / std::sqrt(3.0))).epsilon(1e-13));
    // Sum of squared edges 9, det J = 6 V sqrt(2) = sqrt(2): (9/2) / 2^(1/3).
    CHECK(amips(corner) == doctest::Approx(4.5 / std::cbrt(2.0)).epsilon(1e-13));
    CHECK(amips(corner) > 3);
}

TEST_CASE("tet quality: AMIPS is (sum of squared edges / 2) / (6 sqrt2 V)^(2/3)") {
    // The closed form is symmetric in the corners, so this also checks that the energy
    // does not depend on which corner the Jacobian is built from.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    int checked = 0;
    for (int i = 0; i < 200; ++i) {
        std::array<vec3, 4> p;
        for (auto& x : p) x = {u(rng), u(rng), u(rng)};
        if (orient3d(p[0], p[1], p[2], p[3]) < 0) std::swap(p[2], p[3]);
        const double v = tet_signed_volume(p[0], p[1], p[2], p[3]);
        if (!(v > 1e-3)) continue;
        double sum_sq = 0;
        for (const auto& e : tet_edge_corners) sum_sq += squared_norm(p[e[1]] - p[e[0]]);
        const double expected = (sum_sq / 2) / std::cbrt(72 * v * v);
        CHECK(amips(p) == doctest::Approx(expected).epsilon(1e-10));
        // Even permutations keep the orientation and the energy.
        CHECK(tet_amips(p[1], p[2], p[0], p[3]) == doctest::Approx(amips(p)).epsilon(1e-10));
        CHECK(tet_amips(p[2], p[3], p[0], p[1]) == doctest::Approx(amips(p)).epsilon(1e-10));
        CHECK(amips(p) >= 3 - 1e-12);
        ++checked;
    }
    CHECK(checked > 100);
}

TEST_CASE("tet quality: inverted, flat and nearly flat tets") {
    constexpr double inf = std::numeric_limits<double>::infinity();
    const std::array<vec3, 4> inverted = {regular[0], regular[1], regular[3], regular[2]};
    REQUIRE(orient3d(inverted[0], inverted[1], inverted[2], inverted[3]) < 0);
    CHECK(amips(inverted) == inf);
    CHECK(tet_quality(inverted[0], inverted[1], inverted[2], inverted[3]) ==
          doctest::Approx(-1).epsilon(1e-14));
    CHECK(tet_signed_volume(inverted[0], inverted[1], inverted[2], inverted[3]) < 0);
    // Unsigned angles: the mirror image has the same ones.
    for (double a : tet_dihedral_angles(inverted[0], inverted[1], inverted[2], inverted[3]))
        CHECK(a == doctest::Approx(std::acos(1.0 / 3)).epsilon(1e-14));

    // Four coplanar corners (a square): infinite energy, angles 0 and 180 degrees.
    const std::array<vec3, 4> flat = {vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{1, 1, 0}, vec3{0, 1, 0}};
    CHECK(amips(flat) == inf);
    const auto fa = tet_dihedral_angles(flat[0], flat[1], flat[2], flat[3]);
    CHECK(*std::min_element(fa.begin(), fa.end()) == doctest::Approx(0).epsilon(1e-15));
    CHECK(*std::max_element(fa.begin(), fa.end()) * deg == doctest::Approx(180));

    // A sliver: finite, large energy, and the energy grows as it flattens.
    double last = 3;
    for (double h : {0.5, 0.1, 0.01, 1e-4}) {
        const std::array<vec3, 4> s = {vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{1, 1, h}, vec3{0, 1, -h}};
        REQUIRE(orient3d(s[0], s[1], s[2], s[3]) != 0);
        const std::array<vec3, 4> pos =
            orient3d(s[0], s[1], s[2], s[3]) > 0 ? s : std::array<vec3, 4>{s[0], s[1], s[3], s[2]};
        const double e = amips(pos);
        CHECK(e > last);
        CHECK(e < inf);
        last = e;
    }
    CHECK(last > 100);
}

TEST_CASE("tet quality: tet_amips_three_halves is the energy to the power 3/2, in its order") {
    constexpr double inf = std::numeric_limits<double>::infinity();
    auto three_halves = [](const std::array<vec3, 4>& p) {
        return tet_amips_three_halves(p[0], p[1], p[2], p[3]);
    };
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<std::pair<double, double>> energies; // (energy, power) of the positive tets
    int inverted = 0;
    for (int i = 0; i < 2000; ++i) {
        std::array<vec3, 4> p;
        for (auto& x : p) x = {u(rng), u(rng), u(rng)};
        const double e = amips(p), power = three_halves(p);
        if (e == inf) {
            CHECK(power == inf);
            ++inverted;
            continue;
        }
        CHECK(power == doctest::Approx(e * std::sqrt(e)).epsilon(1e-12));
        energies.push_back({e, power});
    }
    CHECK(inverted > 500);
    REQUIRE(energies.size() > 500);
    // The same order, wherever the energies differ by more than rounding.
    std::sort(energies.begin(), energies.end());
    for (std::size_t i = 1; i < energies.size(); ++i)
        if (energies[i].first > energies[i - 1].first * (1 + 1e-12))
            CHECK(energies[i].second > energies[i - 1].second);
    // Scale-free far beyond where the energy's own det^2 over- or underflows (1e+-51).
    const double corner_power = amips(corner) * std::sqrt(amips(corner));
    for (double scale : {1e-100, 1e-60, 1e-20, 1.0, 1e20, 1e60, 1e100}) {
        std::array<vec3, 4> s = corner;
        for (auto& x : s) x = x * scale;
        CHECK(three_halves(s) == doctest::Approx(corner_power));
    }
    // Slivers: finite and growing as they flatten, past energies of 1e100 (where a cube
    // would overflow and tie them with inverted tets), until the volume itself underflows.
    double last = 0;
    for (double h : {1e-3, 1e-50, 1e-150, 1e-160, 1e-300}) {
        const std::array<vec3, 4> s = {vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{0, 1, 0}, vec3{0, 0, h}};
        const double power = three_halves(s);
        CHECK(power > last);
        CHECK(power < inf);
        last = power;
    }
    CHECK(last > 1e300);
    // Flat and inverted tets: infinite.
    const std::array<vec3, 4> flat = {vec3{0, 0, 0}, vec3{1, 0, 0}, vec3{1, 1, 0}, vec3{0, 1, 0}};
    CHECK(three_halves(flat) == inf);
    CHECK(three_halves({regular[0], regular[1], regular[3], regular[2]}) == inf);
    CHECK(three_halves(regular) == doctest::Approx(3 * std::sqrt(3.0)).epsilon(1e-14));
}

TEST_CASE("tet quality: summary over a tet list") {
    // Tet 0 regular, tet 1 its mirror (inverted), tet 2 the cube corner, tet 3 flat.
    std::vector<vec3> v(regular.begin(), regular.end());
    v.insert(v.end(), corner.begin(), corner.end());
    v.push_back({2, 2, 0});
    const std::vector<tet_indices> tets = {{0, 1, 2, 3}, {0, 1, 3, 2}, {4, 5, 6, 7}, {4, 5, 8, 6}};
    const tet_quality_summary s = summarize_tet_quality(v, tets);
    CHECK(s.tets == 4);
    CHECK(s.inverted == 1);
    CHECK(s.flat == 1);
    CHECK(s.amips_finite == 2);
    CHECK(s.amips.min == doctest::Approx(3));
    CHECK(s.amips.max == doctest::Approx(4.5 / std::cbrt(2.0)));
    CHECK(s.amips.mean == doctest::Approx((3 + 4.5 / std::cbrt(2.0)) / 2));
    CHECK(s.dihedral_deg.min == doctest::Approx(0).epsilon(1e-12));
    CHECK(s.dihedral_deg.max == doctest::Approx(180));
    CHECK(s.volume.min == doctest::Approx(-1 / (6 * std::sqrt(2.0))));
    CHECK(s.volume.max == doctest::Approx(1.0 / 6));
    CHECK(s.total_volume == doctest::Approx(1.0 / 6));
    CHECK(s.quality.min == doctest::Approx(-1));
    CHECK(s.quality.max == doctest::Approx(1));

    const tet_quality_summary empty = summarize_tet_quality(v, {});
    CHECK(empty.tets == 0);
    CHECK(empty.amips_finite == 0);
    CHECK(empty.dihedral_deg.max == 0);
}

TEST_CASE("tet quality: the AMIPS histogram puts each finite energy in its bin") {
    // The regular tet (3, the first bin, even if rounded just below), the cube corner
    // (3.57: [3.5, 3.75)), and the regular tet flattened towards its base until its energy
    // passes 10 and 1000; the inverted and flat tets of the summary test are in no bin.
    std::vector<vec3> v(regular.begin(), regular.end());
    v.insert(v.end(), corner.begin(), corner.end());
    const vec3 base_centre = (regular[0] + regular[1] + regular[2]) / 3.0;
    std::vector<tet_indices> tets = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 3, 2}};
    std::vector<double> energies = {amips(regular), amips(corner)};
    for (const double height : {0.05, 1e-5}) {
        v.push_back(base_centre + (regular[3] - base_centre) * height);
        const index_t apex = index_t(v.size() - 1);
        tets.push_back({0, 1, 2, apex});
        energies.push_back(tet_amips(v[0], v[1], v[2], v[apex]));
    }
    REQUIRE(energies[2] > 10);
    REQUIRE(energies[3] > 1000);
    const tet_quality_summary s = summarize_tet_quality(v, tets);
    CHECK(s.amips_finite == 4);
    const auto& bounds = amips_histogram_bounds;
    std::array<std::size_t, bounds.size()> expected{};
    for (const double e : energies) {
        std::size_t bin = 0;
        while (bin + 1 < bounds.size() && bounds[bin + 1] <= e) ++bin;
        ++expected[bin];
    }
    CHECK(s.amips_histogram == expected);
    CHECK(s.amips_histogram[0] == 1);
    CHECK(s.amips_histogram[2] == 1);     // [3.5, 3.75)
    CHECK(s.amips_histogram.back() == 1); // from 1000 up
    CHECK(std::is_sorted(bounds.begin(), bounds.end()));
    CHECK(bounds.front() == 3);
}
