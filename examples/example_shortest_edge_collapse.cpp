// Shortest edge collapse written out as an IDAS spec, like the paper's first listing,
// then run serially and on two threads by changing one template argument.
//
//   usage: example_shortest_edge_collapse IN OUT [RATIO]
#include <idas/algorithms/decimation_common.hpp>
#include <idas/idas.hpp>
#include <idas/io/io.hpp>

#include <fmt/core.h>

#include <string>

using mesh = idas::tri_mesh<>;
using tuple = mesh::tuple;
namespace op = idas::op;

struct shortest_edge_collapse {
    using operations = idas::op_list<op::collapse_edge>; // S: which operations
    std::int64_t target_faces = 0;

    // I: the link condition is always enforced; add "no normal flip".
    auto invariants() const { return idas::invariant_set<idas::no_normal_flip>{}; }

    // D: shortest edges first.
    double priority(op::collapse_edge, const mesh& m, const tuple& t) const {
        auto [a, b] = m.edge_vertices(t);
        return idas::squared_norm(m.position(a) - m.position(b));
    }

    // A: the merged vertex sits at the midpoint.
    std::optional<idas::vec3> before(op::collapse_edge, const mesh& m, const tuple& t) const {
        auto [a, b] = m.edge_vertices(t);
        return (m.position(a) + m.position(b)) * 0.5;
    }
    bool after(op::collapse_edge, mesh& m, const idas::op_result<tuple>& r,
               const idas::vec3& p) const {
        m.positions(r).set(r.anchor.vid, p);
        return true;
    }

    // S: after a success, the new star's edges go back into the queue; stop at the target.
    template <class Push>
    void renew(op::collapse_edge, const mesh& m, const idas::op_result<tuple>& r,
               Push& push) const {
        idas::algorithms::push_star_edges<op::collapse_edge>(m, r, push);
    }
    bool stop(const idas::progress& p) const { return p.faces <= target_faces; }
};

// The algorithm is a type: spec, data structure, lock, queue and partition policies.
using serial =
    idas::executor<shortest_edge_collapse, mesh, idas::lock::none, idas::queue::dary_heap<4>>;
using parallel = idas::executor<shortest_edge_collapse, mesh, idas::lock::vertex_try_lock,
                                idas::queue::dary_heap<4>, idas::partition::morton>;

int main(int argc, char** argv) {
    if (argc < 3) {
        fmt::print(stderr, "usage: {} IN OUT [RATIO]\n", argv[0]);
        return 2;
    }
    try {
        const auto input = idas::io::read_surface(argv[1]);
        const double ratio = argc > 3 ? std::stod(argv[3]) : 0.1;
        for (unsigned threads : {1u, 2u}) {
            mesh m(input.vertices, input.faces);
            shortest_edge_collapse spec;
            spec.target_faces = static_cast<std::int64_t>(ratio * double(m.n_faces()));
            const auto r =
                threads == 1 ? serial::run(m, spec) : parallel::run(m, spec, {.threads = threads});
            fmt::print("{} thread(s): {} -> {} faces in {:.3f} s ({} collapses)\n", threads,
                       input.faces.size(), m.n_faces(), r.seconds, r.succeeded);
            if (threads == 1) {
                auto [V, F] = m.to_arrays();
                idas::io::write_surface(argv[2], {std::move(V), std::move(F)});
            }
        }
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 2;
    }
    return 0;
}
