// A spec's operation kinds, as a type list. A queue entry names its operation by its
// position in the list, and dispatch is a fold over the list: no registry of kinds, no
// string, no virtual call.
#pragma once

#include <idas/ops/operation.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

namespace idas {

template <operation_kind... Ops>
struct op_list {};

namespace detail {

template <class L>
struct op_list_traits {
    static constexpr bool is_op_list = false;
};

template <class... Ops>
struct op_list_traits<op_list<Ops...>> {
    static constexpr bool is_op_list = true;
    static constexpr std::size_t size = sizeof...(Ops);
    static_assert(size > 0, "idas: a spec's `operations` lists at least one operation kind");
    static_assert(size <= 255, "idas: at most 255 operation kinds per spec");

    template <class Op>
    static constexpr bool contains = (std::is_same_v<Op, Ops> || ...);

    /// The position of Op in the list: what a queue entry stores.
    template <class Op>
    static constexpr std::uint8_t id_of = [] {
        static_assert(contains<Op>, "idas: this operation kind is not in the spec's `operations`");
        std::uint8_t i = 0;
        ((std::is_same_v<Op, Ops> ? false : (++i, true)) && ...);
        return i;
    }();

    /// Calls fn(Op{}) for the Op at position `kind`; false if none is there.
    template <class Fn>
    static bool dispatch(std::uint8_t kind, Fn&& fn) {
        return [&]<std::size_t... I>(std::index_sequence<I...>) {
            return ((kind == I ? (fn(Ops{}), true) : false) || ...);
        }
        (std::index_sequence_for<Ops...>{});
    }
    template <class Fn>
    static void for_each(Fn&& fn) {
        (fn(Ops{}), ...);
    }
    static constexpr bool adds_simplices = ((Ops::adds_vertices + Ops::adds_faces > 0) || ...);
    static constexpr bool adds_vertices = ((Ops::adds_vertices > 0) || ...);
    /// The most top cells one operation of the list adds.
    static constexpr index_t most_faces_added = std::max({index_t(Ops::adds_faces)...});
    static constexpr bool changes_connectivity = (idas::changes_connectivity<Ops> || ...);

    /// Whether the entry kind at `kind` acts on a vertex (its entry follows the vertex,
    /// not the cell its tuple was made in).
    static bool acts_on_vertex(std::uint8_t kind) noexcept {
        static constexpr bool table[] = {(Ops::acts_on == simplex_kind::vertex)...};
        return kind < size && table[kind];
    }
};

} // namespace detail
} // namespace idas
