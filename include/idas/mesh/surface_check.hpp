// A cheap check of a face list that an editing algorithm produced, before it is written:
// an oriented 2-manifold (with boundary), and the two numbers edits must keep, the Euler
// characteristic and the number of boundary loops. diagnose_topology says more, but sorts
// every half-edge and explains each problem; this is O(F log valence) and stops at the
// first problem, so every command can afford it on every result. Vertices are checked
// in parallel (oneTBB); the result, and the problem reported, do not depend on the threads.
#pragma once

#include <idas/core/types.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace idas {

struct surface_summary {
    std::optional<std::string> problem; // the first failed check; nothing if all passed
    long euler_characteristic = 0;
    std::size_t boundary_edges = 0, boundary_loops = 0;
};

/// Checks that `faces` over `n_vertices` vertices form a consistently oriented 2-manifold
/// (every directed edge used once, every vertex star one fan) and counts its Euler
/// characteristic and boundary loops (these only when there is no problem).
inline surface_summary summarize_surface(std::size_t n_vertices,
                                         std::span<const tri_indices> faces) {
    surface_summary s;
    const auto fail = [&](std::string what) {
        s.problem = std::move(what);
        return s;
    };
    if (n_vertices >= invalid_index) return fail("too many vertices");
    // Outgoing half-edges v -> x of every corner, grouped by v (counting sort), each with
    // the face's third vertex y: the face is (v, x, y).
    std::vector<index_t> offset(n_vertices + 1, 0);
    for (std::size_t f = 0; f < faces.size(); ++f) {
        const tri_indices& t = faces[f];
        for (index_t v : t)
            if (v >= n_vertices)
                return fail("face " + std::to_string(f) + " references a missing vertex");
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            return fail("face " + std::to_string(f) + " repeats a vertex");
        for (index_t v : t) ++offset[v + 1];
    }
    for (std::size_t v = 0; v < n_vertices; ++v) offset[v + 1] += offset[v];
    struct half {
        index_t to, third;
        bool operator<(const half& o) const noexcept { return to < o.to; }
    };
    std::vector<half> out(offset.back());
    {
        std::vector<index_t> fill(offset.begin(), offset.end() - 1);
        for (const tri_indices& t : faces)
            for (int i = 0; i < 3; ++i) out[fill[t[i]]++] = {t[(i + 1) % 3], t[(i + 2) % 3]};
    }
    const auto star = [&](index_t v) {
        return std::span<const half>(out.data() + offset[v], out.data() + offset[v + 1]);
    };
    // The half-edge v -> x, if some face has it.
    const auto find = [&](index_t v, index_t x) -> const half* {
        const auto st = star(v);
        const auto it = std::lower_bound(st.begin(), st.end(), half{x, 0});
        return it != st.end() && it->to == x ? &*it : nullptr;
    };

    // The per-vertex checks run in parallel blocks of vertices. Each block stops at its
    // first problem; the problem of the lowest vertex is reported, as a serial scan would.
    struct tally {
        std::size_t referenced = 0, edges = 0, boundary_edges = 0;
        index_t failed_at = invalid_index;
        std::string problem;
        void fail(index_t v, std::string what) {
            if (v < failed_at) failed_at = v, problem = std::move(what);
        }
        void join(tally& o) {
            referenced += o.referenced, edges += o.edges, boundary_edges += o.boundary_edges;
            if (o.failed_at < failed_at) failed_at = o.failed_at, problem = std::move(o.problem);
        }
    };
    using range = tbb::blocked_range<index_t>;
    constexpr index_t serial_below = 1u << 16; // vertices
    const auto over_vertices = [&](auto&& per_vertex) {
        const auto block = [&](const range& r, tally t) {
            for (index_t v = r.begin(); v != r.end() && t.failed_at == invalid_index; ++v)
                per_vertex(v, t);
            return t;
        };
        // Small meshes stay on the calling thread: tasks cost more than they save there,
        // and ThreadSanitizer cannot see the joins of Debian's uninstrumented oneTBB.
        const auto n = static_cast<index_t>(n_vertices);
        if (n < serial_below) return block(range(0, n), tally{});
        return tbb::parallel_deterministic_reduce(range(0, n, 4096), tally{}, block,
                                                  [](tally a, tally b) {
                                                      a.join(b);
                                                      return a;
                                                  });
    };

    tally sorted = over_vertices([&](index_t v, tally& t) {
        std::sort(out.begin() + offset[v], out.begin() + offset[v + 1]);
        const auto st = star(v);
        for (std::size_t i = 1; i < st.size(); ++i)
            if (st[i].to == st[i - 1].to)
                return t.fail(v, "edge (" + std::to_string(v) + ", " + std::to_string(st[i].to) +
                                     ") is used twice in the same direction (a non-manifold edge "
                                     "or inconsistent orientation)");
        t.referenced += st.empty() ? 0 : 1;
    });
    if (sorted.failed_at != invalid_index) return fail(std::move(sorted.problem));

    std::vector<index_t> boundary_next(n_vertices, invalid_index);
    tally fans = over_vertices([&](index_t v, tally& t) {
        const auto st = star(v);
        for (const half& h : st) {
            if (!find(h.to, v)) {
                ++t.edges, ++t.boundary_edges;
                boundary_next[v] = h.to; // one per vertex once its star is one fan
            } else if (v < h.to) {
                ++t.edges;
            }
        }
        if (st.empty()) return;
        // Walk the fan: from (v, x, y) the next face around v has v -> y. Rewind first to
        // where an open fan starts, then count what one walk reaches.
        const half* start = &st[0];
        for (std::size_t k = 0; k < st.size(); ++k) {
            const half* in = find(start->to, v); // x -> v, in the face (x, v, w)
            if (!in) break;
            const half* prev = find(v, in->third);
            if (!prev || prev == &st[0]) break;
            start = prev;
        }
        std::size_t reached = 1;
        for (const half* h = find(v, start->third); h && h != start && reached <= st.size();
             h = find(v, h->third))
            ++reached;
        if (reached != st.size())
            t.fail(v, "vertex " + std::to_string(v) + ": its " + std::to_string(st.size()) +
                          " faces do not form one fan (a non-manifold vertex)");
    });
    if (fans.failed_at != invalid_index) return fail(std::move(fans.problem));
    const std::size_t referenced = sorted.referenced, edges = fans.edges;
    s.boundary_edges = fans.boundary_edges;
    for (index_t v = 0; v < n_vertices; ++v) {
        if (boundary_next[v] == invalid_index) continue;
        ++s.boundary_loops;
        for (index_t w = v; boundary_next[w] != invalid_index;) {
            const index_t next = boundary_next[w];
            boundary_next[w] = invalid_index;
            w = next;
        }
    }
    s.euler_characteristic =
        static_cast<long>(referenced) - static_cast<long>(edges) + static_cast<long>(faces.size());
    return s;
}

} // namespace idas
