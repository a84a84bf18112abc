// Slot bookkeeping shared by the connectivity backends: which slot a new vertex or top
// cell goes into, and how to undo that.
//
// Serially, dead slots are recycled (most recently freed first), so a long run of splits
// and collapses keeps the arrays at a steady size instead of growing without bound.
//
// In a parallel phase each worker takes new vertex and cell slots from its own pool, so
// adding a simplex needs no reallocation and no atomics. The pools are filled before the
// workers start: first with the backend's dead slots, then, only if those are too few,
// with slots past the end of its arrays. Executor passes that run one after another then
// reuse the same slots instead of growing the arrays each time.
#pragma once

#include <idas/core/types.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <span>
#include <vector>

namespace idas::detail {

/// Grows `v` to `n` elements of `value` (never shrinks it). A parallel phase's growth is
/// all fresh memory, made while every worker waits, and a first touch of a page costs
/// about 10 us on a virtual machine (a trap to the hypervisor): the sphere's first split
/// phase on 2 threads spent 15 of its 45 ms growing the tet arrays. So past a megabyte of
/// new storage, oneTBB's threads touch the fresh pages first, in parallel, and the
/// elements are then made in memory that is already there.
template <class T, class Alloc>
void grow_prefaulted(std::vector<T, Alloc>& v, std::size_t n, const T& value) {
    if (n <= v.size()) return;
    constexpr std::size_t page = 4096, worth_it = std::size_t{1} << 20;
    if (n > v.capacity() && (n - v.size()) * sizeof(T) >= worth_it) {
        const T copy = value; // `value` may be an element, which the reserve moves
        // Geometric, as resize's own growth: a deterministic run grows its arrays round
        // after round, and an exact reserve would move them every round.
        v.reserve(std::max(n, 2 * v.capacity()));
        const auto first = reinterpret_cast<std::uintptr_t>(v.data() + v.size());
        const auto last = reinterpret_cast<std::uintptr_t>(v.data() + n);
        const std::uintptr_t first_page = first / page, pages = (last - 1) / page - first_page + 1;
        tbb::parallel_for(tbb::blocked_range<std::uintptr_t>(0, pages, 64),
                          [&](const tbb::blocked_range<std::uintptr_t>& r) {
                              for (std::uintptr_t p = r.begin(); p < r.end(); ++p) {
                                  const std::uintptr_t at =
                                      std::max(first, (first_page + p) * page);
                                  *reinterpret_cast<volatile unsigned char*>(at) = 0;
                              }
                          });
        v.resize(n, copy);
        return;
    }
    v.resize(n, value);
}

/// Per-worker pools of one kind of slot (vertices, or top cells), kept in one array:
/// pool w hands out slots_[next_[w]] up to slots_[end_[w]], in ascending order. One
/// array whose capacity stays, so a deterministic run that deals pools every round
/// allocates nothing once it has grown.
class slot_pool {
public:
    /// Deals `wanted` slots to `workers` pools in contiguous blocks. Dead slots come
    /// first, taken from the back of `free` (most recently freed); the rest are new slots
    /// numbered from `slots` up. Returns the slot count the backend's arrays must be
    /// resized to.
    index_t deal(unsigned workers, std::vector<index_t>& free, index_t slots, index_t wanted) {
        const index_t grown = fill(free, slots, wanted);
        next_.resize(workers), end_.resize(workers);
        for (unsigned w = 0; w < workers; ++w) {
            next_[w] = slots_.size() * w / workers;
            end_[w] = slots_.size() * (w + 1) / workers;
        }
        return grown;
    }
    /// The same with a quota per pool (pool w gets quotas[w] slots, in pool order).
    index_t deal(std::span<const index_t> quotas, std::vector<index_t>& free, index_t slots) {
        std::size_t wanted = 0;
        for (index_t q : quotas) wanted += q;
        const index_t grown = fill(free, slots, wanted);
        next_.resize(quotas.size()), end_.resize(quotas.size());
        std::size_t at = 0;
        for (std::size_t w = 0; w < quotas.size(); ++w) {
            next_[w] = at;
            end_[w] = at += quotas[w];
        }
        return grown;
    }
    std::size_t available(unsigned worker) const noexcept { return end_[worker] - next_[worker]; }
    index_t take(unsigned worker) noexcept {
        assert(next_[worker] < end_[worker]);
        return slots_[next_[worker]++];
    }
    /// Undoing a take.
    void give_back(unsigned worker, [[maybe_unused]] index_t s) noexcept {
        assert(next_[worker] > 0 && slots_[next_[worker] - 1] == s);
        --next_[worker];
    }
    /// Unused slots become the backend's dead slots again (each pool's in ascending order).
    void release(std::vector<index_t>& free) {
        for (std::size_t w = 0; w < next_.size(); ++w)
            free.insert(free.end(), slots_.begin() + std::ptrdiff_t(next_[w]),
                        slots_.begin() + std::ptrdiff_t(end_[w]));
        slots_.clear(), next_.clear(), end_.clear();
    }
    friend bool operator==(const slot_pool&, const slot_pool&) = default;

private:
    /// slots_ = `wanted` slots, sorted: dead ones first, then new ones from `slots` up.
    index_t fill(std::vector<index_t>& free, index_t slots, std::size_t wanted) {
        const std::size_t reused = std::min<std::size_t>(free.size(), wanted);
        slots_.assign(free.end() - std::ptrdiff_t(reused), free.end());
        // erase rather than resize: g++ 12 warns (-Wstringop-overflow) on a resize it
        // cannot see only shrinks.
        free.erase(free.end() - std::ptrdiff_t(reused), free.end());
        // Dead slots lie below `slots` and the new ones count up from it: only the dead
        // ones need sorting (a tet mesh's split phase asks for 100,000 slots and more,
        // most of them new).
        std::sort(slots_.begin(), slots_.end());
        slots_.resize(wanted);
        std::iota(slots_.begin() + std::ptrdiff_t(reused), slots_.end(), slots);
        return static_cast<index_t>(
            std::max<std::size_t>(slots, slots_.empty() ? 0 : std::size_t(slots_.back()) + 1));
    }

    std::vector<index_t> slots_;
    std::vector<std::size_t> next_, end_;
};

/// The undo log of a backend whose log is a plain list of entries, with the slot pool its
/// operations' new simplices come from. Every backend's log carries `pool`: the executor
/// sets it in the operation's context (op_context::conn) to the parallel worker's pool, or
/// in a deterministic round to the operation's own; 0 outside parallel phases. So the
/// backends read it from the log they are handed, never from the running thread.
template <class Entry>
struct undo_list : std::vector<Entry> {
    unsigned pool = 0;
};

/// How slot_allocator::acquire found a slot: what undoing it takes.
enum class slot_source : std::uint8_t {
    appended, // one past the end: the backend grows its arrays (and shrinks them on undo)
    reused,   // a dead slot from the free list
    pooled    // from this worker's pool (parallel phase)
};

/// The slots of one kind of simplex (vertices, or top cells) of a backend: its dead slots
/// waiting to be reused, the per-worker pools of a parallel phase, and the mode. It only
/// picks slot numbers; the backend keeps its arrays and grows, fills and clears them.
/// Every change has an undo that restores the lists exactly when changes are undone
/// newest first, and none allocates once the lists have grown to their working size.
class slot_allocator {
public:
    struct acquired {
        index_t slot;
        slot_source source;
    };

    /// Forgets every dead slot (the backend was rebuilt without any).
    void clear() noexcept { free_.clear(); }

    /// With recycling off, released slots stay dead instead of being handed out again
    /// (the free list is shared state a parallel phase must not touch).
    void set_recycling(bool on) noexcept { recycle_ = on; }

    /// A slot for a new simplex, `slots` being the backend's current slot count: in a
    /// parallel phase from pool `pool` (the operation's log says which), else the newest
    /// dead slot if recycling is on, else `slots` itself (appended: the backend grows).
    acquired acquire(index_t slots, unsigned pool) noexcept {
        if (parallel_) return {pool_.take(pool), slot_source::pooled};
        if (recycle_ && !free_.empty()) {
            const index_t s = free_.back();
            free_.pop_back();
            return {s, slot_source::reused};
        }
        return {slots, slot_source::appended};
    }
    /// Undoes acquire. Returns true if the slot was appended: the backend then drops its
    /// last slot (`slots` is its current slot count, checked to end with this one).
    bool undo_acquire(index_t slot, slot_source source, [[maybe_unused]] index_t slots,
                      unsigned pool) {
        // Capacity is there: the slot came off the same list.
        if (source == slot_source::reused) free_.push_back(slot);
        if (source == slot_source::pooled) pool_.give_back(pool, slot);
        assert(source != slot_source::appended || slot + 1 == slots);
        return source == slot_source::appended;
    }
    /// A slot died. Returns whether it went on the free list (recycling on), which then
    /// needs undo_release.
    bool release(index_t slot) {
        if (!recycle_) return false;
        free_.push_back(slot);
        return true;
    }
    void undo_release([[maybe_unused]] index_t slot) noexcept {
        assert(!free_.empty() && free_.back() == slot);
        free_.pop_back();
    }

    /// Prepares for `workers` concurrent workers: `extra` slots, dead ones first, are
    /// dealt out to their pools, and recycling is off until end_parallel. Returns the
    /// slot count the backend's arrays must grow to (from `slots`, the current one).
    index_t begin_parallel(unsigned workers, index_t slots, index_t extra) {
        recycle_ = false;
        parallel_ = true;
        return pool_.deal(workers, free_, slots, extra);
    }
    /// The same with a quota per worker (a deterministic round: one pool per operation).
    index_t begin_parallel(std::span<const index_t> quotas, index_t slots) {
        recycle_ = false;
        parallel_ = true;
        return pool_.deal(quotas, free_, slots);
    }
    /// Unused pool slots become ordinary recyclable dead slots again.
    void end_parallel() {
        parallel_ = false;
        recycle_ = true;
        pool_.release(free_);
    }
    /// Whether pool `pool` can hand out `n` slots (always, outside a parallel phase).
    bool has_room(index_t n, unsigned pool) const noexcept {
        return !parallel_ || pool_.available(pool) >= n;
    }
    std::size_t available(unsigned worker) const noexcept { return pool_.available(worker); }

    /// The dead slots to reuse, the next one last.
    std::span<const index_t> free_slots() const noexcept { return free_; }
    std::size_t memory_bytes() const noexcept { return free_.capacity() * sizeof(index_t); }

    friend bool operator==(const slot_allocator&, const slot_allocator&) = default;

private:
    std::vector<index_t> free_;
    slot_pool pool_; // per parallel worker, between begin_ and end_parallel
    bool recycle_ = true;
    bool parallel_ = false;
};

} // namespace idas::detail
