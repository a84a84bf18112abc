// Topological diagnosis of a face list before it becomes an editable mesh: manifoldness,
// orientation, boundary loops, components, Euler characteristic. Editing requires a
// consistently oriented 2-manifold (with boundary); this says exactly where input is not.
#pragma once

#include <idas/core/types.hpp>

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

namespace idas {

struct topology_report {
    std::size_t vertices = 0, referenced_vertices = 0, faces = 0, edges = 0;
    std::size_t boundary_edges = 0, boundary_loops = 0, components = 0;
    std::size_t nonmanifold_edges = 0, nonmanifold_vertices = 0, misoriented_edges = 0;
    std::size_t degenerate_faces = 0, out_of_range_faces = 0;
    long euler_characteristic = 0;
    std::vector<std::string> problems; // first few, each naming the element

    bool manifold() const noexcept {
        return nonmanifold_edges == 0 && nonmanifold_vertices == 0 && degenerate_faces == 0 &&
               out_of_range_faces == 0;
    }
    bool oriented() const noexcept { return misoriented_edges == 0; }
    bool editable() const noexcept { return manifold() && oriented(); }
    bool closed() const noexcept { return boundary_edges == 0; }
};

namespace detail {
struct union_find {
    std::vector<index_t> parent;
    explicit union_find(std::size_t n)
        : parent(n) {
        std::iota(parent.begin(), parent.end(), index_t{0});
    }
    index_t find(index_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    }
    void unite(index_t a, index_t b) { parent[find(a)] = find(b); }
};
} // namespace detail

inline topology_report diagnose_topology(std::size_t n_vertices,
                                         const std::vector<tri_indices>& faces,
                                         std::size_t max_problems = 8) {
    topology_report r;
    r.vertices = n_vertices;
    r.faces = faces.size();
    auto note = [&](const std::string& s) {
        if (r.problems.size() < max_problems) r.problems.push_back(s);
    };

    // Half-edges keyed by their undirected edge; sorting groups each edge's faces.
    struct half {
        index_t lo, hi, face;
        bool forward; // lo -> hi in the face's orientation
    };
    std::vector<half> hs;
    hs.reserve(faces.size() * 3);
    std::vector<char> used(n_vertices, 0);
    for (index_t f = 0; f < faces.size(); ++f) {
        const auto& t = faces[f];
        if (t[0] >= n_vertices || t[1] >= n_vertices || t[2] >= n_vertices) {
            ++r.out_of_range_faces;
            note("face " + std::to_string(f) + " references a vertex index out of range");
            continue;
        }
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
            ++r.degenerate_faces;
            note("face " + std::to_string(f) + " repeats a vertex");
            continue;
        }
        for (int i = 0; i < 3; ++i) {
            index_t a = t[i], b = t[(i + 1) % 3];
            used[a] = 1;
            hs.push_back({std::min(a, b), std::max(a, b), f, a < b});
        }
    }
    r.referenced_vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
    tbb::parallel_sort(hs.begin(), hs.end(), [](const half& x, const half& y) {
        return x.lo != y.lo ? x.lo < y.lo : (x.hi != y.hi ? x.hi < y.hi : x.face < y.face);
    });

    detail::union_find face_sets(faces.size());
    // Per vertex: union-find over incident faces joined through manifold edges at the
    // vertex; more than one group means the vertex star is not a single fan.
    std::vector<std::pair<index_t, index_t>> boundary; // boundary edges, for loops
    std::vector<std::pair<index_t, std::pair<index_t, index_t>>> vertex_joins; // (vertex, faces)
    vertex_joins.reserve(hs.size() * 2);
    for (std::size_t i = 0; i < hs.size();) {
        std::size_t j = i;
        while (j < hs.size() && hs[j].lo == hs[i].lo && hs[j].hi == hs[i].hi) ++j;
        const std::size_t k = j - i;
        ++r.edges;
        if (k == 1) {
            ++r.boundary_edges;
            boundary.push_back({hs[i].lo, hs[i].hi});
        } else if (k == 2) {
            if (hs[i].forward == hs[i + 1].forward) {
                ++r.misoriented_edges;
                if (r.misoriented_edges <= 3)
                    note("edge (" + std::to_string(hs[i].lo) + ", " + std::to_string(hs[i].hi) +
                         ") is used in the same direction by faces " + std::to_string(hs[i].face) +
                         " and " + std::to_string(hs[i + 1].face) + " (inconsistent orientation)");
            }
            face_sets.unite(hs[i].face, hs[i + 1].face);
            vertex_joins.push_back({hs[i].lo, {hs[i].face, hs[i + 1].face}});
            vertex_joins.push_back({hs[i].hi, {hs[i].face, hs[i + 1].face}});
        } else {
            ++r.nonmanifold_edges;
            note("non-manifold edge (" + std::to_string(hs[i].lo) + ", " +
                 std::to_string(hs[i].hi) + ") is shared by " + std::to_string(k) + " faces");
            for (std::size_t m = i + 1; m < j; ++m) face_sets.unite(hs[i].face, hs[m].face);
        }
        i = j;
    }

    // Vertex fans: count face groups around each vertex.
    {
        std::vector<index_t> offset(n_vertices + 1, 0);
        for (const auto& t : faces)
            if (t[0] < n_vertices && t[1] < n_vertices && t[2] < n_vertices && t[0] != t[1] &&
                t[1] != t[2] && t[0] != t[2])
                for (index_t v : t) ++offset[v + 1];
        std::partial_sum(offset.begin(), offset.end(), offset.begin());
        std::vector<index_t> star(offset.back());
        std::vector<index_t> fill(offset.begin(), offset.end() - 1);
        for (index_t f = 0; f < faces.size(); ++f) {
            const auto& t = faces[f];
            if (t[0] < n_vertices && t[1] < n_vertices && t[2] < n_vertices && t[0] != t[1] &&
                t[1] != t[2] && t[0] != t[2])
                for (index_t v : t) star[fill[v]++] = f;
        }
        tbb::parallel_sort(vertex_joins.begin(), vertex_joins.end());
        std::size_t jpos = 0;
        std::vector<index_t> local_parent;
        for (index_t v = 0; v < n_vertices; ++v) {
            const index_t b = offset[v], e = offset[v + 1];
            const index_t n = e - b;
            local_parent.resize(n);
            std::iota(local_parent.begin(), local_parent.end(), index_t{0});
            auto find = [&](index_t x) {
                while (local_parent[x] != x) x = local_parent[x] = local_parent[local_parent[x]];
                return x;
            };
            auto local = [&](index_t f) {
                return static_cast<index_t>(
                    std::lower_bound(star.begin() + b, star.begin() + e, f) - (star.begin() + b));
            };
            std::size_t groups = n;
            while (jpos < vertex_joins.size() && vertex_joins[jpos].first == v) {
                index_t x = find(local(vertex_joins[jpos].second.first));
                index_t y = find(local(vertex_joins[jpos].second.second));
                if (x != y) local_parent[x] = y, --groups;
                ++jpos;
            }
            if (n > 0 && groups > 1) {
                ++r.nonmanifold_vertices;
                note("non-manifold vertex " + std::to_string(v) + ": its " + std::to_string(n) +
                     " faces form " + std::to_string(groups) + " separate fans");
            }
        }
    }

    // Components and boundary loops.
    {
        std::vector<char> seen(faces.size(), 0);
        for (index_t f = 0; f < faces.size(); ++f) {
            const auto& t = faces[f];
            if (t[0] >= n_vertices || t[1] >= n_vertices || t[2] >= n_vertices) continue;
            index_t root = face_sets.find(f);
            if (!seen[root]) seen[root] = 1, ++r.components;
        }
        detail::union_find loops(n_vertices);
        std::vector<char> on_boundary(n_vertices, 0);
        for (auto [a, b] : boundary) loops.unite(a, b), on_boundary[a] = on_boundary[b] = 1;
        for (index_t v = 0; v < n_vertices; ++v)
            if (on_boundary[v] && loops.find(v) == v) ++r.boundary_loops;
    }
    r.euler_characteristic = static_cast<long>(r.referenced_vertices) - static_cast<long>(r.edges) +
                             static_cast<long>(r.faces - r.degenerate_faces - r.out_of_range_faces);
    return r;
}

/// One-line summary of why a face list cannot be edited, for error messages.
inline std::string describe_problems(const topology_report& r) {
    std::ostringstream s;
    s << "not an orientable 2-manifold (" << r.nonmanifold_edges << " non-manifold edges, "
      << r.nonmanifold_vertices << " non-manifold vertices, " << r.misoriented_edges
      << " inconsistently oriented edges, " << r.degenerate_faces << " degenerate faces)";
    for (const auto& p : r.problems) s << "; " << p;
    return s.str();
}

} // namespace idas
