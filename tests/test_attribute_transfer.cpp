// Attributes through decimation and remeshing (issue 21): texture coordinates stay in their
// charts and seams stay closed, colours stay within the range of the input around them,
// face tags keep their regions, constrained vertices never move.
#include "test_support.hpp"

#include <idas/algorithms/attribute_transfer.hpp>
#include <idas/algorithms/isotropic_remeshing.hpp>
#include <idas/algorithms/qslim.hpp>
#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/core/aabb_tree.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

using namespace idas;
using namespace idas::algorithms;
using idas::io::attribute_domain;

namespace {

using mesh = tri_mesh<>;

struct edited {
    io::surface in, out;
    std::size_t constrained = 0;
};

/// Reads `file`, lets `edit(mesh, transfer)` run, returns input and output surfaces.
template <class Edit>
edited edit_with_attributes(const io::surface& in, Edit&& edit,
                            const attribute_transfer_options& o = {}) {
    edited e;
    e.in = in;
    mesh m(in.vertices, in.faces);
    attribute_transfer transfer;
    transfer.attach(m, in, o);
    e.constrained = transfer.constrained_count(m);
    edit(m, transfer);
    REQUIRE(!find_inconsistency(m));
    std::tie(e.out.vertices, e.out.faces) = m.to_arrays();
    e.out.attributes = transfer.exported(m);
    e.out.header_lines = in.header_lines;
    return e;
}

double uv_area(const io::attribute_column& uv, std::size_t f) {
    const double* c = uv.values.data() + 6 * f;
    return (c[2] - c[0]) * (c[5] - c[1]) - (c[4] - c[0]) * (c[3] - c[1]);
}

/// Seam edges: edges whose two faces disagree on an end's texture coordinates. Returns
/// per vertex its number of seam edges.
std::map<index_t, int> seam_degrees(const io::surface& s) {
    const auto* uv = io::find_attribute(s, "uv", attribute_domain::corner);
    std::map<std::pair<index_t, index_t>, std::vector<std::pair<std::size_t, int>>> edges;
    for (std::size_t f = 0; f < s.faces.size(); ++f)
        for (int i = 0; i < 3; ++i) {
            const index_t a = s.faces[f][i], b = s.faces[f][(i + 1) % 3];
            edges[{std::min(a, b), std::max(a, b)}].push_back({f, i});
        }
    const auto corner = [&](std::size_t f, index_t v) {
        for (int c = 0; c < 3; ++c)
            if (s.faces[f][c] == v)
                return std::pair{uv->values[(3 * f + c) * 2], uv->values[(3 * f + c) * 2 + 1]};
        return std::pair{0.0, 0.0};
    };
    std::map<index_t, int> degree;
    for (const auto& [e, faces] : edges) {
        if (faces.size() != 2) continue;
        const auto f = faces[0].first, g = faces[1].first;
        if (corner(f, e.first) != corner(g, e.first) || corner(f, e.second) != corner(g, e.second))
            ++degree[e.first], ++degree[e.second];
    }
    return degree;
}

/// Texture checks shared by decimation and remeshing of blub.
void check_texture(const edited& e) {
    const auto* in_uv = io::find_attribute(e.in, "uv", attribute_domain::corner);
    const auto* out_uv = io::find_attribute(e.out, "uv", attribute_domain::corner);
    REQUIRE((in_uv && out_uv));
    CHECK(out_uv->values.size() == 6 * e.out.faces.size());
    // Within the input's texture range.
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
    for (std::size_t i = 0; i < in_uv->values.size(); ++i)
        lo[i % 2] = std::min(lo[i % 2], in_uv->values[i]),
               hi[i % 2] = std::max(hi[i % 2], in_uv->values[i]);
    for (std::size_t i = 0; i < out_uv->values.size(); ++i) {
        CHECK(out_uv->values[i] >= lo[i % 2]);
        CHECK(out_uv->values[i] <= hi[i % 2]);
    }
    // No texture triangle folds that did not already.
    const auto folded = [](const io::attribute_column& uv, std::size_t faces) {
        std::size_t n = 0;
        for (std::size_t f = 0; f < faces; ++f) n += uv_area(uv, f) < 0;
        return n;
    };
    CHECK(folded(*out_uv, e.out.faces.size()) <= folded(*in_uv, e.in.faces.size()));
    // Seams stay closed curves: every seam vertex has two or more seam edges (as in the
    // input), and the seams are still there.
    const auto in_seams = seam_degrees(e.in), out_seams = seam_degrees(e.out);
    REQUIRE(!in_seams.empty());
    CHECK(out_seams.size() >= 3);
    int open_in = 0, open_out = 0;
    for (const auto& [v, d] : in_seams) open_in += d == 1;
    for (const auto& [v, d] : out_seams) open_out += d == 1;
    CHECK(open_out <= open_in);
    // Texture error: at each output face's centroid, its interpolated uv against the
    // input's at the nearest input point, relative to the texture's extent. Faces whose
    // nearest input face is in another chart (across a seam) are not comparable.
    const triangle_aabb_tree tree(e.in.vertices, e.in.faces);
    const double extent = std::hypot(hi[0] - lo[0], hi[1] - lo[1]);
    std::vector<double> errors;
    for (std::size_t f = 0; f < e.out.faces.size(); ++f) {
        const auto& fv = e.out.faces[f];
        const vec3 c =
            (e.out.vertices[fv[0]] + e.out.vertices[fv[1]] + e.out.vertices[fv[2]]) / 3.0;
        double u = 0, v = 0;
        for (int k = 0; k < 3; ++k)
            u += out_uv->values[(3 * f + k) * 2] / 3, v += out_uv->values[(3 * f + k) * 2 + 1] / 3;
        const auto hit = tree.closest_point(c);
        const auto& gv = e.in.faces[hit.face];
        // Barycentric coordinates of the hit in the input face.
        const vec3 x = e.in.vertices[gv[0]], y = e.in.vertices[gv[1]], z = e.in.vertices[gv[2]];
        const vec3 e0 = y - x, e1 = z - x, d = hit.point - x;
        const double a = dot(e0, e0), b = dot(e0, e1), cc = dot(e1, e1);
        const double det = a * cc - b * b;
        if (!(det > 0)) continue;
        const double wy = (cc * dot(d, e0) - b * dot(d, e1)) / det,
                     wz = (a * dot(d, e1) - b * dot(d, e0)) / det, wx = 1 - wy - wz;
        const double* g = in_uv->values.data() + 6 * hit.face;
        const double iu = wx * g[0] + wy * g[2] + wz * g[4], iv = wx * g[1] + wy * g[3] + wz * g[5];
        errors.push_back(std::hypot(u - iu, v - iv) / extent);
    }
    std::sort(errors.begin(), errors.end());
    const double median = errors[errors.size() / 2], p90 = errors[errors.size() * 9 / 10];
    MESSAGE("uv error / texture extent: median " << median << ", 90th percentile " << p90);
    CHECK(median < 0.01);
    CHECK(p90 < 0.01);
}

io::surface blub() {
    return io::read_surface(test::data("blub.obj"));
}

/// bunny with an 8-bit colour per vertex (a smooth function of position, so nearby input
/// vertices have close colours) and a face tag (which side of a plane it is on).
io::surface coloured_bunny() {
    io::surface s = io::read_surface(test::data("bunny.off"));
    vec3 lo = s.vertices[0], hi = lo;
    for (const vec3& p : s.vertices)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    for (int k = 0; k < 3; ++k) {
        io::attribute_column c{
            std::string(1, "rgb"[k]), attribute_domain::vertex, io::scalar_type::uint8, 1, {}, {}};
        for (const vec3& p : s.vertices)
            c.values.push_back(std::round(255 * (p[k] - lo[k]) / (hi[k] - lo[k])));
        s.attributes.push_back(std::move(c));
    }
    io::attribute_column tag{"region", attribute_domain::face, io::scalar_type::int32, 1, {}, {}};
    const double mid = 0.5 * (lo.x + hi.x);
    for (const auto& f : s.faces) tag.values.push_back(s.vertices[f[0]].x < mid ? 1 : 2);
    s.attributes.push_back(std::move(tag));
    return s;
}

void check_colours_and_tags(const edited& e) {
    // Each output colour lies within the colours of the input vertices near it (the
    // nearest input face's corners and their two rings: a vertex left after decimation to
    // 10% stands for about ten), up to rounding.
    std::vector<std::set<index_t>> ring(e.in.vertices.size());
    for (const auto& f : e.in.faces)
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) ring[f[i]].insert(f[j]);
    std::vector<std::set<index_t>> ring2 = ring;
    for (std::size_t v = 0; v < ring.size(); ++v)
        for (index_t w : ring[v]) ring2[v].insert(ring[w].begin(), ring[w].end());
    ring = std::move(ring2);
    const triangle_aabb_tree tree(e.in.vertices, e.in.faces);
    std::size_t outside = 0;
    for (int k = 0; k < 3; ++k) {
        const auto name = std::string(1, "rgb"[k]);
        const auto* in = io::find_attribute(e.in, name, attribute_domain::vertex);
        const auto* out = io::find_attribute(e.out, name, attribute_domain::vertex);
        REQUIRE((in && out));
        CHECK(out->type == io::scalar_type::uint8);
        for (std::size_t v = 0; v < e.out.vertices.size(); ++v) {
            const auto hit = tree.closest_point(e.out.vertices[v]);
            double lo = 1e300, hi = -1e300;
            for (index_t c : e.in.faces[hit.face])
                for (index_t w : ring[c])
                    lo = std::min(lo, in->values[w]), hi = std::max(hi, in->values[w]);
            const double x = out->values[v];
            CHECK(x == std::round(x));
            outside += x < lo - 1 || x > hi + 1;
        }
    }
    MESSAGE("colours outside their input neighbourhood: " << outside);
    CHECK(outside <= e.out.vertices.size() / 100);
    // Tags keep their regions: a face's tag is that of the input face nearest its centroid,
    // except along the border.
    const auto* in_tag = io::find_attribute(e.in, "region", attribute_domain::face);
    const auto* out_tag = io::find_attribute(e.out, "region", attribute_domain::face);
    REQUIRE((in_tag && out_tag));
    std::size_t wrong = 0, tags[3] = {0, 0, 0};
    for (std::size_t f = 0; f < e.out.faces.size(); ++f) {
        const auto& fv = e.out.faces[f];
        const vec3 c =
            (e.out.vertices[fv[0]] + e.out.vertices[fv[1]] + e.out.vertices[fv[2]]) / 3.0;
        wrong += in_tag->values[tree.closest_point(c).face] != out_tag->values[f];
        ++tags[static_cast<int>(out_tag->values[f])];
    }
    MESSAGE("faces whose tag differs from the nearest input face's: " << wrong);
    CHECK(tags[1] > 0);
    CHECK(tags[2] > 0);
    CHECK(wrong <= e.out.faces.size() / 50);
}

} // namespace

TEST_CASE("attribute transfer: QSlim to 10% keeps blub's texture, seams and charts") {
    const io::surface in = blub();
    const auto e = edit_with_attributes(in, [&](mesh& m, const attribute_transfer& t) {
        qslim_spec spec;
        spec.transfer = &t;
        spec.target_faces = static_cast<std::int64_t>(in.faces.size() / 10);
        qslim<>::run(m, spec);
    });
    CHECK(e.constrained > 0);
    CHECK(e.out.faces.size() < in.faces.size() / 2);
    check_texture(e);
}

TEST_CASE("attribute transfer: remeshing blub keeps its texture, seams and charts") {
    const io::surface in = blub();
    const auto e = edit_with_attributes(in, [&](mesh& m, const attribute_transfer& t) {
        remeshing_options o;
        vec3 lo = in.vertices[0], hi = lo;
        for (const vec3& p : in.vertices)
            for (int k = 0; k < 3; ++k)
                lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
        o.target_length = 0.01 * norm(hi - lo);
        o.iterations = 3;
        o.transfer = &t;
        isotropic_remeshing<mesh>::run(m, o);
    });
    check_texture(e);
}

TEST_CASE("attribute transfer: colours and tags through QSlim, shortest edge collapse and "
          "remeshing, on 1 and 2 threads") {
    const io::surface in = coloured_bunny();
    for (unsigned threads : {1u, 2u}) {
        exec_options x;
        x.threads = threads;
        check_colours_and_tags(edit_with_attributes(in, [&](mesh& m, const attribute_transfer& t) {
            qslim_spec spec;
            spec.transfer = &t;
            spec.target_faces = static_cast<std::int64_t>(in.faces.size() / 10);
            qslim<>::run(m, spec, x);
        }));
        check_colours_and_tags(edit_with_attributes(in, [&](mesh& m, const attribute_transfer& t) {
            shortest_edge_collapse_spec<true> spec;
            spec.transfer = &t;
            spec.target_faces = static_cast<std::int64_t>(in.faces.size() / 10);
            shortest_edge_collapse<>::run(m, spec, x);
        }));
        check_colours_and_tags(edit_with_attributes(in, [&](mesh& m, const attribute_transfer& t) {
            remeshing_options o;
            o.target_length = 0.004;
            o.iterations = 3;
            o.transfer = &t;
            isotropic_remeshing<mesh>::run(m, o, x);
        }));
    }
}

TEST_CASE("attribute transfer: kept boundary and feature vertices neither move nor vanish") {
    const io::surface in = io::read_surface(test::data("bunny.obj")); // open: 5 holes
    attribute_transfer_options o;
    o.keep_boundary = true;
    const auto e = edit_with_attributes(
        in,
        [&](mesh& m, const attribute_transfer& t) {
            qslim_spec spec;
            spec.transfer = &t;
            spec.target_faces = static_cast<std::int64_t>(in.faces.size() / 10);
            qslim<>::run(m, spec);
        },
        o);
    // Every input boundary vertex is still there, at the same place.
    std::map<std::pair<index_t, index_t>, int> uses;
    for (const auto& f : in.faces)
        for (int i = 0; i < 3; ++i)
            ++uses[{std::min(f[i], f[(i + 1) % 3]), std::max(f[i], f[(i + 1) % 3])}];
    std::set<std::array<double, 3>> out_points;
    for (const vec3& p : e.out.vertices) out_points.insert({p.x, p.y, p.z});
    std::size_t boundary = 0, kept = 0;
    std::set<index_t> seen;
    for (const auto& [edge, n] : uses)
        if (n == 1)
            for (index_t v : {edge.first, edge.second})
                if (seen.insert(v).second) {
                    ++boundary;
                    const vec3& p = in.vertices[v];
                    kept += out_points.count({p.x, p.y, p.z});
                }
    CHECK(boundary > 0);
    CHECK(kept == boundary);
    CHECK(e.constrained == boundary);
}

TEST_CASE("attribute transfer: too many components are refused with a clear message") {
    io::surface s = io::read_surface(test::data("bunny.off"));
    for (int k = 0; k < 70; ++k) {
        std::string name = "c"; // (GCC 12 warns falsely about "c" + std::string)
        name += std::to_string(k);
        s.attributes.push_back({name,
                                attribute_domain::vertex,
                                io::scalar_type::float32,
                                1,
                                std::vector<double>(s.vertices.size(), 1.0),
                                {}});
    }
    mesh m(s.vertices, s.faces);
    attribute_transfer t;
    CHECK_THROWS_WITH_AS(t.attach(m, s), doctest::Contains("at most 64"), input_error);
}
