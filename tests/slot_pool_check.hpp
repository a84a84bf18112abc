// A check shared by the triangle and tet mesh tests: new simplices come from the slot pool
// their undo log names.
#pragma once

#include <idas/core/attribute.hpp>
#include <idas/core/types.hpp>

#include <doctest/doctest.h>

#include <cstddef>

namespace idas::test {

/// The executor sets each operation's pool in its context (op_context::conn.pool); a
/// backend takes it from the log it is handed, never from the running thread. Two logs of
/// two pools on one thread take slots from their own pools and give them back there. `m`
/// has no dead vertex slots, and is left as it came.
template <class Mesh>
void check_slots_come_from_the_logs_pool(Mesh& m) {
    const index_t v0 = m.vertex_slots();
    const std::size_t vertices = m.n_vertices();
    m.begin_parallel(2, 4, 4); // new vertex slots v0, v0 + 1 (pool 0) and v0 + 2, v0 + 3 (pool 1)
    typename Mesh::undo_log first, second;
    first.pool = 0, second.pool = 1;
    attribute_journal attrs; // the new slots' attribute resets (not rolled back here)
    CHECK(m.has_room(2, 2, 1));
    CHECK_FALSE(m.has_room(3, 0, 1));
    CHECK(m.add_vertex(second, attrs) == v0 + 2);
    CHECK(m.add_vertex(first, attrs) == v0);
    CHECK(m.add_vertex(second, attrs) == v0 + 3);
    CHECK_FALSE(m.has_room(1, 0, 1));
    CHECK(m.has_room(1, 0, 0));
    m.rollback(second, 0); // both of pool 1's slots go back to pool 1
    CHECK(m.has_room(2, 0, 1));
    CHECK(m.add_vertex(second, attrs) == v0 + 2);
    m.rollback(second, 0);
    m.rollback(first, 0);
    m.end_parallel();
    CHECK(m.n_vertices() == vertices);
}

} // namespace idas::test
