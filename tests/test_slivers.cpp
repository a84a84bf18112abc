// Issue 16 item 5 (a): decimation made slivers (faces of area ~1e-17 along a subdivided
// cube's edges) and folded some of them inward. no_normal_flip now refuses new faces whose
// twice area is below sliver_ratio times their longest edge squared.
#include "test_support.hpp"

#include <idas/algorithms/qslim.hpp>

#include <cmath>
#include <utility>

using namespace idas;
using namespace idas::algorithms;

namespace {

/// Faces of a unit cube's surface that are slivers or face into the cube (their normal
/// against the outward direction of the nearest side).
template <class Mesh>
std::pair<int, int> slivers_and_inward(const Mesh& m) {
    int slivers = 0, inward = 0;
    m.for_each_face([&](const typename Mesh::tuple& t) {
        if (is_sliver(m, t.fid)) ++slivers;
        const auto& fv = m.face_vertices(t.fid);
        const vec3 c = (m.position(fv[0]) + m.position(fv[1]) + m.position(fv[2])) / 3.0;
        int axis = 0;
        double best = 1;
        for (int k = 0; k < 3; ++k)
            for (double side : {0.0, 1.0})
                if (std::abs(c[k] - side) < best) best = std::abs(c[k] - side), axis = k;
        vec3 out{};
        out[axis] = c[axis] < 0.5 ? -1 : 1;
        if (!(dot(face_normal_unnormalised(m, t.fid), out) > 0)) ++inward;
    });
    return {slivers, inward};
}

} // namespace

TEST_CASE_TEMPLATE("QSlim on a subdivided cube leaves no slivers and no inward faces", Mesh,
                   IDAS_TRI_MESHES) {
    const auto in = idas::test::subdivided_cube<Mesh>(32);
    for (double ratio : {0.1, 0.01}) {
        CAPTURE(ratio);
        Mesh m = in;
        qslim_spec spec;
        spec.target_faces = static_cast<std::int64_t>(double(m.n_faces()) * ratio);
        qslim<Mesh, lock::none>::run(m, spec);
        CHECK(std::int64_t(m.n_faces()) <= spec.target_faces + 1);
        const auto [slivers, inward] = slivers_and_inward(m);
        CHECK(slivers == 0);
        CHECK(inward == 0);
    }
}
