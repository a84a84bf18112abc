// Locking policies: how a worker claims the vertices of an operation's region.
#pragma once

#include <idas/core/types.hpp>

#include <atomic>
#include <concepts>
#include <cstdint>
#include <memory>

namespace idas {

/// Owner ids are 1-based worker numbers; 0 means free.
template <class L>
concept lock_policy = requires(L l, index_t v, std::uint32_t owner, std::size_t n) {
    { L::parallel } -> std::convertible_to<bool>;
    {L(n)};
    { l.try_lock(v, owner) } -> std::same_as<bool>;
    {l.unlock(v, owner)};
};

namespace lock {

/// Serial execution: claiming always succeeds and nothing is stored. Compiles to no
/// atomics at all.
struct none {
    static constexpr bool parallel = false;
    explicit none(std::size_t = 0) noexcept {}
    static constexpr bool try_lock(index_t, std::uint32_t) noexcept { return true; }
    static constexpr void unlock(index_t, std::uint32_t) noexcept {}
};

/// One atomic owner word per vertex; a worker claims a vertex by compare-and-swap and
/// gives up (rather than waits) if another worker holds it. Claiming a vertex it
/// already holds succeeds, so overlapping regions need no bookkeeping by the caller.
class vertex_try_lock {
public:
    static constexpr bool parallel = true;
    explicit vertex_try_lock(std::size_t n)
        : owner_(std::make_unique<std::atomic<std::uint32_t>[]>(n))
        , n_(n) {
        for (std::size_t i = 0; i < n; ++i) owner_[i].store(0, std::memory_order_relaxed);
    }
    bool try_lock(index_t v, std::uint32_t me) noexcept {
        std::uint32_t expected = 0;
        if (owner_[v].compare_exchange_strong(expected, me, std::memory_order_acquire,
                                              std::memory_order_relaxed))
            return true;
        return expected == me;
    }
    /// Like try_lock, but tells a fresh claim (1) from one `me` already held (0); -1 if
    /// another worker holds v. Lets callers keep their list of held vertices duplicate-free
    /// without searching it.
    int try_acquire(index_t v, std::uint32_t me) noexcept {
        // A plain load first: re-claims of held vertices (most claims of a tet star) and
        // claims of busy ones then cost no locked instruction. Only `me` writes `me`, so
        // seeing it is proof; a stale 0 just lets the CAS decide.
        const std::uint32_t seen = owner_[v].load(std::memory_order_relaxed);
        if (seen == me) return 0;
        if (seen != 0) return -1;
        std::uint32_t expected = 0;
        if (owner_[v].compare_exchange_strong(expected, me, std::memory_order_acquire,
                                              std::memory_order_relaxed))
            return 1;
        return expected == me ? 0 : -1;
    }
    void unlock(index_t v, std::uint32_t) noexcept {
        owner_[v].store(0, std::memory_order_release);
    }
    std::size_t size() const noexcept { return n_; }

private:
    std::unique_ptr<std::atomic<std::uint32_t>[]> owner_;
    std::size_t n_;
};

/// Owner computes first, then claims. In a first phase each worker runs only the
/// operations whose every claimed vertex lies in its own part: a claim is a plain read of
/// the part map, with no locked instruction and no shared cache line written (on a tet
/// mesh a claim covers dozens of vertices). Vertices a worker creates join its part. The
/// operations that reach into another part wait for a second phase, which claims like
/// vertex_try_lock. Parts are spatially compact, so few operations wait.
class own_part_first : public vertex_try_lock {
public:
    static constexpr bool owner_phase = true;
    using vertex_try_lock::vertex_try_lock;
};

} // namespace lock

/// A lock policy whose runs start with the lock-free owner phase (see own_part_first).
template <class L>
concept owner_phase_lock = lock_policy<L> && requires {
    { L::owner_phase } -> std::convertible_to<bool>;
} && L::owner_phase;

static_assert(lock_policy<lock::none>);
static_assert(lock_policy<lock::vertex_try_lock>);
static_assert(lock_policy<lock::own_part_first> && owner_phase_lock<lock::own_part_first>);
static_assert(!owner_phase_lock<lock::vertex_try_lock>);

} // namespace idas
