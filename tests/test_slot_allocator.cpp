// detail::slot_allocator: the slot bookkeeping every backend delegates to. Each undo must
// restore the free list and the pools exactly when undone newest first.
#include <idas/mesh/backend/slot_pools.hpp>

#include <doctest/doctest.h>

#include <array>
#include <span>
#include <vector>

using idas::index_t;
using idas::detail::slot_allocator;
using idas::detail::slot_source;

namespace {
std::vector<index_t> free_list(const slot_allocator& a) {
    return {a.free_slots().begin(), a.free_slots().end()};
}
} // namespace

TEST_CASE("slot allocator: serial append, release, reuse newest first, undo") {
    slot_allocator a;
    auto x = a.acquire(5, 0);
    CHECK(x.slot == 5);
    CHECK(x.source == slot_source::appended);
    CHECK(a.release(2));
    CHECK(a.release(4));
    CHECK(free_list(a) == std::vector<index_t>{2, 4});
    const slot_allocator before = a;

    x = a.acquire(6, 0);
    CHECK(x.slot == 4); // the most recently freed
    CHECK(x.source == slot_source::reused);
    const auto y = a.acquire(6, 0);
    CHECK(y.slot == 2);
    const auto z = a.acquire(6, 0);
    CHECK(z.slot == 6);
    CHECK(z.source == slot_source::appended);
    CHECK(free_list(a).empty());
    CHECK(a.release(4));
    // Undo newest first.
    a.undo_release(4);
    CHECK(a.undo_acquire(z.slot, z.source, 7, 0)); // appended: the caller drops slot 6
    CHECK(!a.undo_acquire(y.slot, y.source, 6, 0));
    CHECK(free_list(a) == std::vector<index_t>{2});
    CHECK(!a.undo_acquire(x.slot, x.source, 6, 0));
    CHECK(a == before);

    // Without recycling, released slots stay dead and dead slots are not reused.
    a.set_recycling(false);
    CHECK(!a.release(7));
    CHECK(a.acquire(9, 0).slot == 9);
    CHECK(free_list(a) == std::vector<index_t>{2, 4});
    a.set_recycling(true);
    CHECK(a.acquire(9, 0).slot == 4);
    a.clear();
    CHECK(free_list(a).empty());
    CHECK(a.acquire(9, 0).source == slot_source::appended);
}

TEST_CASE("slot allocator: parallel pools take dead slots first, undo, end_parallel") {
    slot_allocator a;
    CHECK(a.release(3));
    CHECK(a.release(7));
    CHECK(a.release(1));
    // 10 slots exist; 6 extra: the 3 dead ones, then 10, 11, 12; dealt in sorted
    // contiguous blocks: worker 0 gets {1, 3, 7}, worker 1 gets {10, 11, 12}.
    CHECK(a.begin_parallel(2, 10, 6) == 13);
    CHECK(free_list(a).empty());
    CHECK(a.available(0) == 3);
    CHECK(a.available(1) == 3);

    // Worker 1's operations name pool 1 (their undo log's `pool`).
    CHECK(a.has_room(3, 1));
    CHECK(!a.has_room(4, 1));
    const auto p = a.acquire(13, 1);
    CHECK(p.slot == 10); // ascending within a worker
    CHECK(p.source == slot_source::pooled);
    const auto q = a.acquire(13, 1);
    CHECK(q.slot == 11);
    CHECK(!a.release(11)); // recycling is off in a parallel phase
    CHECK(a.available(1) == 1);
    CHECK(!a.undo_acquire(q.slot, q.source, 13, 1));
    CHECK(a.available(1) == 2);
    CHECK(a.acquire(13, 1).slot == 11); // given back where it was taken

    CHECK(a.acquire(13, 0).slot == 1);
    CHECK(a.available(0) == 2);

    // Unused slots become dead slots, recycled again.
    a.end_parallel();
    CHECK(free_list(a) == std::vector<index_t>{3, 7, 12});
    const auto r = a.acquire(13, 0);
    CHECK(r.slot == 12);
    CHECK(r.source == slot_source::reused);
    CHECK(a.has_room(1000, 0)); // serial: no limit
}

TEST_CASE("slot allocator: quota pools, one per operation, dealt in order") {
    // A deterministic round deals one pool per winning operation, sized by what it may
    // add: dead slots first (ascending), then new ones, in pool order.
    slot_allocator a;
    CHECK(a.release(7));
    CHECK(a.release(3));
    const std::vector<index_t> quotas{2, 0, 3};
    CHECK(a.begin_parallel(std::span<const index_t>(quotas), 10) == 13);
    CHECK(free_list(a).empty());
    CHECK(a.available(0) == 2);
    CHECK(a.available(1) == 0);
    CHECK(a.available(2) == 3);
    CHECK(a.acquire(13, 0).slot == 3);
    CHECK(a.acquire(13, 0).slot == 7);
    CHECK_FALSE(a.has_room(1, 0));
    const auto x = a.acquire(13, 2);
    CHECK(x.slot == 10);
    CHECK(x.source == slot_source::pooled);
    CHECK_FALSE(a.undo_acquire(x.slot, x.source, 13, 2)); // back to its pool
    CHECK(a.available(2) == 3);
    CHECK(a.acquire(13, 2).slot == 10);
    a.end_parallel();
    CHECK(free_list(a) == std::vector<index_t>{11, 12}); // the unused, as dead slots
}

TEST_CASE("grow_prefaulted: old values kept, new ones made, past a megabyte and below") {
    // Past a megabyte the fresh pages are touched by several threads before the elements
    // are made; below it, a plain resize. Either way: a resize's result.
    for (const std::size_t n : {std::size_t{3000}, std::size_t{300000}}) {
        std::vector<std::array<index_t, 4>> v(1000);
        for (std::size_t i = 0; i < v.size(); ++i) v[i] = {index_t(i), 1, 2, 3};
        idas::detail::grow_prefaulted(v, n, {7, 7, 7, 7});
        REQUIRE(v.size() == n);
        for (std::size_t i = 0; i < 1000; ++i)
            REQUIRE(v[i] == std::array<index_t, 4>{index_t(i), 1, 2, 3});
        for (std::size_t i = 1000; i < n; ++i) REQUIRE(v[i] == std::array<index_t, 4>{7, 7, 7, 7});
        idas::detail::grow_prefaulted(v, 10, {0, 0, 0, 0}); // never shrinks
        CHECK(v.size() == n);
    }
    // Elements that own memory: the old ones are moved, the new ones copies of the value.
    std::vector<std::vector<index_t>> lists(100, std::vector<index_t>{1, 2});
    idas::detail::grow_prefaulted(lists, 100000, std::vector<index_t>{9});
    REQUIRE(lists.size() == 100000);
    CHECK(lists[99] == std::vector<index_t>{1, 2});
    CHECK(lists[100] == std::vector<index_t>{9});
    CHECK(lists.back() == std::vector<index_t>{9});
}
