// Partition policies: split the vertices into parts, one queue per part, so workers
// start far apart and rarely contend for the same vertices.
#pragma once

#include <idas/core/types.hpp>

#include <metis.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <bit>
#include <concepts>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <vector>

namespace idas {

/// `assign(mesh, parts)` gives each vertex slot a part in [0, parts).
template <class P, class Mesh>
concept partition_policy = requires(const Mesh& m, unsigned parts) {
    { P::assign(m, parts) } -> std::same_as<std::vector<std::uint32_t>>;
};

/// A policy that can also weigh the vertices: `assign(mesh, parts, weight)` gives each
/// part about the same total weight (weight per vertex slot).
template <class P, class Mesh>
concept weighted_partition_policy = partition_policy<P, Mesh> &&
    requires(const Mesh& m, unsigned parts, const std::vector<std::uint32_t>& weight) {
    { P::assign(m, parts, weight) } -> std::same_as<std::vector<std::uint32_t>>;
};

namespace partition {

namespace detail {
/// Spreads the low 21 bits of x so two zero bits separate each (for 3D interleaving).
constexpr std::uint64_t spread_bits(std::uint64_t x) noexcept {
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    return x;
}
} // namespace detail

/// Orders vertices along a Morton (Z-order) curve and cuts it into parts of equal vertex
/// count, or of equal weight: cheap, and parts are spatially compact. Each executor run
/// partitions anew (a remeshing of armadillo x16 runs twenty), so the cut is linear and
/// parallel: codes and a histogram of the codes' leading bits in one pass, then only the
/// few vertices of the buckets where a cut falls are sorted. The parts are those of a full
/// sort by (code, vertex), whatever the thread count.
struct morton {
    using keyed_vertex = std::pair<std::uint64_t, index_t>;

    /// (Morton code, vertex) of every live vertex, in slot order; codes on a 2^21 grid over
    /// the bounding cube.
    template <class Mesh>
    static std::vector<keyed_vertex> keys(const Mesh& m) {
        const grid g = grid_of(m);
        const index_t n = m.vertex_slots();
        const std::size_t blocks = (std::size_t{n} + grain - 1) / grain;
        std::vector<std::size_t> first(blocks + 1, 0); // live vertices before each block
        tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t k) {
            for (index_t v = index_t(k * grain); v < std::min<std::size_t>(n, (k + 1) * grain); ++v)
                first[k + 1] += m.vertex_alive(v) ? 1 : 0;
        });
        std::partial_sum(first.begin(), first.end(), first.begin());
        std::vector<keyed_vertex> keyed(first.back());
        tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t k) {
            std::size_t i = first[k];
            for (index_t v = index_t(k * grain); v < std::min<std::size_t>(n, (k + 1) * grain); ++v)
                if (m.vertex_alive(v)) keyed[i++] = {g.code(m.position(v)), v};
        });
        return keyed;
    }

    /// (Morton code, index) of each point of a list, on the same grid over their bounding
    /// cube: a spatially coherent order for any per-point work.
    static std::vector<keyed_vertex> keys(const std::vector<vec3>& points) {
        struct view {
            const std::vector<vec3>& p;
            index_t vertex_slots() const noexcept { return index_t(p.size()); }
            bool vertex_alive(index_t) const noexcept { return true; }
            const vec3& position(index_t v) const noexcept { return p[v]; }
        };
        return keys(view{points});
    }

    /// Equal vertex counts: the vertex of rank i along the curve goes to part
    /// i * parts / (live vertices), as a sort would give.
    template <class Mesh>
    static std::vector<std::uint32_t> assign(const Mesh& m, unsigned parts) {
        return cut(m, parts, nullptr);
    }

    /// Equal weights instead (weight per vertex slot): each part within one vertex's weight
    /// of its share. Without any weight, equal vertex counts.
    template <class Mesh>
    static std::vector<std::uint32_t> assign(const Mesh& m, unsigned parts,
                                             const std::vector<std::uint32_t>& weight) {
        return cut(m, parts, &weight);
    }

private:
    static constexpr std::size_t grain = 16384; // vertices per parallel task

    /// Codes on a 2^21 grid over the bounding cube of the live vertices.
    struct grid {
        vec3 lo{};
        double scale = 0;
        std::uint64_t code(const vec3& p) const noexcept {
            std::uint64_t c = 0;
            for (int k = 0; k < 3; ++k)
                c |= detail::spread_bits(static_cast<std::uint64_t>((p[k] - lo[k]) * scale)) << k;
            return c;
        }
    };
    template <class Mesh>
    static grid grid_of(const Mesh& m) {
        struct box {
            vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
        };
        const box b = tbb::parallel_reduce(
            tbb::blocked_range<index_t>(0, m.vertex_slots(), grain), box{},
            [&](const tbb::blocked_range<index_t>& r, box acc) {
                for (index_t v = r.begin(); v != r.end(); ++v) {
                    if (!m.vertex_alive(v)) continue;
                    const vec3& p = m.position(v);
                    for (int k = 0; k < 3; ++k)
                        acc.lo[k] = std::min(acc.lo[k], p[k]),
                        acc.hi[k] = std::max(acc.hi[k], p[k]);
                }
                return acc;
            },
            [](box x, const box& y) {
                for (int k = 0; k < 3; ++k)
                    x.lo[k] = std::min(x.lo[k], y.lo[k]), x.hi[k] = std::max(x.hi[k], y.hi[k]);
                return x;
            });
        const double extent = std::max({b.hi.x - b.lo.x, b.hi.y - b.lo.y, b.hi.z - b.lo.z, 1e-300});
        return {b.lo, 2097151.0 / extent};
    }

    /// Cut k (1 <= k < parts) lies before the vertex of weight w whose weight before it,
    /// `w_before`, is at most the cut's target t and whose own weight passes it, or after
    /// that vertex if that brings the part nearer t. Unweighted (every weight 1) with t the
    /// rank ceil(k * n / parts), the cut is at that rank.
    template <class Mesh>
    static std::vector<std::uint32_t> cut(const Mesh& m, unsigned parts,
                                          const std::vector<std::uint32_t>* weight) {
        const index_t n = m.vertex_slots();
        std::vector<std::uint32_t> part(n, 0);
        if (parts <= 1 || n == 0) return part;
        const auto weight_of = [&](index_t v) -> std::uint64_t {
            return weight ? (*weight)[v] : 1;
        };
        const grid g = grid_of(m);
        // About 64 vertices per bucket, at most 2^14 buckets (a histogram that stays in
        // the cache); codes have 63 bits.
        const int bits = std::clamp(int(std::bit_width(std::size_t{n})) - 6, 1, 14);
        const int shift = 63 - bits;
        const std::size_t buckets = std::size_t{1} << bits;
        std::vector<std::uint64_t> code(n, 0);
        tbb::enumerable_thread_specific<std::vector<std::uint64_t>> local_sum(
            [&] { return std::vector<std::uint64_t>(buckets, 0); });
        tbb::parallel_for(tbb::blocked_range<index_t>(0, n, grain), [&](const auto& r) {
            auto& sum = local_sum.local();
            for (index_t v = r.begin(); v != r.end(); ++v)
                if (m.vertex_alive(v))
                    code[v] = g.code(m.position(v)), sum[code[v] >> shift] += weight_of(v);
        });
        std::vector<std::uint64_t> before(buckets + 1, 0); // weight before each bucket
        for (const auto& sum : local_sum)
            for (std::size_t b = 0; b < buckets; ++b) before[b + 1] += sum[b];
        std::partial_sum(before.begin(), before.end(), before.begin());
        const std::uint64_t total = before.back();
        if (weight && total == 0) return cut(m, parts, nullptr); // no live vertex weighs

        // The cuts' targets and the buckets they fall in (the first whose weight passes).
        std::vector<std::uint64_t> target(parts);
        std::vector<std::size_t> bucket(parts);
        std::vector<char> cut_in(buckets, 0);
        for (unsigned k = 1; k < parts; ++k) {
            target[k] = weight ? total * k / parts : (total * k + parts - 1) / parts;
            bucket[k] = std::size_t(std::upper_bound(before.begin() + 1, before.end(), target[k]) -
                                    (before.begin() + 1));
            if (bucket[k] < buckets) cut_in[bucket[k]] = 1;
        }
        // The vertices of those buckets, in curve order.
        tbb::enumerable_thread_specific<std::vector<keyed_vertex>> local_cut;
        tbb::parallel_for(tbb::blocked_range<index_t>(0, n, grain), [&](const auto& r) {
            for (index_t v = r.begin(); v != r.end(); ++v)
                if (m.vertex_alive(v) && cut_in[code[v] >> shift])
                    local_cut.local().push_back({code[v], v});
        });
        std::vector<keyed_vertex> at_cuts;
        for (const auto& l : local_cut) at_cuts.insert(at_cuts.end(), l.begin(), l.end());
        std::sort(at_cuts.begin(), at_cuts.end());
        // Each cut as the key of the first vertex past it (a vertex's key is unique).
        constexpr keyed_vertex past_all{~std::uint64_t{0}, invalid_index};
        std::vector<keyed_vertex> first_of(parts, past_all);
        for (unsigned k = 1; k < parts; ++k) {
            if (bucket[k] >= buckets) continue; // the curve ends before the target
            auto it = std::lower_bound(at_cuts.begin(), at_cuts.end(),
                                       keyed_vertex{std::uint64_t(bucket[k]) << shift, 0});
            for (std::uint64_t w_before = before[bucket[k]];; ++it) {
                const std::uint64_t w = weight_of(it->second);
                if (w_before + w > target[k]) {
                    first_of[k] = 2 * (target[k] - w_before) > w
                                      ? keyed_vertex{it->first, it->second + 1}
                                      : *it;
                    break;
                }
                w_before += w;
            }
        }
        // A bucket without a cut lies in one part: the number of cuts in earlier buckets.
        std::vector<std::uint32_t> part_of(buckets, 0);
        for (unsigned k = 1; k < parts; ++k)
            if (bucket[k] + 1 < buckets) ++part_of[bucket[k] + 1];
        std::partial_sum(part_of.begin(), part_of.end(), part_of.begin());
        tbb::parallel_for(tbb::blocked_range<index_t>(0, n, grain), [&](const auto& r) {
            for (index_t v = r.begin(); v != r.end(); ++v) {
                if (!m.vertex_alive(v)) continue;
                const std::size_t b = code[v] >> shift;
                part[v] = cut_in[b]
                              ? std::uint32_t(std::upper_bound(first_of.begin() + 1, first_of.end(),
                                                               keyed_vertex{code[v], v}) -
                                              (first_of.begin() + 1))
                              : part_of[b];
            }
        });
        return part;
    }
};

/// METIS k-way partition of the vertex graph: minimal cut, so fewer operations touch
/// two parts; costs a graph build and a METIS call.
struct metis {
    template <class Mesh>
    static std::vector<std::uint32_t> assign(const Mesh& m, unsigned parts) {
        const index_t n = m.vertex_slots();
        std::vector<std::uint32_t> part(n, 0);
        if (parts <= 1 || n == 0) return part;
        // The graph has only the vertices with neighbours. METIS balances node counts, so
        // dead slots (most of them after a collapse phase) and unreferenced input vertices
        // would fill whole parts: on armadillo x4 decimated to 10% every live vertex went
        // to one part, and the next 2-thread remeshing phases ran 40x slower.
        std::vector<idx_t> id(n, -1);
        std::vector<index_t> live, neighbours, ring;
        std::vector<idx_t> xadj{0};
        for (index_t v = 0; v < n; ++v) {
            if (!m.vertex_alive(v)) continue;
            ring.clear();
            m.one_ring_vertices(v, ring);
            if (ring.empty()) continue;
            id[v] = static_cast<idx_t>(live.size());
            live.push_back(v);
            neighbours.insert(neighbours.end(), ring.begin(), ring.end());
            xadj.push_back(static_cast<idx_t>(neighbours.size()));
        }
        if (live.size() < 2) return part;
        std::vector<idx_t> adjncy(neighbours.size());
        for (std::size_t i = 0; i < neighbours.size(); ++i) adjncy[i] = id[neighbours[i]];
        idx_t nv = static_cast<idx_t>(live.size()), ncon = 1, nparts = static_cast<idx_t>(parts),
              objval = 0;
        std::vector<idx_t> result(live.size(), 0);
        idx_t options[METIS_NOPTIONS];
        METIS_SetDefaultOptions(options);
        options[METIS_OPTION_SEED] = 1; // deterministic
        const int status =
            METIS_PartGraphKway(&nv, &ncon, xadj.data(), adjncy.data(), nullptr, nullptr, nullptr,
                                &nparts, nullptr, nullptr, options, &objval, result.data());
        if (status != METIS_OK) throw std::runtime_error("METIS_PartGraphKway failed");
        for (std::size_t i = 0; i < live.size(); ++i)
            part[live[i]] = static_cast<std::uint32_t>(result[i]);
        return part;
    }
};

} // namespace partition

} // namespace idas
