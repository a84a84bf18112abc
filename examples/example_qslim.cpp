// QSlim through the library's spec, plus a user invariant composed at compile time:
// refuse collapses that create a triangle with an angle below 5 degrees.
//
//   usage: example_qslim IN OUT [RATIO]
#include <idas/algorithms/qslim.hpp>
#include <idas/core/geometry.hpp>
#include <idas/idas.hpp>
#include <idas/io/io.hpp>

#include <fmt/core.h>

#include <numbers>

using mesh = idas::tri_mesh<>;

// A user invariant: checked on every face a collapse creates.
struct min_angle {
    struct state {};
    double radians = 5.0 * std::numbers::pi / 180.0;
    bool after(idas::op::collapse_edge, const mesh& m, const idas::op_result<mesh::tuple>& r,
               state&) const {
        for (const auto& t : r.cells) {
            const auto& f = m.face_vertices(t.fid);
            for (double a :
                 idas::triangle_angles(m.position(f[0]), m.position(f[1]), m.position(f[2])))
                if (a < radians) return false;
        }
        return true;
    }
};

// QSlim with one more invariant: everything else is inherited from the library's spec.
struct qslim_min_angle : idas::algorithms::qslim_spec {
    auto invariants() const { return idas::invariant_set<idas::no_normal_flip, min_angle>{}; }
};

using algorithm = idas::executor<qslim_min_angle, mesh, idas::lock::vertex_try_lock,
                                 idas::queue::dary_heap<4>, idas::partition::morton>;

int main(int argc, char** argv) {
    if (argc < 3) {
        fmt::print(stderr, "usage: {} IN OUT [RATIO]\n", argv[0]);
        return 2;
    }
    try {
        const auto input = idas::io::read_surface(argv[1]);
        mesh m(input.vertices, input.faces);
        qslim_min_angle spec;
        spec.target_faces =
            static_cast<std::int64_t>((argc > 3 ? std::stod(argv[3]) : 0.1) * double(m.n_faces()));
        const auto r = algorithm::run(m, spec, {.threads = 2});
        fmt::print("{} -> {} faces in {:.3f} s: {} collapses, {} refused by invariants or link "
                   "condition\n",
                   input.faces.size(), m.n_faces(), r.seconds, r.succeeded, r.refused);
        auto [V, F] = m.to_arrays();
        idas::io::write_surface(argv[2], {std::move(V), std::move(F)});
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 2;
    }
    return 0;
}
