// Top cells of either mesh kind, for code that runs on both (the executor, lock claims):
// faces of a triangle mesh, tets of a tetrahedral mesh. Tet meshes are told apart by
// their tet incidence; everything else is a triangle mesh.
#pragma once

#include <idas/core/concepts.hpp>
#include <idas/core/tuple.hpp>
#include <idas/core/types.hpp>

#include <concepts>
#include <cstddef>
#include <ranges>

namespace idas {

namespace detail {
template <class M>
concept has_tets = requires(const M& m, index_t i) {
    { m.vertex_tets(i) } -> std::ranges::forward_range;
    { m.tet_vertices(i) } -> std::convertible_to<tet_indices>;
    { m.n_tets() } -> std::convertible_to<std::size_t>;
};
} // namespace detail

/// What the executor needs of a tetrahedral mesh (tet_mesh<B> models it).
template <class M>
concept tet_mesh_like = detail::has_tets<M> &&
    requires(M m, const M cm, typename M::tuple t, index_t v, bool on) {
    typename M::undo_log;
    { cm.is_valid(t) } -> std::convertible_to<bool>;
    { cm.vertex_slots() } -> std::convertible_to<index_t>;
    { cm.tet_slots() } -> std::convertible_to<index_t>;
    { cm.n_vertices() } -> std::convertible_to<std::size_t>;
    { cm.vertex_alive(v) } -> std::convertible_to<bool>;
    {cm.edge_vertices(t)};
    {cm.face_vertices(t)};
    { cm.position(v) } -> std::convertible_to<vec3>;
    {m.set_slot_recycling(on)};
};

/// Meshes the executor runs on: triangle or tetrahedral.
template <class M>
concept executable_mesh = tri_mesh_like<M> || tet_mesh_like<M>;

namespace cells {

/// The cells around vertex v.
template <class M>
decltype(auto) around(const M& m, index_t v) {
    if constexpr (detail::has_tets<M>)
        return m.vertex_tets(v);
    else
        return m.vertex_faces(v);
}
/// The vertices of cell c.
template <class M>
decltype(auto) vertices(const M& m, index_t c) {
    if constexpr (detail::has_tets<M>)
        return m.tet_vertices(c);
    else
        return m.face_vertices(c);
}
/// The cell a tuple names.
template <class M, class Tuple>
index_t of(const M&, const Tuple& t) noexcept {
    if constexpr (detail::has_tets<M>)
        return t.tid;
    else
        return t.fid;
}
/// Live cells.
template <class M>
std::size_t live(const M& m) {
    if constexpr (detail::has_tets<M>)
        return m.n_tets();
    else
        return m.n_faces();
}
/// Cell slots, live or dead.
template <class M>
std::size_t slots(const M& m) {
    if constexpr (detail::has_tets<M>)
        return m.tet_slots();
    else
        return m.face_slots();
}
/// Backends whose versions may be read while other workers bump them.
template <class M>
inline constexpr bool has_relaxed_versions = requires(const M& m, index_t i) {
    m.connectivity().face_version_relaxed(i);
}
|| requires(const M& m, index_t i) {
    m.connectivity().tet_version_relaxed(i);
};

/// Whether the tuple's cell changed since the tuple was made, read while other workers
/// may bump versions (only backends with relaxed version reads).
template <class M, class Tuple>
bool version_moved_on(const M& m, const Tuple& t) noexcept {
    if constexpr (detail::has_tets<M>)
        return m.connectivity().tet_version_relaxed(t.tid) != t.version;
    else
        return m.connectivity().face_version_relaxed(t.fid) != t.version;
}

} // namespace cells

} // namespace idas
