// The spatial index of no_self_intersection (no_self_intersection.hpp): the faces of a
// triangle mesh in a uniform grid, each cell listing the faces whose bounding box overlaps
// it. Cells live in an open-addressing table that never resizes, so workers holding
// different cells can add cells and move faces at the same time.
#pragma once

#include <idas/core/types.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

namespace idas {

/// An axis-aligned box of grid cells, bounds included.
struct cell_range {
    std::array<std::int32_t, 3> lo{}, hi{};
    friend bool operator==(const cell_range&, const cell_range&) = default;
    bool contains(const cell_range& o) const noexcept {
        for (int i = 0; i < 3; ++i)
            if (o.lo[i] < lo[i] || o.hi[i] > hi[i]) return false;
        return true;
    }
};

/// The faces of a triangle mesh in a uniform grid (see the top of this file).
///
/// Coordinates are quantized to 16 bits per axis over the mesh's box (rounded outwards;
/// points beyond the box clamp to its sides, which keeps every overlap, as the map is
/// monotone), and a grid cell is a whole number of quanta: so an entry is 16 bytes, its
/// box says which cells it is in, and a scan reads four entries per cache line.
class self_intersection_index {
public:
    /// Grid cells per lock cell along each axis is 1 << lock_shift.
    static constexpr int lock_shift = 0;

    /// One face in one cell: its id and its quantized bounding box.
    struct entry {
        std::array<std::uint16_t, 3> lo, hi;
        index_t face;
    };

    /// Indexes every live face of m. Cells are a power of two of quanta, between half of
    /// `cell_size` and all of it (default: four times the mean edge length), at least one
    /// quantum (1/65000 of the box's longest side).
    template <class Mesh>
    explicit self_intersection_index(const Mesh& m, double cell_size = 0) {
        rebuild(m, cell_size);
    }

    /// Indexes the live faces of m anew, with cells sized for the mesh as it is now (see
    /// the constructor). Only while no operation reads or writes the index. Parallel with
    /// oneTBB (its threads as the caller allows), and the same index at any thread count:
    /// the sums are deterministic reductions, and cells list their faces by id.
    template <class Mesh>
    void rebuild(const Mesh& m, double cell_size = 0) {
        using range = tbb::blocked_range<index_t>;
        const index_t slots = m.face_slots();
        const extent_sum box = tbb::parallel_deterministic_reduce(
            range(0, slots, 4096), extent_sum{},
            [&](const range& r, extent_sum acc) {
                for (index_t f = r.begin(); f < r.end(); ++f)
                    if (m.face_alive(f)) acc.add(m, f);
                return acc;
            },
            [](extent_sum a, const extent_sum& b) { return a.merge(b); });
        faces_ = box.faces;
        const std::size_t edges = 3 * box.faces;
        vec3 lo = box.lo, hi = box.hi;
        if (edges == 0) lo = hi = vec3{0, 0, 0};
        const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
        quantum_ = extent > 0 && std::isfinite(extent) ? extent / 65000 : 1;
        inv_quantum_ = 1 / quantum_;
        origin_ = lo;
        double h = cell_size > 0 ? cell_size : edges ? 4 * box.edge_sum / double(edges) : 0;
        if (!(h > 0) || !std::isfinite(h)) h = 64 * quantum_;
        // A power of two of quanta per cell, so a cell coordinate is a shift away.
        cell_shift_ = 0;
        while (cell_shift_ < 15 && double(2u << cell_shift_) <= h * inv_quantum_) ++cell_shift_;
        for (int i = 0; i < 3; ++i) {
            top_[i] = std::uint16_t(std::min(65535.0, std::ceil((hi[i] - lo[i]) * inv_quantum_)));
            lock_dims_[i] = (std::int32_t(top_[i] >> cell_shift_) >> lock_shift) + 1;
        }

        // Every (cell, face) pair, sorted by cell: counted, placed, sorted.
        std::vector<std::size_t> first(std::size_t(slots) + 1, 0);
        tbb::parallel_for(range(0, slots, 4096), [&](const range& r) {
            for (index_t f = r.begin(); f < r.end(); ++f)
                first[f + 1] = m.face_alive(f) ? cells_in(range_of(entry_of(m, f))) : 0;
        });
        for (std::size_t f = 0; f < slots; ++f) first[f + 1] += first[f];
        std::vector<std::pair<std::uint64_t, index_t>> pairs(first[slots]);
        tbb::parallel_for(range(0, slots, 4096), [&](const range& r) {
            for (index_t f = r.begin(); f < r.end(); ++f) {
                if (!m.face_alive(f)) continue;
                std::size_t at = first[f];
                for_each_cell(range_of(entry_of(m, f)), [&](std::uint64_t key) {
                    pairs[at++] = {key, f};
                });
            }
        });
        tbb::parallel_sort(pairs.begin(), pairs.end());
        std::vector<std::size_t> starts; // where each cell's pairs begin
        for (std::size_t i = 0; i < pairs.size(); ++i)
            if (i == 0 || pairs[i].first != pairs[i - 1].first) starts.push_back(i);
        starts.push_back(pairs.size());
        const std::size_t distinct = starts.size() - 1;
        // Room for the cells operations will move faces into, without resizing in parallel:
        // the table is at most half full with four times the cells it starts with. (Cells
        // are never removed and growing faces cover ever more of them: with twice, a
        // parallel decimation of armadillo x16 to 1% on 2 threads filled the table, and
        // 33k collapses were refused for want of a cell; serial runs refit instead.)
        capacity_ = 4 * distinct + 4096;
        std::size_t n = 1;
        while (n < 2 * capacity_) n *= 2;
        mask_ = n - 1;
        slots_ = std::make_unique<slot[]>(n);
        used_.store(0, std::memory_order_relaxed);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, distinct, 256),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t c = r.begin(); c < r.end(); ++c) {
                                  const std::size_t i = starts[c], j = starts[c + 1];
                                  std::vector<entry>& cell = *find_or_add(pairs[i].first);
                                  cell.reserve(j - i + 2);
                                  for (std::size_t k = i; k < j; ++k)
                                      cell.push_back(entry_of(m, pairs[k].second));
                              }
                          });
    }

    self_intersection_index(const self_intersection_index&) = delete;
    self_intersection_index& operator=(const self_intersection_index&) = delete;

    double cell_size() const noexcept { return double(1u << cell_shift_) * quantum_; }
    std::size_t lock_cells() const noexcept {
        return std::size_t(lock_dims_[0]) * lock_dims_[1] * lock_dims_[2];
    }
    /// Live faces at the last (re)build.
    std::size_t faces_indexed() const noexcept { return faces_; }
    /// Grid cells that hold (or held) faces.
    std::size_t cells_used() const noexcept { return used_.load(std::memory_order_relaxed); }

    // ---- geometry to cells ----

    /// An entry for face f as it is now.
    template <class Mesh>
    entry entry_of(const Mesh& m, index_t f) const {
        const auto& fv = m.face_vertices(f);
        const vec3 &a = m.position(fv[0]), &b = m.position(fv[1]), &c = m.position(fv[2]);
        entry e{};
        for (int i = 0; i < 3; ++i) {
            e.lo[i] = below(std::min({a[i], b[i], c[i]}), i);
            e.hi[i] = above(std::max({a[i], b[i], c[i]}), i);
        }
        e.face = f;
        return e;
    }
    /// An entry's box for a box of doubles.
    entry box_of(const vec3& lo, const vec3& hi) const noexcept {
        entry e{};
        for (int i = 0; i < 3; ++i) e.lo[i] = below(lo[i], i), e.hi[i] = above(hi[i], i);
        return e;
    }
    /// The first quantum of cell c along an axis.
    std::uint16_t first_quantum(std::int32_t c) const noexcept {
        return std::uint16_t(std::uint32_t(c) << cell_shift_);
    }
    /// The cells an entry's box overlaps.
    cell_range range_of(const entry& e) const noexcept {
        cell_range r;
        for (int i = 0; i < 3; ++i)
            r.lo[i] = std::int32_t(e.lo[i] >> cell_shift_),
            r.hi[i] = std::int32_t(e.hi[i] >> cell_shift_);
        return r;
    }
    /// Whether two entries' boxes overlap.
    static bool overlap(const entry& a, const entry& b) noexcept {
        return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] &&
               b.lo[1] <= a.hi[1] && a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
    }
    static cell_range locks_of(const cell_range& r) noexcept {
        cell_range l;
        for (int i = 0; i < 3; ++i)
            l.lo[i] = r.lo[i] >> lock_shift, l.hi[i] = r.hi[i] >> lock_shift;
        return l;
    }
    std::size_t lock_word(std::int32_t x, std::int32_t y, std::int32_t z) const noexcept {
        return std::size_t(x) + std::size_t(lock_dims_[0]) *
                                    (std::size_t(y) + std::size_t(lock_dims_[1]) * std::size_t(z));
    }

    /// The centre of the lock cell behind word w (see lock_word).
    vec3 lock_cell_centre(std::size_t w) const noexcept {
        const std::size_t nx = std::size_t(lock_dims_[0]), ny = std::size_t(lock_dims_[1]);
        const double x = double(w % nx), y = double(w / nx % ny), z = double(w / (nx * ny));
        const double side = double(1u << (cell_shift_ + lock_shift)) * quantum_;
        return origin_ + vec3{(x + 0.5) * side, (y + 0.5) * side, (z + 0.5) * side};
    }

    template <class Fn>
    static void for_each_cell(const cell_range& r, Fn&& fn) {
        for (std::int32_t z = r.lo[2]; z <= r.hi[2]; ++z)
            for (std::int32_t y = r.lo[1]; y <= r.hi[1]; ++y)
                for (std::int32_t x = r.lo[0]; x <= r.hi[0]; ++x) fn(key(x, y, z));
    }
    static std::uint64_t key(std::int32_t x, std::int32_t y, std::int32_t z) noexcept {
        return std::uint64_t(x) | std::uint64_t(y) << 16 | std::uint64_t(z) << 32;
    }
    static std::array<std::int32_t, 3> coordinates(std::uint64_t k) noexcept {
        return {std::int32_t(k & 0xffff), std::int32_t(k >> 16 & 0xffff), std::int32_t(k >> 32)};
    }

    // ---- cells ----

    /// Starts loading the cell with key k (a scan asks for all its cells first, so that
    /// their cache misses overlap).
    void prefetch(std::uint64_t k) const noexcept { __builtin_prefetch(&slots_[hash(k)]); }

    /// The entries of the cell with key k, or null if no face was ever there. Safe while
    /// other threads add other cells (a cell's entries are touched only by the holder of
    /// its lock cell).
    const std::vector<entry>* find(std::uint64_t k) const noexcept {
        for (std::size_t s = hash(k);; s = (s + 1) & mask_) {
            const std::uint64_t seen = slots_[s].key.load(std::memory_order_acquire);
            if (seen == 0) return nullptr;
            if (seen == k + 1) return &slots_[s].entries;
        }
    }
    /// The entries of cell k, made if need be; null if the table is full (the caller
    /// refuses its operation). Lock-free: keys are claimed by compare-and-swap and never
    /// removed.
    std::vector<entry>* find_or_add(std::uint64_t k) noexcept {
        for (std::size_t s = hash(k);; s = (s + 1) & mask_) {
            std::uint64_t seen = slots_[s].key.load(std::memory_order_acquire);
            if (seen == 0) {
                if (used_.fetch_add(1, std::memory_order_relaxed) >= capacity_) {
                    used_.fetch_sub(1, std::memory_order_relaxed);
                    return nullptr;
                }
                if (slots_[s].key.compare_exchange_strong(seen, k + 1, std::memory_order_acq_rel))
                    return &slots_[s].entries;
                used_.fetch_sub(1, std::memory_order_relaxed); // another key took the slot
            }
            if (seen == k + 1) return &slots_[s].entries;
        }
    }

private:
    static constexpr double inf = std::numeric_limits<double>::infinity();

    /// The faces' box, count and summed edge lengths, over a range of faces.
    struct extent_sum {
        vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
        double edge_sum = 0;
        std::size_t faces = 0;
        template <class Mesh>
        void add(const Mesh& m, index_t f) {
            ++faces;
            const auto& fv = m.face_vertices(f);
            for (int k = 0; k < 3; ++k) {
                const vec3& p = m.position(fv[k]);
                for (int i = 0; i < 3; ++i)
                    lo[i] = std::min(lo[i], p[i]), hi[i] = std::max(hi[i], p[i]);
                edge_sum += norm(m.position(fv[(k + 1) % 3]) - p);
            }
        }
        extent_sum merge(const extent_sum& o) const {
            extent_sum r = *this;
            for (int i = 0; i < 3; ++i)
                r.lo[i] = std::min(lo[i], o.lo[i]), r.hi[i] = std::max(hi[i], o.hi[i]);
            r.edge_sum += o.edge_sum, r.faces += o.faces;
            return r;
        }
    };
    static std::size_t cells_in(const cell_range& r) noexcept {
        return std::size_t(r.hi[0] - r.lo[0] + 1) * std::size_t(r.hi[1] - r.lo[1] + 1) *
               std::size_t(r.hi[2] - r.lo[2] + 1);
    }

    /// A cell: its key (plus one; 0 while free) beside its entries.
    struct slot {
        std::atomic<std::uint64_t> key{0};
        std::vector<entry> entries;
    };

    // Quantized coordinates: monotone in x, clamped to [0, top] (NaN: the whole range).
    // A cast truncates, which is the floor of a positive number.
    std::uint16_t below(double x, int axis) const noexcept {
        const double q = (x - origin_[axis]) * inv_quantum_;
        return q > 0 ? (q < double(top_[axis]) ? std::uint16_t(q) : top_[axis]) : 0;
    }
    std::uint16_t above(double x, int axis) const noexcept {
        const double q = (x - origin_[axis]) * inv_quantum_;
        if (!(q < double(top_[axis]))) return top_[axis];
        if (!(q > 0)) return 0;
        const auto t = std::uint16_t(q);
        return double(t) < q ? std::uint16_t(t + 1) : t;
    }
    std::size_t hash(std::uint64_t k) const noexcept {
        return std::size_t((k * 0x9E3779B97F4A7C15ull) >> 20) & mask_;
    }

    vec3 origin_{};
    double quantum_ = 1, inv_quantum_ = 1;
    unsigned cell_shift_ = 0;
    std::array<std::uint16_t, 3> top_{0, 0, 0};
    std::array<std::int32_t, 3> lock_dims_{1, 1, 1};
    std::unique_ptr<slot[]> slots_;
    std::size_t mask_ = 0, capacity_ = 0, faces_ = 0;
    std::atomic<std::size_t> used_{0};
};

} // namespace idas
