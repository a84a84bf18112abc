// No tet may be flat or inverted: every new tet must be positively oriented, decided by
// the exact orient3d predicate (so no tolerance, and no false accepts near zero volume).
#pragma once

#include <idas/core/types.hpp>
#include <idas/ops/operation.hpp>
#include <idas/predicates/orient.hpp>

namespace idas {

struct positive_orientation {
    struct state {};

    template <class Op, class Mesh, class Result>
    bool after(Op, const Mesh& m, const Result& r, state&) const {
        const auto p = m.positions();
        for (const auto& t : r.cells) {
            const auto& tv = m.tet_vertices(t.tid);
            if (orient3d(p[tv[0]], p[tv[1]], p[tv[2]], p[tv[3]]) <= 0) return false;
        }
        return true;
    }
};

static_assert(invariant<positive_orientation>);

} // namespace idas
