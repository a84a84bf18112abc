// The paper's indexed connectivity for triangle meshes: each face stores its three
// vertices, each vertex the faces incident to it. switch_face searches a vertex star.
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

class indexed_tri {
public:
    /// One reversible change. Undone newest-first, so each entry only has to restore
    /// what it changed itself.
    struct undo_entry {
        enum class what : std::uint8_t {
            face_set,
            face_acquired,   // a: face slot, b: its detail::slot_source
            face_released,   // a: face slot, put on the free list
            vertex_acquired, // a: vertex slot, b: its detail::slot_source
            vertex_released, // a: vertex slot, b: 1 if it went on the free list
            vf_insert,
            vf_erase
        };
        what kind;
        index_t a = 0, b = 0, c = 0; // face or vertex; vf: vertex, face, position
        tri_indices verts{};
        version_t version = 0;
    };
    using undo_log = detail::undo_list<undo_entry>;

    // Inline capacity covers the valences met in practice (a regular vertex has 6), so
    // incidence lists rarely touch the heap.
    using face_list = boost::container::small_vector<index_t, 10>;

    indexed_tri() = default;

    void build(index_t n_vertices, const std::vector<tri_indices>& faces) {
        fv_ = faces;
        version_.assign(faces.size(), 0);
        vf_.assign(n_vertices, {});
        valive_.assign(n_vertices, 1);
        vertex_alloc_.clear(), face_alloc_.clear();
        for (index_t f = 0; f < faces.size(); ++f)
            for (index_t v : faces[f]) vf_[v].push_back(f);
    }
    void reserve(index_t vertices, index_t faces) {
        fv_.reserve(faces), version_.reserve(faces), vf_.reserve(vertices),
            valive_.reserve(vertices);
    }

    index_t vertex_slots() const noexcept { return static_cast<index_t>(vf_.size()); }
    index_t face_slots() const noexcept { return static_cast<index_t>(fv_.size()); }
    bool vertex_alive(index_t v) const noexcept { return valive_[v] != 0; }
    bool face_alive(index_t f) const noexcept { return fv_[f][0] != invalid_index; }
    const tri_indices& face_vertices(index_t f) const noexcept { return fv_[f]; }
    version_t face_version(index_t f) const noexcept { return version_[f]; }
    /// A version read that may race with the face's owner bumping it: parallel workers
    /// use it to purge stale entries from their queues without holding the face's locks.
    /// (Versions are written through relaxed atomics, which cost nothing extra on x86.)
    version_t face_version_relaxed(index_t f) const noexcept {
        return std::atomic_ref<version_t>(const_cast<version_t&>(version_[f]))
            .load(std::memory_order_relaxed);
    }
    std::span<const index_t> vertex_faces(index_t v) const noexcept {
        return {vf_[v].data(), vf_[v].size()};
    }

    /// The face across local edge `le` of `f`, or invalid_index on the boundary.
    IDAS_ALWAYS_INLINE index_t opposite_face(index_t f, std::uint8_t le) const noexcept {
        const index_t x = fv_[f][(le + 1) % 3], y = fv_[f][(le + 2) % 3];
        for (index_t g : vf_[x]) {
            if (g == f) continue;
            const auto& gv = fv_[g];
            if (gv[0] == y || gv[1] == y || gv[2] == y) return g;
        }
        return invalid_index;
    }

    std::size_t memory_bytes() const noexcept {
        std::size_t bytes = fv_.capacity() * sizeof(tri_indices) +
                            version_.capacity() * sizeof(version_t) +
                            vf_.capacity() * sizeof(face_list) + valive_.capacity();
        for (const auto& l : vf_)
            if (l.capacity() > 10) bytes += l.capacity() * sizeof(index_t);
        return bytes;
    }

    /// Parallel workers share this backend, so while they run, removed slots are not
    /// recycled (the free lists would be shared state); `consolidate` reclaims them later.
    void set_slot_recycling(bool on) noexcept {
        vertex_alloc_.set_recycling(on), face_alloc_.set_recycling(on);
    }

    /// Prepares for `workers` concurrent workers that may add simplices: the arrays grow
    /// once, here, by the given number of dead slots, which are dealt out to per-worker
    /// pools. An add_* then takes from the pool its undo log names (`log.pool`): no
    /// reallocation, no atomics. Recycling is off until end_parallel.
    void begin_parallel(unsigned workers, index_t extra_vertices, index_t extra_faces) {
        const index_t nv = vertex_alloc_.begin_parallel(workers, vertex_slots(), extra_vertices);
        const index_t nf = face_alloc_.begin_parallel(workers, face_slots(), extra_faces);
        grow_to(nv, nf);
    }
    /// The same with a quota per pool: a deterministic round deals one pool per operation.
    void begin_parallel(std::span<const index_t> vertex_quotas,
                        std::span<const index_t> face_quotas) {
        const index_t nv = vertex_alloc_.begin_parallel(vertex_quotas, vertex_slots());
        const index_t nf = face_alloc_.begin_parallel(face_quotas, face_slots());
        grow_to(nv, nf);
    }
    /// Unused pool slots become ordinary recyclable dead slots again.
    void end_parallel() { vertex_alloc_.end_parallel(), face_alloc_.end_parallel(); }
    /// Whether slot pool `pool` can serve an operation adding these many simplices.
    bool has_room(index_t vertices, index_t faces, unsigned pool) const noexcept {
        return vertex_alloc_.has_room(vertices, pool) && face_alloc_.has_room(faces, pool);
    }

    // ---- journaled mutation ----

    // Slots come from detail::slot_allocator (a worker's pool, a dead slot newest first,
    // or appended). A recycled face slot keeps counting versions, so old tuples to it
    // stay stale.
    index_t add_vertex(undo_log& log) {
        const auto [v, source] = vertex_alloc_.acquire(vertex_slots(), log.pool);
        if (source == detail::slot_source::appended)
            vf_.emplace_back(), valive_.push_back(1);
        else
            valive_[v] = 1;
        log.push_back({undo_entry::what::vertex_acquired, v, index_t(source)});
        return v;
    }
    void remove_vertex(index_t v, undo_log& log) {
        assert(vf_[v].empty());
        valive_[v] = 0;
        log.push_back({undo_entry::what::vertex_released, v, index_t(vertex_alloc_.release(v))});
    }
    index_t add_face(const tri_indices& f, undo_log& log) {
        const auto [id, source] = face_alloc_.acquire(face_slots(), log.pool);
        log.push_back({undo_entry::what::face_acquired, id, index_t(source)});
        if (source == detail::slot_source::appended) {
            fv_.push_back(f);
            version_.push_back(0);
        } else {
            save_face(id, log);
            fv_[id] = f;
            bump_version(id);
        }
        for (index_t v : f) vf_insert(v, id, log);
        return id;
    }
    void remove_face(index_t f, undo_log& log) {
        save_face(f, log);
        for (index_t v : fv_[f]) vf_erase(v, f, log);
        fv_[f] = {invalid_index, invalid_index, invalid_index};
        bump_version(f);
        if (face_alloc_.release(f)) log.push_back({undo_entry::what::face_released, f});
    }
    /// Rewrites a face in place (same slot, new version).
    void set_face(index_t f, const tri_indices& nv, undo_log& log) {
        save_face(f, log);
        const tri_indices old = fv_[f];
        for (index_t v : old)
            if (!contains(nv, v)) vf_erase(v, f, log);
        for (index_t v : nv)
            if (!contains(old, v)) vf_insert(v, f, log);
        fv_[f] = nv;
        bump_version(f);
    }
    /// Marks a face changed (its geometry moved) so tuples made before go stale.
    void touch_face(index_t f, undo_log& log) {
        save_face(f, log);
        bump_version(f);
    }

    void rollback(undo_log& log, std::size_t mark) {
        using w = undo_entry::what;
        while (log.size() > mark) {
            const undo_entry e = log.back();
            log.pop_back();
            switch (e.kind) {
            case w::face_set:
                fv_[e.a] = e.verts, set_version(e.a, e.version);
                break;
            case w::face_acquired:
                if (face_alloc_.undo_acquire(e.a, detail::slot_source(e.b), face_slots(), log.pool))
                    fv_.pop_back(), version_.pop_back();
                break;
            case w::face_released:
                face_alloc_.undo_release(e.a);
                break;
            case w::vertex_acquired:
                if (vertex_alloc_.undo_acquire(e.a, detail::slot_source(e.b), vertex_slots(),
                                               log.pool))
                    vf_.pop_back(), valive_.pop_back();
                else
                    valive_[e.a] = 0;
                break;
            case w::vertex_released:
                valive_[e.a] = 1;
                if (e.b) vertex_alloc_.undo_release(e.a);
                break;
            case w::vf_insert:
                assert(!vf_[e.a].empty() && vf_[e.a].back() == e.b);
                vf_[e.a].pop_back();
                break;
            case w::vf_erase:
                vf_[e.a].insert(vf_[e.a].begin() + e.c, e.b);
                break;
            }
        }
    }

    friend bool operator==(const indexed_tri& x, const indexed_tri& y) {
        return x.fv_ == y.fv_ && x.version_ == y.version_ && x.valive_ == y.valive_ &&
               x.vf_ == y.vf_ && x.face_alloc_ == y.face_alloc_ &&
               x.vertex_alloc_ == y.vertex_alloc_;
    }

private:
    /// The arrays grow to the slot counts the pools were dealt from.
    void grow_to(index_t nv, index_t nf) {
        detail::grow_prefaulted(vf_, nv, {});
        valive_.resize(nv, 0);
        detail::grow_prefaulted(fv_, nf, {invalid_index, invalid_index, invalid_index});
        detail::grow_prefaulted(version_, nf, version_t{0});
    }

    static bool contains(const tri_indices& f, index_t v) noexcept {
        return f[0] == v || f[1] == v || f[2] == v;
    }
    void set_version(index_t f, version_t v) noexcept {
        std::atomic_ref<version_t>(version_[f]).store(v, std::memory_order_relaxed);
    }
    void bump_version(index_t f) noexcept { set_version(f, version_[f] + 1); }
    void save_face(index_t f, undo_log& log) {
        log.push_back({undo_entry::what::face_set, f, 0, 0, fv_[f], version_[f]});
    }
    void vf_insert(index_t v, index_t f, undo_log& log) {
        vf_[v].push_back(f);
        log.push_back({undo_entry::what::vf_insert, v, f});
    }
    void vf_erase(index_t v, index_t f, undo_log& log) {
        auto& l = vf_[v];
        auto it = std::find(l.begin(), l.end(), f);
        assert(it != l.end());
        const auto pos = static_cast<index_t>(it - l.begin());
        l.erase(it); // order-preserving, so the undo restores the list exactly
        log.push_back({undo_entry::what::vf_erase, v, f, pos});
    }

    std::vector<tri_indices> fv_;
    std::vector<version_t> version_;
    std::vector<face_list> vf_;
    std::vector<std::uint8_t> valive_;
    detail::slot_allocator vertex_alloc_, face_alloc_;
};

static_assert(tri_connectivity<indexed_tri>);

} // namespace idas::backend
