// The spatial index of no_self_intersection (no_self_intersection.hpp): the faces of a
// triangle mesh in a uniform grid, each cell listing the faces whose bounding box overlaps
// it. The grid is addressed directly (a word per grid cell, naming the cell's record), and
// the records are made once per build for every grid cell, so workers holding different
// cells can add cells and move faces at the same time.
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
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <type_traits>
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
    /// Grid cells per lock cell along each axis is 1 << lock_shift: one, for the words
    /// that lock the cells are the directory's (lock_word).
    static constexpr int lock_shift = 0;

    /// One face in one cell: its id and its quantized bounding box.
    struct entry {
        std::array<std::uint16_t, 3> lo, hi;
        index_t face;
    };

    /// One cell's entries. Trivial, so that a zeroed block of them is empty cells; each
    /// lives in the index's block from the last build until it outgrows its room there.
    /// Only the holder of the cell's lock cell touches it.
    struct cell {
        entry* items;
        std::uint32_t count, room;

        const entry* data() const noexcept { return items; }
        std::size_t size() const noexcept { return count; }
        bool empty() const noexcept { return count == 0; }
        entry* begin() noexcept { return items; }
        entry* end() noexcept { return items + count; }
        const entry* begin() const noexcept { return items; }
        const entry* end() const noexcept { return items + count; }
        entry& back() noexcept { return items[count - 1]; }
        void pop_back() noexcept { --count; }
        /// Adds e; outgrown room moves to a heap block of twice the size (`owned`: items is
        /// such a block already). Throws std::bad_alloc when memory runs out.
        void push_back(const entry& e, bool owned) {
            if (count == room) {
                const std::uint32_t more = std::max<std::uint32_t>(8, 2 * room);
                auto* grown = static_cast<entry*>(owned ? std::realloc(items, more * sizeof(entry))
                                                        : std::malloc(more * sizeof(entry)));
                if (!grown) throw std::bad_alloc();
                if (!owned && count) std::memcpy(grown, items, count * sizeof(entry));
                items = grown, room = more;
            }
            items[count++] = e;
        }
    };
    static_assert(std::is_trivial_v<cell> && std::is_trivially_copyable_v<entry>);

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
        for (int i = 0; i < 3; ++i)
            top_[i] = std::uint16_t(std::min(65535.0, std::ceil((hi[i] - lo[i]) * inv_quantum_)));
        // The grid's cells are addressed directly (and are the lock words): a mesh whose
        // faces are tiny beside its box (a detailed part inside a large sparse frame) gets
        // coarser cells, so that the grid stays within a few words per face.
        const std::size_t most_cells = std::max<std::size_t>(16 * box.faces, std::size_t(1) << 16);
        for (;; ++cell_shift_) {
            for (int i = 0; i < 3; ++i) dims_[i] = std::int32_t(top_[i] >> cell_shift_) + 1;
            if (cell_shift_ == 15 || grid_cells() <= most_cells) break;
        }

        // Each cell's faces: counted (in the directory), given a record and room in one
        // block, placed, then sorted by face (placing in parallel leaves them in any order).
        const std::size_t n_cells = grid_cells();
        release();
        directory_.reset(static_cast<std::uint32_t*>(std::calloc(n_cells, sizeof(std::uint32_t))));
        cells_.reset(static_cast<cell*>(std::calloc(n_cells, sizeof(cell))));
        if (!directory_ || !cells_) throw std::bad_alloc();
        tbb::parallel_for(range(0, slots, 4096), [&](const range& r) {
            for (index_t f = r.begin(); f < r.end(); ++f)
                if (m.face_alive(f))
                    for_each_cell(range_of(entry_of(m, f)), [&](std::uint64_t key) {
                        std::atomic_ref<std::uint32_t>(directory_[dense(key)])
                            .fetch_add(1, std::memory_order_relaxed);
                    });
        });
        std::size_t used = 0, room = 0;
        for (std::size_t d = 0; d < n_cells; ++d)
            if (const std::uint32_t count = directory_[d]) {
                cells_[used].room = count + spare_room; // the block's share, for now
                room += count + spare_room;
                directory_[d] = std::uint32_t(++used);
            }
        used_.store(used, std::memory_order_relaxed);
        block_.reset(
            static_cast<entry*>(std::malloc(std::max<std::size_t>(room, 1) * sizeof(entry))));
        if (!block_) throw std::bad_alloc();
        block_size_ = room;
        for (std::size_t c = 0, at = 0; c < used; at += cells_[c].room, ++c)
            cells_[c].items = block_.get() + at;
        tbb::parallel_for(range(0, slots, 4096), [&](const range& r) {
            for (index_t f = r.begin(); f < r.end(); ++f) {
                if (!m.face_alive(f)) continue;
                const entry e = entry_of(m, f);
                for_each_cell(range_of(e), [&](std::uint64_t key) {
                    cell& c = cells_[directory_[dense(key)] - 1];
                    c.items[std::atomic_ref<std::uint32_t>(c.count).fetch_add(
                        1, std::memory_order_relaxed)] = e;
                });
            }
        });
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, used, 1024),
            [&](const tbb::blocked_range<std::size_t>& r) {
                for (std::size_t c = r.begin(); c < r.end(); ++c)
                    std::sort(cells_[c].begin(), cells_[c].end(),
                              [](const entry& a, const entry& b) { return a.face < b.face; });
            });
    }

    self_intersection_index(const self_intersection_index&) = delete;
    self_intersection_index& operator=(const self_intersection_index&) = delete;
    ~self_intersection_index() { release(); }

    double cell_size() const noexcept { return double(1u << cell_shift_) * quantum_; }
    /// Lock cells: the grid's cells (lock_shift is 0), one word each.
    std::size_t lock_cells() const noexcept { return grid_cells(); }
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
        return std::size_t(x) +
               std::size_t(dims_[0]) * (std::size_t(y) + std::size_t(dims_[1]) * std::size_t(z));
    }

    /// The centre of the lock cell behind word w (see lock_word).
    vec3 lock_cell_centre(std::size_t w) const noexcept {
        const std::size_t nx = std::size_t(dims_[0]), ny = std::size_t(dims_[1]);
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
    void prefetch(std::uint64_t k) const noexcept { __builtin_prefetch(&directory_[dense(k)]); }

    /// The entries of the cell with key k, or null if no face was ever there. Safe while
    /// other threads add other cells (a cell's entries are touched only by the holder of
    /// its lock cell).
    const cell* find(std::uint64_t k) const noexcept {
        const std::uint32_t at =
            std::atomic_ref<std::uint32_t>(directory_[dense(k)]).load(std::memory_order_acquire);
        return at ? &cells_[at - 1] : nullptr;
    }
    /// The entries of cell k, made if need be (by its lock cell's holder: no other thread
    /// adds the same cell).
    cell& find_or_add(std::uint64_t k) noexcept {
        std::atomic_ref<std::uint32_t> slot(directory_[dense(k)]);
        std::uint32_t at = slot.load(std::memory_order_acquire);
        if (!at) {
            const auto made = std::uint32_t(used_.fetch_add(1, std::memory_order_relaxed) + 1);
            at = slot.compare_exchange_strong(at, made, std::memory_order_acq_rel) ? made : at;
        }
        return cells_[at - 1];
    }
    /// Adds e to cell c, which find_or_add gave.
    void push(cell& c, const entry& e) { c.push_back(e, c.items && !in_block(c.items)); }

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

    /// The directory, records and block come from calloc/malloc (zeroed memory is empty
    /// cells, untouched pages cost nothing).
    struct frees {
        void operator()(void* p) const noexcept { std::free(p); }
    };
    bool in_block(const entry* p) const noexcept {
        return p >= block_.get() && p < block_.get() + block_size_;
    }
    /// Frees the cells' records and what they point to: the build's block and what
    /// outgrew it.
    void release() noexcept {
        if (cells_)
            for (std::size_t i = 0, used = used_.load(std::memory_order_relaxed); i < used; ++i)
                if (cells_[i].items && !in_block(cells_[i].items)) std::free(cells_[i].items);
        cells_.reset(), block_.reset(), block_size_ = 0;
        used_.store(0, std::memory_order_relaxed);
    }
    /// Extra room per cell in the build's block.
    static constexpr std::uint32_t spare_room = 2;

    std::size_t grid_cells() const noexcept {
        return std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]);
    }
    std::size_t dense(std::uint64_t k) const noexcept {
        const auto [x, y, z] = coordinates(k);
        return lock_word(x, y, z);
    }

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
    vec3 origin_{};
    double quantum_ = 1, inv_quantum_ = 1;
    unsigned cell_shift_ = 0;
    std::array<std::uint16_t, 3> top_{0, 0, 0};
    std::array<std::int32_t, 3> dims_{1, 1, 1};         // grid cells along each axis
    std::unique_ptr<std::uint32_t[], frees> directory_; // per grid cell: record + 1, or 0
    std::unique_ptr<cell[], frees> cells_; // records (one per grid cell at most), in the order made
    std::unique_ptr<entry[], frees> block_; // the entries placed by the last build
    std::size_t block_size_ = 0;
    std::size_t faces_ = 0;
    std::atomic<std::size_t> used_{0};
};

} // namespace idas
