// Appearance attributes in QSlim's error: the quadric of Hoppe 1999 ("New quadric metric
// for simplifying meshes with appearance attributes"), so that texture and colour detail
// guide the simplification.
//
//   A  per vertex, added to its geometric quadric: for every face around it and every
//      attribute component j, area * (g_j . p + d_j - s_j)^2, the distance of the
//      vertex's value s_j from the face's linear field (gradient g_j in the face's plane).
//      Summed, E(p, s) = q(p) - 2 sum_j s_j (G_j . p + e_j) + w sum_j s_j^2: a 4x4
//      quadric q (the geometric one included), the area w and one (G_j, e_j) per
//      component, 11 + 4m numbers (the dense (4 + m)^2 matrix of Garland and Heckbert 1998
//      grows with m^2), in one column for m <= 4, so that a priority reads one place per
//      vertex (measured on the coloured armadillo, m = 3: 2-4% faster than a column per
//      component)
//   D  the collapse's error with the values at their best, min_s E: a 4x4 quadric in p
//      (q - sum_j (G_j, e_j)(G_j, e_j)^T / w), minimised by QSlim as before
//
// Per vertex, not per wedge (one value set per chart corner, as Hoppe): a vertex whose
// corners disagree is on a seam, and attribute_transfer constrains it (it never moves nor
// vanishes); every other vertex has one value per component, so its terms are in one s.
// A constrained vertex has only its geometric quadric (its faces may lie in several charts,
// whose terms cannot share one s); a collapse into it is priced at its place with its
// values in the collapsed edge's face (what the transfer writes there), and the removed
// vertex's attribute terms are dropped with it.
// The new vertex's values stay the transfer's barycentric interpolation, not min_s E's
// optimum: interpolation stays within the input's values around (an optimum can
// extrapolate past a chart's border), and it is what the transfer's texture-fold and seam
// checks judge for every editing spec alike.
// Scale: values are multiplied by weight * diagonal / range (range of the whole attribute,
// e.g. of uv), so that an error of the attribute's whole range weighs as much as a
// distance of weight times the bounding-box diagonal; the result does not depend on the
// units of either.
#pragma once

#include <idas/algorithms/attribute_transfer.hpp>
#include <idas/algorithms/quadric.hpp>
#include <idas/core/concepts.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace idas::algorithms {

/// One component's sum over a vertex's faces of area * (g_j, d_j).
using attribute_gradient = std::array<double, 4>;

/// A vertex's terms: its geometric quadric plus the sum over its faces and components of
/// area * (g_j . p + d_j)^2, the faces' area, and the first `inline_components` gradients
/// (uv, rgb, rgba: all of them).
struct attribute_terms {
    static constexpr std::size_t inline_components = 4;
    quadric q;
    double w = 0;
    attribute_gradient g[inline_components] = {};
};

/// The gradients of further components, four to a column.
struct attribute_gradients {
    attribute_gradient g[attribute_terms::inline_components] = {};
};

static_assert(attribute_value<attribute_terms> && attribute_value<attribute_gradients>);

class attribute_quadric {
public:
    static constexpr std::size_t max_components = attribute_transfer::max_values;

    /// The merged vertex's terms, from a collapse's `before` to its `after`; fixed size, so
    /// nothing is allocated per operation.
    struct merged {
        quadric q;
        double w = 0;
        std::uint32_t count = 0; // gradients; none for a constrained survivor
        attribute_gradient g[max_components];
        merged() {} // the array stays uninitialised until filled
    };

    /// True if attach() found components to weigh (some that are not constant).
    bool active() const noexcept { return !scale_.empty(); }

    /// Adds the run's columns: every vertex's geometric quadric, plus every face's terms in
    /// its unconstrained corners. `weight` > 0 (0 adds nothing).
    template <tri_mesh_like Mesh>
    void attach(Mesh& m, const attribute_transfer& t, double weight,
                vertex_attribute<quadric> geometric) {
        const std::vector<double> range = t.component_ranges(m);
        vec3 lo{1e300, 1e300, 1e300}, hi = -lo;
        m.for_each_vertex([&](const typename Mesh::tuple& v) {
            const vec3& p = m.position(v.vid);
            for (int k = 0; k < 3; ++k)
                lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
        });
        const double diagonal = norm(hi - lo);
        for (std::size_t k = 0; k < range.size(); ++k) {
            // A constant adds no error. Normals follow the shape, which the geometric quadric
            // already measures; weighed as appearance they made QSlim spend the faces on
            // curvature (armadillo to 10%, weight 0.03: 1.7x the distance to the input).
            if (!(range[k] > 0) || !(weight > 0) || is_normal(t.component_attribute(k))) continue;
            component_.push_back(k);
            scale_.push_back(weight * diagonal / range[k]);
        }
        if (!active()) return;
        terms_ = m.template add_vertex_attribute<attribute_terms>("qslim_attribute_terms");
        for (std::size_t j = block; j < scale_.size(); j += block)
            more_.push_back(m.template add_vertex_attribute<attribute_gradients>(
                "qslim_attribute_gradients_" + std::to_string(j)));
        auto terms = m.attribute(terms_);
        const auto q = m.attribute(geometric);
        for (index_t v = 0; v < m.vertex_slots(); ++v) terms.raw(v).q = q[v];
        m.for_each_face([&](const typename Mesh::tuple& f) {
            const auto& fv = m.face_vertices(f.fid);
            bool loose[3]; // unconstrained corners
            for (int i = 0; i < 3; ++i) loose[i] = !t.constrained(m, fv[i]);
            if (!loose[0] && !loose[1] && !loose[2]) return;
            const vec3& p0 = m.position(fv[0]);
            const vec3 e1 = m.position(fv[1]) - p0, e2 = m.position(fv[2]) - p0;
            const double a11 = dot(e1, e1), a12 = dot(e1, e2), a22 = dot(e2, e2);
            const double det = a11 * a22 - a12 * a12; // (twice the area)^2
            if (!(det > 0)) return;
            const double area = 0.5 * std::sqrt(det), inv = 1 / det;
            quadric face;
            for (std::size_t j = 0; j < scale_.size(); ++j) {
                const auto v = t.face_values(m, f.fid, component_[j]);
                // The gradient in the face's plane: g = x e1 + y e2 with g . e1 = s1 - s0 and
                // g . e2 = s2 - s0.
                const double d1 = scale_[j] * (v[1] - v[0]), d2 = scale_[j] * (v[2] - v[0]);
                const vec3 g =
                    e1 * ((a22 * d1 - a12 * d2) * inv) + e2 * ((a11 * d2 - a12 * d1) * inv);
                const double d = scale_[j] * v[0] - dot(g, p0);
                face += quadric::plane(g, d, area);
                const attribute_gradient h{area * g.x, area * g.y, area * g.z, area * d};
                for (int i = 0; i < 3; ++i) {
                    if (!loose[i]) continue;
                    attribute_gradient& x =
                        j < block ? terms.raw(fv[i]).g[j]
                                  : m.attribute(more_[j / block - 1]).raw(fv[i]).g[j % block];
                    for (int c = 0; c < 4; ++c) x[c] += h[c];
                }
            }
            for (int i = 0; i < 3; ++i)
                if (loose[i]) terms.raw(fv[i]).q += face, terms.raw(fv[i]).w += area;
        });
    }

    /// Removes the run's columns.
    template <tri_mesh_like Mesh>
    void detach(Mesh& m) {
        if (terms_.valid()) m.remove_attribute(terms_);
        for (auto h : more_) m.remove_attribute(h);
        *this = attribute_quadric{};
    }

    /// min_s E of the merged vertex of a and b (the geometric error included), a quadric in
    /// its position.
    template <tri_mesh_like Mesh>
    quadric reduced(const Mesh& m, index_t a, index_t b) const {
        const auto terms = m.attribute(terms_);
        quadric r = terms[a].q + terms[b].q;
        const double w = terms[a].w + terms[b].w;
        if (!(w > 0)) return r;
        // The outer products summed in scalars, not added to r one quadric at a time.
        double x00 = 0, x01 = 0, x02 = 0, x11 = 0, x12 = 0, x22 = 0, y0 = 0, y1 = 0, y2 = 0, z = 0;
        for_each_pair(m, a, b, [&](std::size_t, const attribute_gradient& h) {
            x00 += h[0] * h[0], x01 += h[0] * h[1], x02 += h[0] * h[2], x11 += h[1] * h[1];
            x12 += h[1] * h[2], x22 += h[2] * h[2];
            y0 += h[0] * h[3], y1 += h[1] * h[3], y2 += h[2] * h[3], z += h[3] * h[3];
        });
        const double k = 1 / w;
        r.a00 -= k * x00, r.a01 -= k * x01, r.a02 -= k * x02, r.a11 -= k * x11;
        r.a12 -= k * x12, r.a22 -= k * x22;
        r.b0 -= k * y0, r.b1 -= k * y1, r.b2 -= k * y2, r.c -= k * z;
        return r;
    }

    /// E of the merged vertex of a and b (the geometric error included) at p with the values
    /// a has in face f (a collapse into a constrained a: it keeps its place and those values).
    template <tri_mesh_like Mesh>
    double error_at(const Mesh& m, const attribute_transfer& t, index_t f, index_t a, index_t b,
                    const vec3& p) const {
        const auto terms = m.attribute(terms_);
        const double w = terms[a].w + terms[b].w;
        double e = (terms[a].q + terms[b].q).error(p);
        for_each_pair(m, a, b, [&](std::size_t j, const attribute_gradient& h) {
            const double s = scale_[j] * t.value(m, f, a, component_[j]);
            e += s * (w * s - 2 * (h[0] * p.x + h[1] * p.y + h[2] * p.z + h[3]));
        });
        return std::max(e, 0.0); // rounding can dip below zero
    }

    /// The merged terms of a collapse of b into a, whose geometric quadrics add up to
    /// `geometric`: only that for a constrained a.
    template <tri_mesh_like Mesh>
    void merge(const Mesh& m, const attribute_transfer& t, index_t a, index_t b,
               const quadric& geometric, merged& out) const {
        out.count = 0;
        if (t.constrained(m, a)) {
            out.q = geometric, out.w = 0;
            return;
        }
        out.count = static_cast<std::uint32_t>(scale_.size());
        const auto terms = m.attribute(terms_);
        out.q = terms[a].q + terms[b].q;
        out.w = terms[a].w + terms[b].w;
        for_each_pair(m, a, b, [&](std::size_t j, const attribute_gradient& h) { out.g[j] = h; });
    }

    /// Writes the merged terms at the collapse's survivor.
    template <tri_mesh_like Mesh>
    void write(Mesh& m, const op_result<typename Mesh::tuple>& r, const merged& in) const {
        const index_t a = r.anchor.vid;
        attribute_terms x{in.q, in.w};
        for (std::size_t j = 0; j < std::min<std::size_t>(block, in.count); ++j) x.g[j] = in.g[j];
        m.attribute(terms_, r).set(a, x);
        if (in.count == 0) return; // a constrained survivor's other gradients stay zero
        for (std::size_t k = 0; k < more_.size(); ++k) {
            attribute_gradients y;
            for (std::size_t j = block * (k + 1), i = 0; i < block && j < scale_.size(); ++i, ++j)
                y.g[i] = in.g[j];
            m.attribute(more_[k], r).set(a, y);
        }
    }

private:
    static constexpr std::size_t block = attribute_terms::inline_components;

    /// Normals as the readers name them: OBJ's vn and OFF's N, and PLY's properties, each
    /// an attribute of its own.
    static bool is_normal(const std::string& name) {
        return name == "normal" || name == "nx" || name == "ny" || name == "nz";
    }

    /// fn(j, gradient j of a + gradient j of b) for every component j.
    template <class Mesh, class Fn>
    void for_each_pair(const Mesh& m, index_t a, index_t b, Fn&& fn) const {
        const auto sum = [](const attribute_gradient& x, const attribute_gradient& y) {
            return attribute_gradient{x[0] + y[0], x[1] + y[1], x[2] + y[2], x[3] + y[3]};
        };
        const auto terms = m.attribute(terms_);
        const attribute_terms &x = terms[a], &y = terms[b];
        const std::size_t n = scale_.size();
        for (std::size_t j = 0; j < std::min(block, n); ++j) fn(j, sum(x.g[j], y.g[j]));
        for (std::size_t k = 0; k < more_.size(); ++k) {
            const auto col = m.attribute(more_[k]);
            const attribute_gradients &u = col[a], &v = col[b];
            for (std::size_t j = block * (k + 1), i = 0; i < block && j < n; ++i, ++j)
                fn(j, sum(u.g[i], v.g[i]));
        }
    }

    vertex_attribute<attribute_terms> terms_;
    std::vector<vertex_attribute<attribute_gradients>> more_; // components 4-7, 8-11, ...
    std::vector<std::size_t> component_; // the transfer's component of each weighed one
    std::vector<double> scale_;          // weight * diagonal / range of that component
};

} // namespace idas::algorithms
