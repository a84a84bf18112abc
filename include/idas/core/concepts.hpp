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
/// Nothing above mesh/ depends on anything but this concept.
template <class B>
concept tri_connectivity =
    std::default_initializable<B> && std::copyable<B> &&
    requires(B b, const B cb, index_t i, std::uint8_t le, tri_indices f,
             typename B::undo_log log, std::size_t mark, const std::vector<tri_indices>& faces) {
        typename B::undo_log;
        { log.size() } -> std::convertible_to<std::size_t>;
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
    };

} // namespace idas
