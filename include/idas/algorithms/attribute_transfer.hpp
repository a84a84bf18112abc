// A: the attributes a file carries (io::surface::attributes), carried through the local
// operations of decimation and remeshing.
//
//   vertex values    interpolated: the midpoint on a split; where a collapse or a smoothing
//                    step puts the vertex, barycentric interpolation in the old star (the
//                    old triangle nearest to the new position)
//   face values      tags: a new face takes its parent's
//   corner values    (texture coordinates, per-face normals) the same interpolation, per
//                    face; a split keeps a seam (each side interpolates its own values)
//   constraints      a vertex on a seam (its corners disagree), on the border of two tags,
//                    and on request on the boundary or a sharp feature, never vanishes nor
//                    moves; a collapse or move that would fold a texture triangle (flip the
//                    sign of its area in uv) is refused
//
// The values live in journaled mesh columns, so a refused operation restores them exactly.
// Per operation nothing is allocated: the values travel in a fixed-size cache
// (`carried_values`), which is why at most max_values components are carried per vertex.
#pragma once

#include <idas/core/aabb_tree.hpp>
#include <idas/core/attribute.hpp>
#include <idas/core/geometry.hpp>
#include <idas/invariants/no_normal_flip.hpp>
#include <idas/io/surface.hpp>
#include <idas/ops/operation.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

namespace idas::algorithms {

/// What a collapse or a smoothing step carries from `before` (old mesh) to `after`.
struct carried_values {
    static constexpr std::size_t max_values = 64; // vertex + corner components
    static constexpr std::size_t max_star = 48;   // faces around the removed vertex
    vec3 kept_position;                           // a constrained survivor stays here
    bool survivor_constrained = false;
    std::uint32_t star_size = 0;
    double values[max_values]; // vertex components, then corner components
    index_t star[max_star];    // faces of the removed vertex
    carried_values() {}        // the arrays stay uninitialised until filled
};

/// The cache of an operation that moves a vertex: where to, and what it carries there.
struct placed_values {
    vec3 position;
    carried_values carried;
};

struct attribute_transfer_options {
    bool keep_boundary = false;    // boundary vertices never move nor vanish
    double feature_angle_deg = -1; // dihedral angle above which an edge is kept; <0: none
};

class attribute_transfer {
public:
    static constexpr std::size_t max_values = carried_values::max_values;

    /// Adds a mesh column for every attribute of `s` (whose vertices and faces the mesh was
    /// built from, in the same order) and marks the constrained vertices. Throws
    /// input_error if the attributes need more than max_values components per vertex.
    template <class Mesh>
    void attach(Mesh& m, const io::surface& s, const attribute_transfer_options& o = {}) {
        options_ = o;
        for (const io::attribute_column& a : s.attributes) {
            group g;
            g.meta = a;
            g.meta.values.clear();
            if (a.domain == io::attribute_domain::vertex) {
                g.first = vertex_.size();
                for (std::uint32_t k = 0; k < a.width; ++k) {
                    const auto h = m.template add_vertex_attribute<double>(
                        "file_" + a.name + "_" + std::to_string(k), 0.0);
                    auto col = m.attribute(h);
                    for (std::size_t v = 0; v < s.vertices.size(); ++v)
                        col.raw(static_cast<index_t>(v)) = a.values[v * a.width + k];
                    vertex_.push_back(h);
                }
            } else if (a.domain == io::attribute_domain::face) {
                g.first = face_.size();
                for (std::uint32_t k = 0; k < a.width; ++k) {
                    const auto h = m.template add_face_attribute<double>(
                        "file_" + a.name + "_" + std::to_string(k), 0.0);
                    auto col = m.attribute(h);
                    for (std::size_t f = 0; f < s.faces.size(); ++f)
                        col.raw(static_cast<index_t>(f)) = a.values[f * a.width + k];
                    face_.push_back(h);
                }
            } else {
                g.first = corner_.size();
                if (a.width >= 2 && (a.name == "uv" || a.name == "texcoord"))
                    textures_.push_back(g.first);
                for (std::uint32_t k = 0; k < a.width; ++k) {
                    const auto h = m.template add_face_attribute<corner_triple>(
                        "file_" + a.name + "_" + std::to_string(k), corner_triple{});
                    auto col = m.attribute(h);
                    for (std::size_t f = 0; f < s.faces.size(); ++f)
                        for (int c = 0; c < 3; ++c)
                            col.raw(static_cast<index_t>(f))[c] =
                                a.values[(3 * f + c) * a.width + k];
                    corner_.push_back(h);
                }
            }
            groups_.push_back(std::move(g));
        }
        if (vertex_.size() + corner_.size() > max_values)
            throw input_error("the file's attributes have " +
                              std::to_string(vertex_.size() + corner_.size()) +
                              " components per vertex; at most " + std::to_string(max_values) +
                              " can be carried through editing (--drop-attributes skips them)");
        constrained_ = m.template add_vertex_attribute<std::uint8_t>("file_constrained", 0);
        mark_constraints(m);
    }

    /// Removes the columns attach() added.
    template <class Mesh>
    void detach(Mesh& m) {
        for (auto h : vertex_) m.remove_attribute(h);
        for (auto h : face_) m.remove_attribute(h);
        for (auto h : corner_) m.remove_attribute(h);
        if (constrained_.valid()) m.remove_attribute(constrained_);
        *this = attribute_transfer{};
    }

    /// True if attach() found something to carry or to keep in place.
    bool active() const noexcept { return constrained_.valid(); }

    /// Vertices that never move nor vanish.
    template <class Mesh>
    bool constrained(const Mesh& m, index_t v) const {
        return m.attribute(constrained_)[v] != 0;
    }
    template <class Mesh>
    std::size_t constrained_count(const Mesh& m) const {
        std::size_t n = 0;
        m.for_each_vertex([&](const typename Mesh::tuple& t) { n += constrained(m, t.vid); });
        return n;
    }

    /// Components carried per vertex: the vertex components, then the corner ones (the
    /// order of value() and component_ranges()).
    std::size_t components() const noexcept { return vertex_.size() + corner_.size(); }

    /// Component k of vertex v as face f sees it: its corner value in f for a corner
    /// attribute (one chart's value on a seam).
    template <class Mesh>
    double value(const Mesh& m, index_t f, index_t v, std::size_t k) const {
        if (k < vertex_.size()) return m.attribute(vertex_[k])[v];
        return m.attribute(corner_[k - vertex_.size()])[f][slot_of(m, f, v)];
    }

    /// Component k at face f's three corners, in the order of its vertices.
    template <class Mesh>
    std::array<double, 3> face_values(const Mesh& m, index_t f, std::size_t k) const {
        if (k >= vertex_.size()) return m.attribute(corner_[k - vertex_.size()])[f];
        const auto col = m.attribute(vertex_[k]);
        const auto& fv = m.face_vertices(f);
        return {col[fv[0]], col[fv[1]], col[fv[2]]};
    }

    /// The name of the attribute component k belongs to ("uv", "normal", "color", ...).
    const std::string& component_attribute(std::size_t k) const {
        for (const group& g : groups_) {
            if (g.meta.domain == io::attribute_domain::face) continue;
            const std::size_t first = first_component(g);
            if (k >= first && k < first + g.meta.width) return g.meta.name;
        }
        throw std::out_of_range("attribute_transfer: no component " + std::to_string(k));
    }

    /// Per component, the range (largest minus smallest value over the live elements) of
    /// the attribute it belongs to, the largest of its components' ranges: one scale for
    /// all of uv or a colour keeps distances in that space undistorted.
    template <class Mesh>
    std::vector<double> component_ranges(const Mesh& m) const {
        const std::size_t n = components();
        std::vector<double> lo(n, std::numeric_limits<double>::infinity()),
            hi(n, -std::numeric_limits<double>::infinity());
        m.for_each_face([&](const typename Mesh::tuple& t) {
            for (std::size_t k = 0; k < n; ++k)
                for (const double x : face_values(m, t.fid, k))
                    lo[k] = std::min(lo[k], x), hi[k] = std::max(hi[k], x);
        });
        std::vector<double> range(n, 0.0);
        for (const group& g : groups_) {
            if (g.meta.domain == io::attribute_domain::face) continue;
            const std::size_t first = first_component(g);
            double r = 0;
            for (std::size_t k = first; k < first + g.meta.width; ++k)
                if (hi[k] > lo[k]) r = std::max(r, hi[k] - lo[k]);
            for (std::size_t k = first; k < first + g.meta.width; ++k) range[k] = r;
        }
        return range;
    }

    /// The attributes of the mesh's live elements, in the order of Mesh::to_arrays().
    template <class Mesh>
    std::vector<io::attribute_column> exported(const Mesh& m) const {
        std::vector<index_t> vertices, faces;
        for (index_t v = 0; v < m.vertex_slots(); ++v)
            if (m.vertex_alive(v) && !std::ranges::empty(m.connectivity().vertex_faces(v)))
                vertices.push_back(v);
        for (index_t f = 0; f < m.face_slots(); ++f)
            if (m.connectivity().face_alive(f)) faces.push_back(f);
        std::vector<io::attribute_column> out;
        for (const group& g : groups_) {
            io::attribute_column a = g.meta;
            const std::uint32_t w = a.width;
            if (a.domain == io::attribute_domain::vertex) {
                a.values.resize(vertices.size() * w);
                for (std::uint32_t k = 0; k < w; ++k) {
                    const auto col = m.attribute(vertex_[g.first + k]);
                    for (std::size_t i = 0; i < vertices.size(); ++i)
                        a.values[i * w + k] = io::representable(a.type, col[vertices[i]]);
                }
            } else if (a.domain == io::attribute_domain::face) {
                a.values.resize(faces.size() * w);
                for (std::uint32_t k = 0; k < w; ++k) {
                    const auto col = m.attribute(face_[g.first + k]);
                    for (std::size_t i = 0; i < faces.size(); ++i)
                        a.values[i * w + k] = col[faces[i]];
                }
            } else {
                a.values.resize(3 * faces.size() * w);
                for (std::uint32_t k = 0; k < w; ++k) {
                    const auto col = m.attribute(corner_[g.first + k]);
                    for (std::size_t i = 0; i < faces.size(); ++i)
                        for (int c = 0; c < 3; ++c)
                            a.values[(3 * i + c) * w + k] =
                                io::representable(a.type, col[faces[i]][c]);
                }
            }
            if (a.name == "normal" && w == 3) normalize_triples(a.values);
            out.push_back(std::move(a));
        }
        return out;
    }

    // ---- the operations' hooks ----------------------------------------------------------

    /// The four vertices' corner values before a swap, by vertex (one chart).
    struct swap_values {
        index_t vertex[4] = {invalid_index, invalid_index, invalid_index, invalid_index};
        double values[4][max_values];
        double uv_area_sign = 0;
        swap_values() {}
        double value(index_t v, std::size_t k) const {
            for (int i = 0; i < 4; ++i)
                if (vertex[i] == v) return values[i][k];
            return 0;
        }
    };

    /// Collapse of t's edge into t.vid (the survivor), which will sit at p. False: refused
    /// (the removed vertex is constrained, or its star is too large to remember).
    template <class Mesh>
    bool collapse_before(const Mesh& m, const typename Mesh::tuple& t, const vec3& p,
                         carried_values& c) const {
        const auto [a, b] = m.edge_vertices(t);
        if (constrained(m, b)) return false;
        c.survivor_constrained = constrained(m, a);
        c.kept_position = m.position(a);
        c.star_size = 0;
        if (c.survivor_constrained) {
            // The survivor keeps its place and values; in the faces it takes over from b it
            // gets its corner values of b's chart (that of the collapsed edge's face).
            for (index_t f : m.connectivity().vertex_faces(b)) {
                if (c.star_size == carried_values::max_star) return false;
                c.star[c.star_size++] = f;
            }
            const index_t slot = slot_of(m, t.fid, a);
            for (std::size_t k = 0; k < corner_.size(); ++k)
                c.values[vertex_.size() + k] = m.attribute(corner_[k])[t.fid][slot];
            return true;
        }
        interpolate(m, p, c, m.connectivity().vertex_faces(a), m.connectivity().vertex_faces(b));
        return true;
    }

    /// Writes the survivor's values (or puts a constrained survivor back in place). False:
    /// a texture triangle would fold.
    template <class Mesh>
    bool collapse_after(Mesh& m, const op_result<typename Mesh::tuple>& r,
                        const carried_values& c) const {
        const index_t a = r.anchor.vid;
        if (c.survivor_constrained) {
            m.positions(r).set(a, c.kept_position);
            if (corner_.empty()) return true;
            const double* corner_values = c.values + vertex_.size();
            for (std::uint32_t i = 0; i < c.star_size; ++i) {
                const index_t f = c.star[i];
                if (!m.connectivity().face_alive(f)) continue; // a face of the collapsed edge
                const index_t s = slot_of(m, f, a);
                if (!write_corners(m, r, f, s, [&](std::size_t k) { return corner_values[k]; }))
                    return false;
            }
            return true;
        }
        return write_star(m, a, r, c);
    }

    /// A smoothing step moving v to p.
    template <class Mesh>
    bool smooth_before(const Mesh& m, index_t v, const vec3& p, carried_values& c) const {
        if (constrained(m, v)) return false;
        c.star_size = 0;
        interpolate(m, p, c, m.connectivity().vertex_faces(v));
        return true;
    }
    template <class Mesh>
    bool smooth_after(Mesh& m, const op_result<typename Mesh::tuple>& r,
                      const carried_values& c) const {
        return write_star(m, r.anchor.vid, r, c);
    }

    /// A split (no cache: the old values are still in the faces the split reused).
    template <class Mesh>
    void split_after(Mesh& m, const op_result<typename Mesh::tuple>& r) const {
        const index_t nv = r.anchor.vid;
        index_t ends[2] = {invalid_index, invalid_index};
        bool disagree = false;
        index_t first_old = invalid_index;
        for (std::size_t i = 0; i < r.cells.size(); ++i) {
            const index_t fresh = r.cells[i].fid, old = r.origins[i];
            if (fresh == old) continue;
            // `old` now reads (a, nv, c) and `fresh` (nv, b, c) in the same slots.
            const index_t sb = slot_of(m, old, nv), sa = slot_of(m, fresh, nv);
            const index_t a = m.face_vertices(old)[sa], b = m.face_vertices(fresh)[sb];
            ends[0] = a, ends[1] = b;
            for (std::size_t k = 0; k < corner_.size(); ++k) {
                auto col = m.attribute(corner_[k], r);
                corner_triple o = col[old];
                const double mid = 0.5 * (o[sa] + o[sb]);
                corner_triple n = o;
                n[sa] = mid;
                o[sb] = mid;
                col.set(old, o);
                col.set(fresh, n);
            }
            for (auto h : face_) {
                auto col = m.attribute(h, r);
                col.set(fresh, col[old]);
            }
            if (first_old == invalid_index)
                first_old = old;
            else
                disagree = sides_differ(m, first_old, old, nv);
        }
        auto vcol = [&](auto h) {
            auto col = m.attribute(h, r);
            col.set(nv, 0.5 * (col[ends[0]] + col[ends[1]]));
        };
        for (auto h : vertex_) vcol(h);
        // The new vertex lies on a seam, a tag border, a kept boundary or a feature if the
        // edge did.
        auto fixed = m.attribute(constrained_, r);
        const bool boundary = first_old != invalid_index && r.cells.size() == 2;
        bool keep = disagree;
        if (boundary && options_.keep_boundary) keep = true;
        if (!keep && !boundary && options_.feature_angle_deg >= 0 && fixed[ends[0]] &&
            fixed[ends[1]])
            keep = sharp(m, r);
        fixed.set(nv, keep ? 1 : 0);
    }

    /// Swaps keep the corner values of the four vertices; they are refused across a seam
    /// or a tag border (the edge is a constraint) and if a texture triangle would fold.
    template <class Mesh>
    bool swap_allowed(const Mesh& m, const typename Mesh::tuple& t) const {
        const auto g = m.switch_face(t);
        if (!g) return false;
        const auto [a, b] = m.edge_vertices(t);
        return !tags_differ(m, t.fid, g->fid) && !corners_differ(m, t.fid, g->fid, a) &&
               !corners_differ(m, t.fid, g->fid, b);
    }

    /// After a swap of faces f and h (same chart, so a vertex has one value in both):
    /// rewrites the corner values by vertex.
    template <class Mesh>
    bool swap_after(Mesh& m, const op_result<typename Mesh::tuple>& r,
                    const swap_values& old) const {
        for (const auto& cell : r.cells) {
            const index_t f = cell.fid;
            const double before = textures_.empty() ? 0 : old.uv_area_sign;
            for (std::size_t k = 0; k < corner_.size(); ++k) {
                auto col = m.attribute(corner_[k], r);
                corner_triple n{};
                for (int s = 0; s < 3; ++s) n[s] = old.value(m.face_vertices(f)[s], k);
                col.set(f, n);
            }
            if (!textures_.empty() && before != 0 && !same_sign(uv_area(m, f), before))
                return false;
        }
        return true;
    }

    template <class Mesh>
    void swap_before(const Mesh& m, const typename Mesh::tuple& t, swap_values& out) const {
        const auto g = m.switch_face(t);
        const auto& f = m.face_vertices(t.fid);
        const index_t d = m.opposite_vertex(*g);
        for (int s = 0; s < 3; ++s) {
            out.vertex[s] = f[s];
            for (std::size_t k = 0; k < corner_.size(); ++k)
                out.values[s][k] = m.attribute(corner_[k])[t.fid][s];
        }
        out.vertex[3] = d;
        const index_t sd = slot_of(m, g->fid, d);
        for (std::size_t k = 0; k < corner_.size(); ++k)
            out.values[3][k] = m.attribute(corner_[k])[g->fid][sd];
        out.uv_area_sign = textures_.empty() ? 0 : uv_area(m, t.fid);
    }

private:
    using corner_triple = std::array<double, 3>;

    struct group {
        io::attribute_column meta; // name, domain, type, width, labels
        std::size_t first = 0;     // its first component's column
    };

    /// The component (vertex components first, then corner ones) of a group's first column.
    std::size_t first_component(const group& g) const noexcept {
        return g.first + (g.meta.domain == io::attribute_domain::vertex ? 0 : vertex_.size());
    }

    template <class Mesh>
    static index_t slot_of(const Mesh& m, index_t f, index_t v) {
        const auto& fv = m.face_vertices(f);
        for (index_t s = 0; s < 3; ++s)
            if (fv[s] == v) return s;
        return invalid_index;
    }

    static bool same_sign(double x, double y) { return (x > 0 && y > 0) || (x < 0 && y < 0); }

    /// Twice the signed area of face f in texture space (the first texture attribute).
    template <class Mesh>
    double uv_area(const Mesh& m, index_t f) const {
        const std::size_t k = textures_.front();
        const auto u = m.attribute(corner_[k])[f], v = m.attribute(corner_[k + 1])[f];
        return (u[1] - u[0]) * (v[2] - v[0]) - (u[2] - u[0]) * (v[1] - v[0]);
    }

    /// True if faces f and g (the two halves on a split's new vertex nv that kept their
    /// slots, one per side) differ in a tag or in nv's corner values: the split edge was a
    /// tag border or a seam, and so is the new vertex.
    template <class Mesh>
    bool sides_differ(const Mesh& m, index_t f, index_t g, index_t nv) const {
        return tags_differ(m, f, g) || corners_differ(m, f, g, nv);
    }

    /// Faces f and g carry different tags: the edge between them is a tag border.
    template <class Mesh>
    bool tags_differ(const Mesh& m, index_t f, index_t g) const {
        for (auto h : face_)
            if (m.attribute(h)[f] != m.attribute(h)[g]) return true;
        return false;
    }

    /// Vertex v has different corner values (bit for bit) in faces f and g: a seam.
    template <class Mesh>
    bool corners_differ(const Mesh& m, index_t f, index_t g, index_t v) const {
        const index_t sf = slot_of(m, f, v), sg = slot_of(m, g, v);
        for (auto h : corner_) {
            const auto col = m.attribute(h);
            if (std::bit_cast<std::uint64_t>(col[f][sf]) !=
                std::bit_cast<std::uint64_t>(col[g][sg]))
                return true;
        }
        return false;
    }

    /// The dihedral angle between faces f and h is above the feature angle.
    template <class Mesh>
    bool sharp_between(const Mesh& m, index_t f, index_t h) const {
        const vec3 n1 = face_normal_unnormalised(m, f), n2 = face_normal_unnormalised(m, h);
        const double l = norm(n1) * norm(n2);
        return l > 0 &&
               dot(n1, n2) / l < std::cos(options_.feature_angle_deg * std::numbers::pi / 180.0);
    }

    template <class Mesh>
    bool sharp(const Mesh& m, const op_result<typename Mesh::tuple>& r) const {
        // The halves that kept their old faces' slots, one on each side of the split edge
        // (coplanar with the old faces, so their normals are the old ones).
        index_t sides[2] = {invalid_index, invalid_index};
        int n = 0;
        for (std::size_t i = 0; i < r.cells.size() && n < 2; ++i)
            if (r.cells[i].fid == r.origins[i]) sides[n++] = r.cells[i].fid;
        return n == 2 && sharp_between(m, sides[0], sides[1]);
    }

    /// Barycentric interpolation at p in the old triangle nearest to it among `stars`
    /// (the faces around the collapsed edge's ends, or the moved vertex's star).
    template <class Mesh, class... Stars>
    void interpolate(const Mesh& m, const vec3& p, carried_values& c, const Stars&... stars) const {
        double best = std::numeric_limits<double>::infinity();
        index_t face = invalid_index;
        std::array<double, 3> w{1, 0, 0};
        auto consider = [&](index_t f) {
            const auto& fv = m.face_vertices(f);
            const vec3 &x = m.position(fv[0]), &y = m.position(fv[1]), &z = m.position(fv[2]);
            const vec3 q = closest_point_on_triangle(p, x, y, z);
            const double d = squared_norm(q - p);
            if (d < best) best = d, face = f, w = barycentric(q, x, y, z);
        };
        (..., [&](const auto& star) {
            for (index_t f : star) consider(f);
        }(stars));
        const auto& fv = m.face_vertices(face);
        std::size_t i = 0;
        for (auto h : vertex_) {
            const auto col = m.attribute(h);
            c.values[i++] = w[0] * col[fv[0]] + w[1] * col[fv[1]] + w[2] * col[fv[2]];
        }
        for (auto h : corner_) {
            const auto v = m.attribute(h)[face];
            c.values[i++] = w[0] * v[0] + w[1] * v[1] + w[2] * v[2];
        }
    }

    /// Barycentric coordinates of q (on the triangle) in (x, y, z); a degenerate triangle
    /// gives its nearest corner all the weight.
    static std::array<double, 3> barycentric(const vec3& q, const vec3& x, const vec3& y,
                                             const vec3& z) {
        const vec3 e0 = y - x, e1 = z - x, d = q - x;
        const double a = dot(e0, e0), b = dot(e0, e1), cc = dot(e1, e1);
        const double d0 = dot(d, e0), d1 = dot(d, e1);
        const double det = a * cc - b * b;
        if (!(det > 1e-300) || !(det > 1e-14 * a * cc)) {
            const double dx = squared_norm(q - x), dy = squared_norm(q - y),
                         dz = squared_norm(q - z);
            if (dx <= dy && dx <= dz) return {1, 0, 0};
            return dy <= dz ? std::array<double, 3>{0, 1, 0} : std::array<double, 3>{0, 0, 1};
        }
        double v = (cc * d0 - b * d1) / det, w = (a * d1 - b * d0) / det;
        v = std::clamp(v, 0.0, 1.0), w = std::clamp(w, 0.0, 1.0);
        if (v + w > 1) {
            const double s = v + w;
            v /= s, w /= s;
        }
        return {1 - v - w, v, w};
    }

    /// Writes the carried values at v and into v's corner of every face of its star.
    template <class Mesh>
    bool write_star(Mesh& m, index_t v, const op_result<typename Mesh::tuple>& r,
                    const carried_values& c) const {
        std::size_t i = 0;
        for (auto h : vertex_) m.attribute(h, r).set(v, c.values[i++]);
        if (corner_.empty()) return true;
        for (const auto& cell : r.cells) {
            const index_t s = slot_of(m, cell.fid, v);
            if (s == invalid_index) continue;
            if (!write_corners(m, r, cell.fid, s, [&](std::size_t k) { return c.values[i + k]; }))
                return false;
        }
        return true;
    }

    /// Sets corner `s` of face f to value(k) for every corner component k; false if that
    /// folds the face's texture triangle.
    template <class Mesh, class Value>
    bool write_corners(Mesh& m, const op_result<typename Mesh::tuple>& r, index_t f, index_t s,
                       Value&& value) const {
        const double before = textures_.empty() ? 0 : uv_area(m, f);
        for (std::size_t k = 0; k < corner_.size(); ++k) {
            auto col = m.attribute(corner_[k], r);
            corner_triple t = col[f];
            t[s] = value(k);
            col.set(f, t);
        }
        return before == 0 || same_sign(uv_area(m, f), before);
    }

    static void normalize_triples(std::vector<double>& v) {
        for (std::size_t i = 0; i + 2 < v.size(); i += 3) {
            const double l = std::sqrt(v[i] * v[i] + v[i + 1] * v[i + 1] + v[i + 2] * v[i + 2]);
            if (l > 0 && std::isfinite(l)) v[i] /= l, v[i + 1] /= l, v[i + 2] /= l;
        }
    }

    template <class Mesh>
    void mark_constraints(Mesh& m) {
        auto fixed = m.attribute(constrained_);
        m.for_each_edge([&](const typename Mesh::tuple& t) {
            const auto [a, b] = m.edge_vertices(t);
            const auto g = m.switch_face(t);
            if (!g) {
                if (options_.keep_boundary) fixed.raw(a) = fixed.raw(b) = 1;
                return;
            }
            const index_t f = t.fid, h = g->fid;
            if (tags_differ(m, f, h) || (options_.feature_angle_deg >= 0 && sharp_between(m, f, h)))
                fixed.raw(a) = fixed.raw(b) = 1;
            for (index_t v : {a, b})
                if (corners_differ(m, f, h, v)) fixed.raw(v) = 1;
        });
    }

    attribute_transfer_options options_;
    std::vector<vertex_attribute<double>> vertex_;
    std::vector<face_attribute<double>> face_;
    std::vector<face_attribute<corner_triple>> corner_;
    std::vector<std::size_t> textures_; // first corner component of each texture attribute
    std::vector<group> groups_;
    vertex_attribute<std::uint8_t> constrained_;
};

} // namespace idas::algorithms
