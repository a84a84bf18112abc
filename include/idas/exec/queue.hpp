// Scheduler queue policies. A queue holds plain entries (priority, tuple, operation
// kind); lower priority values are processed first.
#pragma once

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <vector>

namespace idas {

template <class Tuple>
struct queue_entry {
    double priority;
    Tuple tuple;
    std::uint8_t kind;    // operation kind id: dispatched by a compile-time fold
    std::uint8_t retries; // failed lock attempts so far
};

template <class Q, class E>
concept queue_for = std::default_initializable<Q> && requires(Q q, const E& e, E& out) {
    {q.push(e)};
    { q.pop(out) } -> std::same_as<bool>;
    { q.size() } -> std::convertible_to<std::size_t>;
    {q.clear()};
    {q.reserve(std::size_t{})};
};

/// A queue policy names a family of queues, one per entry type.
template <class P, class E>
concept queue_policy = queue_for<typename P::template type<E>, E>;

namespace queue {

/// Binary min-heap on a vector: O(log n) push and pop, no allocation once reserved.
struct binary_heap {
    template <class E>
    class type {
    public:
        void push(const E& e) {
            heap_.push_back(e);
            std::push_heap(heap_.begin(), heap_.end(), later);
        }
        bool pop(E& out) {
            if (heap_.empty()) return false;
            std::pop_heap(heap_.begin(), heap_.end(), later);
            out = heap_.back();
            heap_.pop_back();
            return true;
        }
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
        // Ties are broken by tuple, so runs are deterministic whatever the heap does.
        static bool later(const E& a, const E& b) noexcept {
            if (a.priority != b.priority) return a.priority > b.priority;
            if (a.tuple.fid != b.tuple.fid) return a.tuple.fid > b.tuple.fid;
            return a.tuple.local_edge > b.tuple.local_edge;
        }
        std::vector<E> heap_;
    };
};

/// D-ary min-heap: a shallower tree whose children share cache lines, so a pop walks
/// log_D(n) levels instead of log_2(n) and misses the cache less on large queues.
template <unsigned D = 4>
struct dary_heap {
    static_assert(D >= 2);
    template <class E>
    class type {
    public:
        void push(const E& e) {
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
        bool pop(E& out) {
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
            if (heap_.size() < 2) return;
            for (std::size_t i = (heap_.size() - 2) / D + 1; i-- > 0;) sift_down(i, heap_[i]);
        }

    private:
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
        static bool earlier(const E& a, const E& b) noexcept {
            if (a.priority != b.priority) return a.priority < b.priority;
            if (a.tuple.fid != b.tuple.fid) return a.tuple.fid < b.tuple.fid;
            return a.tuple.local_edge < b.tuple.local_edge;
        }
        std::vector<E> heap_;
    };
};

/// FIFO with no priorities: for schedules where order does not matter (e.g. flips to
/// convergence). O(1) push and pop.
struct fifo {
    template <class E>
    class type {
    public:
        void push(const E& e) { items_.push_back(e); }
        bool pop(E& out) {
            if (head_ == items_.size()) {
                items_.clear(), head_ = 0;
                return false;
            }
            out = items_[head_++];
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

} // namespace queue

} // namespace idas
