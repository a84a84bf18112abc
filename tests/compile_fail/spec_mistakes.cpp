// A new user's split spec with a 10-degree minimum-angle invariant, and one mistake per
// MISTAKE value. Each mistake used to compile and be skipped silently (or fail without a
// reason); now each must fail to compile with a message naming the hook. MISTAKE 0 is the
// correct spec, which must compile. tests/CMakeLists.txt builds each and checks the message.
#include <idas/core/geometry.hpp>
#include <idas/exec/executor.hpp>
#include <idas/mesh/tri_mesh.hpp>

#include <algorithm>
#include <numbers>
#include <optional>

namespace user {

using namespace idas;
using mesh = tri_mesh<>;

struct min_angle {
#if MISTAKE != 7
    struct state {};
#endif
    double limit = 10 * std::numbers::pi / 180;
#if MISTAKE == 1 // the new cells' mesh taken as mutable: never called
    template <class Op>
    bool after(Op, mesh& m, const op_result<mesh::tuple>& r, auto&) const {
#else
    template <class Op>
    bool after(Op, const mesh& m, const op_result<mesh::tuple>& r, auto&) const {
#endif
        for (const auto& c
             : r.cells) {
            const auto & f = m.face_vertices(c.fid);
    const auto a = triangle_angles(m.position(f[0]), m.position(f[1]), m.position(f[2]));
    if (std::min({a[0], a[1], a[2]}) < limit) return false;
} return true;
} // namespace user
}
;

struct wrong_cache {};

struct split_spec {
#if MISTAKE != 6
    using operations = op_list<op::split_edge>;
#endif
    double L = 0.01;

#if MISTAKE == 2 // the mesh taken as mutable: ignored, every priority 0
    double priority(op::split_edge, mesh& m, const mesh::tuple& t) const {
#else
    double priority(op::split_edge, const mesh& m, const mesh::tuple& t) const {
#endif
        const auto [a, b] = m.edge_vertices(t);
        return -squared_norm(m.position(a) - m.position(b));
    }
    template <class Mesh>
    std::optional<vec3> before(op::split_edge, const Mesh& m, const typename Mesh::tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        if (squared_norm(m.position(a) - m.position(b)) < L * L) return std::nullopt;
        return (m.position(a) + m.position(b)) * 0.5;
    }
    template <class Mesh>
#if MISTAKE == 3 || MISTAKE == 5 // the wrong cache type: never called, vertices at the origin
    bool after(op::split_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const wrong_cache&) const {
        (void)m, (void)r;
        return true;
    }
#elif MISTAKE == 4 // tagged with an operation the spec does not list: never called
    bool after(op::collapse_edge, Mesh& m, const op_result<typename Mesh::tuple>& r,
               const vec3& p) const {
        m.positions(r).set(r.anchor.vid, p);
        return true;
    }
#elif MISTAKE == 9 // written past the operation's journal: a refused split would keep it
bool after(op::split_edge, Mesh& m, const op_result<typename Mesh::tuple>& r, const vec3& p) const {
    m.positions().set(r.anchor.vid, p);
    return true;
}
#else
bool after(op::split_edge, Mesh& m, const op_result<typename Mesh::tuple>& r, const vec3& p) const {
    m.positions(r).set(r.anchor.vid, p);
    return true;
}
#endif
#if MISTAKE != 5
    auto invariants() const {
        return invariant_set<min_angle>{};
    }
#endif
};

#if MISTAKE == 8 // a decorated spec passed to the undecorated algorithm: sliced to its base
struct counting_spec : split_spec {
    int stops = 0;
    bool stop(const progress&) { return ++stops < 0; }
};
#endif

} // namespace user

int main() {
    using user::mesh;
    mesh m({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
    using algorithm = idas::executor<user::split_spec, mesh>;
#if MISTAKE == 8
    user::counting_spec spec;
#else
    user::split_spec spec;
#endif
    return int(algorithm::run(m, spec).succeeded > 0 ? 0 : 1);
}
