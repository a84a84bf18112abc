// The C++20 concepts every policy of idas is checked against.
#pragma once

#include <idas/core/tuple.hpp>
#include <idas/core/types.hpp>

#include <concepts>
#include <cstddef>
#include <ranges>
#include <vector>

namespace idas {

/// A triangle connectivity backend: owns vertex/face slots and their incidence, and
/// journals each change in a per-thread undo log so it can be rolled back exactly.
/// Nothing above mesh/ depends on anything but this concept. `vertex_faces` may be any
/// forward range (a stored list or a circulation); the undo log is anything with
/// size(), reserve() and a truncating resize() (what a transaction commits with).
// clang-format off
template <class B>
concept tri_connectivity =
    std::default_initializable<B> && std::copyable<B> &&
    requires(B b, const B cb, index_t i, std::uint8_t le, tri_indices f,
             typename B::undo_log log, std::size_t mark, const std::vector<tri_indices>& faces) {
        typename B::undo_log;
        { log.size() } -> std::convertible_to<std::size_t>;
        { log.reserve(mark) };
        { log.resize(mark) };
        { cb.vertex_slots() } -> std::convertible_to<index_t>;
        { cb.face_slots() } -> std::convertible_to<index_t>;
        { cb.vertex_alive(i) } -> std::convertible_to<bool>;
        { cb.face_alive(i) } -> std::convertible_to<bool>;
        { cb.face_vertices(i) } -> std::convertible_to<tri_indices>;
        { cb.face_version(i) } -> std::convertible_to<version_t>;
        { cb.vertex_faces(i) } -> std::ranges::forward_range;
        { cb.opposite_face(i, le) } -> std::convertible_to<index_t>;
        { cb.memory_bytes() } -> std::convertible_to<std::size_t>;
        { b.build(i, faces) };
        { b.add_vertex(log) } -> std::convertible_to<index_t>;
        { b.add_face(f, log) } -> std::convertible_to<index_t>;
        { b.remove_face(i, log) };
        { b.remove_vertex(i, log) };
        { b.set_face(i, f, log) };
        { b.touch_face(i, log) };
        { b.rollback(log, mark) };
        { b.reserve(i, i) };
        { b.set_slot_recycling(true) };
    };
// clang-format on

} // namespace idas

namespace idas {

/// A tetrahedral connectivity backend: vertex/tet slots, incidence, and the same
/// journaled, exactly reversible mutations as tri_connectivity.
// clang-format off
template <class B>
concept tet_connectivity =
    std::default_initializable<B> && std::copyable<B> &&
    requires(B b, const B cb, index_t i, std::uint8_t lf, tet_indices t,
             typename B::undo_log log, std::size_t mark, const std::vector<tet_indices>& tets) {
        typename B::undo_log;
        { log.size() } -> std::convertible_to<std::size_t>;
        { log.reserve(mark) };
        { log.resize(mark) };
        { cb.vertex_slots() } -> std::convertible_to<index_t>;
        { cb.tet_slots() } -> std::convertible_to<index_t>;
        { cb.vertex_alive(i) } -> std::convertible_to<bool>;
        { cb.tet_alive(i) } -> std::convertible_to<bool>;
        { cb.tet_vertices(i) } -> std::convertible_to<tet_indices>;
        { cb.tet_version(i) } -> std::convertible_to<version_t>;
        { cb.vertex_tets(i) } -> std::ranges::forward_range;
        { cb.opposite_tet(i, lf) } -> std::convertible_to<index_t>;
        { cb.memory_bytes() } -> std::convertible_to<std::size_t>;
        { b.build(i, tets) };
        { b.add_vertex(log) } -> std::convertible_to<index_t>;
        { b.add_tet(t, log) } -> std::convertible_to<index_t>;
        { b.remove_tet(i, log) };
        { b.remove_vertex(i, log) };
        { b.set_tet(i, t, log) };
        { b.touch_tet(i, log) };
        { b.rollback(log, mark) };
        { b.reserve(i, i) };
        { b.set_slot_recycling(true) };
    };
// clang-format on

} // namespace idas

namespace idas {

/// What executors and algorithms need of a triangle mesh: tuples, validity,
/// navigation, positions and the journaled mutation entry points (tri_mesh<B> for any
/// tri_connectivity B models it).
template <class M>
concept tri_mesh_like = requires(M m, const M cm, typename M::tuple t, index_t v, bool on) {
    typename M::tuple;
    typename M::undo_log;
    { cm.is_valid(t) } -> std::convertible_to<bool>;
    { cm.vertex_slots() } -> std::convertible_to<index_t>;
    { cm.face_slots() } -> std::convertible_to<index_t>;
    { cm.n_faces() } -> std::convertible_to<std::size_t>;
    { cm.n_vertices() } -> std::convertible_to<std::size_t>;
    { cm.vertex_alive(v) } -> std::convertible_to<bool>;
    { cm.switch_vertex(t) } -> std::same_as<typename M::tuple>;
    { cm.switch_edge(t) } -> std::same_as<typename M::tuple>;
    {cm.switch_face(t)};
    {cm.edge_vertices(t)};
    { cm.vertex_faces(v) } -> std::ranges::forward_range;
    {cm.face_vertices(v)};
    { cm.position(v) } -> std::convertible_to<vec3>;
    {m.set_slot_recycling(on)};
};

} // namespace idas
