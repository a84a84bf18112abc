// `idas tetmesh` and idas.tetmesh: the full run (tool/tetmesh.hpp), compiled once for both.
#include "tetmesh.hpp"

#include <string>
#include <utility>
#include <vector>

#if IDAS_CLI_HAVE_CGAL
namespace idas::tool {

tetmeshed tetmesh_volume(const idas::io::surface& s, const std::string& source,
                         const tetmesh_options& a, const tetmesh_setup& setup,
                         const round_observer* observer) {
    idas::tetmesh::quality_options q;
    q.stop_energy = a.stop_energy, q.max_iterations = a.max_iterations;
    q.stall_rounds = a.stall_rounds;
    q.threads = a.threads, q.keep_outside = a.keep_outside;
    q.sizing = setup.sizing ? &*setup.sizing : nullptr;
    idas::tetmesh::volume_mesh res =
        idas::tetmesh::mesh_volume(s.vertices, s.faces, setup.options, q, source,
                                   [observer](unsigned round, double max_energy) {
                                       if (observer) (*observer)(round, max_energy);
                                   });
    check_insertion_guarantee(res.insertion);
    tetmeshed out;
    out.insertion = res.insertion;
    out.quality = res.quality;
    idas::io::volume& v = out.mesh;
    v.vertices = std::move(res.vertices);
    for (std::size_t t = 0; t < res.tets.size(); ++t)
        if (a.keep_outside || res.inside[t]) {
            v.tets.push_back(res.tets[t]);
            v.tags.push_back(res.inside[t] ? 1 : 2);
        }
    if (!a.keep_outside) { // drop the vertices only outside tets used
        std::vector<idas::index_t> id(v.vertices.size(), idas::invalid_index);
        std::vector<idas::vec3> kept;
        for (auto& t : v.tets)
            for (auto& x : t) {
                if (id[x] == idas::invalid_index)
                    id[x] = idas::index_t(kept.size()), kept.push_back(v.vertices[x]);
                x = id[x];
            }
        v.vertices = std::move(kept);
    }
    return out;
}

} // namespace idas::tool
#endif
