// Pieces the decimation specs share.
#pragma once

#include <idas/algorithms/attribute_transfer.hpp>

#include <idas/exec/executor.hpp>
#include <idas/invariants/no_self_intersection.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <utility>
#include <vector>

namespace idas::algorithms {

/// After a collapse into a, every edge of a's new star changed: the spokes (a,
/// x) and the rim edges (x, y) opposite a. Each is pushed once.
template <class Op, class Mesh, class Push>
void push_star_edges(const Mesh& m, const op_result<typename Mesh::tuple>& r, Push& push) {
    const bool open_fan = m.is_boundary_vertex(r.anchor.vid);
    for (const auto& spoke : r.cells) {
        push(Op{}, spoke); // (a, next)
        push(Op{},
             m.switch_edge(m.switch_vertex(spoke))); // the rim edge opposite a
        // In an open fan one spoke (prev, a) is on the boundary and in no other
        // cell.
        if (open_fan) {
            const auto prev = m.switch_edge(spoke);
            if (m.is_boundary_edge(prev)) push(Op{}, prev);
        }
    }
}

/// Edges an invariant refused, remembered by their endpoints: a later collapse
/// next to one pushes it again, since its neighbourhood changed and it may pass
/// now (at 1% of the input, QSlim's distance to the input is ~25% worse without
/// these retries). Written by the worker that holds both endpoints, so safe in
/// parallel.
struct refusal_memory {
    std::vector<std::uint8_t> refused_at;

    template <class Mesh>
    void forget_refusals(const Mesh& m) {
        refused_at.assign(m.vertex_slots(), 0);
    }
    template <class Mesh>
    void refused(op::collapse_edge, const Mesh& m, const typename Mesh::tuple& t) {
        const auto [a, b] = m.edge_vertices(t);
        refused_at[a] = refused_at[b] = 1;
    }
    bool maybe_refused(std::pair<index_t, index_t> e) const noexcept {
        const auto n = refused_at.size();
        return e.first < n && e.second < n && refused_at[e.first] && refused_at[e.second];
    }
};

/// Decimation queues name every edge by one canonical tuple: in the face where
/// the edge runs from its smaller to its larger vertex id (the only face, on
/// the boundary). A collapse rewrites just the faces of the merged vertex's
/// star, so a queued rim edge whose canonical face lies outside the star is
/// still valid, with an unchanged priority (its length and its vertices'
/// quadrics are untouched), and need not be pushed again. That halves the rim
/// pushes, which were nine tenths stale.
template <class Mesh>
bool runs_upwards(const Mesh& m, const typename Mesh::tuple& t) {
    const auto& fv = m.face_vertices(t.fid);
    return fv[(t.local_edge + 1) % 3] < fv[(t.local_edge + 2) % 3];
}

/// The edges whose smaller vertex is v, each once by its canonical tuple: over all
/// vertices, every edge once. A spec's `initial_at` uses it so that parallel workers
/// find the initial entries of their own part's vertices, without a serial edge scan.
template <class Mesh, class Fn>
void for_each_edge_from(const Mesh& m, index_t v, Fn&& fn) {
    // Around v each face has corners (v, next, prev). An edge (v, x) runs upwards in the
    // face where x is next; it has no such face only on the boundary, where its one
    // face has x as prev.
    boost::container::small_vector<index_t, 16> nexts;
    for (index_t f : m.vertex_faces(v)) {
        const auto& fv = m.face_vertices(f);
        nexts.push_back(fv[0] == v ? fv[1] : fv[1] == v ? fv[2] : fv[0]);
    }
    std::size_t k = 0;
    for (index_t f : m.vertex_faces(v)) {
        const auto& fv = m.face_vertices(f);
        const int i = fv[0] == v ? 0 : fv[1] == v ? 1 : 2;
        const index_t next = nexts[k++], prev = fv[(i + 2) % 3];
        // Local edge le joins corners le + 1 and le + 2: (v, next) is le = i + 2 and
        // (prev, v) is le = i + 1.
        if (v < next) fn(m.tuple_from_edge(f, std::uint8_t((i + 2) % 3)));
        if (v < prev && std::find(nexts.begin(), nexts.end(), prev) == nexts.end())
            fn(m.tuple_from_edge(f, std::uint8_t((i + 1) % 3)));
    }
}

/// Every edge once, by its canonical tuple (the initial queue of a decimation).
template <class Op, class Mesh, class Push>
void push_all_edges(const Mesh& m, Push& push) {
    // As for_each_edge (an edge is seen from its smaller half-edge slot), but with one
    // search for the face across per half-edge where for_each_edge and switch_face take two.
    for (index_t f = 0; f < m.face_slots(); ++f) {
        if (!m.face_alive(f)) continue;
        for (std::uint8_t le = 0; le < 3; ++le) {
            const auto t = m.tuple_from_edge(f, le);
            const auto across = m.switch_face(t);
            if (across && 3 * across->fid + across->local_edge < 3 * f + le) continue;
            push(Op{}, runs_upwards(m, t) || !across ? t : *across);
        }
    }
}

/// After a collapse into a: every spoke (a, x), whose priority changed, and the
/// rim edges (x, y) whose canonical face was rewritten. The queue must hold
/// canonical tuples only (push_all_edges first). Each edge is seen from the
/// star face where it runs upwards, or from its only face on the boundary; so
/// no face across an edge need be looked up, except to tell boundary edges
/// apart.
template <class Op, class Mesh, class Push>
void push_changed_edges(const Mesh& m, const op_result<typename Mesh::tuple>& r, Push& push,
                        const refusal_memory& refusals) {
    const bool open_fan = m.is_boundary_vertex(r.anchor.vid);
    for (const auto& spoke : r.cells) {
        const auto back = m.switch_edge(spoke);                 // (prev, a)
        const auto rim = m.switch_edge(m.switch_vertex(spoke)); // (next, prev)
        // Each interior spoke is (a, next) in one cell and (prev, a) in the other,
        // and runs upwards in just one of them; a boundary spoke is in one cell
        // only.
        for (const auto& e : {spoke, back})
            if (runs_upwards(m, e) || (open_fan && m.is_boundary_edge(e))) push(Op{}, e);
        if (runs_upwards(m, rim) || m.is_boundary_edge(rim)) {
            push(Op{}, rim);
        } else if (refusals.maybe_refused(m.edge_vertices(rim))) {
            // Its queued entry may be gone (refused earlier); its neighbourhood
            // changed, so it may pass now. A duplicate, if the entry is still queued,
            // is harmless.
            push(Op{}, *m.switch_face(rim));
        }
    }
}

/// Stops a decimation once the live face count reaches the target. In parallel the
/// workers stop `serial_tail` faces earlier and the executor's final serial pass makes the
/// last collapses. Each part's queue orders only its own edges, and once the parts are a
/// few hundred faces each, workers also block each other's regions (entries that keep
/// losing races leave the parallel run); so a parallel run to the end collapsed costly
/// edges in one part while cheap ones waited elsewhere: QSlim to 1% of a subdivided cube
/// on 8 threads ended 0.06-0.4 of the diagonal from the input, 1e-13 on one thread. The
/// last collapses are the costliest, so they run in the serial pass's one global order.
struct face_target {
    std::int64_t target_faces = 0;
    std::int64_t serial_tail = 0; // set by plan_serial_tail
    /// Faces left to the serial pass: a quarter of the target (at most a quarter of the
    /// faces to remove), plus `tail_faces_per_part` for each part. The per-part faces keep
    /// small meshes' results near the serial ones (bench/RESULTS.md, "Parallel decimation
    /// quality"); the quarter bounds the serial fraction of large runs by Amdahl's law:
    /// with all of the target, QSlim to 10% made 12% of its collapses in the serial pass
    /// (16 cores: 2.6 of 6.0 s at 8 threads), with a quarter 3%, and a run to more than
    /// half of its input was serial at any thread count.
    static constexpr std::int64_t tail_faces_per_part = 512;
    static constexpr std::int64_t tail_share_of_target_inverse = 4;
    /// A mesh that starts with at most this many faces is decimated serially at any
    /// thread count (the whole run is the serial tail, so the executor starts no workers).
    /// Parts of a few thousand faces chose their collapses among a few hundred edges each,
    /// and one run in five or ten ended 1.12-1.16x the serial run's Hausdorff distance on
    /// bunny.off (6,966 faces) and the 12,288-face box, to save milliseconds. The size is
    /// the deterministic policy's serial tail (16,384); a larger mesh's tail was not made
    /// as large, since that did not bring it closer to the serial result (bench/RESULTS.md,
    /// "Session 43"). 0 runs small meshes in parallel (the tests load their workers that
    /// way).
    static constexpr std::int64_t default_serial_up_to_faces =
        lock::deterministic_rounds::serial_tail_faces;
    std::int64_t serial_up_to_faces = default_serial_up_to_faces;
    void plan_serial_tail(const exec_options& o, std::int64_t faces) noexcept {
        const std::int64_t parts = std::int64_t(o.threads) * std::max(1u, o.parts_per_thread);
        const std::int64_t share =
            std::min(target_faces, std::max<std::int64_t>(0, faces - target_faces)) /
            tail_share_of_target_inverse;
        // Deterministic rounds meet the target themselves, best first, on any thread count.
        if (o.threads <= 1 || o.deterministic)
            serial_tail = 0;
        else if (faces <= serial_up_to_faces)
            serial_tail = faces;
        else
            serial_tail = share + tail_faces_per_part * parts;
    }
    bool stop(const progress& p) const noexcept { return p.faces <= target_faces; }
    /// The parallel workers' goal. A collapse removes two faces (one on the boundary).
    std::int64_t remaining(const progress& p) const noexcept {
        return (p.faces - target_faces - serial_tail) / 2;
    }
};

/// The schedule both decimations share: every edge first; after a collapse, the edges it
/// changed; stop at the target face count.
struct collapse_schedule : face_target, refusal_memory {
    /// A: the file's attributes, carried through the collapses (none when null).
    const attribute_transfer* transfer = nullptr;
    /// I: no collapse makes faces meet (disabled unless made from an index of the mesh).
    no_self_intersection self_intersections;

    /// Between operations: the index's cells follow the faces as they grow.
    template <class Mesh>
    void quiescent(Mesh& m, const progress& p) {
        self_intersections.refit(m, p.faces);
    }

    template <class Mesh, class Push>
    void initial(const Mesh& m, Push& push) const {
        push_all_edges<op::collapse_edge>(m, push);
    }
    template <class Mesh, class Push>
    void renew(op::collapse_edge, const Mesh& m, const op_result<typename Mesh::tuple>& r,
               Push& push) const {
        push_changed_edges<op::collapse_edge>(m, r, push, *this);
    }
};

} // namespace idas::algorithms
