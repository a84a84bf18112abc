// What every local operation shares: operation kinds as types, the per-thread
// operation context (undo logs, scratch buffers), the spec's hooks and the
// invariant machinery, and the transaction that commits or rolls back.
#pragma once

#include <idas/core/attribute.hpp>
#include <idas/core/tuple.hpp>

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace idas {

/// Operation kinds are types. Each says what it acts on (the simplex its tuple names: the
/// executor seeds the default queue and the lock footprint from it) and at most how many
/// simplices one operation creates (`adds_vertices` / `adds_faces`, faces meaning top
/// cells), so a parallel worker can tell in advance whether its slot pool can serve it.
/// `changes_connectivity` (default true) lets a schedule tell moves from edits;
/// `new_facets` (default `anywhere`) says where the facets with new geometry can be, so an
/// invariant on facets tests only those. A queue
/// entry stores an operation's position in its spec's `op_list`, so a user adds a kind by
/// declaring a type like these and an `apply` overload for it (see tests/test_contract.cpp).
/// Where the facets (edges of triangles, faces of tets) of an operation's output cells
/// whose geometry is new can be: anywhere; only through the anchor vertex (the operation
/// creates or moves that one vertex); or only inside the operation's region (it moves no
/// vertex and keeps every facet on the region's border).
enum class new_facets { anywhere, through_anchor, inside_region };

namespace op {
struct split_edge {
    static constexpr simplex_kind acts_on = simplex_kind::edge;
    static constexpr index_t adds_vertices = 1, adds_faces = 2;
};
struct collapse_edge {
    static constexpr simplex_kind acts_on = simplex_kind::edge;
    static constexpr index_t adds_vertices = 0, adds_faces = 0;
    static constexpr idas::new_facets new_facets = idas::new_facets::through_anchor;
};
struct swap_edge {
    static constexpr simplex_kind acts_on = simplex_kind::edge;
    static constexpr index_t adds_vertices = 0, adds_faces = 0;
    static constexpr idas::new_facets new_facets = idas::new_facets::inside_region;
};
struct smooth_vertex {
    static constexpr simplex_kind acts_on = simplex_kind::vertex;
    static constexpr index_t adds_vertices = 0, adds_faces = 0;
    static constexpr bool changes_connectivity = false;
    static constexpr idas::new_facets new_facets = idas::new_facets::through_anchor;
};
} // namespace op

template <class Op>
concept operation_kind = std::is_empty_v<Op> && std::default_initializable<Op> && requires {
    { Op::acts_on } -> std::convertible_to<simplex_kind>;
    { Op::adds_vertices } -> std::convertible_to<index_t>;
    { Op::adds_faces } -> std::convertible_to<index_t>;
};

/// Whether operations of this kind may change connectivity (a move does not).
template <operation_kind Op>
inline constexpr bool changes_connectivity = [] {
    if constexpr (requires { Op::changes_connectivity; })
        return bool(Op::changes_connectivity);
    else
        return true;
}();

/// Where an operation kind's new facets can be (`new_facets`; anywhere if it does not say).
template <operation_kind Op>
inline constexpr new_facets where_new_facets = [] {
    if constexpr (requires { Op::new_facets; })
        return new_facets(Op::new_facets);
    else
        return new_facets::anywhere;
}();

static_assert(operation_kind<op::split_edge> && operation_kind<op::collapse_edge> &&
              operation_kind<op::swap_edge> && operation_kind<op::smooth_vertex>);
static_assert(!changes_connectivity<op::smooth_vertex> && changes_connectivity<op::split_edge>);
static_assert(where_new_facets<op::split_edge> == new_facets::anywhere &&
              where_new_facets<op::collapse_edge> == new_facets::through_anchor);

/// What an operation created: an anchor tuple (documented per operation) and the faces
/// (or tets) that are new or changed, each with the old simplex it came from. While the
/// operation runs (in `after`) it also names the operation's attribute journal, so the
/// hook writes with `m.attribute(h, r)` / `m.positions(r)` and a refusal undoes it; the
/// result an operation returns names none.
template <class Tuple>
struct op_result {
    Tuple anchor;
    std::span<const Tuple> cells;
    std::span<const index_t> origins;
    attribute_journal* journal = nullptr;
};

/// The state of one worker's running operations, passed to every operation explicitly:
/// the connectivity undo log, the attribute journal, reused buffers (so steady-state
/// operations allocate nothing) and the worker's index.
template <class Mesh>
struct op_context {
    typename Mesh::undo_log conn;
    attribute_journal attrs;
    std::vector<typename Mesh::tuple> cells;
    std::vector<index_t> origins;
    std::vector<index_t> scratch;
    // Net live-simplex changes of committed operations on this thread, and those of the
    // running operation (folded in on commit). Plain integers: each thread owns its context.
    std::int64_t face_delta = 0, vertex_delta = 0;
    std::int64_t pending_faces = 0, pending_vertices = 0;
    /// The parallel worker this context belongs to (0 in serial runs). The slot pool new
    /// simplices come from is `conn.pool`, which the executor sets: the worker's, or in a
    /// deterministic round each operation's own.
    unsigned worker = 0;

    op_context() { conn.reserve(256), cells.reserve(64), origins.reserve(64), scratch.reserve(64); }
};

/// Opens an undo scope on `ctx`; destroys as a rollback unless committed.
template <class Mesh>
class transaction {
public:
    transaction(Mesh& m, op_context<Mesh>& ctx)
        : m_(m)
        , ctx_(ctx)
        , conn_mark_(ctx.conn.size())
        , attr_mark_(ctx.attrs.mark()) {}
    transaction(const transaction&) = delete;
    transaction& operator=(const transaction&) = delete;
    ~transaction() {
        if (!done_) rollback();
    }
    void commit() {
        ctx_.conn.resize(conn_mark_);
        ctx_.attrs.truncate(attr_mark_);
        finish();
    }
    void rollback() {
        m_.rollback(ctx_.conn, conn_mark_);
        ctx_.attrs.rollback(attr_mark_, m_.attributes().columns());
        finish();
    }

private:
    void finish() { done_ = true; }
    Mesh& m_;
    op_context<Mesh>& ctx_;
    std::size_t conn_mark_, attr_mark_;
    bool done_ = false;
};

// ---------------------------------------------------------------------------------
// The spec's hooks. All are optional; each is detected at compile time.
//   before(Op, const Mesh&, tuple)                -> bool or std::optional<Cache>
//   after(Op, Mesh&, const op_result&[, Cache&])  -> bool; writes m.attribute(h, r)
//   invariants()                                  -> invariant_set<...>
// ---------------------------------------------------------------------------------

struct no_cache {};

namespace detail {

template <class T>
struct is_optional : std::false_type {};
template <class T>
struct is_optional<std::optional<T>> : std::true_type {};

/// Runs spec.before and normalises its answer to std::optional<Cache>.
template <class Op, class Spec, class Mesh, class Tuple>
auto run_before(Spec& spec, const Mesh& m, const Tuple& t) {
    if constexpr (requires { spec.before(Op{}, m, t); }) {
        using R = decltype(spec.before(Op{}, m, t));
        if constexpr (is_optional<R>::value) {
            return spec.before(Op{}, m, t);
        } else {
            static_assert(std::convertible_to<R, bool>,
                          "before() must return bool or std::optional<Cache>");
            return spec.before(Op{}, m, t) ? std::optional<no_cache>(no_cache{}) : std::nullopt;
        }
    } else {
        return std::optional<no_cache>(no_cache{});
    }
}

template <class Op, class Spec, class Mesh, class Result, class Cache>
bool run_after(Spec& spec, Mesh& m, const Result& r, Cache& cache) {
    if constexpr (requires {
                      { spec.after(Op{}, m, r, cache) } -> std::convertible_to<bool>;
                  })
        return spec.after(Op{}, m, r, cache);
    else if constexpr (requires {
                           { spec.after(Op{}, m, r) } -> std::convertible_to<bool>;
                       })
        return spec.after(Op{}, m, r);
    else
        return true;
}

} // namespace detail

// ---------------------------------------------------------------------------------
// Invariants: types with optional
//   bool before(Op, const Mesh&, tuple, state&)   checked on the old mesh
//   bool after(Op, const Mesh&, const op_result&, state&)  checked on the new cells
// `state` is per operation (on the stack), so invariants are stateless and thread-safe.
// ---------------------------------------------------------------------------------

template <class I>
concept invariant = std::copy_constructible<I> && std::default_initializable<typename I::state>;

template <class I, class Op, class Mesh>
concept invariant_for = invariant<I> &&(
    requires(const I& inv, const Mesh& m, typename I::state& s, typename Mesh::tuple t) {
        { inv.before(Op{}, m, t, s) } -> std::convertible_to<bool>;
    } ||
    requires(const I& inv, const Mesh& m, typename I::state& s, op_result<typename Mesh::tuple> r) {
        { inv.after(Op{}, m, r, s) } -> std::convertible_to<bool>;
    });

namespace detail {
/// Says what an invariant type lacks, if anything.
template <class I>
constexpr bool check_invariant() {
    static_assert(
        requires { typename I::state; },
        "idas: an invariant declares its per-operation scratch as a nested type `state` "
        "(`struct state {};` if it keeps none)");
    if constexpr (requires { typename I::state; })
        static_assert(std::default_initializable<typename I::state>,
                      "idas: an invariant's `state` must be default-constructible");
    static_assert(std::copy_constructible<I>, "idas: an invariant must be copy-constructible");
    return invariant<I>;
}
} // namespace detail

namespace detail {
/// An invariant that updates a structure of its own when its `after` accepts (the
/// spatial index of no_self_intersection) must be checked last: after it nothing may
/// refuse the operation, or the structure would describe a mesh that was rolled back.
template <class I>
inline constexpr bool commits_on_accept = requires {
    requires I::commits_on_accept;
};
/// An invariant that reads beyond the operation's star claims that space in parallel
/// runs: `std::size_t extra_lock_words(const Mesh&) const` lock words past the vertices,
/// taken by `bool claim(Op, const Mesh&, const tuple&, Take&, std::size_t first_word)`.
template <class I>
inline constexpr bool claims_space = requires {
    requires I::claims_space;
};
/// An invariant that claims space and says where each of its words lies
/// (`vec3 lock_cell_centre(std::size_t k) const`, k counted past the vertices).
template <class I>
inline constexpr bool locates_space = requires(const I& i, std::size_t k) {
    { i.lock_cell_centre(k) } -> std::convertible_to<vec3>;
};
template <class... Is>
constexpr bool commits_last() {
    constexpr bool flags[] = {commits_on_accept<Is>..., false};
    for (std::size_t i = 0; i + 1 < sizeof...(Is); ++i)
        if (flags[i]) return false;
    return true;
}
} // namespace detail

/// Compile-time conjunction of invariants, checked in order; the first failure stops.
template <class... Is>
class invariant_set {
    static_assert((detail::check_invariant<Is>() && ...));
    static_assert(detail::commits_last<Is...>(),
                  "idas: an invariant that updates its own index when it accepts (such as "
                  "no_self_intersection) must be the last of the invariant_set");
    static_assert((int(detail::claims_space<Is>) + ... + 0) <= 1,
                  "idas: at most one invariant of a set may claim space beyond the star");

public:
    using states = std::tuple<typename Is::state...>;
    /// Whether an invariant claims lock words past the vertices (see detail::claims_space).
    static constexpr bool claims_space = (detail::claims_space<Is> || ...);

    /// The claiming invariant's lock words past the vertices.
    template <class Mesh>
    std::size_t extra_lock_words(const Mesh& m) const {
        std::size_t n = 0;
        std::apply([&](const auto&... inv) { ((n += claimed_words(inv, m)), ...); }, invariants_);
        return n;
    }
    /// Whether the claiming invariant, if any, says where its words lie.
    static constexpr bool locates_space =
        ((!detail::claims_space<Is> || detail::locates_space<Is>)&&...);
    /// Where the claiming invariant's word k (counted past the vertices) lies.
    vec3 lock_cell_centre(std::size_t k) const requires(claims_space&& locates_space) {
        vec3 c{0, 0, 0};
        std::apply([&](const auto&... inv) { ((located(inv, k, c)), ...); }, invariants_);
        return c;
    }
    /// The claiming invariant's claim for an operation of kind Op at t (star already held).
    template <class Op, class Mesh, class Tuple, class Take>
    bool claim(const Mesh& m, const Tuple& t, Take& take) const {
        return std::apply(
            [&](const auto&... inv) { return (claim_one<Op>(inv, m, t, take) && ...); },
            invariants_);
    }

    constexpr invariant_set() = default;
    template <class... Args>
    requires(sizeof...(Args) == sizeof...(Is) &&
             sizeof...(Is) > 0) constexpr explicit invariant_set(Args... is)
        : invariants_(std::move(is)...) {}

    template <class Op, class Mesh, class Tuple>
    bool before(const Mesh& m, const Tuple& t, states& s) const {
        return check_before<Op>(m, t, s, std::index_sequence_for<Is...>{});
    }
    template <class Op, class Mesh, class Result>
    bool after(const Mesh& m, const Result& r, states& s) const {
        return check_after<Op>(m, r, s, std::index_sequence_for<Is...>{});
    }

private:
    template <class Op, class Mesh, class Tuple, std::size_t... k>
    bool check_before(const Mesh& m, const Tuple& t, states& s, std::index_sequence<k...>) const {
        return (one_before<Op>(std::get<k>(invariants_), m, t, std::get<k>(s)) && ...);
    }
    template <class Op, class Mesh, class Result, std::size_t... k>
    bool check_after(const Mesh& m, const Result& r, states& s, std::index_sequence<k...>) const {
        return (one_after<Op>(std::get<k>(invariants_), m, r, std::get<k>(s)) && ...);
    }
    template <class I, class Mesh>
    static std::size_t claimed_words(const I& inv, const Mesh& m) {
        if constexpr (detail::claims_space<I>)
            return inv.extra_lock_words(m);
        else
            return 0;
    }
    template <class I>
    static void located(const I& inv, std::size_t k, vec3& c) {
        if constexpr (detail::claims_space<I>) c = inv.lock_cell_centre(k);
    }
    template <class Op, class I, class Mesh, class Tuple, class Take>
    static bool claim_one(const I& inv, const Mesh& m, const Tuple& t, Take& take) {
        if constexpr (detail::claims_space<I>)
            return inv.claim(Op{}, m, t, take, std::size_t(m.vertex_slots()));
        else
            return true;
    }
    template <class Op, class I, class Mesh, class Tuple>
    static bool one_before(const I& inv, const Mesh& m, const Tuple& t, typename I::state& s) {
        if constexpr (requires { inv.before(Op{}, m, t, s); })
            return inv.before(Op{}, m, t, s);
        else
            return true;
    }
    template <class Op, class I, class Mesh, class Result>
    static bool one_after(const I& inv, const Mesh& m, const Result& r, typename I::state& s) {
        if constexpr (requires { inv.after(Op{}, m, r, s); })
            return inv.after(Op{}, m, r, s);
        else
            return true;
    }

    std::tuple<Is...> invariants_;
};

template <class... Is>
invariant_set(Is...) -> invariant_set<Is...>;

namespace detail {
template <class Spec>
auto spec_invariants(const Spec& spec) {
    if constexpr (requires { spec.invariants(); })
        return spec.invariants();
    else
        return invariant_set<>{};
}
} // namespace detail

/// The empty spec: operations with no hooks and no extra invariants.
struct no_spec {};

} // namespace idas
