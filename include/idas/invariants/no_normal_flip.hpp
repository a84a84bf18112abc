// No face may turn over: each new face's normal must point the same way as the normal
// of the face it came from. Also refuses slivers, faces of (nearly) zero area: a sliver's
// normal is rounding noise, so the next operation's flip test against it means nothing
// (QSlim left faces of area 1e-17 along a subdivided cube's edges, and folded them).
#pragma once

#include <idas/core/types.hpp>
#include <idas/ops/operation.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>

namespace idas {

template <class Mesh>
vec3 face_normal_unnormalised(const Mesh& m, index_t f) {
    const auto& fv = m.face_vertices(f);
    const auto p = m.positions();
    return cross(p[fv[1]] - p[fv[0]], p[fv[2]] - p[fv[0]]);
}

/// Twice a face's area over its longest edge squared, below which it is a sliver (about
/// the sine of its smallest angle). No output face of the decimation tests comes near it.
inline constexpr double sliver_ratio = 1e-6;

/// Whether the triangle a, b, c with normal n = (b - a) x (c - a) is a sliver.
inline bool is_sliver(const vec3& a, const vec3& b, const vec3& c, const vec3& n) {
    const double longest2 =
        std::max({squared_norm(b - a), squared_norm(c - b), squared_norm(a - c)});
    return !(norm(n) > sliver_ratio * longest2);
}

/// Whether face f is a sliver (sliver_ratio).
template <class Mesh>
bool is_sliver(const Mesh& m, index_t f) {
    const auto& fv = m.face_vertices(f);
    const auto p = m.positions();
    const vec3 a = p[fv[0]], b = p[fv[1]], c = p[fv[2]];
    return is_sliver(a, b, c, cross(b - a, c - a));
}

struct no_normal_flip {
    struct state {
        boost::container::small_vector<std::pair<index_t, vec3>, 48> normals;
    };

    template <class Op, class Mesh>
    bool before(Op, const Mesh& m, const typename Mesh::tuple& t, state& s) const {
        auto remember = [&](index_t f) {
            for (const auto& [g, n] : s.normals)
                if (g == f) return;
            s.normals.push_back({f, face_normal_unnormalised(m, f)});
        };
        if constexpr (std::is_same_v<Op, op::smooth_vertex>) {
            for (index_t f : m.vertex_faces(t.vid)) remember(f);
        } else if constexpr (std::is_same_v<Op, op::collapse_edge>) {
            const auto [a, b] = m.edge_vertices(t);
            for (index_t f : m.vertex_faces(a)) remember(f);
            for (index_t f : m.vertex_faces(b)) remember(f);
        } else {
            remember(t.fid);
            if (auto g = m.switch_face(t)) remember(g->fid);
        }
        return true;
    }

    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh& m, const Result& r, state& s) const {
        const auto p = m.positions();
        for (std::size_t i = 0; i < r.cells.size(); ++i) {
            // One normal per new face serves both tests.
            const auto& fv = m.face_vertices(r.cells[i].fid);
            const vec3 a = p[fv[0]], b = p[fv[1]], c = p[fv[2]];
            const vec3 n = cross(b - a, c - a);
            if (is_sliver(a, b, c, n)) return false;
            const index_t origin = r.origins[i];
            const auto it = std::find_if(s.normals.begin(), s.normals.end(),
                                         [&](const auto& e) { return e.first == origin; });
            if (it == s.normals.end()) continue;
            if (!(dot(n, it->second) > 0)) return false;
        }
        return true;
    }
};

static_assert(invariant<no_normal_flip>);

} // namespace idas
