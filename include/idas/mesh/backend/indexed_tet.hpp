// The paper's indexed connectivity for tetrahedral meshes: each tet stores its four
// vertices (positively oriented), each vertex the tets incident to it. Adjacency across
// a face is found by searching a vertex star, so there is no adjacency to keep in sync.
#pragma once

#include <idas/core/concepts.hpp>
#include <idas/core/types.hpp>
#include <idas/mesh/backend/slot_pools.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <span>
#include <vector>

namespace idas::backend {

class indexed_tet {
public:
    /// One reversible change. Undone newest-first, so each entry only restores what it
    /// changed itself.
    struct undo_entry {
        enum class what : std::uint8_t {
            tet_set,
            tet_acquired,    // a: tet slot, b: its detail::slot_source
            tet_released,    // a: tet slot, put on the free list
            vertex_acquired, // a: vertex slot, b: its detail::slot_source
            vertex_released, // a: vertex slot, b: 1 if it went on the free list
            vt_insert,
            vt_erase
        };
        what kind;
        index_t a = 0, b = 0, c = 0; // tet or vertex; vt: vertex, tet, position
        tet_indices verts{};
        version_t version = 0;
    };
    using undo_log = detail::undo_list<undo_entry>;

    // A vertex of a good-quality mesh has 20-30 tets; most lists stay inline.
    static constexpr std::size_t inline_tets = 28;
    using tet_list = boost::container::small_vector<index_t, inline_tets>;

    indexed_tet() = default;

    void build(index_t n_vertices, const std::vector<tet_indices>& tets) {
        tv_ = tets;
        version_.assign(tets.size(), 0);
        vt_.assign(n_vertices, {});
        valive_.assign(n_vertices, 1);
        vertex_alloc_.clear(), tet_alloc_.clear();
        for (index_t t = 0; t < tets.size(); ++t)
            for (index_t v : tets[t]) vt_[v].push_back(t);
    }
    void reserve(index_t vertices, index_t tets) {
        tv_.reserve(tets), version_.reserve(tets), vt_.reserve(vertices), valive_.reserve(vertices);
    }

    index_t vertex_slots() const noexcept { return static_cast<index_t>(vt_.size()); }
    index_t tet_slots() const noexcept { return static_cast<index_t>(tv_.size()); }
    bool vertex_alive(index_t v) const noexcept { return valive_[v] != 0; }
    bool tet_alive(index_t t) const noexcept { return tv_[t][0] != invalid_index; }
    const tet_indices& tet_vertices(index_t t) const noexcept { return tv_[t]; }
    version_t tet_version(index_t t) const noexcept { return version_[t]; }
    /// A version read that may race with the tet's owner bumping it: parallel workers use
    /// it to purge stale entries from their queues without holding the tet's locks.
    /// (Versions are written through relaxed atomics, which cost nothing extra on x86.)
    version_t tet_version_relaxed(index_t t) const noexcept {
        return std::atomic_ref<version_t>(const_cast<version_t&>(version_[t]))
            .load(std::memory_order_relaxed);
    }
    std::span<const index_t> vertex_tets(index_t v) const noexcept {
        return {vt_[v].data(), vt_[v].size()};
    }

    /// The tet across local face `lf` (the face opposite local vertex lf) of `t`, or
    /// invalid_index on the boundary.
    index_t opposite_tet(index_t t, std::uint8_t lf) const noexcept {
        const auto& tv = tv_[t];
        const index_t x = tv[(lf + 1) % 4], y = tv[(lf + 2) % 4], z = tv[(lf + 3) % 4];
        for (index_t g : vt_[x]) {
            if (g == t) continue;
            const auto& gv = tv_[g];
            if (contains(gv, y) && contains(gv, z)) return g;
        }
        return invalid_index;
    }

    std::size_t memory_bytes() const noexcept {
        std::size_t bytes = tv_.capacity() * sizeof(tet_indices) +
                            version_.capacity() * sizeof(version_t) +
                            vt_.capacity() * sizeof(tet_list) + valive_.capacity() +
                            tet_alloc_.memory_bytes() + vertex_alloc_.memory_bytes();
        for (const auto& l : vt_)
            if (l.capacity() > inline_tets) bytes += l.capacity() * sizeof(index_t);
        return bytes;
    }

    /// With recycling off, removed slots stay dead instead of being handed out again
    /// (the free lists are shared state a parallel phase must not touch); `consolidate`
    /// reclaims them later.
    void set_slot_recycling(bool on) noexcept {
        vertex_alloc_.set_recycling(on), tet_alloc_.set_recycling(on);
    }

    /// Prepares for `workers` concurrent workers that may add simplices: the arrays grow
    /// once, here, by the given number of dead slots, dealt out to per-worker pools. A
    /// worker's add_* then takes from the pool its undo log names (`log.pool`): no
    /// reallocation, no atomics. Recycling is off until end_parallel.
    void begin_parallel(unsigned workers, index_t extra_vertices, index_t extra_tets) {
        const index_t nv = vertex_alloc_.begin_parallel(workers, vertex_slots(), extra_vertices);
        const index_t nt = tet_alloc_.begin_parallel(workers, tet_slots(), extra_tets);
        grow_to(nv, nt);
    }
    /// The same with a quota per pool: a deterministic round deals one pool per operation.
    void begin_parallel(std::span<const index_t> vertex_quotas,
                        std::span<const index_t> tet_quotas) {
        const index_t nv = vertex_alloc_.begin_parallel(vertex_quotas, vertex_slots());
        const index_t nt = tet_alloc_.begin_parallel(tet_quotas, tet_slots());
        grow_to(nv, nt);
    }
    /// Unused pool slots become ordinary recyclable dead slots again.
    void end_parallel() { vertex_alloc_.end_parallel(), tet_alloc_.end_parallel(); }
    /// Whether slot pool `pool` can serve an operation adding these many simplices.
    bool has_room(index_t vertices, index_t tets, unsigned pool) const noexcept {
        return vertex_alloc_.has_room(vertices, pool) && tet_alloc_.has_room(tets, pool);
    }

    // ---- journaled mutation ----

    // Slots come from detail::slot_allocator (a worker's pool, a dead slot newest first,
    // or appended). A recycled tet slot keeps counting versions, so old tuples to it stay
    // stale.
    index_t add_vertex(undo_log& log) {
        const auto [v, source] = vertex_alloc_.acquire(vertex_slots(), log.pool);
        if (source == detail::slot_source::appended)
            vt_.emplace_back(), valive_.push_back(1);
        else
            valive_[v] = 1;
        log.push_back({undo_entry::what::vertex_acquired, v, index_t(source)});
        return v;
    }
    void remove_vertex(index_t v, undo_log& log) {
        assert(vt_[v].empty());
        valive_[v] = 0;
        log.push_back({undo_entry::what::vertex_released, v, index_t(vertex_alloc_.release(v))});
    }
    index_t add_tet(const tet_indices& t, undo_log& log) {
        const auto [id, source] = tet_alloc_.acquire(tet_slots(), log.pool);
        log.push_back({undo_entry::what::tet_acquired, id, index_t(source)});
        if (source == detail::slot_source::appended) {
            tv_.push_back(t);
            version_.push_back(0);
        } else {
            save_tet(id, log);
            tv_[id] = t;
            bump_version(id);
        }
        for (index_t v : t) vt_insert(v, id, log);
        return id;
    }
    void remove_tet(index_t t, undo_log& log) {
        save_tet(t, log);
        for (index_t v : tv_[t]) vt_erase(v, t, log);
        tv_[t] = {invalid_index, invalid_index, invalid_index, invalid_index};
        bump_version(t);
        if (tet_alloc_.release(t)) log.push_back({undo_entry::what::tet_released, t});
    }
    /// Rewrites a tet in place (same slot, new version).
    void set_tet(index_t t, const tet_indices& nv, undo_log& log) {
        save_tet(t, log);
        const tet_indices old = tv_[t];
        for (index_t v : old)
            if (!contains(nv, v)) vt_erase(v, t, log);
        for (index_t v : nv)
            if (!contains(old, v)) vt_insert(v, t, log);
        tv_[t] = nv;
        bump_version(t);
    }
    /// Marks a tet changed (a vertex moved) so tuples made before go stale.
    void touch_tet(index_t t, undo_log& log) {
        save_tet(t, log);
        bump_version(t);
    }

    void rollback(undo_log& log, std::size_t mark) {
        using w = undo_entry::what;
        while (log.size() > mark) {
            const undo_entry e = log.back();
            log.pop_back();
            switch (e.kind) {
            case w::tet_set:
                tv_[e.a] = e.verts, set_version(e.a, e.version);
                break;
            case w::tet_acquired:
                if (tet_alloc_.undo_acquire(e.a, detail::slot_source(e.b), tet_slots(), log.pool))
                    tv_.pop_back(), version_.pop_back();
                break;
            case w::tet_released:
                tet_alloc_.undo_release(e.a);
                break;
            case w::vertex_acquired:
                if (vertex_alloc_.undo_acquire(e.a, detail::slot_source(e.b), vertex_slots(),
                                               log.pool))
                    vt_.pop_back(), valive_.pop_back();
                else
                    valive_[e.a] = 0;
                break;
            case w::vertex_released:
                valive_[e.a] = 1;
                if (e.b) vertex_alloc_.undo_release(e.a);
                break;
            case w::vt_insert:
                assert(!vt_[e.a].empty() && vt_[e.a].back() == e.b);
                vt_[e.a].pop_back();
                break;
            case w::vt_erase:
                vt_[e.a].insert(vt_[e.a].begin() + e.c, e.b);
                break;
            }
        }
    }

    friend bool operator==(const indexed_tet& x, const indexed_tet& y) {
        return x.tv_ == y.tv_ && x.version_ == y.version_ && x.valive_ == y.valive_ &&
               x.vt_ == y.vt_ && x.tet_alloc_ == y.tet_alloc_ && x.vertex_alloc_ == y.vertex_alloc_;
    }

private:
    /// The arrays grow to the slot counts the pools were dealt from.
    void grow_to(index_t nv, index_t nt) {
        detail::grow_prefaulted(vt_, nv, {});
        valive_.resize(nv, 0);
        detail::grow_prefaulted(tv_, nt,
                                {invalid_index, invalid_index, invalid_index, invalid_index});
        detail::grow_prefaulted(version_, nt, version_t{0});
    }

    static bool contains(const tet_indices& t, index_t v) noexcept {
        return t[0] == v || t[1] == v || t[2] == v || t[3] == v;
    }
    void set_version(index_t t, version_t v) noexcept {
        std::atomic_ref<version_t>(version_[t]).store(v, std::memory_order_relaxed);
    }
    void bump_version(index_t t) noexcept { set_version(t, version_[t] + 1); }
    void save_tet(index_t t, undo_log& log) {
        log.push_back({undo_entry::what::tet_set, t, 0, 0, tv_[t], version_[t]});
    }
    void vt_insert(index_t v, index_t t, undo_log& log) {
        vt_[v].push_back(t);
        log.push_back({undo_entry::what::vt_insert, v, t});
    }
    void vt_erase(index_t v, index_t t, undo_log& log) {
        auto& l = vt_[v];
        auto it = std::find(l.begin(), l.end(), t);
        assert(it != l.end());
        const auto pos = static_cast<index_t>(it - l.begin());
        l.erase(it); // order-preserving, so the undo restores the list exactly
        log.push_back({undo_entry::what::vt_erase, v, t, pos});
    }

    std::vector<tet_indices> tv_;
    std::vector<version_t> version_;
    std::vector<tet_list> vt_;
    std::vector<std::uint8_t> valive_;
    detail::slot_allocator vertex_alloc_, tet_alloc_;
};

static_assert(tet_connectivity<indexed_tet>);

} // namespace idas::backend
