// Slots for simplices created by parallel workers. Each worker takes new vertex and cell
// slots from its own pool, so adding a simplex needs no reallocation and no atomics. The
// pools are filled before the workers start: first with the backend's dead slots, then,
// only if those are too few, with slots past the end of its arrays. Executor passes that
// run one after another then reuse the same slots instead of growing the arrays each time.
#pragma once

#include <idas/core/types.hpp>

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <vector>

namespace idas::detail {

/// Per-worker pools of one kind of slot (vertices, or top cells).
class slot_pool {
public:
    /// Deals `wanted` slots to `workers` pools. Dead slots come first, taken from the back
    /// of `free` (most recently freed); the rest are new slots numbered from `slots` up.
    /// Returns the slot count the backend's arrays must be resized to.
    index_t deal(unsigned workers, std::vector<index_t>& free, index_t slots, index_t wanted) {
        pools_.assign(workers, {});
        const std::size_t reused = std::min<std::size_t>(free.size(), wanted);
        std::vector<index_t> dealt(free.end() - std::ptrdiff_t(reused), free.end());
        free.resize(free.size() - reused);
        for (index_t s = slots; dealt.size() < wanted; ++s) dealt.push_back(s);
        std::sort(dealt.begin(), dealt.end());
        // Contiguous blocks, pushed in reverse so each worker hands out ascending slots.
        for (unsigned w = 0; w < workers; ++w) {
            const std::size_t b = dealt.size() * w / workers, e = dealt.size() * (w + 1) / workers;
            auto& p = pools_[w];
            p.reserve(e - b);
            for (std::size_t i = e; i-- > b;) p.push_back(dealt[i]);
        }
        return static_cast<index_t>(
            std::max<std::size_t>(slots, dealt.empty() ? 0 : std::size_t(dealt.back()) + 1));
    }
    std::size_t available(unsigned worker) const noexcept { return pools_[worker].size(); }
    index_t take(unsigned worker) noexcept {
        auto& p = pools_[worker];
        assert(!p.empty());
        const index_t s = p.back();
        p.pop_back();
        return s;
    }
    /// Undoing a take.
    void give_back(unsigned worker, index_t s) { pools_[worker].push_back(s); }
    /// Unused slots become the backend's dead slots again.
    void release(std::vector<index_t>& free) {
        for (auto& p : pools_) free.insert(free.end(), p.rbegin(), p.rend());
        pools_.clear();
    }
    friend bool operator==(const slot_pool&, const slot_pool&) = default;

private:
    std::vector<std::vector<index_t>> pools_;
};

} // namespace idas::detail
