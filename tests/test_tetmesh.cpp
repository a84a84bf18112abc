// Tetrahedral meshing of triangle soups, part 1: exact insertion, rounding, inside and
// outside (include/idas/algorithms/triangle_insertion.hpp, include/idas/cgal/tetmesh.hpp).
#include <doctest/doctest.h>

#if defined(IDAS_HAS_CGAL)
#include <idas/algorithms/triangle_insertion.hpp>
#include <idas/algorithms/winding_number.hpp>
#include <idas/cgal/delaunay.hpp>
#include <idas/cgal/tetmesh.hpp>
#include <idas/io/io.hpp>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>

using namespace idas;

namespace {

std::string data(const char* name) {
    return std::string(IDAS_DATA_DIR) + "/" + name;
}

/// A valid subdivision of the background's box: every tet positive (exact), every face
/// in at most two tets and then with opposite orientations, and the tets' exact volumes
/// sum to the box's (so nothing overlaps and nothing is missing).
void check_valid(const insertion::inserted_mesh& m, const vec3& lo, const vec3& hi) {
    CHECK(insertion::count_inverted(m) == 0);
    std::map<std::array<index_t, 3>, std::vector<tri_indices>> faces;
    mpq_class volume6 = 0;
    for (const auto& t : m.tets) {
        for (const auto& lf : tet_local::face_vertices) {
            tri_indices f{t[lf[0]], t[lf[1]], t[lf[2]]};
            std::array<index_t, 3> key = f;
            std::sort(key.begin(), key.end());
            faces[key].push_back(f);
        }
        const rational_point a = m.exact_position(t[0]), b = m.exact_position(t[1]),
                             c = m.exact_position(t[2]), d = m.exact_position(t[3]);
        const auto u = insertion::detail::minus(b, a), v = insertion::detail::minus(c, a);
        volume6 += insertion::detail::dot(insertion::detail::cross(u, v), d) -
                   insertion::detail::dot(insertion::detail::cross(u, v), a);
    }
    std::size_t over_shared = 0, same_side = 0;
    for (const auto& [key, uses] : faces) {
        over_shared += uses.size() > 2;
        if (uses.size() == 2) {
            // Opposite orientations: the second is a rotation of the first reversed.
            const tri_indices r{uses[0][0], uses[0][2], uses[0][1]};
            bool reversed = false;
            for (int k = 0; k < 3; ++k)
                reversed |= uses[1] == tri_indices{r[k], r[(k + 1) % 3], r[(k + 2) % 3]};
            same_side += !reversed;
        }
    }
    CHECK(over_shared == 0);
    CHECK(same_side == 0);
    const mpq_class box =
        6 * (mpq_class(hi.x) - lo.x) * (mpq_class(hi.y) - lo.y) * (mpq_class(hi.z) - lo.z);
    CHECK(volume6 == box);
}

struct background {
    insertion::insertion_input in;
    vec3 lo, hi;
};

/// Delaunay of the soup's vertices and the corners of a box around them.
background make_background(const std::vector<vec3>& v, const std::vector<tri_indices>& f) {
    background b;
    b.lo = b.hi = v[0];
    for (const vec3& p : v)
        for (int k = 0; k < 3; ++k)
            b.lo[k] = std::min(b.lo[k], p[k]), b.hi[k] = std::max(b.hi[k], p[k]);
    for (int k = 0; k < 3; ++k) b.lo[k] -= 1, b.hi[k] += 1;
    std::vector<vec3> pts = v;
    for (int i = 0; i < 8; ++i)
        pts.push_back(
            {(i & 1) ? b.hi.x : b.lo.x, (i & 2) ? b.hi.y : b.lo.y, (i & 4) ? b.hi.z : b.lo.z});
    const auto dt = cgal::delaunay_tetrahedralization(pts);
    b.in.vertices = dt.vertices;
    b.in.tets = dt.tets;
    for (const auto& t : f)
        b.in.triangles.push_back({dt.index_of[t[0]], dt.index_of[t[1]], dt.index_of[t[2]]});
    return b;
}

/// Inserts, checks validity and exact cover before rounding, then rounds and checks
/// again. Returns the number of triangles covered exactly.
std::size_t insert_and_check(const std::vector<vec3>& v, const std::vector<tri_indices>& f) {
    background b = make_background(v, f);
    insertion::inserted_mesh m = insertion::insert_triangles(b.in);
    check_valid(m, b.lo, b.hi);
    const std::size_t covered =
        tetmesh::count_covered(m, tetmesh::clean_soup{b.in.vertices, b.in.triangles});
    insertion::round_vertices(m);
    check_valid(m, b.lo, b.hi);
    return covered;
}

/// n random triangles in the unit cube (fixed seed). With needles, every other one has its
/// third corner 1e-7 to 1e-12 of its length off the edge of the first two.
std::pair<std::vector<vec3>, std::vector<tri_indices>> random_soup(unsigned seed, int n,
                                                                   bool needles) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<vec3> v;
    std::vector<tri_indices> f;
    for (int i = 0; i < n; ++i) {
        const vec3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)};
        vec3 c{u(rng), u(rng), u(rng)};
        if (needles && i % 2 == 0) {
            const vec3 side = cross(b - a, c);
            c = a + (b - a) * u(rng) + side * (std::pow(10.0, -7 - i % 6) / norm(side));
        }
        v.insert(v.end(), {a, b, c});
        f.push_back({index_t(3 * i), index_t(3 * i + 1), index_t(3 * i + 2)});
    }
    return {v, f};
}

/// The smallest box around the points.
std::pair<vec3, vec3> box_of(const std::vector<vec3>& v) {
    vec3 lo = v[0], hi = v[0];
    for (const vec3& p : v)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    return {lo, hi};
}

/// The winding number at p by the sum of every triangle's solid angle.
double exact_winding(const io::surface& s, const vec3& p) {
    double sum = 0;
    for (const auto& t : s.faces)
        sum += solid_angle(p, s.vertices[t[0]], s.vertices[t[1]], s.vertices[t[2]]);
    return sum / (4 * std::acos(-1.0));
}

/// Signed volume enclosed by a closed, outward-oriented surface.
double enclosed_volume(const std::vector<vec3>& v, const std::vector<tri_indices>& f) {
    double s = 0;
    for (const auto& t : f) s += dot(v[t[0]], cross(v[t[1]], v[t[2]]));
    return s / 6;
}

double inside_volume(const tetmesh::result& r) {
    double s = 0;
    for (std::size_t t = 0; t < r.mesh.tets.size(); ++t)
        if (r.inside[t]) {
            const auto& x = r.mesh.tets[t];
            const auto& p = r.mesh.vertices;
            s += dot(p[x[1]] - p[x[0]], cross(p[x[2]] - p[x[0]], p[x[3]] - p[x[0]])) / 6;
        }
    return s;
}

} // namespace

TEST_CASE("triangle insertion: two triangles crossing each other are both covered exactly") {
    const std::vector<vec3> v{{0, 0, 0},      {2, 0, 0},     {0, 2, 0},
                              {0.5, 0.5, -1}, {0.7, 0.4, 1}, {0.3, 0.9, 1}};
    CHECK(insert_and_check(v, {{0, 1, 2}, {3, 4, 5}}) == 2);
}

TEST_CASE("triangle insertion: coplanar overlapping, touching and T-junction triangles") {
    // Three triangles in z = 0: two overlapping, one sharing an edge, one whose corner
    // lies in the middle of another's edge.
    const std::vector<vec3> v{{0, 0, 0}, {4, 0, 0},  {0, 4, 0}, {1, 1, 0}, {5, 1, 0},
                              {1, 5, 0}, {0, -3, 0}, {2, 0, 0}, {2, -2, 0}};
    CHECK(insert_and_check(v, {{0, 1, 2}, {3, 4, 5}, {0, 6, 1}, {7, 8, 1}}) == 4);
}

TEST_CASE("triangle insertion: a triangle lying on a face of the background") {
    // The background is one tet split by nothing; the triangle is inside one of its faces.
    insertion::insertion_input in;
    in.vertices = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0, 0, 4}, {1, 1, 0}, {2, 1, 0}, {1, 2, 0}};
    // Split the tet so that the small triangle's corners are vertices: Delaunay does it.
    const auto dt = cgal::delaunay_tetrahedralization(in.vertices);
    in.vertices = dt.vertices;
    in.tets = dt.tets;
    in.triangles = {{dt.index_of[4], dt.index_of[5], dt.index_of[6]},
                    {dt.index_of[0], dt.index_of[5], dt.index_of[3]}};
    insertion::inserted_mesh m = insertion::insert_triangles(in);
    CHECK(insertion::count_inverted(m) == 0);
    CHECK(tetmesh::count_covered(m, tetmesh::clean_soup{in.vertices, in.triangles}) == 2);
}

TEST_CASE("triangle insertion: random soups of intersecting triangles (fixed seeds)") {
    for (unsigned seed : {1u, 2u, 3u}) {
        const auto [v, f] = random_soup(seed, 12, false);
        CAPTURE(seed);
        CHECK(insert_and_check(v, f) == f.size());
    }
}

TEST_CASE("triangle insertion: orientation from doubles agrees with exact rationals") {
    // Tets with rational corners (cut points: a + s (b - a) + t (c - a), off the plane by
    // h), from coplanar to clearly off it, at unit size near the origin and 1e-3 in size
    // at 1024 (where rounding a corner to doubles moves it by 1e-13, far more than the
    // tet's own rounding error: a filter without the corners' ulps would guess there).
    // The filter must never contradict the exact sign, and must decide the clear cases.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    int decided = 0, clear = 0;
    for (int i = 0; i < 4000; ++i) {
        const bool far = i % 8 >= 4;
        const double size = far ? 1e-3 : 1, at = far ? 1024 : 0;
        insertion::inserted_mesh r;
        std::array<rational_point, 4> q;
        for (int k = 0; k < 3; ++k)
            q[k] = to_rational(vec3{at + size * u(rng), at + size * u(rng), at + size * u(rng)});
        const mpq_class s(int(rng() % 97) + 1, 101), t(int(rng() % 89) + 1, 103);
        const mpq_class scale = far ? mpq_class(1, 1000000) : mpq_class(1);
        const mpq_class h[] = {0, mpq_class(1, 1000000) * mpq_class(1, 1000000000000),
                               mpq_class(-1, 1000000000000), mpq_class(1, 1000)};
        const mpq_class off = h[i % 4] * scale;
        for (int k = 0; k < 3; ++k)
            q[3][k] = q[0][k] + s * (q[1][k] - q[0][k]) + t * (q[2][k] - q[0][k]) +
                      (k == 2 ? off : mpq_class(0));
        // Corner 3 always rational; corner 1 too in every other case.
        const bool second_rational = i % 2 == 1;
        if (second_rational)
            for (int k = 0; k < 3; ++k) q[1][k] += mpq_class(1, 3) * mpq_class(1, 1 << 30) * scale;
        for (int k = 0; k < 4; ++k) {
            r.vertices.push_back(to_vec3(q[k]));
            if (k == 3 || (k == 1 && second_rational)) r.exact.emplace(index_t(k), q[k]);
        }
        const tet_indices tet{0, 1, 2, 3};
        const int exact = idas::detail::predicates::orient3d_rational_mpz(q[0], q[1], q[2], q[3]);
        const int filtered = insertion::detail::orientation_from_doubles(r, tet);
        CAPTURE(i);
        if (filtered != 0) CHECK(filtered == exact);
        CHECK(insertion::orientation(r, tet) == exact);
        decided += filtered != 0;
        clear += i % 4 == 3;
    }
    CHECK(decided >= clear);
}

TEST_CASE("triangle insertion: the plane filters never contradict the exact sign") {
    // Needle triangles (the third corner 1e-4 to 1e-14 of the length off the long edge,
    // where the computed normal is mostly rounding error) and ordinary ones, at unit size
    // and far from the origin, against points near their planes and edge planes. Where a
    // filter decides, GMP must agree; a bound relative to the computed normal alone (the
    // one used before) contradicts it on the thinnest needles.
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1, 1);
    int decided = 0, wrong = 0, samples = 0;
    mpz_class N, D;
    for (int i = 0; i < 3000; ++i) {
        const double at = i % 2 ? 1000.0 : 0.0, thin = std::pow(10.0, -4 - i % 11);
        const vec3 a{at + u(rng), at + u(rng), at + u(rng)}, b{at + u(rng), u(rng), u(rng)};
        const vec3 side = cross(b - a, vec3{u(rng), u(rng), u(rng)});
        const vec3 c =
            (a + b) * 0.5 + side * ((i % 3 == 0 ? 0.5 : thin * norm(b - a)) / norm(side));
        const auto edges = insertion::detail::edge_planes({a, b, c});
        insertion::detail::exact_plane planes[4] = {insertion::detail::plane_through(a, b, c),
                                                    edges[0], edges[1], edges[2]};
        insertion::detail::make_exact(planes[0]);
        if (sgn(planes[0].n[0]) == 0 && sgn(planes[0].n[1]) == 0 && sgn(planes[0].n[2]) == 0)
            continue; // the corners rounded onto one line
        for (const auto& pl : planes)
            for (int j = 0; j < 8; ++j) {
                // A point near the plane: on it up to 1e-6 to 1e-18 along a random direction.
                const double s = u(rng), t = u(rng), h = std::pow(10.0, -6 - 2 * (j % 7)) * u(rng);
                const vec3 x = a + (b - a) * s + (c - a) * t + vec3{u(rng), u(rng), u(rng)} * h;
                const vec3 d = x - pl.anchor;
                const double val = dot(pl.normal, d);
                const double tol = insertion::detail::filter_bound(pl, d, 0);
                insertion::detail::plane_value(pl, to_rational(x), N, D);
                const int exact = sgn(N);
                ++samples;
                if (std::abs(val) > tol) {
                    ++decided;
                    wrong += (val > 0 ? 1 : -1) != exact;
                }
            }
    }
    CHECK(wrong == 0);
    CHECK(decided > samples / 3); // the filter still decides the clear cases
}

TEST_CASE("triangle insertion: exact planes built one after another in shared scratch") {
    // Each thread builds every plane in the same scratch integers: a plane must not keep
    // anything of the one before, whose corners were longer, or nonzero where its own are
    // zero. Triangle planes vanish at their corners and agree with orient3d elsewhere; edge
    // planes vanish at their edge ends and are negative at the third corner.
    namespace d = insertion::detail;
    std::mt19937 rng(29);
    std::uniform_real_distribution<double> u(-1, 1);
    mpz_class N, D;
    int checked = 0;
    for (int i = 0; i < 600; ++i) {
        const double scale = std::pow(10.0, 30 * (i % 3) - 30);
        std::array<vec3, 3> tri;
        for (vec3& p : tri) p = vec3{u(rng), u(rng), u(rng)} * scale;
        if (i % 2 == 0) tri[0][i % 3] = 0, tri[1][(i + 1) % 3] = 0, tri[2][i % 3] = 0;
        if (orient3d(tri[0], tri[1], tri[2], tri[0] + vec3{1, 2, 3} * scale) == 0) continue;
        d::exact_plane plane = d::plane_through(tri[0], tri[1], tri[2]);
        const auto edges = d::edge_planes(tri, &plane);
        d::exact_plane alone = d::plane_through(tri[0], tri[1], tri[2]);
        d::make_exact(alone);
        for (const vec3& p : tri) {
            d::plane_value(plane, to_rational(p), N, D);
            CHECK(sgn(N) == 0);
        }
        const vec3 x = vec3{u(rng), u(rng), u(rng)} * scale;
        const int side = orient3d(tri[0], tri[1], tri[2], x);
        d::plane_value(plane, to_rational(x), N, D);
        CHECK(sgn(N) == side);
        d::plane_value(alone, to_rational(x), N, D);
        CHECK(sgn(N) == side);
        for (std::size_t e = 0; e < 3; ++e) {
            for (std::size_t k : {e, (e + 1) % 3}) {
                d::plane_value(edges[e], to_rational(tri[k]), N, D);
                CHECK(sgn(N) == 0);
            }
            d::plane_value(edges[e], to_rational(tri[(e + 2) % 3]), N, D);
            CHECK(sgn(N) < 0);
        }
        ++checked;
    }
    CHECK(checked > 500);
}

TEST_CASE("triangle insertion: homogeneous cut points agree with canonical rationals") {
    // Cut points as the cutter makes them (three planes met by Cramer's rule, not reduced)
    // against the same points reduced to canonical rationals, on every operation the
    // cutter does with them. Tiny and huge scales, and planes through nearly equal points,
    // give denominators of both signs and long integers.
    namespace d = insertion::detail;
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    auto random_point = [&](double scale) { return vec3{u(rng), u(rng), u(rng)} * scale; };
    auto reference_average = [](const rational_point& a, const rational_point& b, int wa, int wb) {
        rational_point r;
        for (int k = 0; k < 3; ++k) r[k] = (wa * a[k] + wb * b[k]) / (wa + wb);
        return r;
    };
    int checked = 0, doubles = 0;
    std::vector<std::pair<insertion::homogeneous_point, rational_point>> points;
    for (int i = 0; i < 400; ++i) {
        const double scale = std::pow(10.0, -30 + 10 * (i % 7)); // 1e-30 .. 1e30
        std::array<d::exact_plane, 3> planes;
        for (auto& pl : planes) {
            const vec3 a = random_point(scale);
            // Every fourth plane through a point that is a double (the crossing is one).
            const vec3 b = i % 4 == 0 ? a + vec3{scale, 0, 0} : random_point(scale);
            const vec3 c = i % 4 == 0 ? a + vec3{0, scale, 0} : random_point(scale);
            pl = d::plane_through(a, b, c);
            d::make_exact(pl);
        }
        if (i % 4 == 0) {
            const vec3 a = random_point(scale);
            planes[0] = d::plane_through(a, a + vec3{scale, 0, 0}, a + vec3{0, scale, 0});
            planes[1] = d::plane_through(a, a + vec3{0, scale, 0}, a + vec3{0, 0, scale});
            planes[2] = d::plane_through(a, a + vec3{0, 0, scale}, a + vec3{scale, 0, 0});
            for (auto& pl : planes) pl.has_exact = false, d::make_exact(pl);
        }
        // Cramer's rule, as tet_cutter::meet.
        const auto c0 = d::cross(planes[1].n, planes[2].n), c1 = d::cross(planes[2].n, planes[0].n),
                   c2 = d::cross(planes[0].n, planes[1].n);
        insertion::homogeneous_point h;
        h.W = d::dot(planes[0].n, c0);
        if (sgn(h.W) == 0) continue;
        for (std::size_t k = 0; k < 3; ++k)
            h.X[k] = planes[0].off * c0[k] + planes[1].off * c1[k] + planes[2].off * c2[k];
        if (i % 2) { // the same point with a negative, unreduced denominator
            for (auto& x : h.X) x *= -3;
            h.W *= -3;
        }
        const rational_point q = d::canonical(h);
        CAPTURE(i);
        // On the three planes, exactly.
        for (const auto& pl : planes) {
            mpz_class N, D, scratch;
            CHECK(d::plane_sign(pl, h, scratch) == 0);
            d::plane_value(pl, q, N, D);
            CHECK(sgn(N) == 0);
        }
        // Rounding and the test for doubles.
        const vec3 approx = d::to_vec3(h);
        CHECK(approx == to_vec3(q));
        bool is_double = true;
        for (int k = 0; k < 3; ++k) {
            double x = 0;
            const bool exact = idas::detail::predicates::exact_double(q[k], x);
            CHECK(d::equals_double(h.X[std::size_t(k)], h.W, approx[k]) == exact);
            is_double = is_double && exact;
        }
        doubles += is_double;
        // A double point's homogeneous form is exact.
        CHECK(d::canonical(d::to_homogeneous(approx)) == to_rational(approx));
        points.emplace_back(h, q);
        ++checked;
    }
    CHECK(checked > 300);
    CHECK(doubles > 0); // the planes through shared axis-aligned corners meet in doubles
    CHECK(doubles < checked);
    for (std::size_t i = 0; i + 3 < points.size(); ++i) {
        const auto& [a, qa] = points[i];
        const auto& [b, qb] = points[i + 1];
        const auto& [c, qc] = points[i + 2];
        const auto& [e, qe] = points[i + 3];
        CAPTURE(i);
        for (int k = 0; k < 3; ++k)
            CHECK(d::compare_coordinate(a, b, k) == sgn(mpq_class(qa[k] - qb[k])));
        CHECK(d::same_point(a, a));
        CHECK(d::same_point(a, qa));
        CHECK(d::same_point(a, b) == (qa == qb));
        CHECK(d::orient_exact(a, b, c, e) ==
              idas::detail::predicates::orient3d_rational_mpz(qa, qb, qc, qe));
        CHECK(d::canonical(d::average({&a, &b}, {2, 1})) == reference_average(qa, qb, 2, 1));
        // A positive multiple of b - a: the same signs, and parallel.
        d::int_vector row;
        d::difference_row(b, a, row);
        for (int k = 0; k < 3; ++k)
            CHECK(sgn(row[std::size_t(k)]) == sgn(mpq_class(qb[k] - qa[k])));
        const mpq_class ratio = mpq_class(row[0]) / (qb[0] - qa[0]);
        for (int k = 1; k < 3; ++k)
            if (qb[k] != qa[k]) CHECK(mpq_class(row[std::size_t(k)]) / (qb[k] - qa[k]) == ratio);
    }
}

TEST_CASE("rational: to_double of unreduced fractions with either sign of denominator") {
    std::mt19937_64 rng(5);
    for (int i = 0; i < 2000; ++i) {
        mpz_class num = mpz_class(rng() >> (i % 60)) - mpz_class(rng() >> (i % 50));
        mpz_class den = mpz_class(rng() >> (i % 63)) + 1;
        num <<= (i % 5) * 200; // magnitudes up to 2^800 and down to 2^-800
        den <<= (i % 7) * 150;
        const mpz_class common = mpz_class(rng() % 1000) + 1;
        const mpq_class q(num, den);
        mpq_class reduced = q;
        reduced.canonicalize();
        const double want = to_double(reduced);
        CAPTURE(i);
        CHECK(to_double(mpz_class(num * common), mpz_class(den * common)) == want);
        CHECK(to_double(mpz_class(-num * common), mpz_class(-den * common)) == want);
        CHECK(to_double(mpz_class(num), mpz_class(-den)) == -want);
    }
}

TEST_CASE("triangle insertion: needle triangles crossing ordinary ones are covered exactly") {
    // With the former filters (margins relative to the computed normals), seeds 4, 6 and 8
    // stopped with "a cone made a flat tet".
    for (unsigned seed : {4u, 6u, 8u}) {
        const auto [v, f] = random_soup(seed, 10, true);
        CAPTURE(seed);
        CHECK(insert_and_check(v, f) == f.size());
    }
}

TEST_CASE("triangle insertion: the small meshes of data/, exactly covered and valid") {
    for (const char* name :
         {"edge_with_four_triangles.off", "hour_glass.off", "sphere.obj", "x.stl"}) {
        CAPTURE(name);
        const io::surface s = io::read_surface(data(name));
        tetmesh::report r;
        const tetmesh::clean_soup c = tetmesh::clean(s.vertices, s.faces, name, r);
        CHECK(insert_and_check(c.vertices, c.faces) == c.faces.size());
    }
}

TEST_CASE("tetmesh: closed inputs, inside volume equals the enclosed volume") {
    for (const char* name : {"sphere.obj", "hour_glass.off", "blub.obj"}) {
        CAPTURE(name);
        const io::surface s = io::read_surface(data(name));
        const tetmesh::result r = tetmesh::mesh_insertion(s.vertices, s.faces, {}, name);
        CHECK(r.stats.covered_triangles == r.stats.triangles);
        CHECK(r.stats.inverted_tets == 0);
        const double want = enclosed_volume(s.vertices, s.faces);
        CHECK(std::abs(inside_volume(r) - want) <= 0.01 * std::abs(want));
    }
}

namespace {

/// The inside's boundary faces by their definition: the faces of inside tets that no other
/// inside tet has, in the order of their sorted vertices (as boundary_of lists them).
std::vector<tri_indices> boundary_by_count(const std::vector<tet_indices>& T,
                                           const std::vector<std::uint8_t>& in) {
    std::map<tri_indices, std::pair<int, tri_indices>> seen;
    for (std::size_t t = 0; t < T.size(); ++t) {
        if (!in[t]) continue;
        for (std::uint8_t lf = 0; lf < 4; ++lf) {
            const auto f = tet_local::face_vertices[lf];
            tri_indices face{T[t][f[0]], T[t][f[1]], T[t][f[2]]}, key = face;
            std::sort(key.begin(), key.end());
            auto& [count, kept] = seen[key];
            ++count, kept = face;
        }
    }
    std::vector<tri_indices> out;
    for (const auto& [key, counted] : seen)
        if (counted.first == 1) out.push_back(counted.second);
    return out;
}

} // namespace

TEST_CASE("tetmesh: non-manifold, inconsistently oriented 37989_sf and open bunny") {
    for (const char* name : {"37989_sf.obj", "bunny.off"}) {
        CAPTURE(name);
        const io::surface s = io::read_surface(data(name));
        const tetmesh::result r = tetmesh::mesh_insertion(s.vertices, s.faces, {}, name);
        CHECK(r.stats.covered_triangles == r.stats.triangles);
        CHECK(r.stats.inverted_tets == 0);
        CHECK(r.stats.inside_tets > 0);
        CHECK(r.stats.inside_tets < r.stats.tets);
        // 37989_sf's parts touch along 232 edges. Closing the boundary by adding the
        // outside tets around every non-manifold vertex, round after round (until session
        // 22), added 8,967 tets to 11,730 inside ones after the optimization and took the
        // boundary 19 units (90 epsilons) from the input; copies of the vertices part them.
        auto V = r.mesh.vertices;
        auto T = r.mesh.tets;
        auto in = r.inside;
        const auto before = tetmesh::detail::boundary_of(V.size(), T, in);
        CHECK(before.faces == boundary_by_count(T, in));
        // Each face's neighbour, found once before the rounds, still tells the boundary
        // after vertices were copied and tets filled in (what close_boundary relies on).
        const auto across = tetmesh::detail::face_neighbours(T);
        tetmesh::detail::inside_boundary last;
        const std::size_t added = tetmesh::detail::close_boundary(V, T, in, true, &last);
        const auto after = tetmesh::detail::boundary_of(V.size(), T, in);
        CHECK(last.faces == after.faces);
        CHECK(after.non_manifold_edges == 0);
        CHECK(after.bad_vertices.empty());
        CHECK(after.faces == boundary_by_count(T, in));
        CHECK(tetmesh::detail::boundary_of(V.size(), T, in, across).faces == after.faces);
        if (std::string(name) == "37989_sf.obj") {
            CHECK(before.non_manifold_edges > 100);
            CHECK(added < r.stats.inside_tets / 50);
            CHECK(V.size() > r.mesh.vertices.size());
        }
    }
}

namespace {

/// An nx x ny x nz block of unit cubes, each cut into six positive tets (Kuhn's cut, the
/// same diagonal in every cube, so the cubes' faces match); cube (i, j, k)'s tets are
/// 6 (i + nx (j + ny k)) .. + 5.
struct cube_block {
    std::vector<vec3> V;
    std::vector<tet_indices> T;
};
cube_block kuhn_block(int nx, int ny, int nz = 1) {
    cube_block b;
    auto id = [&](int x, int y, int z) { return index_t(x + (nx + 1) * (y + (ny + 1) * z)); };
    for (int z = 0; z <= nz; ++z)
        for (int y = 0; y <= ny; ++y)
            for (int x = 0; x <= nx; ++x) b.V.push_back(vec3{double(x), double(y), double(z)});
    const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i)
                for (const auto& p : perms) {
                    int c[3] = {i, j, k};
                    tet_indices t;
                    t[0] = id(c[0], c[1], c[2]);
                    for (int q = 0; q < 3; ++q) ++c[p[q]], t[q + 1] = id(c[0], c[1], c[2]);
                    const auto& V = b.V;
                    if (tet_signed_volume(V[t[0]], V[t[1]], V[t[2]], V[t[3]]) < 0)
                        std::swap(t[2], t[3]);
                    b.T.push_back(t);
                }
    return b;
}

} // namespace

TEST_CASE("tetmesh: solids touching along an edge are parted by copies of its vertices") {
    // Cubes (0, 0) and (1, 1) of a 2 x 2 block are inside: they meet along the vertical
    // edge x = y = 1 only, so its two ends are non-manifold vertices and the edge is in
    // four boundary faces.
    for (const bool split : {true, false}) {
        CAPTURE(split);
        cube_block b = kuhn_block(2, 2);
        std::vector<std::uint8_t> in(b.T.size(), 0);
        for (int cube : {0, 3})
            for (int k = 0; k < 6; ++k) in[6 * cube + k] = 1;
        const auto before = tetmesh::detail::boundary_of(b.V.size(), b.T, in);
        CHECK(before.non_manifold_edges == 1);
        const std::size_t vertices = b.V.size();
        const auto across = tetmesh::detail::face_neighbours(b.T);
        const std::size_t added = tetmesh::detail::close_boundary(b.V, b.T, in, split);
        const auto after = tetmesh::detail::boundary_of(b.V.size(), b.T, in, across);
        CHECK(after.faces == boundary_by_count(b.T, in));
        CHECK(after.non_manifold_edges == 0);
        CHECK(after.bad_vertices.empty());
        if (split) {
            // Nothing added; one copy of each end of the edge, at the same place.
            CHECK(added == 0);
            CHECK(b.V.size() == vertices + 2);
            CHECK(after.faces.size() == 24); // two closed cubes of 12 boundary triangles
            for (std::size_t v = vertices; v < b.V.size(); ++v)
                CHECK((b.V[v] == vec3{1, 1, 0} || b.V[v] == vec3{1, 1, 1}));
        } else {
            // Only tets around the edge are added (one of the two empty cubes at most).
            CHECK(added > 0);
            CHECK(added <= 6);
            CHECK(b.V.size() == vertices);
        }
    }
}

TEST_CASE("tetmesh: solids touching at a vertex get a copy of it") {
    // Cubes (0, 0, 0) and (1, 1, 1) of a 2 x 2 x 2 block meet at the centre only.
    cube_block b = kuhn_block(2, 2, 2);
    std::vector<std::uint8_t> in(b.T.size(), 0);
    for (int cube : {0, 7})
        for (int k = 0; k < 6; ++k) in[6 * cube + k] = 1;
    CHECK(tetmesh::detail::boundary_of(b.V.size(), b.T, in).bad_vertices.size() == 1);
    const std::size_t vertices = b.V.size();
    CHECK(tetmesh::detail::close_boundary(b.V, b.T, in, true) == 0);
    const auto after = tetmesh::detail::boundary_of(b.V.size(), b.T, in);
    CHECK(after.non_manifold_edges == 0);
    CHECK(after.bad_vertices.empty());
    CHECK(after.faces.size() == 24);
    REQUIRE(b.V.size() == vertices + 1);
    CHECK(b.V.back() == vec3{1, 1, 1});
}

TEST_CASE("tetmesh: a soup of shards gets a closed 2-manifold boundary") {
    // Every triangle of the sphere with its own corners, moved by up to a quarter of its
    // edge (a fixed sequence). Parting the vertices where solids touch cut through the
    // stars of vertices next to them, whose stars then filled up all inside with a
    // boundary that is no disk: 2 to 7 vertices stayed non-manifold after one round (three
    // seeds), until such copies went back into their originals.
    const io::surface s = io::read_surface(data("sphere.obj"));
    std::vector<vec3> V;
    std::vector<tri_indices> F;
    std::uint64_t state = 12345;
    auto offset = [&state] { // in [-0.25, 0.25)
        state = state * 6364136223846793005ULL + 1442695040888963407ULL;
        return double(state >> 11) * 0x1.0p-53 * 0.5 - 0.25;
    };
    for (const auto& f : s.faces) {
        const double edge = norm(s.vertices[f[1]] - s.vertices[f[0]]);
        const vec3 d{offset() * edge, offset() * edge, offset() * edge};
        const index_t first = index_t(V.size());
        for (index_t v : f) V.push_back(s.vertices[v] + d);
        F.push_back({first, first + 1, first + 2});
    }
    tetmesh::quality_options q;
    q.max_iterations = 1;
    const tetmesh::volume_mesh m = tetmesh::mesh_volume(V, F, {}, q, "sphere shards");
    CHECK(m.quality.added_for_manifold > 0);
    CHECK(m.quality.non_manifold_edges == 0);
    CHECK(m.quality.non_manifold_vertices == 0);
    CHECK(m.quality.flat_or_inverted == 0);
    const auto b = tetmesh::detail::boundary_of(m.vertices.size(), m.tets, m.inside);
    CHECK(b.faces.size() == m.quality.boundary_faces);
    CHECK(b.bad_vertices.empty());
}

TEST_CASE("tetmesh: the result does not depend on the number of threads") {
    const io::surface s = io::read_surface(data("sphere.obj"));
    auto run = [&](int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        return tetmesh::mesh_insertion(s.vertices, s.faces, {}, "sphere.obj");
    };
    const tetmesh::result one = run(1), three = run(3);
    CHECK(one.mesh.vertices == three.mesh.vertices);
    CHECK(one.mesh.tets == three.mesh.tets);
    CHECK(one.mesh.tracked == three.mesh.tracked);
    CHECK(one.inside == three.inside);
}

TEST_CASE("tetmesh: bad inputs are refused with input_error") {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<tri_indices> two{{0, 1, 2}, {0, 1, 3}};
    CHECK_THROWS_AS(tetmesh::mesh_insertion({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {}, {}, "empty"),
                    input_error);
    CHECK_THROWS_AS(
        tetmesh::mesh_insertion({{0, 0, 0}, {1, 0, 0}, {nan, 1, 0}, {0, 0, 1}}, two, {}, "nan"),
        input_error);
    CHECK_THROWS_AS(
        tetmesh::mesh_insertion({{0, 0, 0}, {1e308, 0, 0}, {0, 1, 0}, {0, 0, 1}}, two, {}, "huge"),
        input_error);
    CHECK_THROWS_AS(
        tetmesh::mesh_insertion({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 1, 2}}, {}, "line"),
        input_error);
    CHECK_THROWS_AS(
        tetmesh::mesh_insertion({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 7}}, {}, "index"),
        input_error);
    // A flat sheet is meshed (its triangle is inserted) but encloses nothing.
    const tetmesh::result flat =
        tetmesh::mesh_insertion({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, {}, "flat");
    CHECK(flat.stats.covered_triangles == 1);
    CHECK(flat.stats.inside_tets == 0);
}

namespace {
/// n random points (seeded) in the box of `s` grown by a tenth of its size on each side.
std::vector<vec3> points_around(const io::surface& s, unsigned seed, int n) {
    const auto [lo, hi] = box_of(s.vertices);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-0.1, 1.1);
    std::vector<vec3> out;
    for (int i = 0; i < n; ++i) {
        const double x = u(rng), y = u(rng), z = u(rng); // in this order, as before
        out.push_back(
            {lo.x + (hi.x - lo.x) * x, lo.y + (hi.y - lo.y) * y, lo.z + (hi.z - lo.z) * z});
    }
    return out;
}
} // namespace

TEST_CASE("winding number: the hierarchy is within 1e-2 of the exact sum around blub") {
    // Random points in and around blub's box against the sum of every solid angle. With
    // the far field cut to its first term at the default beta of 2, the largest error
    // here is several times the bound.
    const io::surface s = io::read_surface(data("blub.obj"));
    const winding_number w(s.vertices, s.faces);
    double worst = 0;
    for (const vec3& p : points_around(s, 3, 150))
        worst = std::max(worst, std::abs(w(p) - exact_winding(s, p)));
    CHECK(worst < 1e-2);
}

TEST_CASE("winding number: solid angles summed as a product count every turn") {
    // With beta huge no node is far: the hierarchy sums every solid angle as one product
    // of complex numbers, and must agree with the sum of atan2s. Near the surface single
    // angles approach 2 pi and the product turns many times; points on vertices, edges and
    // faces make angles of 0 and +-2 pi on the cut.
    const io::surface s = io::read_surface(data("bunny.obj"));
    const winding_number w(s.vertices, s.faces, 1e9);
    std::vector<vec3> points = points_around(s, 7, 40);
    for (std::size_t i = 0; i < 200; ++i) {
        const auto& t = s.faces[i * 97 % s.faces.size()];
        const vec3 &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
        const vec3 n = cross(b - a, c - a);
        const vec3 g = (a + b + c) * (1.0 / 3.0);
        points.push_back(a);
        points.push_back((a + b) * 0.5);
        points.push_back(g);
        points.push_back(g + n * 1e-3);
        points.push_back(g - n * 1e-3);
    }
    int far_from_zero = 0;
    for (const vec3& p : points) {
        const double exact = exact_winding(s, p);
        CAPTURE(p);
        CHECK(w(p) == doctest::Approx(exact).epsilon(1e-9));
        far_from_zero += std::abs(exact) > 0.25;
    }
    CHECK(far_from_zero > 100);
}

TEST_CASE("winding number: labels from the coarse pass are those of the full accuracy") {
    // bunny is open: around its holes the winding number passes through 1/2, so the
    // coarse pass must hand those points back to the full accuracy.
    const io::surface s = io::read_surface(data("bunny.obj"));
    const winding_number w(s.vertices, s.faces);
    int near_half = 0, refined = 0;
    for (const vec3& p : points_around(s, 5, 4000)) {
        const double full = w(p), label = w.for_label(p);
        REQUIRE((label > 0.5) == (full > 0.5));
        near_half += std::abs(full - 0.5) < 0.2;
        refined += label == full;
        // Away from 1/2 the coarse value stands, close to the full one.
        CHECK(std::abs(label - full) < 0.05);
    }
    CHECK(near_half > 0); // the test reaches the points that matter
    CHECK(refined > 0);
}

TEST_CASE("tetmesh: labels taken along a Morton curve are each tet's own") {
    // The labels visit the tets in a spatial order; each value must still be the winding
    // number at its own tet's centroid, whatever the order the tets come in.
    const io::surface s = io::read_surface(data("sphere.obj"));
    const winding_number w(s.vertices, s.faces);
    background b = make_background(s.vertices, {});
    std::mt19937 rng(3);
    std::shuffle(b.in.tets.begin(), b.in.tets.end(), rng);
    std::vector<double> winding;
    std::vector<std::uint8_t> inside;
    tetmesh::detail::label(w, b.in.vertices, b.in.tets, winding, inside);
    REQUIRE(winding.size() == b.in.tets.size());
    std::size_t same = 0, in = 0;
    for (std::size_t t = 0; t < b.in.tets.size(); ++t) {
        const auto& tv = b.in.tets[t];
        const auto& V = b.in.vertices;
        const double expected = w.for_label((V[tv[0]] + V[tv[1]] + V[tv[2]] + V[tv[3]]) * 0.25);
        same += winding[t] == expected && inside[t] == (expected > 0.5);
        in += inside[t];
    }
    CHECK(same == b.in.tets.size());
    CHECK(in > 0);
    CHECK(in < b.in.tets.size());
}

TEST_CASE("winding number: 1 inside a closed surface, 0 outside, near and far") {
    const io::surface s = io::read_surface(data("sphere.obj"));
    const winding_number w(s.vertices, s.faces);
    const auto [lo, hi] = box_of(s.vertices);
    const vec3 c = (lo + hi) * 0.5, d = hi - lo;
    CHECK(w(c) == doctest::Approx(1.0).epsilon(1e-3));
    CHECK(w(c + d * 3.0) == doctest::Approx(0.0).epsilon(1e-3));
    CHECK(std::abs(w(c + d * 100.0)) < 1e-3);
    // Brute force agrees with the hierarchy at a point near the surface.
    const vec3 p = s.vertices[0] * 1.01 + c * (-0.01);
    CHECK(w(p) == doctest::Approx(exact_winding(s, p)).epsilon(1e-2));
}

#endif
