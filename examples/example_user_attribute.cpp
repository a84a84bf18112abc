// A user attribute and a user invariant in an IDAS spec: refine a surface by splitting
// long edges, carrying a scalar field (here: the height of each vertex above the lowest
// input vertex, as a stand-in for temperature or a texture coordinate) through the
// splits by linear interpolation, and refusing any split that would make a triangle with
// an angle under a minimum (a user invariant). The field is the user's column: it stays on
// the mesh after the run, and is checked at the end against the exact height.
//
//   usage: example_user_attribute IN [EDGE_LENGTH_RELATIVE] [MIN_ANGLE_DEG]
#include <idas/algorithms/decimation_common.hpp>
#include <idas/core/geometry.hpp>
#include <idas/idas.hpp>
#include <idas/io/io.hpp>

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

using mesh = idas::tri_mesh<>;
using tuple = mesh::tuple;
namespace op = idas::op;

/// I: no new triangle has an angle under `limit` (radians). `state` is per operation.
struct min_angle_invariant {
    double limit = 0;
    struct state {};
    template <class Op>
    bool after(Op, const mesh& m, const idas::op_result<tuple>& r, state&) const {
        for (const auto& c : r.cells) {
            const auto& f = m.face_vertices(c.fid);
            const auto a =
                idas::triangle_angles(m.position(f[0]), m.position(f[1]), m.position(f[2]));
            if (std::min({a[0], a[1], a[2]}) < limit) return false;
        }
        return true;
    }
};

struct refine_with_field {
    using operations = idas::op_list<op::split_edge>;
    double longest = 0;                   // split edges longer than this
    idas::vertex_attribute<double> field; // A: the user's scalar per vertex
    min_angle_invariant angles;

    auto invariants() const { return idas::invariant_set<min_angle_invariant>{angles}; }

    double length2(const mesh& m, const tuple& t) const {
        const auto [a, b] = m.edge_vertices(t);
        return idas::squared_norm(m.position(a) - m.position(b));
    }
    // S: the edges that are too long to start with (the default would queue every edge).
    template <class Push>
    void initial(const mesh& m, Push& push) const {
        m.for_each_edge([&](const tuple& t) {
            if (length2(m, t) > longest * longest) push(op::split_edge{}, t);
        });
    }
    // D: longest first.
    double priority(op::split_edge, const mesh& m, const tuple& t) const { return -length2(m, t); }

    // A, before the split: the new vertex's position and field value (the mesh is const
    // here, so its attributes are read-only).
    struct midpoint {
        idas::vec3 position;
        double value;
    };
    std::optional<midpoint> before(op::split_edge, const mesh& m, const tuple& t) const {
        if (!(length2(m, t) > longest * longest)) return std::nullopt;
        const auto [a, b] = m.edge_vertices(t);
        const auto f = m.attribute(field);
        return midpoint{(m.position(a) + m.position(b)) * 0.5, 0.5 * (f[a] + f[b])};
    }
    // A, after the split: write them (journaled: rolled back if the invariant refuses).
    bool after(op::split_edge, mesh& m, const idas::op_result<tuple>& r, const midpoint& p) const {
        m.positions(r).set(r.anchor.vid, p.position);
        m.attribute(field, r).set(r.anchor.vid, p.value);
        return true;
    }
    // S: the halves and the new spokes may still be too long.
    template <class Push>
    void renew(op::split_edge, const mesh& m, const idas::op_result<tuple>& r, Push& push) const {
        auto long_ones = [&](op::split_edge o, const tuple& t) {
            if (length2(m, t) > longest * longest) push(o, t);
        };
        idas::algorithms::push_star_edges<op::split_edge>(m, r, long_ones);
    }
};

using refine = idas::executor<refine_with_field, mesh, idas::lock::none, idas::queue::dary_heap<4>>;

int main(int argc, char** argv) {
    if (argc < 2) {
        fmt::print(stderr, "usage: {} IN [EDGE_LENGTH_RELATIVE] [MIN_ANGLE_DEG]\n", argv[0]);
        return 2;
    }
    try {
        const auto input = idas::io::read_surface(argv[1]);
        mesh m(input.vertices, input.faces);
        double lo = std::numeric_limits<double>::infinity(), diag2 = 0;
        idas::vec3 bmin = m.position(0), bmax = bmin;
        for (const auto& p : input.vertices) {
            lo = std::min(lo, p.z);
            for (int i = 0; i < 3; ++i)
                bmin[i] = std::min(bmin[i], p[i]), bmax[i] = std::max(bmax[i], p[i]);
        }
        diag2 = idas::squared_norm(bmax - bmin);

        refine_with_field spec;
        spec.longest = (argc > 2 ? std::stod(argv[2]) : 0.005) * std::sqrt(diag2);
        spec.angles.limit = (argc > 3 ? std::stod(argv[3]) : 15.0) * std::numbers::pi / 180;
        spec.field = m.add_vertex_attribute<double>("height", 0.0);
        {
            auto f = m.attribute(spec.field);
            for (idas::index_t v = 0; v < m.vertex_slots(); ++v) f.raw(v) = m.position(v).z - lo;
        }
        const auto r = refine::run(m, spec);

        // The field is linear, so interpolation along edges keeps it exact up to rounding.
        double worst = 0;
        const auto f = std::as_const(m).attribute(spec.field);
        for (idas::index_t v = 0; v < m.vertex_slots(); ++v)
            if (m.vertex_alive(v)) worst = std::max(worst, std::abs(f[v] - (m.position(v).z - lo)));
        fmt::print("{} -> {} faces: {} splits, {} refused by the {:.0f}-degree invariant; "
                   "field error {:.3g} (relative to the diagonal)\n",
                   input.faces.size(), m.n_faces(), r.succeeded, r.refused,
                   spec.angles.limit * 180 / std::numbers::pi, worst / std::sqrt(diag2));
        return worst <= 1e-12 * std::sqrt(diag2) ? 0 : 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 2;
    }
}
