// A corner table (Rossignac's "O table") for triangle meshes. Each face stores its
// three vertices and, for each of its corners, the opposite corner: the corner of the
// neighbour face that faces the same edge from the other side. Each vertex stores one
// incident corner (its anchor). switch_face is one array load; a vertex's faces are
// enumerated by circulating through the opposite table, so nothing per vertex grows
// with its valence.
//
// Corners, half-edges and circulation
// -----------------------------------
// Corner c = 4f + i (i < 3) is vertex faces[f].v[i]; the stride of 4 makes face and
// local index a shift and a mask, and a face record is 32 bytes. The half-edge opposite
// c runs from the vertex at next(c) to the vertex at prev(c) (local edge i of
// tri_tuple): it "enters" the vertex at prev(c). Its twin, the same edge in the
// neighbour face, runs the other way; opp(c) is the twin's corner, or invalid_index on
// the boundary. Links are always symmetric (opp(opp(c)) == c) and only ever join true
// twins, so around a vertex v at corner c,
//   forward:  prev(opp(prev(c)))   (across the edge from v to the vertex at next(c))
//   backward: next(opp(next(c)))   (across the edge entering v from prev(c))
// are each other's inverse. vertex_faces(v) walks forward from v's anchor until it is
// back (closed fan) or meets the boundary, then backward from the anchor.
//
// Between operations a boundary vertex is anchored where its fan starts: at the corner
// whose entering half-edge is on the boundary. is_boundary_vertex is then one load, and
// vertex_faces visits the fan in order.
//
// Keeping the links right through any sequence of add_face / set_face / remove_face
// ------------------------------------------------------------------------------------
// An operation passes through states that are not manifold (a collapse rewrites the
// star of b one face at a time), so links cannot be found by walking stars as it goes.
// Instead every half-edge that loses its twin, or is created or kept without one, goes
// on a short "pending" list kept in the (per-thread) undo log. A half-edge x->y that
// needs a twin takes an unlinked y->x from that list. Failing that, a new one may glue
// onto a boundary edge that was there before the operation (hole filling): such a
// half-edge y->x was where x's fan started, so x is anchored there, and no rule below
// moves an anchor away from an entering half-edge that is untouched and unlinked; one
// comparison finds it. Otherwise x->y goes on the list.
// Then, if the operation ends manifold, every edge with two faces is linked: of its two
// half-edges, the later to need a twin finds the other on the list or at the anchor.
// Entries are checked when used (a listed corner may have been linked or rewritten
// since) and dropped when the transaction that made them commits or rolls back.
//
// Anchors follow: a vertex gets a new corner when its face is rewritten or removed;
// when a half-edge entering it waits for a twin and its anchor's entering half-edge is
// linked (its fan may start there now); and when its anchor's entering half-edge gets a
// twin while another entering one still waits. A relocated anchor prefers such a
// waiting half-edge, then a neighbour across one of the old face's edges at the vertex,
// then any face the operation touched (pending list, then undo log) that holds the
// vertex, else it becomes invalid (no faces left). That search is complete: a face of
// the vertex's star that the operation did not touch is linked, through untouched
// faces, to one it did touch, or the whole star is untouched and the anchor would not
// have moved. At the end of a manifold operation the anchor of a boundary vertex is at
// the start of its fan again (validate.hpp checks this after every test operation).
//
// Parallel use (the executor locks the closed stars of an operation's vertices and
// lets a thread read a vertex's incidence only while holding that vertex)
// -----------------------------------------------------------------------------------
// Writes: a mutated face f (its vertices, version and its own three links), the link
// of the twin across each half-edge of f that is lost, gained or moved, and the anchors
// of the vertices of f and of those twins. Reads beyond f: the twins' faces, the anchor
// corner of a vertex of f, and faces named in the thread's own pending list and log.
//   split_edge(a, b): rewrites f = abc and g = bad, adds two faces around the new
//     vertex (a slot no other thread can reach). The changed half-edges all have a or b
//     as an endpoint (ab, bc, db and their new pieces), so their twins lie in the stars
//     of a or b; c->a and a->d keep their corner (no write across them).
//   collapse_edge(a <- b): rewrites the faces of b's star with b replaced in place, and
//     removes abc and bad. The rim half-edges opposite b keep their corner, so the
//     faces across the rim (whose third vertex may be outside the locked region) are
//     never written; every other changed half-edge has a or b as an endpoint, so its
//     twin is in the star of a or b.
//   swap_edge(x, y): rewrites f = cxy and h = dyx as cxd and dyc. Half-edges c->x and
//     d->y move to another corner and x->d, y->c change face, so the faces across cx,
//     dy, xd and yc get new links: each contains x or y, so it is in their stars.
//   smooth_vertex: only bumps versions of the vertex's faces.
// In every case each written face has all its vertices in the locked region, so each
// written anchor belongs to a locked vertex too. The pending list and the undo log are
// per thread.
#pragma once

#include <idas/core/concepts.hpp>
#include <idas/core/types.hpp>
#include <idas/mesh/backend/slot_pools.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <cstddef>
#include <iterator>
#include <optional>
#include <ranges>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace idas::backend {

class corner_table_tri {
public:
    /// One reversible change, undone newest-first.
    struct undo_entry {
        enum class what : std::uint8_t {
            face_saved,      // a: face; verts, opp, version: its record before the change
            opp_set,         // a: corner, b: its old opposite corner
            anchor_set,      // a: vertex, b: its old anchor corner
            face_acquired,   // a: face slot, b: its detail::slot_source
            face_released,   // a: face slot, put on the free list
            vertex_acquired, // a: vertex slot, b: its detail::slot_source
            vertex_released  // a: vertex slot, b: 1 if it went on the free list
        };
        what kind;
        index_t a = 0, b = 0;
        version_t version = 0;
        tri_indices verts{};
        tri_indices opp{};
    };

    /// The per-thread journal: the undo entries, plus the half-edges of the running
    /// operation still waiting for a twin (scratch; not part of the mesh state).
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
        friend class corner_table_tri;
        struct pending_half {
            index_t corner;
            index_t from, to;      // its vertices when listed (checked again on use)
            std::uint32_t made_at; // log size when listed
        };
        void forget_pending_after(std::size_t n) {
            if (n == 0) return pending_.clear();
            std::erase_if(pending_, [n](const pending_half& p) { return p.made_at > n; });
        }
        /// Builds the entry in place: a temporary copied in would be read back wider than
        /// it was written, which stalls store forwarding on every push.
        template <class... Fields>
        void push(Fields... fields) {
            entries_.emplace_back(fields...);
        }
        std::vector<undo_entry> entries_;
        std::vector<pending_half> pending_;
    };

    /// A face: its vertices (all invalid_index when dead), its version, and the opposite
    /// corner of each of its corners; padded to 32 bytes. (Not alignas(32): over-aligned
    /// vectors need the aligned operator new, which programs that replace the global
    /// allocator, like the allocation-counting tests and benchmarks, must then replace too.)
    struct face_record {
        tri_indices v{};
        version_t version = 0;
        tri_indices opp{};
        std::uint32_t unused = 0;
        friend bool operator==(const face_record&, const face_record&) = default;
    };

    // Corner i of face f is 4f + i (i < 3): face and local index are a shift and a mask.
    static constexpr index_t corner(index_t f, index_t i) noexcept { return 4 * f + i; }
    static constexpr index_t face_of(index_t c) noexcept { return c >> 2; }
    static constexpr index_t local(index_t c) noexcept { return c & 3; }
    static constexpr index_t next(index_t c) noexcept { return local(c) == 2 ? c - 2 : c + 1; }
    static constexpr index_t prev(index_t c) noexcept { return local(c) == 0 ? c + 2 : c - 1; }

    /// Forward iterator over the faces around a vertex (see the top of the file).
    class face_iterator {
    public:
        using iterator_concept = std::forward_iterator_tag;
        using iterator_category = std::input_iterator_tag; // yields values, not references
        using value_type = index_t;
        using difference_type = std::ptrdiff_t;
        using reference = index_t;
        using pointer = void;

        face_iterator() = default;
        index_t operator*() const noexcept { return face_of(cur_); }
        face_iterator& operator++() noexcept {
            if (!backward_) {
                const index_t o = link(prev(cur_));
                if (o != invalid_index) {
                    const index_t n = prev(o);
                    cur_ = n == start_ ? invalid_index : n;
                    return *this;
                }
                backward_ = true; // open fan: go the other way from the start
                cur_ = start_;
            }
            const index_t o = link(next(cur_));
            cur_ = o == invalid_index ? invalid_index : next(o);
            return *this;
        }
        face_iterator operator++(int) noexcept {
            face_iterator t = *this;
            ++*this;
            return t;
        }
        friend bool operator==(const face_iterator& a, const face_iterator& b) noexcept {
            return a.cur_ == b.cur_;
        }

    private:
        friend class corner_table_tri;
        face_iterator(const face_record* faces, index_t start) noexcept
            : faces_(faces)
            , start_(start)
            , cur_(start) {}
        index_t link(index_t c) const noexcept { return faces_[face_of(c)].opp[local(c)]; }
        const face_record* faces_ = nullptr;
        index_t start_ = invalid_index, cur_ = invalid_index;
        bool backward_ = false;
    };

    /// The faces around a vertex, circulated from its anchor. Iterators point into the
    /// backend, not into the range, so the range is a borrowed view.
    class face_range : public std::ranges::view_interface<face_range> {
    public:
        face_range() = default;
        face_iterator begin() const noexcept { return {faces_, start_}; }
        face_iterator end() const noexcept { return {}; }

    private:
        friend class corner_table_tri;
        face_range(const face_record* faces, index_t start) noexcept
            : faces_(faces)
            , start_(start) {}
        const face_record* faces_ = nullptr;
        index_t start_ = invalid_index;
    };

    corner_table_tri() = default;

    void build(index_t n_vertices, const std::vector<tri_indices>& faces) {
        if (faces.size() >= (std::size_t{1} << 30))
            throw input_error("corner_table_tri holds at most 2^30 - 1 faces");
        const auto n_faces = static_cast<index_t>(faces.size());
        faces_.assign(n_faces, {});
        for (index_t f = 0; f < n_faces; ++f)
            faces_[f] = {faces[f], 0, {invalid_index, invalid_index, invalid_index}, 0};
        anchor_.assign(n_vertices, invalid_index);
        valive_.assign(n_vertices, 1);
        vertex_alloc_.clear(), face_alloc_.clear();
        // The corners of each vertex (CSR, in face order); each half-edge x->y finds its
        // twin y->x among the corners of x.
        std::vector<index_t> start(std::size_t(n_vertices) + 1, 0),
            corners(3 * std::size_t(n_faces));
        for (const auto& f : faces)
            for (index_t v : f) ++start[v + 1];
        for (index_t v = 0; v < n_vertices; ++v) start[v + 1] += start[v];
        std::vector<index_t> fill(start.begin(), start.end() - 1);
        for (index_t f = 0; f < n_faces; ++f)
            for (index_t i = 0; i < 3; ++i) corners[fill[faces[f][i]]++] = corner(f, i);
        for (index_t f = 0; f < n_faces; ++f)
            for (index_t i = 0; i < 3; ++i) {
                const index_t c = corner(f, i), x = vertex_at(next(c)), y = vertex_at(prev(c));
                for (index_t k = start[x]; k < start[x + 1]; ++k) {
                    const index_t d = next(corners[k]); // prev(d) is x's corner
                    if (vertex_at(next(d)) == y) {
                        link_ref(c) = d;
                        break;
                    }
                }
            }
        // Anchors: where a boundary vertex's fan starts (the corner whose entering edge
        // is on the boundary), else the corner of the lowest face.
        for (index_t v = 0; v < n_vertices; ++v) {
            if (start[v] == start[v + 1]) continue;
            anchor_[v] = corners[start[v]];
            for (index_t k = start[v]; k < start[v + 1]; ++k)
                if (link(next(corners[k])) == invalid_index) {
                    anchor_[v] = corners[k];
                    break;
                }
        }
    }
    void reserve(index_t vertices, index_t faces) {
        faces_.reserve(faces), anchor_.reserve(vertices), valive_.reserve(vertices);
    }

    index_t vertex_slots() const noexcept { return static_cast<index_t>(anchor_.size()); }
    index_t face_slots() const noexcept { return static_cast<index_t>(faces_.size()); }
    bool vertex_alive(index_t v) const noexcept { return valive_[v] != 0; }
    bool face_alive(index_t f) const noexcept { return faces_[f].v[0] != invalid_index; }
    const tri_indices& face_vertices(index_t f) const noexcept { return faces_[f].v; }
    version_t face_version(index_t f) const noexcept { return faces_[f].version; }
    /// As indexed_tri: a version read that may race with the face's owner bumping it
    /// (parallel workers purge stale queue entries without holding the face's locks), so
    /// versions are written through relaxed atomics (free on x86).
    version_t face_version_relaxed(index_t f) const noexcept {
        return std::atomic_ref<version_t>(const_cast<version_t&>(faces_[f].version))
            .load(std::memory_order_relaxed);
    }
    face_range vertex_faces(index_t v) const noexcept { return {faces_.data(), anchor_[v]}; }

    /// The face across local edge `le` of `f`, or invalid_index on the boundary.
    index_t opposite_face(index_t f, std::uint8_t le) const noexcept {
        const index_t o = faces_[f].opp[le];
        return o == invalid_index ? invalid_index : face_of(o);
    }
    /// The same edge seen from the face across: that face and the edge's local index
    /// there, or {invalid_index, 0} on the boundary. One load.
    std::pair<index_t, std::uint8_t> opposite_edge(index_t f, std::uint8_t le) const noexcept {
        const index_t o = faces_[f].opp[le];
        if (o == invalid_index) return {invalid_index, 0};
        return {face_of(o), static_cast<std::uint8_t>(local(o))};
    }

    /// True iff v's fan is open (v has a boundary edge); false for a vertex without faces.
    /// One load: a boundary vertex is anchored where its fan starts.
    bool is_boundary_vertex(index_t v) const noexcept {
        const index_t a = anchor_[v];
        return a != invalid_index && link(next(a)) == invalid_index;
    }

    /// Checks what the generic validity checks cannot see: face f's links are
    /// symmetric and join true twins. Returns a description of the first problem.
    std::optional<std::string> check_face(index_t f) const {
        for (index_t i = 0; i < 3; ++i) {
            const index_t c = corner(f, i), o = link(c);
            if (o == invalid_index) continue;
            if (face_of(o) >= faces_.size() || !face_alive(face_of(o)) || local(o) > 2 ||
                link(o) != c || !runs(o, vertex_at(prev(c)), vertex_at(next(c))))
                return "corner " + std::to_string(i) + " is linked to corner " +
                       std::to_string(local(o)) + " of face " + std::to_string(face_of(o)) +
                       ", which is not its twin";
        }
        return std::nullopt;
    }
    /// Checks v's anchor: a live corner of v, and where v's fan starts if it is open.
    std::optional<std::string> check_vertex(index_t v) const {
        const index_t a = anchor_[v];
        if (a == invalid_index) return std::nullopt;
        if (face_of(a) >= faces_.size() || !face_alive(face_of(a)) || vertex_at(a) != v)
            return std::string("anchor is not a live corner of the vertex");
        for (index_t c = a;;) {
            const index_t o = link(prev(c));
            if (o == invalid_index) break;               // open fan
            if ((c = prev(o)) == a) return std::nullopt; // closed fan
        }
        if (link(next(a)) != invalid_index)
            return std::string("open fan, but the anchor is not where it starts");
        return std::nullopt;
    }

    std::size_t memory_bytes() const noexcept {
        return faces_.capacity() * sizeof(face_record) + anchor_.capacity() * sizeof(index_t) +
               valive_.capacity();
    }

    /// As indexed_tri: while parallel workers share the backend, removed slots are not
    /// recycled (the free lists would be shared state).
    void set_slot_recycling(bool on) noexcept {
        vertex_alloc_.set_recycling(on), face_alloc_.set_recycling(on);
    }

    /// As indexed_tri: prepares for `workers` concurrent workers that may add simplices.
    /// The arrays grow once, here, by that many dead slots, dealt out to per-worker pools
    /// (the undo log's `pool` picks one): no reallocation, no atomics. Recycling is
    /// off until end_parallel.
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

    // Slots are reused as in indexed_tri: from the worker's pool in a parallel phase,
    // else dead slots newest first (when recycling is on), else appended. A reused face
    // slot keeps counting versions, so old tuples to it stay stale.
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

    index_t add_face(const tri_indices& f, undo_log& log) {
        const auto [id, source] = face_alloc_.acquire(face_slots(), log.pool);
        log.push(undo_entry::what::face_acquired, id, index_t(source));
        if (source == detail::slot_source::appended) {
            faces_.push_back({f, 0, {invalid_index, invalid_index, invalid_index}, 0});
        } else {
            save_face(id, log);
            face_record& r = faces_[id];
            r.v = f;
            r.opp = {invalid_index, invalid_index, invalid_index};
            bump_version(r);
        }
        for (index_t j = 0; j < 3; ++j)
            if (anchor_[f[j]] == invalid_index) set_anchor(f[j], corner(id, j), log);
        for (index_t j = 0; j < 3; ++j) attach(corner(id, j), log);
        return id;
    }

    void remove_face(index_t f, undo_log& log) {
        save_face(f, log);
        const face_record old = faces_[f];
        faces_[f].v = {invalid_index, invalid_index, invalid_index};
        faces_[f].opp = {invalid_index, invalid_index, invalid_index};
        bump_version(faces_[f]);
        for (index_t i = 0; i < 3; ++i)
            if (const index_t t = old.opp[i]; t != invalid_index) detach_twin(t, log);
        if (face_alloc_.release(f)) log.push(undo_entry::what::face_released, f);
        for (index_t i = 0; i < 3; ++i)
            if (const index_t a = anchor_[old.v[i]]; a != invalid_index && face_of(a) == f)
                relocate_anchor(old.v[i], old, i, log);
    }

    /// Rewrites a face in place (same slot, new version). A half-edge the face keeps
    /// keeps its twin (moving to its new corner); the others are unlinked and relinked.
    void set_face(index_t f, const tri_indices& nv, undo_log& log) {
        save_face(f, log);
        const face_record old = faces_[f];
        face_record& r = faces_[f];
        r.v = nv;
        r.opp = {invalid_index, invalid_index, invalid_index};
        bump_version(r);
        bool kept[3] = {false, false, false};
        index_t lost[3] = {invalid_index, invalid_index, invalid_index};
        for (index_t i = 0; i < 3; ++i) {
            const index_t x = old.v[(i + 1) % 3], y = old.v[(i + 2) % 3], t = old.opp[i];
            index_t j = 0;
            while (j < 3 && !(nv[(j + 1) % 3] == x && nv[(j + 2) % 3] == y)) ++j;
            if (j == 3) {
                lost[i] = t;
                continue;
            }
            kept[j] = true;
            r.opp[j] = t;
            if (t != invalid_index && j != i) set_link(t, corner(f, j), log);
        }
        // Anchors into this face first (every later step may read them): vertices that
        // left move elsewhere, vertices that stayed follow their corner, vertices that
        // arrived take this face if they had none.
        for (index_t i = 0; i < 3; ++i) {
            const index_t v = old.v[i], a = anchor_[v];
            if (a == invalid_index || face_of(a) != f) continue;
            const index_t j = corner_in(nv, v);
            if (j == 3)
                relocate_anchor(v, old, i, log);
            else if (a != corner(f, j))
                set_anchor(v, corner(f, j), log);
        }
        for (index_t j = 0; j < 3; ++j)
            if (anchor_[nv[j]] == invalid_index) set_anchor(nv[j], corner(f, j), log);
        for (index_t j = 0; j < 3; ++j)
            if (kept[j] && r.opp[j] == invalid_index) list_pending(corner(f, j), log);
        for (index_t i = 0; i < 3; ++i)
            if (lost[i] != invalid_index) detach_twin(lost[i], log);
        for (index_t j = 0; j < 3; ++j)
            if (!kept[j]) attach(corner(f, j), log);
    }

    /// Marks a face changed (its geometry moved) so tuples made before go stale.
    void touch_face(index_t f, undo_log& log) {
        save_face(f, log);
        bump_version(faces_[f]);
    }

    void rollback(undo_log& log, std::size_t mark) {
        using w = undo_entry::what;
        auto& entries = log.entries_;
        while (entries.size() > mark) {
            const undo_entry e = entries.back();
            entries.pop_back();
            switch (e.kind) {
            case w::face_saved:
                faces_[e.a].v = e.verts, faces_[e.a].opp = e.opp;
                set_version(faces_[e.a], e.version);
                break;
            case w::opp_set:
                link_ref(e.a) = e.b;
                break;
            case w::anchor_set:
                anchor_[e.a] = e.b;
                break;
            case w::face_acquired:
                if (face_alloc_.undo_acquire(e.a, detail::slot_source(e.b), face_slots(), log.pool))
                    faces_.pop_back();
                break;
            case w::face_released:
                face_alloc_.undo_release(e.a);
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

    friend bool operator==(const corner_table_tri& x, const corner_table_tri& y) {
        return x.faces_ == y.faces_ && x.anchor_ == y.anchor_ && x.valive_ == y.valive_ &&
               x.face_alloc_ == y.face_alloc_ && x.vertex_alloc_ == y.vertex_alloc_;
    }

private:
    /// The arrays grow to the slot counts the pools were dealt from.
    void grow_to(index_t nv, index_t nf) {
        detail::grow_prefaulted(anchor_, nv, invalid_index);
        valive_.resize(nv, 0);
        detail::grow_prefaulted(faces_, nf, dead_face());
    }

    static constexpr face_record dead_face() noexcept {
        return {{invalid_index, invalid_index, invalid_index},
                0,
                {invalid_index, invalid_index, invalid_index},
                0};
    }
    static void set_version(face_record& r, version_t v) noexcept {
        std::atomic_ref<version_t>(r.version).store(v, std::memory_order_relaxed);
    }
    static void bump_version(face_record& r) noexcept { set_version(r, r.version + 1); }
    index_t vertex_at(index_t c) const noexcept { return faces_[face_of(c)].v[local(c)]; }
    index_t link(index_t c) const noexcept { return faces_[face_of(c)].opp[local(c)]; }
    index_t& link_ref(index_t c) noexcept { return faces_[face_of(c)].opp[local(c)]; }
    static index_t corner_in(const tri_indices& f, index_t v) noexcept {
        return f[0] == v ? 0 : (f[1] == v ? 1 : (f[2] == v ? 2 : 3));
    }
    /// v's corner in face g, or invalid_index if g is out of range, dead or lacks v.
    index_t corner_of(index_t g, index_t v) const noexcept {
        if (g >= faces_.size()) return invalid_index;
        const index_t i = corner_in(faces_[g].v, v);
        return i == 3 ? invalid_index : corner(g, i);
    }
    /// Is c a live corner whose half-edge has no twin yet?
    bool unlinked(index_t c) const noexcept {
        return face_of(c) < faces_.size() && faces_[face_of(c)].v[0] != invalid_index &&
               link(c) == invalid_index;
    }
    /// Is c a live corner whose unlinked half-edge enters v?
    bool enters(index_t c, index_t v) const noexcept {
        return unlinked(c) && vertex_at(prev(c)) == v;
    }
    /// Does the half-edge opposite c run from x to y?
    bool runs(index_t c, index_t x, index_t y) const noexcept {
        return vertex_at(next(c)) == x && vertex_at(prev(c)) == y;
    }

    void save_face(index_t f, undo_log& log) {
        const face_record& r = faces_[f];
        log.push(undo_entry::what::face_saved, f, 0, r.version, r.v, r.opp);
    }
    void set_link(index_t c, index_t value, undo_log& log) {
        log.push(undo_entry::what::opp_set, c, link(c));
        link_ref(c) = value;
    }
    void set_anchor(index_t v, index_t c, undo_log& log) {
        log.push(undo_entry::what::anchor_set, v, anchor_[v]);
        anchor_[v] = c;
    }
    /// The half-edge opposite c has no twin: list it, and if the vertex it enters has
    /// its anchor at a linked corner, anchor that vertex here (its fan may start here).
    void list_pending(index_t c, undo_log& log) {
        const index_t h = prev(c), w = vertex_at(h), a = anchor_[w];
        log.pending_.push_back(
            {c, vertex_at(next(c)), w, static_cast<std::uint32_t>(log.entries_.size())});
        if (a != h && (a == invalid_index || link(next(a)) != invalid_index)) set_anchor(w, h, log);
    }
    /// Links the half-edges opposite c and d (c's own link is written directly: its face
    /// was saved in this mutation). A vertex anchored at the corner whose entering
    /// half-edge just got a twin re-anchors where another of its half-edges still waits.
    void link_pair(index_t c, index_t d, undo_log& log, bool c_saved) {
        if (c_saved)
            link_ref(c) = d;
        else
            set_link(c, d, log);
        set_link(d, c, log);
        for (const index_t h : {prev(c), prev(d)}) {
            const index_t w = vertex_at(h);
            if (anchor_[w] != h) continue;
            for (const auto& p : log.pending_)
                if (p.to == w && enters(p.corner, w)) {
                    set_anchor(w, prev(p.corner), log);
                    break;
                }
        }
    }

    /// The half-edge at t lost its twin: unlink it, then link it to a pending half-edge
    /// running the other way, or list it. (A boundary half-edge the operation has not
    /// touched cannot be its twin: before the operation its edge had two faces.)
    void detach_twin(index_t t, undo_log& log) {
        set_link(t, invalid_index, log);
        const index_t d = find_pending(vertex_at(next(t)), vertex_at(prev(t)), log);
        if (d == invalid_index) return list_pending(t, log);
        link_pair(t, d, log, false);
    }

    /// Links the new half-edge x->y opposite corner c (whose face was saved in this
    /// mutation) to its twin y->x: a pending half-edge, or a boundary half-edge the
    /// operation has not touched, which can only be the one entering x at x's anchor
    /// (see the top of the file). Otherwise lists it.
    void attach(index_t c, undo_log& log) {
        const index_t x = vertex_at(next(c)), y = vertex_at(prev(c));
        index_t d = find_pending(x, y, log);
        if (d == invalid_index) {
            const index_t a = anchor_[x];
            if (a != invalid_index && link(next(a)) == invalid_index && vertex_at(prev(a)) == y)
                d = next(a);
        }
        if (d == invalid_index) return list_pending(c, log);
        link_pair(c, d, log, true);
    }

    /// A pending half-edge y->x, taken off the list. Entries are compared by the
    /// vertices they had when listed, then checked: one that has been linked, died or
    /// been rewritten since is dropped.
    index_t find_pending(index_t x, index_t y, undo_log& log) const {
        auto& p = log.pending_;
        for (std::size_t k = 0; k < p.size();) {
            if (p[k].from != y || p[k].to != x) {
                ++k;
                continue;
            }
            const index_t d = p[k].corner;
            p.erase(p.begin() + static_cast<std::ptrdiff_t>(k)); // keeps the order
            if (unlinked(d) && runs(d, y, x)) return d;
        }
        return invalid_index;
    }

    /// v's anchor was in the face whose record before the change is `old` (v at corner
    /// i); that face no longer holds v. Prefers a corner where a pending half-edge
    /// enters v (where v's fan may now start). See the top of the file for why this
    /// finds a face of v whenever v still has one.
    void relocate_anchor(index_t v, const face_record& old, index_t i, undo_log& log) {
        for (const auto& p : log.pending_)
            if (p.to == v && enters(p.corner, v)) return set_anchor(v, prev(p.corner), log);
        for (index_t k : {(i + 1) % 3, (i + 2) % 3}) // the two edges of the face at v
            if (const index_t t = old.opp[k]; t != invalid_index)
                if (const index_t c = corner_of(face_of(t), v); c != invalid_index)
                    return set_anchor(v, c, log);
        for (const auto& p : log.pending_)
            if (const index_t c = corner_of(face_of(p.corner), v); c != invalid_index)
                return set_anchor(v, c, log);
        using w = undo_entry::what;
        for (auto e = log.entries_.rbegin(); e != log.entries_.rend(); ++e) {
            index_t g;
            // (A reused or pooled slot has its face_saved entry too.)
            if (e->kind == w::face_saved ||
                (e->kind == w::face_acquired &&
                 detail::slot_source(e->b) == detail::slot_source::appended))
                g = e->a;
            else if (e->kind == w::opp_set)
                g = face_of(e->a);
            else
                continue;
            if (const index_t c = corner_of(g, v); c != invalid_index) return set_anchor(v, c, log);
        }
        set_anchor(v, invalid_index, log);
    }

    std::vector<face_record> faces_;
    std::vector<index_t> anchor_; // one corner per vertex, invalid_index without faces
    std::vector<std::uint8_t> valive_;
    detail::slot_allocator vertex_alloc_, face_alloc_;
};

} // namespace idas::backend

template <>
inline constexpr bool
    std::ranges::enable_borrowed_range<idas::backend::corner_table_tri::face_range> = true;

namespace idas::backend {
static_assert(tri_connectivity<corner_table_tri>);
static_assert(std::ranges::forward_range<corner_table_tri::face_range>);
static_assert(std::ranges::borrowed_range<corner_table_tri::face_range>);
} // namespace idas::backend
