// TetWild-style tetrahedral meshing of a triangle soup, part 1: the soup cleaned, a
// Delaunay background mesh of its vertices and a box around them (CGAL), every triangle
// inserted exactly (algorithms/triangle_insertion.hpp), rational vertices rounded where
// every tet stays positive, and each tet labelled inside or outside by the generalized
// winding number of the soup at its centroid.
//
// Nothing is dropped from the mesh: outside tets are kept with their label (the quality
// optimization needs them), and the tracked surface says which faces cover the input.
#pragma once

#include <idas/algorithms/soup_simplification.hpp>
#include <idas/algorithms/tet_optimization.hpp>
#include <idas/algorithms/triangle_insertion.hpp>
#include <idas/algorithms/winding_number.hpp>
#include <idas/cgal/delaunay.hpp>
#include <idas/exec/partition.hpp>
#include <idas/invariants/envelope.hpp>
#include <idas/mesh/geometry_range.hpp>
#include <idas/mesh/sizing_field.hpp>
#include <idas/mesh/tet_quality.hpp>

#include <boost/container/small_vector.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <vector>

namespace idas::tetmesh {

struct options {
    /// Envelope half-width, relative to the bounding-box diagonal unless `absolute`. The
    /// insertion is exact, so only the optimization (the next stage) uses it.
    double epsilon = 1e-3;
    /// Target edge length, relative to the diagonal unless `absolute`: the spacing of the
    /// points on the background box.
    double edge_length = 1.0 / 20.0;
    bool absolute = false;
    /// Collapse the soup's short edges inside an envelope of 0.8 epsilon before the
    /// insertion, as fTetWild does (the full pipeline only: part 1 alone inserts every
    /// input triangle as it is).
    bool simplify = true;
    /// The same mesh at any thread count: the simplification and the optimization run on
    /// lock::deterministic_rounds instead of vertex_try_lock (the other stages are
    /// deterministic at any thread count already).
    bool deterministic = false;
};

/// No target length below this fraction of the diagonal (the edge length option; a sizing
/// field's smaller values are raised to it): a thousandth already means billions of tets.
inline constexpr double min_relative_length = 1e-3;

/// What the input held and what each stage did, with its seconds.
struct report {
    std::size_t input_vertices = 0, input_faces = 0;
    std::size_t welded_vertices = 0;      ///< exact duplicates merged
    std::size_t degenerate_faces = 0;     ///< collinear corners (exact), dropped
    std::size_t repeated_faces = 0;       ///< same corners as an earlier face, dropped
    std::size_t triangles = 0;            ///< faces left after cleaning
    std::size_t simplified_triangles = 0; ///< inserted: faces left after the simplification
    std::size_t covered_triangles = 0;    ///< exactly covered by tracked faces (checked)
    std::size_t background_tets = 0, cut_tets = 0, refined_tets = 0;
    std::size_t tets = 0, vertices = 0, inside_tets = 0, tracked_faces = 0;
    std::size_t rational_vertices_created = 0, rational_vertices_left = 0;
    std::size_t inverted_tets = 0; ///< exact orient3d <= 0 (always 0)
    double diagonal = 0, epsilon = 0, edge_length = 0;
    /// Cleaning includes building the input's distance tree; the Delaunay stage, the
    /// background's points (its grid) and their tetrahedralization.
    double seconds_cleaning = 0, seconds_simplification = 0, seconds_delaunay = 0,
           seconds_insertion = 0, seconds_rounding = 0, seconds_winding = 0, seconds_check = 0;
};

struct result {
    insertion::inserted_mesh mesh;
    std::vector<std::uint8_t> inside; ///< per tet: winding number above 1/2
    /// Per tet, at its centroid, as far as the label needs it (winding_number::for_label).
    std::vector<double> winding;
    report stats;
};

/// The input soup after cleaning: welded, without degenerate or repeated faces.
struct clean_soup {
    std::vector<vec3> vertices;
    std::vector<tri_indices> faces;
};

namespace detail {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Collinear corners, decided exactly: all three coordinate projections are flat.
inline bool degenerate(const vec3& a, const vec3& b, const vec3& c) {
    return orient2d({a.x, a.y}, {b.x, b.y}, {c.x, c.y}) == 0 &&
           orient2d({a.y, a.z}, {b.y, b.z}, {c.y, c.z}) == 0 &&
           orient2d({a.z, a.x}, {b.z, b.x}, {c.z, c.x}) == 0;
}

} // namespace detail

/// Welds exact duplicates and drops degenerate and repeated faces (counted in `r`).
/// Throws input_error naming `source` for non-finite or out-of-range coordinates, and for
/// a soup with no face of positive area.
inline clean_soup clean(const std::vector<vec3>& vertices, const std::vector<tri_indices>& faces,
                        const std::string& source, report& r) {
    r.input_vertices = vertices.size(), r.input_faces = faces.size();
    if (faces.empty()) throw input_error(source + ": the input has no triangles");
    if (auto why = check_geometry_range(vertices)) throw input_error(source + ": " + *why);
    for (const auto& f : faces)
        for (index_t v : f)
            if (v >= vertices.size()) throw input_error(source + ": a face index is out of range");
    clean_soup s;
    std::map<std::array<double, 3>, index_t> id;
    std::vector<index_t> remap(vertices.size());
    for (std::size_t i = 0; i < vertices.size(); ++i) {
        auto [it, fresh] = id.try_emplace({vertices[i].x, vertices[i].y, vertices[i].z},
                                          index_t(s.vertices.size()));
        if (fresh) s.vertices.push_back(vertices[i]);
        remap[i] = it->second;
    }
    r.welded_vertices = vertices.size() - s.vertices.size();
    std::map<std::array<index_t, 3>, bool> seen;
    for (const auto& f : faces) {
        const tri_indices g{remap[f[0]], remap[f[1]], remap[f[2]]};
        if (g[0] == g[1] || g[1] == g[2] || g[0] == g[2] ||
            detail::degenerate(s.vertices[g[0]], s.vertices[g[1]], s.vertices[g[2]])) {
            ++r.degenerate_faces;
            continue;
        }
        std::array<index_t, 3> key = g;
        std::sort(key.begin(), key.end());
        if (!seen.emplace(key, true).second) {
            ++r.repeated_faces;
            continue;
        }
        s.faces.push_back(g);
    }
    if (s.faces.empty())
        throw input_error(source + ": every one of the " + std::to_string(faces.size()) +
                          " triangles is degenerate (no area): nothing to mesh");
    // Keep only the vertices the faces use: stray points would become background
    // vertices for nothing.
    std::vector<index_t> used(s.vertices.size(), invalid_index);
    std::vector<vec3> kept;
    for (auto& f : s.faces)
        for (index_t& v : f) {
            if (used[v] == invalid_index)
                used[v] = index_t(kept.size()), kept.push_back(s.vertices[v]);
            v = used[v];
        }
    s.vertices = std::move(kept);
    r.triangles = s.faces.size();
    return s;
}

/// Input triangles whose tracked faces cover them exactly: the areas of the tracked
/// faces, projected on the triangle's dominant coordinate plane, sum (in rationals) to
/// the triangle's. Tracked faces lie inside their triangles and do not overlap (they are
/// faces of a valid tet mesh), so equal areas mean equal sets.
inline std::size_t count_covered(const insertion::inserted_mesh& m, const clean_soup& s) {
    const std::size_t nt = s.faces.size();
    std::vector<index_t> first(nt + 1, 0), faces;
    for (std::size_t i = 0; i < m.tracked.size(); ++i)
        for (index_t k = m.tracked_first[i]; k < m.tracked_first[i + 1]; ++k)
            ++first[m.tracked_by[k] + 1];
    for (std::size_t t = 0; t < nt; ++t) first[t + 1] += first[t];
    faces.resize(first[nt]);
    {
        std::vector<index_t> fill(first.begin(), first.end() - 1);
        for (std::size_t i = 0; i < m.tracked.size(); ++i)
            for (index_t k = m.tracked_first[i]; k < m.tracked_first[i + 1]; ++k)
                faces[fill[m.tracked_by[k]]++] = index_t(i);
    }
    std::atomic<std::size_t> covered{0};
    tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) {
        const auto& f = s.faces[t];
        const vec3 n =
            cross(s.vertices[f[1]] - s.vertices[f[0]], s.vertices[f[2]] - s.vertices[f[0]]);
        int drop = 0;
        for (int a = 1; a < 3; ++a)
            if (std::abs(n[a]) > std::abs(n[drop])) drop = a;
        const int u = (drop + 1) % 3, w = (drop + 2) % 3;
        // Rows of |W_a W_b| (b - a) and |W_a W_c| (c - a): their cross product is twice
        // the signed area times W_a^2 |W_b W_c|.
        auto area2 = [&](const insertion::homogeneous_point& a,
                         const insertion::homogeneous_point& b,
                         const insertion::homogeneous_point& c) {
            insertion::detail::int_vector rb, rc;
            insertion::detail::difference_row(b, a, rb);
            insertion::detail::difference_row(c, a, rc);
            const auto U = std::size_t(u), W = std::size_t(w);
            mpq_class r;
            r.get_num() = abs(rb[U] * rc[W] - rb[W] * rc[U]);
            r.get_den() = abs(a.W * a.W * b.W * c.W);
            r.canonicalize();
            return r;
        };
        const auto corner = [&](int i) {
            return insertion::detail::to_homogeneous(s.vertices[f[std::size_t(i)]]);
        };
        const mpq_class whole = area2(corner(0), corner(1), corner(2));
        mpq_class sum = 0;
        for (index_t k = first[t]; k < first[t + 1]; ++k) {
            const auto& g = m.tracked[faces[k]];
            sum += area2(m.exact_homogeneous(g[0]), m.exact_homogeneous(g[1]),
                         m.exact_homogeneous(g[2]));
        }
        if (sum == whole) covered.fetch_add(1, std::memory_order_relaxed);
    });
    return covered.load();
}

namespace detail {

/// Cleaning, simplification (if `simplify`), background, exact insertion, the cover check
/// and rounding: part 1 without the labels. `soup` receives the cleaned input and `tree`
/// its distance tree.
inline result insert_soup(const std::vector<vec3>& vertices, const std::vector<tri_indices>& faces,
                          const options& opt, const std::string& source, clean_soup& soup,
                          triangle_aabb_tree& tree, bool simplify = false, unsigned threads = 1) {
    using clock = std::chrono::steady_clock;
    result out;
    report& r = out.stats;
    auto t0 = clock::now();
    soup = clean(vertices, faces, source, r);
    vec3 lo = soup.vertices[0], hi = lo;
    for (const vec3& p : soup.vertices)
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    r.diagonal = norm(hi - lo);
    r.epsilon = opt.absolute ? opt.epsilon : opt.epsilon * r.diagonal;
    r.edge_length = opt.absolute ? opt.edge_length : opt.edge_length * r.diagonal;
    if (!(r.edge_length > 0) || !std::isfinite(r.edge_length))
        throw input_error(source + ": the edge length must be positive and finite");
    if (r.edge_length < min_relative_length * r.diagonal)
        throw input_error(source + ": the edge length " + idas::detail::shortest(r.edge_length) +
                          " is below 1/1000 of the diagonal (" +
                          idas::detail::shortest(r.diagonal) + "): billions of tets");
    // The input's distance tree (the background's grid and the optimization use it) is
    // set-up, as fTetWild builds its tree before any of its stages.
    tree = triangle_aabb_tree(soup.vertices, soup.faces);
    r.seconds_cleaning = detail::seconds_since(t0);

    // The triangles to insert: the cleaned soup, or its simplification welded back.
    t0 = clock::now();
    clean_soup inserted;
    if (simplify) {
        const envelope thinner(soup.vertices, soup.faces, 0.8 * r.epsilon);
        exec_options exec;
        exec.threads = std::max(1u, threads);
        auto [V, F] = opt.deterministic
                          ? algorithms::simplify_soup<lock::deterministic_rounds>(
                                soup.vertices, soup.faces, thinner, exec)
                          : algorithms::simplify_soup(soup.vertices, soup.faces, thinner, exec);
        report ignored;
        inserted = clean(V, F, source, ignored);
    } else {
        inserted = soup;
    }
    r.simplified_triangles = inserted.faces.size();
    r.seconds_simplification = detail::seconds_since(t0);

    // Background, as fTetWild's: the soup's vertices and a grid of spacing diagonal/15 (or
    // the edge length, if longer; at most 50 cells a side, so an absurd edge length cannot
    // exhaust memory) on a box one edge length (at least two epsilons) wider, without the
    // grid points within ten epsilons of the soup. The grid gives the optimization
    // well-shaped tets away from the surface instead of long slivers to split.
    t0 = clock::now();
    std::vector<vec3> points = inserted.vertices;
    {
        const double margin = std::max(r.edge_length, 2 * r.epsilon);
        const double spacing = std::max(r.diagonal / 15, r.edge_length);
        vec3 blo = lo, bhi = hi;
        for (int k = 0; k < 3; ++k) blo[k] -= margin, bhi[k] += margin;
        std::array<int, 3> cells{};
        for (int k = 0; k < 3; ++k) cells[k] = std::clamp(int((bhi[k] - blo[k]) / spacing), 1, 50);
        // Corners and steps are multiples of a power of two near spacing / 1024, so the grid
        // is exactly regular: each cube's eight corners are exactly cospherical, which CGAL
        // decides exactly on short mantissas. Corners rounded from blo + (bhi - blo) i / n
        // were almost cospherical, decided exactly on full ones: the sphere's background
        // (1,613 points) took 16 ms (bench/RESULTS.md, "Tetrahedral meshing, session 48").
        const double unit = std::ldexp(1.0, std::ilogb(spacing) - 10);
        std::array<double, 3> origin{}, step{};
        for (int k = 0; k < 3; ++k) {
            origin[k] = std::floor(blo[k] / unit) * unit;
            step[k] = std::ceil((bhi[k] - origin[k]) / cells[k] / unit) * unit;
            if (origin[k] + cells[k] * step[k] < bhi[k]) step[k] += unit; // a rounded quotient
        }
        auto coord = [&](int k, int i) { return origin[k] + i * step[k]; };
        const double keep_away = 100 * r.epsilon * r.epsilon;
        for (int i = 0; i <= cells[0]; ++i)
            for (int j = 0; j <= cells[1]; ++j)
                for (int k = 0; k <= cells[2]; ++k) {
                    const vec3 q{coord(0, i), coord(1, j), coord(2, k)};
                    const bool on_box = i == 0 || i == cells[0] || j == 0 || j == cells[1] ||
                                        k == 0 || k == cells[2];
                    if (on_box || !tree.closest_point(q, keep_away)) points.push_back(q);
                }
    }
    const cgal::delaunay_result dt = cgal::delaunay_tetrahedralization(points, threads);
    insertion::insertion_input in;
    in.vertices = dt.vertices;
    in.tets = dt.tets;
    in.triangles.reserve(inserted.faces.size());
    for (const auto& f : inserted.faces)
        in.triangles.push_back({dt.index_of[f[0]], dt.index_of[f[1]], dt.index_of[f[2]]});
    r.background_tets = in.tets.size();
    r.seconds_delaunay = detail::seconds_since(t0);

    t0 = clock::now();
    out.mesh = insertion::insert_triangles(in);
    r.cut_tets = out.mesh.cut_tets, r.refined_tets = out.mesh.refined_tets;
    r.rational_vertices_created = out.mesh.rational_vertices();
    r.seconds_insertion = detail::seconds_since(t0);

    // Check the guarantee before rounding moves anything: exact cover of every triangle.
    t0 = clock::now();
    {
        clean_soup in_mesh{in.vertices, in.triangles};
        r.covered_triangles = count_covered(out.mesh, in_mesh);
    }
    r.seconds_check = detail::seconds_since(t0);

    t0 = clock::now();
    r.rational_vertices_left = insertion::round_vertices(out.mesh);
    r.seconds_rounding = detail::seconds_since(t0);

    const auto& M = out.mesh;
    r.tets = M.tets.size(), r.vertices = M.vertices.size(), r.tracked_faces = M.tracked.size();
    t0 = clock::now();
    r.inverted_tets = insertion::count_inverted(M);
    r.seconds_check += detail::seconds_since(t0);
    return out;
}

/// Per tet: the winding number of the soup at its centroid, and whether it is above 1/2.
/// The centroids are taken along a Morton curve: neighbouring queries walk the same nodes
/// and triangles of the hierarchy, which stay in cache (an optimized mesh lists its tets in
/// slot order, scattered over the volume).
inline void label(const winding_number& w, const std::vector<vec3>& V,
                  const std::vector<tet_indices>& T, std::vector<double>& winding,
                  std::vector<std::uint8_t>& inside) {
    inside.assign(T.size(), 0);
    winding.assign(T.size(), 0.0);
    std::vector<vec3> centroid(T.size());
    tbb::parallel_for(std::size_t{0}, T.size(), [&](std::size_t t) {
        const auto& tv = T[t];
        centroid[t] = (V[tv[0]] + V[tv[1]] + V[tv[2]] + V[tv[3]]) * 0.25;
    });
    auto along_curve = partition::morton::keys(centroid);
    tbb::parallel_sort(along_curve.begin(), along_curve.end());
    tbb::parallel_for(std::size_t{0}, along_curve.size(), [&](std::size_t i) {
        const index_t t = along_curve[i].second;
        winding[t] = w.for_label(centroid[t]);
        inside[t] = winding[t] > 0.5;
    });
}

/// Whether some tet's centroid has a winding number above 1/2. Stops at the first one:
/// on a closed input that is among the first few tets looked at, where labelling every
/// tet of the inserted mesh costs as much as the insertion.
inline bool any_inside(const winding_number& w, const std::vector<vec3>& V,
                       const std::vector<tet_indices>& T) {
    std::atomic<bool> found{false};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, T.size(), 256), [&](const auto& range) {
        for (std::size_t t = range.begin(); t != range.end(); ++t) {
            if (found.load(std::memory_order_relaxed)) return;
            const auto& tv = T[t];
            if (w.for_label((V[tv[0]] + V[tv[1]] + V[tv[2]] + V[tv[3]]) * 0.25) > 0.5)
                found.store(true, std::memory_order_relaxed);
        }
    });
    return found.load();
}

} // namespace detail

/// Part 1 of tetrahedral meshing: exact insertion with inside and outside. Throws
/// input_error (naming `source`) for inputs it cannot mesh.
inline result mesh_insertion(const std::vector<vec3>& vertices,
                             const std::vector<tri_indices>& faces, const options& opt,
                             const std::string& source) {
    clean_soup soup;
    triangle_aabb_tree tree;
    result out = detail::insert_soup(vertices, faces, opt, source, soup, tree);
    const auto t0 = std::chrono::steady_clock::now();
    const winding_number w(soup.vertices, soup.faces);
    detail::label(w, out.mesh.vertices, out.mesh.tets, out.winding, out.inside);
    out.stats.seconds_winding = detail::seconds_since(t0);
    for (auto x : out.inside) out.stats.inside_tets += x;
    return out;
}

// ---- part 2: quality optimization and the output ------------------------------------------

struct quality_options {
    double stop_energy = 10;      ///< stop when the largest AMIPS is at most this
    unsigned max_iterations = 80; ///< rounds of split, collapse, swap, smooth
    unsigned stall_rounds = 12;   ///< see tet_optimization_options::stall_rounds
    double last_pass_up_to = 0.6; ///< see tet_optimization_options::last_pass_up_to
    unsigned threads = 1;
    bool keep_outside = false; ///< output every tet (with its label), not only the inside
    /// The user's sizing field (absolute lengths, at least 1/1000 of the diagonal: smaller
    /// values are raised to it); without one the target length is options::edge_length
    /// everywhere.
    const background_sizing* sizing = nullptr;
};

/// What the optimization and the output stage did.
struct quality_report {
    algorithms::tet_optimization_report optimization;
    std::size_t tets = 0, vertices = 0; ///< written
    std::size_t inside_tets = 0;        ///< of all the optimized tets
    std::size_t added_for_manifold = 0; ///< outside tets made inside to close the boundary
    std::size_t boundary_faces = 0;     ///< of the inside
    std::size_t non_manifold_edges = 0; ///< of the inside's boundary, after the repair
    std::size_t non_manifold_vertices = 0;
    std::size_t flat_or_inverted = 0; ///< among the written tets, exact on their doubles
    tet_quality_summary quality;      ///< of the inside tets
    double seconds_optimization = 0, seconds_output = 0;
    double seconds_winding = 0; ///< of seconds_output: the labels alone
};

/// The final mesh: every optimized tet with its label; `inside` says which are the output.
struct volume_mesh {
    std::vector<vec3> vertices;
    std::vector<tet_indices> tets;
    std::vector<std::uint8_t> inside;
    report insertion;
    quality_report quality;
};

namespace detail {

/// Boundary faces of the tets with `in` set (each with its tet's outward orientation),
/// with counts of the boundary's non-manifold edges and vertices.
struct inside_boundary {
    std::vector<tri_indices> faces;
    std::vector<index_t> bad_edge_vertices; ///< both ends of every non-manifold edge
    std::vector<index_t> bad_vertices;      ///< vertices whose boundary fan is not one disk
    std::size_t non_manifold_edges = 0;
};

/// Calls run(element, count) once for each run of equal elements (by `same`) of the
/// sorted vector v.
template <class Vector, class Run, class Same = std::equal_to<>>
void for_each_run(const Vector& v, Run&& run, Same same = {}) {
    for (std::size_t i = 0; i < v.size();) {
        std::size_t j = i + 1;
        while (j < v.size() && same(v[j], v[i])) ++j;
        run(v[i], j - i);
        i = j;
    }
}

/// For each face (tet t, local face lf) of a tet mesh, 4 t + lf of the face across it, or
/// invalid_index on the hull: found once, by sorting every face.
inline std::vector<index_t> face_neighbours(const std::vector<tet_indices>& T) {
    struct rec {
        tri_indices key;
        index_t face; // 4 t + lf
    };
    std::vector<rec> faces;
    faces.reserve(4 * T.size());
    for (std::size_t t = 0; t < T.size(); ++t)
        for (std::uint8_t lf = 0; lf < 4; ++lf) {
            const auto f = tet_local::face_vertices[lf];
            faces.push_back({algorithms::detail::sorted_triple(T[t][f[0]], T[t][f[1]], T[t][f[2]]),
                             index_t(4 * t + lf)});
        }
    std::sort(faces.begin(), faces.end(), [](const rec& a, const rec& b) { return a.key < b.key; });
    std::vector<index_t> across(faces.size(), invalid_index);
    for (std::size_t i = 0; i + 1 < faces.size(); ++i)
        if (faces[i].key == faces[i + 1].key)
            across[faces[i].face] = faces[i + 1].face, across[faces[i + 1].face] = faces[i].face;
    return across;
}

/// A face of an inside tet: its vertices sorted, and as the tet has them (outward:
/// tet_mesh's local faces are stored outward-facing for positive tets).
struct inside_face {
    tri_indices key;
    tri_indices face;
};
/// Calls fn(t, lf, face) for every face of every tet with `in` set.
template <class Fn>
void for_each_inside_face(const std::vector<tet_indices>& T, const std::vector<std::uint8_t>& in,
                          Fn&& fn) {
    for (std::size_t t = 0; t < T.size(); ++t) {
        if (!in[t]) continue;
        for (std::uint8_t lf = 0; lf < 4; ++lf) {
            const auto f = tet_local::face_vertices[lf];
            const tri_indices face{T[t][f[0]], T[t][f[1]], T[t][f[2]]};
            fn(t, lf,
               inside_face{algorithms::detail::sorted_triple(face[0], face[1], face[2]), face});
        }
    }
}

/// Counts the non-manifold edges and vertices of the boundary faces in `out`.
inline void check_boundary(std::size_t n_vertices, inside_boundary& out) {
    // Edges: a closed 2-manifold has every edge in exactly two boundary faces.
    std::vector<std::pair<index_t, index_t>> edges;
    for (const auto& f : out.faces)
        for (int k = 0; k < 3; ++k) edges.push_back(std::minmax(f[k], f[(k + 1) % 3]));
    std::sort(edges.begin(), edges.end());
    for_each_run(edges, [&](const std::pair<index_t, index_t>& e, std::size_t count) {
        if (count == 2) return;
        ++out.non_manifold_edges;
        out.bad_edge_vertices.push_back(e.first);
        out.bad_edge_vertices.push_back(e.second);
    });
    // Vertices: the faces around a vertex form one cycle (their opposite edges chain up).
    std::vector<index_t> first(n_vertices + 1, 0), around;
    for (const auto& f : out.faces)
        for (index_t v : f) ++first[v + 1];
    for (std::size_t v = 0; v < n_vertices; ++v) first[v + 1] += first[v];
    around.resize(first[n_vertices]);
    {
        std::vector<index_t> fill(first.begin(), first.end() - 1);
        for (std::size_t i = 0; i < out.faces.size(); ++i)
            for (index_t v : out.faces[i]) around[fill[v]++] = index_t(i);
    }
    for (std::size_t v = 0; v < n_vertices; ++v) {
        const index_t n = first[v + 1] - first[v];
        if (n == 0) continue;
        // Walk the fan from its first face by the next-vertex links; a single disk visits
        // all n faces before it returns.
        auto next_of = [&](index_t f) {
            const auto& fv = out.faces[f];
            const int i = fv[0] == v ? 0 : fv[1] == v ? 1 : 2;
            return std::pair<index_t, index_t>(fv[(i + 1) % 3], fv[(i + 2) % 3]);
        };
        index_t f = around[first[v]];
        index_t steps = 0;
        const index_t start = next_of(f).first;
        index_t at = next_of(f).second;
        while (steps < n) {
            ++steps;
            if (at == start) break;
            index_t nextf = invalid_index;
            for (index_t k = first[v]; k < first[v + 1]; ++k)
                if (next_of(around[k]).first == at) {
                    nextf = around[k];
                    break;
                }
            if (nextf == invalid_index) break;
            f = nextf, at = next_of(f).second;
        }
        if (!(at == start && steps == n)) out.bad_vertices.push_back(index_t(v));
    }
}

/// The inside's boundary, given each face's neighbour in a mesh whose tets have since only
/// had vertices replaced by copies or copies put back (close_boundary): two tets share a
/// face now only where they did then, so a face of an inside tet is on the boundary unless
/// the tet across it is inside and still has the same three vertices. One sort of every
/// face per round of close_boundary was most of its time on soups of shards.
inline inside_boundary boundary_of(std::size_t n_vertices, const std::vector<tet_indices>& T,
                                   const std::vector<std::uint8_t>& in,
                                   const std::vector<index_t>& across) {
    std::vector<inside_face> faces;
    for_each_inside_face(T, in, [&](std::size_t t, std::uint8_t lf, const inside_face& x) {
        const index_t other = across[4 * t + lf];
        if (other != invalid_index && in[other / 4]) {
            const auto f = tet_local::face_vertices[other % 4];
            const tet_indices& o = T[other / 4];
            if (algorithms::detail::sorted_triple(o[f[0]], o[f[1]], o[f[2]]) == x.key) return;
        }
        faces.push_back(x);
    });
    // In the order of their vertices, as a sort of every face gave them.
    std::sort(faces.begin(), faces.end(),
              [](const inside_face& a, const inside_face& b) { return a.key < b.key; });
    inside_boundary out;
    out.faces.reserve(faces.size());
    for (const inside_face& x : faces) out.faces.push_back(x.face);
    check_boundary(n_vertices, out);
    return out;
}

/// Boundary faces of the tets with `in` set, with counts of the boundary's non-manifold
/// edges and vertices: the faces of inside tets that no other inside tet has, found by
/// sorting them.
inline inside_boundary boundary_of(std::size_t n_vertices, const std::vector<tet_indices>& T,
                                   const std::vector<std::uint8_t>& in) {
    std::vector<inside_face> faces;
    for_each_inside_face(
        T, in, [&](std::size_t, std::uint8_t, const inside_face& x) { faces.push_back(x); });
    std::sort(faces.begin(), faces.end(),
              [](const inside_face& a, const inside_face& b) { return a.key < b.key; });
    inside_boundary out;
    for_each_run(
        faces,
        [&](const inside_face& x, std::size_t count) {
            if (count == 1) out.faces.push_back(x.face);
        },
        [](const inside_face& a, const inside_face& b) { return a.key == b.key; });
    check_boundary(n_vertices, out);
    return out;
}

/// Groups of the tets `in_group` of v's star that share faces through v (components of
/// v's link): group[k] is the group of star tet k, or -1 for a tet not in_group. Returns
/// the number of groups.
template <class InGroup>
int star_groups(index_t v, std::span<const index_t> star, const std::vector<tet_indices>& T,
                InGroup&& in_group, std::vector<int>& group) {
    group.assign(star.size(), -1);
    // Two tets of v's star share a face through v iff they share two vertices besides v.
    auto share_face = [&](index_t s, index_t t) {
        int common = 0;
        for (index_t x : T[s])
            if (x != v && tet_local::contains(T[t], x)) ++common;
        return common == 2;
    };
    int groups = 0;
    std::vector<std::size_t> todo;
    for (std::size_t k = 0; k < star.size(); ++k) {
        if (group[k] >= 0 || !in_group(star[k])) continue;
        group[k] = groups;
        todo.assign(1, k);
        while (!todo.empty()) {
            const std::size_t i = todo.back();
            todo.pop_back();
            for (std::size_t j = 0; j < star.size(); ++j)
                if (group[j] < 0 && in_group(star[j]) && share_face(star[i], star[j]))
                    group[j] = groups, todo.push_back(j);
        }
        ++groups;
    }
    return groups;
}

/// Whether the tets of group g of v's star (see star_groups) form a disk around v: their
/// faces opposite v (a region of v's link, a sphere) have one boundary cycle. The region
/// is connected across edges, so it is a disk iff its Euler characteristic is 1 and every
/// boundary vertex is on exactly two boundary edges (no pinch).
inline bool group_is_disk(index_t v, std::span<const index_t> star,
                          const std::vector<tet_indices>& T, const std::vector<int>& group, int g) {
    boost::container::small_vector<std::pair<index_t, index_t>, 96> edges;
    boost::container::small_vector<index_t, 48> corners;
    long faces = 0;
    for (std::size_t k = 0; k < star.size(); ++k) {
        if (group[k] != g) continue;
        ++faces;
        index_t x[3];
        int n = 0;
        for (index_t y : T[star[k]])
            if (y != v) x[n++] = y;
        for (int i = 0; i < 3; ++i) {
            corners.push_back(x[i]);
            edges.push_back(std::minmax(x[i], x[(i + 1) % 3]));
        }
    }
    std::sort(corners.begin(), corners.end());
    corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
    std::sort(edges.begin(), edges.end());
    long distinct_edges = 0;
    boost::container::small_vector<index_t, 48> boundary_ends;
    for_each_run(edges, [&](const std::pair<index_t, index_t>& e, std::size_t count) {
        ++distinct_edges;
        if (count == 1) {
            boundary_ends.push_back(e.first);
            boundary_ends.push_back(e.second);
        }
    });
    if (long(corners.size()) - distinct_edges + faces != 1) return false;
    std::sort(boundary_ends.begin(), boundary_ends.end());
    bool pinched = false;
    for_each_run(boundary_ends, [&](index_t, std::size_t count) { pinched |= count != 2; });
    return !pinched;
}

/// Makes the inside's boundary a closed 2-manifold, locally, vertex by vertex, where it is
/// not one (round after round until it is):
///  * inside tets that meet at a vertex v only along edges or at v itself (two solids
///    touching, as in many CAD soups: 37989_sf has 232 edges in four faces) are parted:
///    with `may_split_vertices`, when each group of inside tets sharing faces through v is
///    a disk around v, every group but the first gets its own copy of v (appended to V),
///    so nothing is added and the boundary stays on the input. The outside tets keep v,
///    so this is only for an output of the inside;
///  * in a round where no vertex could be parted, the outside tets around each bad vertex
///    fill every gap but the largest (the outside groups of its star): a group that wraps
///    around a gap closes it;
///  * where neither changes anything, the bad vertices' whole stars are made inside (each
///    such step adds a tet, and the whole box is a closed manifold, so the rounds end);
///  * a bad vertex whose star is all inside is next to a copy: a neighbour's split cut
///    through its star and left it a boundary that is not a disk (a soup of shards). The
///    copies of its star's vertices go back into their originals, which are not parted
///    again (the filling steps close them).
/// Returns how many tets were made inside.
/// `last`, when given, receives the boundary the last round found: the inside's boundary
/// on return. The first round sorts the inside's faces; from the second on, each face's
/// neighbour (face_neighbours, found once) tells the boundary without a sort of them all.
inline std::size_t close_boundary(std::vector<vec3>& V, std::vector<tet_indices>& T,
                                  std::vector<std::uint8_t>& in, bool may_split_vertices,
                                  inside_boundary* last = nullptr) {
    std::size_t added = 0;
    std::vector<int> group;
    const std::size_t originals = V.size();
    std::vector<index_t> copied_from; // of each copy, appended to V
    auto original = [&](index_t x) { return x < originals ? x : copied_from[x - originals]; };
    std::vector<std::uint8_t> merged(originals, 0); // copies went back: parted no more
    std::vector<index_t> across;                    // from the second round on
    for (;;) {
        inside_boundary b =
            across.empty() ? boundary_of(V.size(), T, in) : boundary_of(V.size(), T, in, across);
        std::vector<index_t> bad = b.bad_edge_vertices;
        bad.insert(bad.end(), b.bad_vertices.begin(), b.bad_vertices.end());
        std::sort(bad.begin(), bad.end());
        bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
        if (bad.empty()) {
            if (last) *last = std::move(b);
            return added;
        }
        if (across.empty()) across = face_neighbours(T);
        const auto [first, star] = insertion::detail::vertex_stars(V.size(), T);
        auto star_of = [&](index_t v) {
            return std::span<const index_t>(star.data() + first[v], first[v + 1] - first[v]);
        };
        auto is_in = [&](index_t t) { return in[t] != 0; };
        bool changed = false;
        if (may_split_vertices)
            for (index_t v : bad) {
                if (merged[original(v)]) continue;
                const auto st = star_of(v);
                const int groups = star_groups(v, st, T, is_in, group);
                if (groups < 2) continue;
                bool disks = true;
                for (int g = 0; g < groups && disks; ++g) disks = group_is_disk(v, st, T, group, g);
                if (!disks) continue;
                for (int g = 1; g < groups; ++g) {
                    const index_t copy = index_t(V.size());
                    V.push_back(V[v]);
                    copied_from.push_back(original(v));
                    for (std::size_t k = 0; k < st.size(); ++k)
                        if (group[k] == g)
                            for (index_t& x : T[st[k]])
                                if (x == v) x = copy;
                }
                changed = true;
            }
        if (changed) continue;
        for (index_t v : bad) {
            const auto st = star_of(v);
            const int gaps = star_groups(
                v, st, T, [&](index_t t) { return in[t] == 0; }, group);
            if (gaps < 2) continue;
            std::vector<std::size_t> size(gaps, 0);
            for (int g : group)
                if (g >= 0) ++size[g];
            const int largest = int(std::max_element(size.begin(), size.end()) - size.begin());
            for (std::size_t k = 0; k < st.size(); ++k)
                if (group[k] >= 0 && group[k] != largest) in[st[k]] = 1, ++added, changed = true;
        }
        if (changed) continue;
        for (index_t v : bad)
            for (index_t t : star_of(v))
                if (!in[t]) in[t] = 1, ++added, changed = true;
        if (changed) continue;
        // Every bad vertex's star is inside: a copy next to it cut its star. The copies of
        // its star's vertices go back (left unreferenced in V).
        for (index_t v : bad)
            for (index_t t : star_of(v))
                for (index_t x : T[t]) merged[original(x)] = 1;
        for (auto& t : T)
            for (index_t& x : t)
                if (x >= originals && merged[original(x)]) x = original(x), changed = true;
        if (!changed) { // cannot happen; no endless loop either way
            if (last) *last = boundary_of(V.size(), T, in);
            return added;
        }
    }
}

} // namespace detail

/// Tetrahedral meshing of a triangle soup, parts 1 and 2: exact insertion, quality
/// optimization on the executor (algorithms/tet_optimization.hpp) inside the envelope of
/// the input at epsilon, and the inside by winding number with a closed 2-manifold
/// boundary. Throws input_error (naming `source`) for inputs it cannot mesh.
template <class Observer = algorithms::no_round_observer>
volume_mesh mesh_volume(const std::vector<vec3>& vertices, const std::vector<tri_indices>& faces,
                        const options& opt, const quality_options& q, const std::string& source,
                        Observer&& observer = {}) {
    using clock = std::chrono::steady_clock;
    if (!(q.stop_energy >= 3) || !std::isfinite(q.stop_energy))
        throw input_error("the stop energy must be a finite number of at least 3 (the AMIPS "
                          "energy of a regular tet)");
    if (!(q.last_pass_up_to >= 0 && q.last_pass_up_to <= 1))
        throw input_error("the last pass's energy bound must be a fraction of the stop energy "
                          "from 0 to 1");
    volume_mesh out;
    clean_soup soup;
    triangle_aabb_tree input;
    result part1 =
        detail::insert_soup(vertices, faces, opt, source, soup, input, opt.simplify, q.threads);
    out.insertion = part1.stats;
    quality_report& qr = out.quality;

    auto t0 = clock::now();
    const insertion::inserted_mesh& M = part1.mesh;
    const winding_number w(soup.vertices, soup.faces);
    // Nothing inside (a flat or open sheet): say so before optimizing anything.
    if (!detail::any_inside(w, M.vertices, M.tets))
        throw input_error(source + ": the input encloses no volume (no tet has a winding "
                                   "number above 1/2)");
    tet_mesh<> m(M.vertices, M.tets, tet_mesh<>::orientation_checked_by_caller{});
    auto tracked = m.add_tet_attribute<std::uint8_t>("tracked", 0);
    {
        std::vector<tri_indices> keys;
        keys.reserve(M.tracked.size());
        for (const auto& f : M.tracked)
            keys.push_back(algorithms::detail::sorted_triple(f[0], f[1], f[2]));
        std::sort(keys.begin(), keys.end());
        auto col = m.attribute(tracked);
        for (index_t g = 0; g < m.tet_slots(); ++g) {
            const auto& tv = m.tet_vertices(g);
            for (std::uint8_t lf = 0; lf < 4; ++lf) {
                const auto f = tet_local::face_vertices[lf];
                if (std::binary_search(
                        keys.begin(), keys.end(),
                        algorithms::detail::sorted_triple(tv[f[0]], tv[f[1]], tv[f[2]])))
                    col.raw(g) |= std::uint8_t(1u << lf);
            }
        }
    }
    const envelope env(soup.vertices, soup.faces, out.insertion.epsilon);
    env.prepare_exact(); // the optimization asks CGAL: built here, not inside an operation
    algorithms::tet_optimization_options o;
    o.target_length = out.insertion.edge_length;
    o.min_length = min_relative_length * out.insertion.diagonal;
    o.stop_energy = q.stop_energy, o.max_iterations = q.max_iterations;
    o.stall_rounds = q.stall_rounds;
    o.last_pass_up_to = q.last_pass_up_to;
    o.border_epsilon = out.insertion.epsilon; // fTetWild's boundary envelope
    exec_options exec;
    exec.threads = std::max(1u, q.threads);
    const auto optimize = [&]<class Lock>(std::type_identity<Lock>) {
        using optimization = algorithms::tet_optimization<envelope, tet_mesh<>, Lock>;
        return q.sizing ? optimization::run(m, tracked, M.exact, env, input, o, exec, observer,
                                            *q.sizing)
                        : optimization::run(m, tracked, M.exact, env, input, o, exec, observer);
    };
    qr.optimization = opt.deterministic ? optimize(std::type_identity<lock::deterministic_rounds>{})
                                        : optimize(std::type_identity<lock::vertex_try_lock>{});
    qr.seconds_optimization = detail::seconds_since(t0);

    t0 = clock::now();
    auto [V, T] = m.to_arrays();
    std::vector<double> winding;
    detail::label(w, V, T, winding, out.inside);
    qr.seconds_winding = detail::seconds_since(t0);
    for (auto x : out.inside) qr.inside_tets += x;
    if (qr.inside_tets == 0)
        throw input_error(source + ": the input encloses no volume (no tet has a winding "
                                   "number above 1/2)");
    detail::inside_boundary b;
    qr.added_for_manifold = detail::close_boundary(V, T, out.inside, !q.keep_outside, &b);
    qr.boundary_faces = b.faces.size();
    qr.non_manifold_edges = b.non_manifold_edges;
    qr.non_manifold_vertices = b.bad_vertices.size();
    std::vector<tet_indices> kept;
    for (std::size_t t = 0; t < T.size(); ++t)
        if (out.inside[t]) kept.push_back(T[t]);
    qr.quality = summarize_tet_quality(V, kept);
    qr.flat_or_inverted = qr.quality.inverted + qr.quality.flat;
    out.vertices = std::move(V);
    out.tets = std::move(T);
    qr.tets = q.keep_outside ? out.tets.size() : kept.size();
    qr.vertices = out.vertices.size();
    qr.seconds_output = detail::seconds_since(t0);
    return out;
}

} // namespace idas::tetmesh
