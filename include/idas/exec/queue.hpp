// Scheduler queue policies. A queue holds plain entries (priority, tuple, operation
// kind); lower priority values are processed first.
#pragma once

#include <idas/core/tuple.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <concepts>
#include <cstdint>
#include <ranges>
#include <span>
#include <vector>

namespace idas {

template <class Tuple>
struct queue_entry {
    double priority;
    Tuple tuple;
    std::uint8_t kind;    // operation kind id: dispatched by a compile-time fold
    std::uint8_t retries; // failed lock attempts so far
};

/// The whole tuple as two words, for breaking priority ties: entries with equal keys are
/// equal (a tuple's vertex and version count too, so no two different entries tie).
constexpr auto tie_key(const tri_tuple& t) noexcept {
    return std::array<std::uint64_t, 2>{std::uint64_t(t.fid) << 8 | t.local_edge,
                                        std::uint64_t(t.vid) << 32 | t.version};
}
constexpr auto tie_key(const tet_tuple& t) noexcept {
    return std::array<std::uint64_t, 2>{std::uint64_t(t.tid) << 8 | t.local_edge << 4 |
                                            t.local_face,
                                        std::uint64_t(t.vid) << 32 | t.version};
}

/// A mix of a tie key (splitmix64's finaliser).
constexpr std::uint64_t tie_hash(const std::array<std::uint64_t, 2>& k) noexcept {
    std::uint64_t x = k[0] * 0x9e3779b97f4a7c15ULL ^ k[1];
    x ^= x >> 30, x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27, x *= 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

/// Whether entries of type E take equal priorities in tie-hash order, spread over the
/// mesh, rather than by slot. Equal priorities are common (every edge of a flat region
/// costs 0 in QSlim). By slot they are taken in sweeps through neighbouring cells, which
/// the cache likes: QSlim to 10% of armadillo x4 runs 13% faster than in hash order
/// (bench/RESULTS.md, "Executor refactoring (issue 15)", session 19). Spread, a
/// deterministic round finds more of them that do not overlap, so its engine's entries
/// say `spreads_ties`.
template <class E>
inline constexpr bool spreads_ties = requires {
    requires E::spreads_ties;
};

/// How `pops_before` orders entries of equal priority: by tie key (spreads_ties: by its
/// hash first), then kind.
template <class E>
constexpr bool tie_pops_before(const E& a, const E& b) noexcept {
    const auto ka = tie_key(a.tuple), kb = tie_key(b.tuple);
    if (ka != kb) {
        if constexpr (spreads_ties<E>) {
            const std::uint64_t ha = tie_hash(ka), hb = tie_hash(kb);
            if (ha != hb) return ha < hb;
        }
        return ka < kb;
    }
    return a.kind < b.kind;
}

/// The order every priority queue pops in: priority, then the tie-break above. Only
/// identical entries compare equal, so the sequence of pops depends on what was pushed, not
/// on the order of the pushes (what lets a deterministic run merge the pushes of its threads
/// in any order). Forced inline into the heaps' loops; the tie-break, rarer, is not.
template <class E>
IDAS_ALWAYS_INLINE constexpr bool pops_before(const E& a, const E& b) noexcept {
    if (a.priority != b.priority) return a.priority < b.priority;
    return tie_pops_before(a, b);
}

/// A range whose elements are queue entries of type E: what `push_all` takes (a span, or
/// the executor's seeds joined from the blocks they were found in, without a copy).
template <class R, class E>
concept entries_of = std::ranges::input_range<R> && requires(std::ranges::range_reference_t<R> e) {
    { e } -> std::convertible_to<const E&>;
};

namespace detail {
/// Appends a range of entries to a queue's storage, in one copy where the range allows.
template <class E, class R>
void append(std::vector<E>& to, R& es) {
    if constexpr (std::ranges::common_range<R> && std::ranges::forward_range<R>)
        to.insert(to.end(), std::ranges::begin(es), std::ranges::end(es));
    else
        for (const E& e : es) to.push_back(e);
}
} // namespace detail

template <class Q, class E>
concept queue_for = std::default_initializable<Q> && requires(Q q, const E& e, E& out) {
    {q.push(e)};
    { q.pop(out) } -> std::same_as<bool>;
    { q.size() } -> std::convertible_to<std::size_t>;
    {q.clear()};
    {q.reserve(std::size_t{})};
    // The executor sweeps stale entries out of large queues.
    {q.erase_if([](const E&) { return false; })};
};

/// A queue policy names a family of queues, one per entry type.
template <class P, class E>
concept queue_policy = queue_for<typename P::template type<E>, E>;

/// Whether a queue policy pops in `pops_before` order (so its pops depend only on what
/// was pushed). Policies say so with `priority_order`; one that does not is not trusted.
template <class P>
inline constexpr bool pops_in_priority_order = requires {
    requires P::priority_order;
};

namespace queue {

/// Binary min-heap on a vector: O(log n) push and pop, no allocation once reserved.
struct binary_heap {
    static constexpr bool priority_order = true;
    template <class E>
    class type {
    public:
        void push(const E& e) {
            heap_.push_back(e);
            std::push_heap(heap_.begin(), heap_.end(), later);
        }
        /// Many pushes at once: one linear heap build instead of a sift per entry. The
        /// pops are the same (see pops_before).
        template <entries_of<E> R>
        void push_all(R&& es) {
            idas::detail::append(heap_, es);
            std::make_heap(heap_.begin(), heap_.end(), later);
        }
        bool pop(E& out) {
            if (heap_.empty()) return false;
            std::pop_heap(heap_.begin(), heap_.end(), later);
            out = heap_.back();
            heap_.pop_back();
            return true;
        }
        /// The entry `pop` would give; the queue must not be empty.
        const E& top() const noexcept { return heap_.front(); }
        std::size_t size() const noexcept { return heap_.size(); }
        void clear() noexcept { heap_.clear(); }
        void reserve(std::size_t n) { heap_.reserve(n); }
        /// Drops entries for which `stale(e)` holds, then re-heapifies.
        template <class Pred>
        void erase_if(Pred&& stale) {
            std::erase_if(heap_, stale);
            std::make_heap(heap_.begin(), heap_.end(), later);
        }

    private:
        // Ties are broken by tuple and kind, so runs are deterministic whatever the heap does.
        static bool later(const E& a, const E& b) noexcept { return pops_before(b, a); }
        std::vector<E> heap_;
    };
};

/// D-ary min-heap: a shallower tree whose children share cache lines, so a pop walks
/// log_D(n) levels instead of log_2(n) and misses the cache less on large queues.
template <unsigned D = 4>
struct dary_heap {
    static constexpr bool priority_order = true;
    static_assert(D >= 2);
    template <class E>
    class type {
    public:
        [[gnu::flatten]] void push(const E& e) {
            std::size_t i = heap_.size();
            heap_.push_back(e);
            while (i > 0) {
                const std::size_t parent = (i - 1) / D;
                if (!earlier(e, heap_[parent])) break;
                heap_[i] = heap_[parent];
                i = parent;
            }
            heap_[i] = e;
        }
        /// Many pushes at once, as binary_heap's.
        template <entries_of<E> R>
        void push_all(R&& es) {
            idas::detail::append(heap_, es);
            heapify();
        }
        IDAS_ALWAYS_INLINE bool pop(E& out) {
            if (heap_.empty()) return false;
            out = heap_.front();
            const E last = heap_.back();
            heap_.pop_back();
            if (!heap_.empty()) sift_down(0, last);
            return true;
        }
        std::size_t size() const noexcept { return heap_.size(); }
        void clear() noexcept { heap_.clear(); }
        void reserve(std::size_t n) { heap_.reserve(n); }
        template <class Pred>
        void erase_if(Pred&& stale) {
            std::erase_if(heap_, stale);
            heapify();
        }

    private:
        void heapify() {
            if (heap_.size() < 2) return;
            for (std::size_t i = (heap_.size() - 2) / D + 1; i-- > 0;) sift_down(i, heap_[i]);
        }
        void sift_down(std::size_t i, const E e) {
            const std::size_t n = heap_.size();
            for (;;) {
                const std::size_t first = D * i + 1;
                if (first >= n) break;
                const std::size_t end = std::min(first + D, n);
                std::size_t best = first;
                for (std::size_t c = first + 1; c < end; ++c)
                    if (earlier(heap_[c], heap_[best])) best = c;
                if (!earlier(heap_[best], e)) break;
                heap_[i] = heap_[best];
                i = best;
            }
            heap_[i] = e;
        }
        static bool earlier(const E& a, const E& b) noexcept { return pops_before(a, b); }
        std::vector<E> heap_;
    };
};

/// FIFO with no priorities: for schedules where order does not matter (e.g. flips to
/// convergence). O(1) push and pop.
struct fifo {
    static constexpr bool priority_order = false; // pops follow pushes
    template <class E>
    class type {
    public:
        void push(const E& e) { items_.push_back(e); }
        template <entries_of<E> R>
        void push_all(R&& es) {
            idas::detail::append(items_, es);
        }
        bool pop(E& out) {
            if (head_ == items_.size()) {
                items_.clear(), head_ = 0;
                return false;
            }
            out = items_[head_++];
            if (head_ == items_.size()) items_.clear(), head_ = 0;
            return true;
        }
        /// The last entry pushed (for a thief: the farthest from what the owner pops).
        bool pop_back(E& out) {
            if (head_ == items_.size()) return false;
            out = items_.back();
            items_.pop_back();
            if (head_ == items_.size()) items_.clear(), head_ = 0;
            return true;
        }
        std::size_t size() const noexcept { return items_.size() - head_; }
        void clear() noexcept { items_.clear(), head_ = 0; }
        void reserve(std::size_t n) { items_.reserve(n); }
        template <class Pred>
        void erase_if(Pred&& stale) {
            items_.erase(items_.begin(), items_.begin() + static_cast<std::ptrdiff_t>(head_));
            head_ = 0;
            std::erase_if(items_, stale);
        }

    private:
        std::vector<E> items_;
        std::size_t head_ = 0;
    };
};

/// Bucketed heap: the priority's IEEE bits, mapped to an unsigned key in the same order,
/// pick one of 2^Bits buckets by their leading bits (sign, exponent and Bits - 12 mantissa
/// bits: an order-preserving radix split into 2^(Bits - 12) ranges per octave); each
/// bucket is a binary heap and pops come from the lowest non-empty bucket, found with a
/// two-level bitmap. Pops come out in exactly the order of binary_heap, but a pop sifts
/// through one small bucket, and decimation's pops and most of its pushes stay in the
/// few low buckets, which stay in cache. Costs 2^Bits empty vectors per queue.
template <unsigned Bits = 16>
struct bucket_heap {
    static constexpr bool priority_order = true;
    static_assert(Bits >= 12 && Bits <= 18); // the bitmap lives inside the queue
    template <class E>
    class type {
    public:
        static constexpr std::size_t buckets = std::size_t{1} << Bits;

        void push(const E& e) {
            const std::size_t b = bucket_of(e.priority);
            if (buckets_.empty()) buckets_.resize(buckets);
            auto& h = buckets_[b];
            h.push_back(e);
            std::push_heap(h.begin(), h.end(), later);
            if (h.size() == 1) mark(b);
            lowest_ = std::min(lowest_, b);
            ++size_;
        }
        bool pop(E& out) {
            if (size_ == 0) return false;
            auto& h = buckets_[lowest_];
            std::pop_heap(h.begin(), h.end(), later);
            out = h.back();
            h.pop_back();
            --size_;
            if (h.empty()) {
                unmark(lowest_);
                lowest_ = next_marked(lowest_);
            }
            return true;
        }
        std::size_t size() const noexcept { return size_; }
        void clear() noexcept {
            for (std::size_t b = next_marked(0); b < buckets; b = next_marked(b + 1)) {
                buckets_[b].clear();
                unmark(b);
            }
            size_ = 0, lowest_ = buckets;
        }
        /// The buckets' sizes are not known in advance; they grow as needed.
        void reserve(std::size_t) {}
        template <class Pred>
        void erase_if(Pred&& stale) {
            for (std::size_t b = next_marked(0); b < buckets; b = next_marked(b + 1)) {
                auto& h = buckets_[b];
                size_ -= std::erase_if(h, stale);
                if (h.empty())
                    unmark(b);
                else
                    std::make_heap(h.begin(), h.end(), later);
            }
            lowest_ = next_marked(0);
        }

    private:
        /// Order-preserving map of a double to a bucket (NaNs go to the ends).
        static std::size_t bucket_of(double p) noexcept {
            if (p == 0) p = 0; // -0.0 equals +0.0 for the heaps, so it must share its bucket
            const auto u = std::bit_cast<std::uint64_t>(p);
            const std::uint64_t key = (u >> 63) ? ~u : (u | (std::uint64_t{1} << 63));
            return static_cast<std::size_t>(key >> (64 - Bits));
        }
        void mark(std::size_t b) noexcept {
            words_[b / 64] |= std::uint64_t{1} << (b % 64);
            summary_[b / 4096] |= std::uint64_t{1} << (b / 64 % 64);
        }
        void unmark(std::size_t b) noexcept {
            words_[b / 64] &= ~(std::uint64_t{1} << (b % 64));
            if (words_[b / 64] == 0) summary_[b / 4096] &= ~(std::uint64_t{1} << (b / 64 % 64));
        }
        /// The first non-empty bucket at or after b, or `buckets` if there is none.
        std::size_t next_marked(std::size_t b) const noexcept {
            if (b >= buckets) return buckets;
            std::size_t w = b / 64;
            if (const std::uint64_t bits = words_[w] & (~std::uint64_t{0} << (b % 64)))
                return w * 64 + static_cast<std::size_t>(std::countr_zero(bits));
            ++w; // search the summary for the next non-empty word
            for (std::size_t s = w / 64; s < summary_.size(); ++s) {
                std::uint64_t bits = summary_[s];
                if (s == w / 64) bits &= ~std::uint64_t{0} << (w % 64);
                if (bits) {
                    const std::size_t word =
                        s * 64 + static_cast<std::size_t>(std::countr_zero(bits));
                    return word * 64 + static_cast<std::size_t>(std::countr_zero(words_[word]));
                }
            }
            return buckets;
        }
        static bool later(const E& a, const E& b) noexcept { return pops_before(b, a); }
        std::vector<std::vector<E>> buckets_; // allocated on the first push
        std::array<std::uint64_t, buckets / 64> words_{};
        std::array<std::uint64_t, (buckets / 64 + 63) / 64> summary_{};
        std::size_t size_ = 0, lowest_ = buckets;
    };
};

} // namespace queue

static_assert(queue_policy<queue::binary_heap, queue_entry<tri_tuple>>);
static_assert(queue_policy<queue::dary_heap<4>, queue_entry<tri_tuple>>);
static_assert(queue_policy<queue::fifo, queue_entry<tri_tuple>>);
static_assert(queue_policy<queue::bucket_heap<>, queue_entry<tri_tuple>>);
static_assert(pops_in_priority_order<queue::binary_heap> &&
              pops_in_priority_order<queue::dary_heap<>> &&
              pops_in_priority_order<queue::bucket_heap<>> && !pops_in_priority_order<queue::fifo>);

} // namespace idas
