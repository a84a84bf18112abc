// Tet-to-tet adjacency for tetrahedral meshes (the classic "4 vertices + 4 neighbours per
// cell, one cell per vertex" layout). Each tet stores its four vertices (positively
// oriented), for each local face the face of the neighbour across it, and its version:
// a 36-byte record. Each vertex stores one incident tet (its anchor). switch_tetrahedron
// and face adjacency are one load; a vertex's tets are found by walking its star from the
// anchor across the faces that contain the vertex, so nothing per vertex grows with its
// valence. That walk needs every vertex star to be connected through faces: build()
// refuses pinched vertices (tets meeting only at a vertex or an edge), and no operation
// of ops/tet_ops.hpp creates one (they keep topology).
//
// Face references and links
// -------------------------
// Face reference r = 4t + i is local face i of tet t (the face opposite local vertex i).
// link(r) is the reference of the same face seen from the neighbour, or invalid_index on
// the boundary. Links are always symmetric and only ever join a face to one with the
// same three vertices in the opposite cyclic order (its twin), so a link never points to
// a dead tet, and a tet linked across a face holding v holds v.
//
// Keeping the links right through any sequence of add_tet / set_tet / remove_tet
// -------------------------------------------------------------------------------
// As in corner_table_tri: an operation passes through non-manifold states, so links are
// not found by searching stars as it goes. Every face that loses its twin, or is created
// or kept without one, goes on a short "pending" list in the (per-thread) undo log, keyed
// by its vertices in outward order. A face that needs a twin takes a reversed one from
// the list; failing that it is listed itself. If the operation ends manifold, every face
// with two tets is then linked: of the two, the later to need a twin finds the other on
// the list, unless the other was a boundary face that the operation never touched (a
// hole being filled). No operation of tet_ops.hpp fills holes (the swaps work on interior
// faces and edges, a split only cuts faces, and the link condition refuses a collapse
// that would glue two boundary faces together), so mutations do not search for such a
// twin; settle() does, for code that glues new tets onto an existing boundary.
//
// Anchors: when a tet that a vertex is anchored at is removed or rewritten without it,
// the vertex moves to a neighbour across one of the old tet's faces at the vertex, else
// to any tet the operation touched (pending list, then undo log) that holds it, else it
// has no tets left. That search is complete for the same reason as in corner_table_tri:
// an untouched tet of the star is linked, through untouched tets, to a touched one.
//
// Parallel use (the executor holds every vertex of a written tet, and a thread reads a
// vertex's star only while holding the vertex): writes are a mutated tet's record, the
// link of the twin across each of its faces, and anchors of the mutated tets' vertices.
// A twin's link is written only across a face whose three vertices the writer holds, and
// a star walk at v only reads links across faces holding v, so a walker never reads a
// link another thread writes. The pending list and the undo log are per thread.
#pragma once

#include <idas/core/concepts.hpp>
#include <idas/core/types.hpp>
#include <idas/mesh/backend/slot_pools.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace idas::backend {

class adjacency_tet {
public:
    /// One reversible change, undone newest-first.
    struct undo_entry {
        enum class what : std::uint8_t {
            tet_saved,       // a: tet; verts, opp, version: its record before the change
            link_set,        // a: face reference, b: its old link
            anchor_set,      // a: vertex, b: its old anchor tet
            tet_acquired,    // a: tet slot, b: its detail::slot_source
            tet_released,    // a: tet slot, put on the free list
            vertex_acquired, // a: vertex slot, b: its detail::slot_source
            vertex_released  // a: vertex slot, b: 1 if it went on the free list
        };
        what kind;
        index_t a = 0, b = 0;
        version_t version = 0;
        tet_indices verts{};
        tet_indices opp{};
    };

    /// The per-thread journal: undo entries, plus the faces of the running operation
    /// still waiting for a twin (scratch; not part of the mesh state).
    class undo_log {
    public:
        std::size_t size() const noexcept { return entries_.size(); }
        bool empty() const noexcept { return entries_.empty(); }
        void reserve(std::size_t n) {
            entries_.reserve(n);
            pending_.reserve(n / 4 + 16);
        }
        /// Forgets the entries past `n` (a commit); never grows.
        void resize(std::size_t n) {
            assert(n <= entries_.size());
            entries_.resize(n);
            forget_pending_after(n);
        }
        void clear() noexcept { entries_.clear(), pending_.clear(); }
        std::span<const undo_entry> entries() const noexcept { return entries_; }

        /// The slot pool new simplices come from (see detail::undo_list).
        unsigned pool = 0;

    private:
        friend class adjacency_tet;
        struct pending_face {
            index_t ref;
            tri_indices key;       // its vertices when listed, outward, smallest first
            std::uint32_t made_at; // log size when listed
        };
        void forget_pending_after(std::size_t n) {
            if (n == 0) return pending_.clear();
            std::erase_if(pending_, [n](const pending_face& p) { return p.made_at > n; });
        }
        template <class... Fields>
        void push(Fields... fields) {
            entries_.emplace_back(fields...);
        }
        std::vector<undo_entry> entries_;
        std::vector<pending_face> pending_;
    };

    /// A tet: its vertices (all invalid_index when dead), the link of each local face,
    /// its version.
    struct tet_record {
        tet_indices v{};
        tet_indices opp{};
        version_t version = 0;
        friend bool operator==(const tet_record&, const tet_record&) = default;
    };

    /// A vertex's tets, collected by walking its star (most stars fit inline).
    using tet_star = boost::container::small_vector<index_t, 64>;

    static constexpr index_t face_ref(index_t t, index_t lf) noexcept { return 4 * t + lf; }
    static constexpr index_t tet_of(index_t r) noexcept { return r >> 2; }
    static constexpr index_t local(index_t r) noexcept { return r & 3; }

    adjacency_tet() = default;

    /// Builds the links by matching faces. Throws input_error naming a vertex whose tets
    /// are not connected through faces (see the top of the file).
    void build(index_t n_vertices, const std::vector<tet_indices>& tets) {
        if (tets.size() >= (std::size_t{1} << 30))
            throw input_error("adjacency_tet holds at most 2^30 - 1 tets");
        const auto n_tets = static_cast<index_t>(tets.size());
        tets_.assign(n_tets, {});
        for (index_t t = 0; t < n_tets; ++t) tets_[t] = {tets[t], dead_links(), 0};
        anchor_.assign(n_vertices, invalid_index);
        valive_.assign(n_vertices, 1);
        vertex_alloc_.clear(), tet_alloc_.clear();
        // Faces by sorted vertices; a face's two tets end up next to each other.
        struct face {
            tri_indices key;
            index_t ref;
        };
        std::vector<face> faces;
        faces.reserve(4 * std::size_t(n_tets));
        for (index_t t = 0; t < n_tets; ++t)
            for (index_t i = 0; i < 4; ++i) {
                tri_indices k = face_key(tets[t], i);
                std::sort(k.begin(), k.end());
                faces.push_back({k, face_ref(t, i)});
            }
        std::sort(faces.begin(), faces.end(), [](const face& x, const face& y) {
            return std::tie(x.key[0], x.key[1], x.key[2], x.ref) <
                   std::tie(y.key[0], y.key[1], y.key[2], y.ref);
        });
        for (std::size_t i = 0; i + 1 < faces.size(); ++i) {
            const auto& x = faces[i];
            const auto& y = faces[i + 1];
            if (x.key[0] != y.key[0] || x.key[1] != y.key[1] || x.key[2] != y.key[2]) continue;
            if (!same(face_key(tets_[tet_of(y.ref)].v, local(y.ref)),
                      twin_key(face_key(tets_[tet_of(x.ref)].v, local(x.ref)))))
                continue; // same side (tet_mesh refuses such input before it gets here)
            link_ref(x.ref) = y.ref, link_ref(y.ref) = x.ref;
            ++i;
        }
        std::vector<index_t> degree(n_vertices, 0);
        for (index_t t = 0; t < n_tets; ++t)
            for (index_t v : tets[t]) {
                ++degree[v];
                if (anchor_[v] == invalid_index) anchor_[v] = t;
            }
        tet_star star;
        for (index_t v = 0; v < n_vertices; ++v) {
            collect_star(v, star);
            if (star.size() != degree[v])
                throw input_error("vertex " + std::to_string(v) +
                                  " is pinched: its tets are not all connected through faces "
                                  "(adjacency_tet needs face-connected vertex stars)");
        }
    }
    void reserve(index_t vertices, index_t tets) {
        tets_.reserve(tets), anchor_.reserve(vertices), valive_.reserve(vertices);
    }

    index_t vertex_slots() const noexcept { return static_cast<index_t>(anchor_.size()); }
    index_t tet_slots() const noexcept { return static_cast<index_t>(tets_.size()); }
    bool vertex_alive(index_t v) const noexcept { return valive_[v] != 0; }
    bool tet_alive(index_t t) const noexcept { return tets_[t].v[0] != invalid_index; }
    const tet_indices& tet_vertices(index_t t) const noexcept { return tets_[t].v; }
    version_t tet_version(index_t t) const noexcept { return tets_[t].version; }
    /// As indexed_tet: a version read that may race with the tet's owner bumping it.
    version_t tet_version_relaxed(index_t t) const noexcept {
        return std::atomic_ref<version_t>(const_cast<version_t&>(tets_[t].version))
            .load(std::memory_order_relaxed);
    }
    /// One tet holding v, or invalid_index: what a tuple at v starts from.
    index_t vertex_anchor(index_t v) const noexcept { return anchor_[v]; }
    /// v's tets, walked from its anchor (breadth first).
    tet_star vertex_tets(index_t v) const {
        tet_star s;
        collect_star(v, s);
        return s;
    }

    /// The tet across local face `lf` of `t`, or invalid_index on the boundary. One load.
    index_t opposite_tet(index_t t, std::uint8_t lf) const noexcept {
        const index_t o = tets_[t].opp[lf];
        return o == invalid_index ? invalid_index : tet_of(o);
    }
    /// The same face seen from the tet across: that tet and the face's local index there,
    /// or {invalid_index, 0} on the boundary. One load.
    std::pair<index_t, std::uint8_t> opposite_face(index_t t, std::uint8_t lf) const noexcept {
        const index_t o = tets_[t].opp[lf];
        if (o == invalid_index) return {invalid_index, 0};
        return {tet_of(o), static_cast<std::uint8_t>(local(o))};
    }

    /// Checks what the generic checks cannot see: t's links are symmetric and join twins.
    std::optional<std::string> check_tet(index_t t) const {
        for (index_t i = 0; i < 4; ++i) {
            const index_t r = face_ref(t, i), o = link(r);
            if (o == invalid_index) continue;
            if (tet_of(o) >= tets_.size() || !tet_alive(tet_of(o)) || link(o) != r ||
                !same(face_key(tets_[tet_of(o)].v, local(o)), twin_key(face_key(tets_[t].v, i))))
                return "face " + std::to_string(i) + " is linked to face " +
                       std::to_string(local(o)) + " of tet " + std::to_string(tet_of(o)) +
                       ", which is not its twin";
        }
        return std::nullopt;
    }
    /// Checks v's anchor: a live tet holding v, or none exactly when v has no tets.
    std::optional<std::string> check_vertex(index_t v) const {
        const index_t a = anchor_[v];
        if (a == invalid_index) return std::nullopt;
        if (a >= tets_.size() || !tet_alive(a) || !contains(tets_[a].v, v))
            return std::string("anchor is not a live tet of the vertex");
        return std::nullopt;
    }

    std::size_t memory_bytes() const noexcept {
        return tets_.capacity() * sizeof(tet_record) + anchor_.capacity() * sizeof(index_t) +
               valive_.capacity() + tet_alloc_.memory_bytes() + vertex_alloc_.memory_bytes();
    }

    /// As indexed_tet: while parallel workers share the backend, removed slots are not
    /// recycled (the free lists would be shared state).
    void set_slot_recycling(bool on) noexcept {
        vertex_alloc_.set_recycling(on), tet_alloc_.set_recycling(on);
    }

    /// As indexed_tet: the arrays grow once, here, by the given numbers of dead slots,
    /// dealt out to per-worker pools (the undo log's `pool` picks one).
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
    bool has_room(index_t vertices, index_t tets, unsigned pool) const noexcept {
        return vertex_alloc_.has_room(vertices, pool) && tet_alloc_.has_room(tets, pool);
    }

    // ---- journaled mutation ----

    // Slots are reused as in indexed_tet; a reused tet slot keeps counting versions.
    index_t add_vertex(undo_log& log) {
        const auto [v, source] = vertex_alloc_.acquire(vertex_slots(), log.pool);
        if (source == detail::slot_source::appended)
            anchor_.push_back(invalid_index), valive_.push_back(1);
        else
            valive_[v] = 1;
        log.push(undo_entry::what::vertex_acquired, v, index_t(source));
        return v;
    }
    void remove_vertex(index_t v, undo_log& log) {
        assert(anchor_[v] == invalid_index);
        valive_[v] = 0;
        log.push(undo_entry::what::vertex_released, v, index_t(vertex_alloc_.release(v)));
    }

    index_t add_tet(const tet_indices& t, undo_log& log) {
        const auto [id, source] = tet_alloc_.acquire(tet_slots(), log.pool);
        log.push(undo_entry::what::tet_acquired, id, index_t(source));
        if (source == detail::slot_source::appended) {
            tets_.push_back({t, dead_links(), 0});
        } else {
            save_tet(id, log);
            tet_record& r = tets_[id];
            r.v = t, r.opp = dead_links();
            bump_version(r);
        }
        for (index_t v : t)
            if (anchor_[v] == invalid_index) set_anchor(v, id, log);
        for (index_t i = 0; i < 4; ++i) attach(face_ref(id, i), log);
        return id;
    }

    void remove_tet(index_t t, undo_log& log) {
        save_tet(t, log);
        const tet_record old = tets_[t];
        tets_[t].v = dead_links(), tets_[t].opp = dead_links();
        bump_version(tets_[t]);
        for (index_t i = 0; i < 4; ++i)
            if (old.opp[i] != invalid_index) set_link(old.opp[i], invalid_index, log);
        if (tet_alloc_.release(t)) log.push(undo_entry::what::tet_released, t);
        for (index_t v : old.v)
            if (anchor_[v] == t) relocate_anchor(v, old, log);
        for (index_t i = 0; i < 4; ++i)
            if (old.opp[i] != invalid_index) rematch(old.opp[i], log);
    }

    /// Rewrites a tet in place (same slot, new version). A face the tet keeps (same three
    /// vertices, same cyclic order) keeps its twin; the others are unlinked and relinked.
    void set_tet(index_t t, const tet_indices& nv, undo_log& log) {
        save_tet(t, log);
        const tet_record old = tets_[t];
        tet_record& r = tets_[t];
        r.v = nv, r.opp = dead_links();
        bump_version(r);
        bool kept[4] = {false, false, false, false};
        index_t lost[4] = {invalid_index, invalid_index, invalid_index, invalid_index};
        const tri_indices new_keys[4] = {face_key(nv, 0), face_key(nv, 1), face_key(nv, 2),
                                         face_key(nv, 3)};
        for (index_t i = 0; i < 4; ++i) {
            const tri_indices k = face_key(old.v, i);
            index_t j = 0;
            while (j < 4 && !same(new_keys[j], k)) ++j;
            if (j == 4) {
                lost[i] = old.opp[i];
                continue;
            }
            kept[j] = true;
            r.opp[j] = old.opp[i];
            if (old.opp[i] != invalid_index && j != i) set_link(old.opp[i], face_ref(t, j), log);
        }
        for (index_t i = 0; i < 4; ++i)
            if (lost[i] != invalid_index) set_link(lost[i], invalid_index, log);
        // Links are symmetric again; now anchors (the rest may read them), then matching.
        for (index_t i = 0; i < 4; ++i)
            if (anchor_[old.v[i]] == t && !contains(nv, old.v[i]))
                relocate_anchor(old.v[i], old, log);
        for (index_t v : nv)
            if (anchor_[v] == invalid_index) set_anchor(v, t, log);
        for (index_t j = 0; j < 4; ++j)
            if (kept[j] && r.opp[j] == invalid_index) list_pending(face_ref(t, j), log);
        for (index_t i = 0; i < 4; ++i)
            if (lost[i] != invalid_index) rematch(lost[i], log);
        for (index_t j = 0; j < 4; ++j)
            if (!kept[j]) attach(face_ref(t, j), log);
    }

    /// Marks a tet changed (a vertex moved) so tuples made before go stale.
    void touch_tet(index_t t, undo_log& log) {
        save_tet(t, log);
        bump_version(tets_[t]);
    }

    /// Links every face of the running operation still waiting for a twin to a boundary
    /// face that the operation did not touch, if there is one (gluing new tets onto an
    /// existing boundary). Operations of tet_ops.hpp never need it (see the top).
    void settle(undo_log& log) {
        tet_star star;
        for (std::size_t k = 0; k < log.pending_.size(); ++k) {
            const auto p = log.pending_[k];
            if (!unlinked(p.ref) || !same(face_key(tets_[tet_of(p.ref)].v, local(p.ref)), p.key))
                continue;
            const tri_indices want = twin_key(p.key);
            collect_star(p.key[0], star);
            for (index_t g : star) {
                if (g == tet_of(p.ref)) continue;
                for (index_t i = 0; i < 4; ++i)
                    if (link(face_ref(g, i)) == invalid_index &&
                        same(face_key(tets_[g].v, i), want)) {
                        set_link(p.ref, face_ref(g, i), log);
                        set_link(face_ref(g, i), p.ref, log);
                        i = 4;
                    }
                if (link(p.ref) != invalid_index) break;
            }
        }
    }

    void rollback(undo_log& log, std::size_t mark) {
        using w = undo_entry::what;
        auto& entries = log.entries_;
        while (entries.size() > mark) {
            const undo_entry e = entries.back();
            entries.pop_back();
            switch (e.kind) {
            case w::tet_saved:
                tets_[e.a].v = e.verts, tets_[e.a].opp = e.opp;
                set_version(tets_[e.a], e.version);
                break;
            case w::link_set:
                link_ref(e.a) = e.b;
                break;
            case w::anchor_set:
                anchor_[e.a] = e.b;
                break;
            case w::tet_acquired:
                if (tet_alloc_.undo_acquire(e.a, detail::slot_source(e.b), tet_slots(), log.pool))
                    tets_.pop_back();
                break;
            case w::tet_released:
                tet_alloc_.undo_release(e.a);
                break;
            case w::vertex_acquired:
                if (vertex_alloc_.undo_acquire(e.a, detail::slot_source(e.b), vertex_slots(),
                                               log.pool))
                    anchor_.pop_back(), valive_.pop_back();
                else
                    valive_[e.a] = 0;
                break;
            case w::vertex_released:
                valive_[e.a] = 1;
                if (e.b) vertex_alloc_.undo_release(e.a);
                break;
            }
        }
        log.forget_pending_after(mark);
    }

    friend bool operator==(const adjacency_tet& x, const adjacency_tet& y) {
        return x.tets_ == y.tets_ && x.anchor_ == y.anchor_ && x.valive_ == y.valive_ &&
               x.tet_alloc_ == y.tet_alloc_ && x.vertex_alloc_ == y.vertex_alloc_;
    }

private:
    /// The arrays grow to the slot counts the pools were dealt from.
    void grow_to(index_t nv, index_t nt) {
        detail::grow_prefaulted(anchor_, nv, invalid_index);
        valive_.resize(nv, 0);
        detail::grow_prefaulted(tets_, nt, dead_tet());
    }

    static constexpr tet_indices dead_links() noexcept {
        return {invalid_index, invalid_index, invalid_index, invalid_index};
    }
    static constexpr tet_record dead_tet() noexcept { return {dead_links(), dead_links(), 0}; }
    static bool contains(const tet_indices& t, index_t v) noexcept {
        return t[0] == v || t[1] == v || t[2] == v || t[3] == v;
    }
    /// Local face i's vertices in outward order (as tet_local::face_vertices), rotated so
    /// the smallest comes first: equal keys mean the same face seen from the same side.
    static tri_indices face_key(const tet_indices& v, index_t i) noexcept {
        static constexpr std::uint8_t fv[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
        const index_t x = v[fv[i][0]], y = v[fv[i][1]], z = v[fv[i][2]];
        if (x < y && x < z) return {x, y, z};
        if (y < z) return {y, z, x};
        return {z, x, y};
    }
    /// The key of the same face seen from the other side.
    static tri_indices twin_key(const tri_indices& k) noexcept { return {k[0], k[2], k[1]}; }
    /// Element-wise (std::array's == calls memcmp, a third of a split's time here).
    static bool same(const tri_indices& x, const tri_indices& y) noexcept {
        return x[0] == y[0] && x[1] == y[1] && x[2] == y[2];
    }
    static void set_version(tet_record& r, version_t v) noexcept {
        std::atomic_ref<version_t>(r.version).store(v, std::memory_order_relaxed);
    }
    static void bump_version(tet_record& r) noexcept { set_version(r, r.version + 1); }
    index_t link(index_t r) const noexcept { return tets_[tet_of(r)].opp[local(r)]; }
    index_t& link_ref(index_t r) noexcept { return tets_[tet_of(r)].opp[local(r)]; }
    /// Is r a live face with no twin yet?
    bool unlinked(index_t r) const noexcept {
        return tet_of(r) < tets_.size() && tet_alive(tet_of(r)) && link(r) == invalid_index;
    }

    /// Breadth-first walk of v's star from its anchor, across the faces holding v, in a
    /// local buffer; a small open-addressing set remembers the tets seen (stars have a
    /// few dozen tets). A star too big for the buffer finishes in `out` with plain searches.
    template <class Out>
    void collect_star(index_t v, Out& out) const {
        out.clear();
        const index_t a = anchor_[v];
        if (a == invalid_index) return;
        constexpr std::size_t table = 256, mask = table - 1, buffered = table / 2;
        std::array<index_t, table> seen;
        seen.fill(invalid_index);
        const auto first_visit = [&](index_t g) {
            for (std::size_t h = (g * 2654435761u) >> 24;; h = (h + 1) & mask) {
                if (seen[h] == g) return false;
                if (seen[h] == invalid_index) return seen[h] = g, true;
            }
        };
        std::array<index_t, buffered> buf;
        std::size_t n = 1, i = 0;
        buf[0] = a;
        first_visit(a);
        for (; i < n; ++i) {
            const tet_record& r = tets_[buf[i]];
            for (index_t k = 0; k < 4; ++k) {
                if (r.v[k] == v || r.opp[k] == invalid_index) continue;
                const index_t g = tet_of(r.opp[k]);
                if (!first_visit(g)) continue;
                if (n == buffered) { // (g is found again below)
                    out.assign(buf.begin(), buf.end());
                    return collect_big_star(v, i, out);
                }
                buf[n++] = g;
            }
        }
        out.assign(buf.begin(), buf.begin() + std::ptrdiff_t(n));
    }
    /// The rest of a big star's walk, from out[i] on.
    template <class Out>
    void collect_big_star(index_t v, std::size_t i, Out& out) const {
        for (; i < out.size(); ++i) {
            const tet_record r = tets_[out[i]];
            for (index_t k = 0; k < 4; ++k) {
                if (r.v[k] == v || r.opp[k] == invalid_index) continue;
                const index_t g = tet_of(r.opp[k]);
                if (std::find(out.begin(), out.end(), g) == out.end()) out.push_back(g);
            }
        }
    }

    void save_tet(index_t t, undo_log& log) {
        const tet_record& r = tets_[t];
        log.push(undo_entry::what::tet_saved, t, 0, r.version, r.v, r.opp);
    }
    void set_link(index_t r, index_t value, undo_log& log) {
        log.push(undo_entry::what::link_set, r, link(r));
        link_ref(r) = value;
    }
    void set_anchor(index_t v, index_t t, undo_log& log) {
        log.push(undo_entry::what::anchor_set, v, anchor_[v]);
        anchor_[v] = t;
    }
    void list_pending(index_t r, undo_log& log) {
        log.pending_.push_back({r, face_key(tets_[tet_of(r)].v, local(r)),
                                static_cast<std::uint32_t>(log.entries_.size())});
    }
    /// A pending face with this key, taken off the list (the last entry fills its place).
    /// Entries that have been linked, died or been rewritten since they were listed are
    /// dropped.
    index_t find_pending(const tri_indices& key, undo_log& log) const {
        auto& p = log.pending_;
        for (std::size_t k = 0; k < p.size();) {
            if (!same(p[k].key, key)) {
                ++k;
                continue;
            }
            const index_t d = p[k].ref;
            p[k] = p.back();
            p.pop_back();
            if (unlinked(d) && same(face_key(tets_[tet_of(d)].v, local(d)), key)) return d;
        }
        return invalid_index;
    }
    /// New face r (its tet was saved or appended in this mutation, so its own link is
    /// written directly) takes a pending twin, or waits on the list.
    void attach(index_t r, undo_log& log) {
        const index_t d = find_pending(twin_key(face_key(tets_[tet_of(r)].v, local(r))), log);
        if (d == invalid_index) return list_pending(r, log);
        link_ref(r) = d;
        set_link(d, r, log);
    }
    /// Face r of another tet lost its twin (already unlinked): it takes a pending twin,
    /// or waits on the list.
    void rematch(index_t r, undo_log& log) {
        const index_t d = find_pending(twin_key(face_key(tets_[tet_of(r)].v, local(r))), log);
        if (d == invalid_index) return list_pending(r, log);
        set_link(r, d, log);
        set_link(d, r, log);
    }
    /// v's anchor was the tet whose record before the change is `old`, which no longer
    /// holds v. See the top of the file for why this finds a tet of v if v has one.
    void relocate_anchor(index_t v, const tet_record& old, undo_log& log) {
        const auto holds = [&](index_t g) {
            return g < tets_.size() && tet_alive(g) && contains(tets_[g].v, v);
        };
        for (index_t k = 0; k < 4; ++k)
            if (old.v[k] != v && old.opp[k] != invalid_index && holds(tet_of(old.opp[k])))
                return set_anchor(v, tet_of(old.opp[k]), log);
        for (const auto& p : log.pending_)
            if (holds(tet_of(p.ref))) return set_anchor(v, tet_of(p.ref), log);
        using w = undo_entry::what;
        for (auto e = log.entries_.rbegin(); e != log.entries_.rend(); ++e) {
            index_t g;
            // (A reused or pooled slot has its tet_saved entry too.)
            if (e->kind == w::tet_saved ||
                (e->kind == w::tet_acquired &&
                 detail::slot_source(e->b) == detail::slot_source::appended))
                g = e->a;
            else if (e->kind == w::link_set)
                g = tet_of(e->a);
            else
                continue;
            if (holds(g)) return set_anchor(v, g, log);
        }
        set_anchor(v, invalid_index, log);
    }

    std::vector<tet_record> tets_;
    std::vector<index_t> anchor_; // one tet per vertex, invalid_index without tets
    std::vector<std::uint8_t> valive_;
    detail::slot_allocator vertex_alloc_, tet_alloc_;
};

static_assert(tet_connectivity<adjacency_tet>);

} // namespace idas::backend
