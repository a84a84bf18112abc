// Builds against the installed idas package: loads a mesh, splits every edge once.
#include <idas/idas.hpp>
#include <idas/io/io.hpp>

#include <cstdio>

int main(int argc, char** argv) {
    if (argc < 2) return 2;
    const auto s = idas::io::read_surface(argv[1]);
    idas::tri_mesh<> m(s.vertices, s.faces);
    const auto faces_before = m.n_faces();
    for (const auto& e : m.get_edges()) (void)idas::split_edge(m, e);
    const bool ok = !idas::find_inconsistency(m) && m.n_faces() > faces_before;
    std::printf("consumer: %zu -> %zu faces, %s\n", faces_before, m.n_faces(),
                ok ? "valid" : "INVALID");
    return ok ? 0 : 1;
}
