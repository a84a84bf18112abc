// The IDAS contract, checked at compile time. A spec's hooks are optional, but a member
// that carries a hook's name must have the hook's signature: otherwise the executor would
// skip it without a word (an `after` that takes the wrong cache type is never called).
//
// The hooks, for each operation kind Op in `Spec::operations` (Mesh::tuple is `tuple`):
//   double priority(Op, const Mesh&, const tuple&)             lower runs first
//   bool | std::optional<Cache> before(Op, const Mesh&, const tuple&)
//   bool after(Op, Mesh&, const op_result<tuple>&[, Cache&])   Cache: what before returns
//   void renew(Op, const Mesh&, const op_result<tuple>&, Push&)   push(Op2{}, tuple)
//   bool should_process(Op, const Mesh&, const queue_entry<tuple>&)
//   void refused(Op, const Mesh&, const tuple&)
//   bool lock_region(Op, const Mesh&, tuple&, Take&)           take(vertex) -> bool
// and once per spec:
//   bool stop(const progress&)           std::int64_t remaining(const progress&)
//   void initial(const Mesh&, Push&)     void initial_at(const Mesh&, index_t, Push&)
//   void prepare(Mesh&[, const exec_options&])                void finish(Mesh&)
//   void quiescent(Mesh&, const progress&)   where no operation runs: after each success
//                                            of a serial run or of the final serial pass,
//                                            and before each deterministic round
//   parallel_growth(const Mesh&) -> index_t or std::pair<index_t, index_t>
//   invariant_set<...> invariants() const
//   static constexpr bool decides_holding_seeds   should_process reads only the stars of
//                                            the operation's own vertices and what no
//                                            operation of the phase writes: in parallel
//                                            it is asked before the rest of the region
//                                            is claimed
// and for each invariant I of the set (`I::state` default-constructible):
//   bool before(Op, const Mesh&, const tuple&, I::state&)
//   bool after(Op, const Mesh&, const op_result<tuple>&, I::state&)
//
// A member is found by name (any signature, inherited too) with the ambiguity probe
// below; then it must match. What cannot be caught: a misspelled name (only the few
// near misses listed in `near_misses` are), hooks of a `final` spec class, and an
// invariant hook tagged with an operation kind the spec does not list (invariants may
// serve several specs).
#pragma once

#include <idas/exec/op_list.hpp>
#include <idas/exec/queue.hpp>
#include <idas/exec/report.hpp>
#include <idas/ops/operation.hpp>

#include <concepts>
#include <optional>
#include <type_traits>
#include <utility>

namespace idas {

namespace detail {

/// Stands in for the executor's push callbacks when asking what a spec takes.
template <class Tuple>
struct push_probe {
    template <operation_kind Op>
    void operator()(Op, const Tuple&) const noexcept {}
};
/// Stands in for a lock policy's vertex claim.
struct take_probe {
    bool operator()(index_t) const noexcept { return true; }
};

// ---- finding a member by its name, whatever its signature ----
// mix<T> sees `name` twice, in T and in hook_names, if T has such a member: then
// `&mix<T>::name` is ambiguous (ill-formed); it is fine if only hook_names has it.
struct hook_names {
    void priority();
    void before();
    void after();
    void renew();
    void should_process();
    void refused();
    void lock_region();
    void stop();
    void remaining();
    void initial();
    void initial_at();
    void prepare();
    void finish();
    void quiescent();
    void parallel_growth();
    void invariants();
    // near misses of real names
    void operation();
    void invariant();
    void priorities();
    void renews();
};
template <class T>
struct hook_name_probe : T, hook_names {};

#define IDAS_DECLARES(name)                                                                        \
    template <class T>                                                                             \
    concept declares_##name = std::is_class_v<T> && !std::is_final_v<T> && !requires {             \
        &hook_name_probe<T>::name;                                                                 \
    };
IDAS_DECLARES(priority)
IDAS_DECLARES(before)
IDAS_DECLARES(after)
IDAS_DECLARES(renew)
IDAS_DECLARES(should_process)
IDAS_DECLARES(refused)
IDAS_DECLARES(lock_region)
IDAS_DECLARES(stop)
IDAS_DECLARES(remaining)
IDAS_DECLARES(initial)
IDAS_DECLARES(initial_at)
IDAS_DECLARES(prepare)
IDAS_DECLARES(finish)
IDAS_DECLARES(quiescent)
IDAS_DECLARES(parallel_growth)
IDAS_DECLARES(invariants)
IDAS_DECLARES(operation)
IDAS_DECLARES(invariant)
IDAS_DECLARES(priorities)
IDAS_DECLARES(renews)
#undef IDAS_DECLARES

// ---- each hook, called as the executor calls it ----
template <class S, class M, class Op>
concept priority_hook = requires(S& s, const M& m, const typename M::tuple& t) {
    { s.priority(Op{}, m, t) } -> std::convertible_to<double>;
};
/// The mistake that compiles: the mesh or tuple taken by non-const reference.
template <class S, class M, class Op>
concept priority_hook_nonconst = requires(S& s, M& m, typename M::tuple& t) {
    s.priority(Op{}, m, t);
};

template <class S, class M, class Op>
concept before_hook = requires(S& s, const M& m, const typename M::tuple& t) {
    s.before(Op{}, m, t);
};
template <class S, class M, class Op>
concept before_hook_nonconst = requires(S& s, M& m, typename M::tuple& t) {
    s.before(Op{}, m, t);
};

/// What `before` hands to `after`: its optional's value type, or no_cache.
template <class S, class M, class Op>
struct cache_of {
    using type = no_cache;
};
template <class S, class M, class Op>
requires before_hook<S, M, Op>
struct cache_of<S, M, Op> {
    using R = decltype(std::declval<S&>().before(Op{}, std::declval<const M&>(),
                                                 std::declval<const typename M::tuple&>()));
    using type =
        typename std::conditional_t<is_optional<R>::value, R, std::optional<no_cache>>::value_type;
};
template <class S, class M, class Op>
using cache_t = typename cache_of<S, M, Op>::type;

template <class S, class M, class Op>
concept before_returns_bool_or_optional =
    !before_hook<S, M, Op> ||
    is_optional<decltype(std::declval<S&>().before(
        Op{}, std::declval<const M&>(), std::declval<const typename M::tuple&>()))>::value ||
    std::convertible_to<decltype(std::declval<S&>().before(
                            Op{}, std::declval<const M&>(),
                            std::declval<const typename M::tuple&>())),
                        bool>;

template <class S, class M, class Op>
concept after_hook_with_cache = requires(S& s, M& m, const op_result<typename M::tuple>& r,
                                         cache_t<S, M, Op>& c) {
    { s.after(Op{}, m, r, c) } -> std::convertible_to<bool>;
};
template <class S, class M, class Op>
concept after_hook_without_cache = requires(S& s, M& m, const op_result<typename M::tuple>& r) {
    { s.after(Op{}, m, r) } -> std::convertible_to<bool>;
};
template <class S, class M, class Op>
concept after_hook = after_hook_with_cache<S, M, Op> || after_hook_without_cache<S, M, Op>;

template <class S, class M, class Op>
concept renew_hook = requires(S& s, const M& m, const op_result<typename M::tuple>& r,
                              push_probe<typename M::tuple>& push) {
    s.renew(Op{}, m, r, push);
};
template <class S, class M, class Op>
concept should_process_hook = requires(S& s, const M& m, const queue_entry<typename M::tuple>& e) {
    { s.should_process(Op{}, m, e) } -> std::convertible_to<bool>;
};
template <class S, class M, class Op>
concept refused_hook = requires(S& s, const M& m, const typename M::tuple& t) {
    s.refused(Op{}, m, t);
};
template <class S, class M, class Op>
concept lock_region_hook = requires(S& s, const M& m, typename M::tuple& t, take_probe& take) {
    { s.lock_region(Op{}, m, t, take) } -> std::convertible_to<bool>;
};

template <class S>
concept stop_hook = requires(S& s, const progress& p) {
    { s.stop(p) } -> std::convertible_to<bool>;
};
template <class S>
concept remaining_hook = requires(S& s, const progress& p) {
    { s.remaining(p) } -> std::convertible_to<std::int64_t>;
};
template <class S, class M>
concept initial_hook = requires(S& s, const M& m, push_probe<typename M::tuple>& push) {
    s.initial(m, push);
};
template <class S, class M>
concept initial_at_hook = requires(S& s, const M& m, index_t v,
                                   push_probe<typename M::tuple>& push) {
    s.initial_at(m, v, push);
};
template <class S, class M>
concept prepare_hook = requires(S& s, M& m, const exec_options& o) {
    s.prepare(m, o);
}
|| requires(S& s, M& m) {
    s.prepare(m);
};
template <class S, class M>
concept finish_hook = requires(S& s, M& m) {
    s.finish(m);
};
template <class S, class M>
concept quiescent_hook = requires(S& s, M& m, const progress& p) {
    s.quiescent(m, p);
};
/// A spec that may be asked `should_process` holding only the operation's own vertices.
template <class S>
concept decides_holding_seeds = requires {
    requires bool(S::decides_holding_seeds);
};

template <class S, class M>
concept parallel_growth_hook = requires(S& s, const M& m) {
    { s.parallel_growth(m) } -> std::convertible_to<index_t>;
}
|| requires(S& s, const M& m) {
    { s.parallel_growth(m).first } -> std::convertible_to<index_t>;
    { s.parallel_growth(m).second } -> std::convertible_to<index_t>;
};
template <class S>
concept invariants_hook = requires(const S& s) {
    s.invariants();
};

// ---- invariants ----
template <class I, class M, class Op>
concept invariant_before_hook = requires(const I& i, const M& m, const typename M::tuple& t,
                                         typename I::state& st) {
    { i.before(Op{}, m, t, st) } -> std::convertible_to<bool>;
};
template <class I, class M, class Op>
concept invariant_before_nonconst = requires(const I& i, M& m, typename M::tuple& t,
                                             typename I::state& st) {
    i.before(Op{}, m, t, st);
};
template <class I, class M, class Op>
concept invariant_after_hook = requires(const I& i, const M& m,
                                        const op_result<typename M::tuple>& r,
                                        typename I::state& st) {
    { i.after(Op{}, m, r, st) } -> std::convertible_to<bool>;
};
template <class I, class M, class Op>
concept invariant_after_nonconst = requires(const I& i, M& m, op_result<typename M::tuple>& r,
                                            typename I::state& st) {
    i.after(Op{}, m, r, st);
};

/// One invariant's hooks for one operation kind. A hook that only a non-const mesh would
/// reach is the mistake; one that does not apply to Op at all is fine.
template <class I, class M, class Op>
struct invariant_check {
    static constexpr bool before_ok =
        invariant_before_hook<I, M, Op> || !invariant_before_nonconst<I, M, Op>;
    static constexpr bool after_ok =
        invariant_after_hook<I, M, Op> || !invariant_after_nonconst<I, M, Op>;
    static constexpr bool ok = before_ok && after_ok;
    static constexpr bool check() {
        static_assert(before_ok, "idas: invariant hook `before` must take the mesh as const: "
                                 "bool before(Op, const Mesh&, const Mesh::tuple&, state&)");
        static_assert(after_ok,
                      "idas: invariant hook `after` must take the mesh and result as const: "
                      "bool after(Op, const Mesh&, const op_result<Mesh::tuple>&, state&)");
        return ok;
    }
};

template <class Set>
struct invariant_types;
template <class... Is>
struct invariant_types<invariant_set<Is...>> {
    template <class M, class Op>
    static constexpr bool ok = (invariant_check<Is, M, Op>::ok && ...);
    template <class M, class Op>
    static constexpr bool check() {
        return (invariant_check<Is, M, Op>::check() && ...);
    }
};

/// The spec's hooks for one operation kind.
template <class S, class M, class Op>
struct op_hook_check {
    using set = std::remove_cvref_t<decltype(spec_invariants(std::declval<const S&>()))>;
    static constexpr bool priority_ok =
        !declares_priority<S> || priority_hook<S, M, Op> || !priority_hook_nonconst<S, M, Op>;
    static constexpr bool before_ok =
        (!declares_before<S> || before_hook<S, M, Op> ||
         !before_hook_nonconst<S, M, Op>)&&before_returns_bool_or_optional<S, M, Op>;
    // A cache that no `after` takes would be dropped: that is always a mistake.
    static constexpr bool cache_taken =
        std::is_same_v<cache_t<S, M, Op>, no_cache> || after_hook_with_cache<S, M, Op>;
    static constexpr bool invariants_ok = invariant_types<set>::template ok<M, Op>;
    static constexpr bool ok = priority_ok && before_ok && cache_taken && invariants_ok;

    static constexpr bool check() {
        static_assert(priority_ok, "idas: spec hook `priority` must take the mesh and tuple as "
                                   "const: double priority(Op, const Mesh&, const Mesh::tuple&)");
        static_assert(before_ok, "idas: spec hook `before` must be bool or std::optional<Cache> "
                                 "before(Op, const Mesh&, const Mesh::tuple&)");
        static_assert(cache_taken,
                      "idas: spec hook `after` does not take the cache that `before` returns for "
                      "this operation kind: expected bool after(Op, Mesh&, const "
                      "op_result<Mesh::tuple>&, Cache&) with Cache the value type of before()'s "
                      "std::optional");
        return invariant_types<set>::template check<M, Op>() && ok;
    }
};

/// A hook named in the spec must serve at least one of its operation kinds.
template <class S, class M, class... Ops>
struct spec_hook_check {
    static constexpr bool priority_ok = !declares_priority<S> || (priority_hook<S, M, Ops> || ...);
    static constexpr bool before_ok = !declares_before<S> || (before_hook<S, M, Ops> || ...);
    static constexpr bool after_ok = !declares_after<S> || (after_hook<S, M, Ops> || ...);
    static constexpr bool renew_ok = !declares_renew<S> || (renew_hook<S, M, Ops> || ...);
    static constexpr bool should_process_ok =
        !declares_should_process<S> || (should_process_hook<S, M, Ops> || ...);
    static constexpr bool refused_ok = !declares_refused<S> || (refused_hook<S, M, Ops> || ...);
    static constexpr bool lock_region_ok =
        !declares_lock_region<S> || (lock_region_hook<S, M, Ops> || ...);
    static constexpr bool stop_ok = !declares_stop<S> || stop_hook<S>;
    static constexpr bool remaining_ok = !declares_remaining<S> || remaining_hook<S>;
    static constexpr bool initial_ok = !declares_initial<S> || initial_hook<S, M>;
    static constexpr bool initial_at_ok = !declares_initial_at<S> || initial_at_hook<S, M>;
    static constexpr bool prepare_ok = !declares_prepare<S> || prepare_hook<S, M>;
    static constexpr bool finish_ok = !declares_finish<S> || finish_hook<S, M>;
    static constexpr bool quiescent_ok = !declares_quiescent<S> || quiescent_hook<S, M>;
    static constexpr bool parallel_growth_ok =
        !declares_parallel_growth<S> || parallel_growth_hook<S, M>;
    static constexpr bool invariants_ok = !declares_invariants<S> || invariants_hook<S>;
    static constexpr bool names_ok = !declares_operation<S> && !declares_invariant<S> &&
                                     !declares_priorities<S> && !declares_renews<S>;
    static constexpr bool ok =
        priority_ok && before_ok && after_ok && renew_ok && should_process_ok && refused_ok &&
        lock_region_ok && stop_ok && remaining_ok && initial_ok && initial_at_ok && prepare_ok &&
        finish_ok && quiescent_ok && parallel_growth_ok && invariants_ok && names_ok;

    static constexpr bool check() {
        static_assert(priority_ok, "idas: spec hook `priority` matches no operation kind in "
                                   "Spec::operations: expected double priority(Op, const Mesh&, "
                                   "const Mesh::tuple&) for a listed Op");
        static_assert(before_ok, "idas: spec hook `before` matches no operation kind in "
                                 "Spec::operations: expected bool or std::optional<Cache> "
                                 "before(Op, const Mesh&, const Mesh::tuple&) for a listed Op");
        static_assert(after_ok,
                      "idas: spec hook `after` matches no operation kind in Spec::operations: "
                      "expected bool after(Op, Mesh&, const op_result<Mesh::tuple>&[, Cache&]) "
                      "for a listed Op, Cache being what before() returns");
        static_assert(renew_ok, "idas: spec hook `renew` matches no operation kind in "
                                "Spec::operations: expected void renew(Op, const Mesh&, const "
                                "op_result<Mesh::tuple>&, Push&) for a listed Op");
        static_assert(should_process_ok,
                      "idas: spec hook `should_process` matches no operation kind in "
                      "Spec::operations: expected bool should_process(Op, const Mesh&, const "
                      "queue_entry<Mesh::tuple>&) for a listed Op");
        static_assert(refused_ok, "idas: spec hook `refused` matches no operation kind in "
                                  "Spec::operations: expected void refused(Op, const Mesh&, "
                                  "const Mesh::tuple&) for a listed Op");
        static_assert(lock_region_ok,
                      "idas: spec hook `lock_region` matches no operation kind in "
                      "Spec::operations: expected bool lock_region(Op, const Mesh&, "
                      "Mesh::tuple&, Take&) for a listed Op");
        static_assert(stop_ok, "idas: spec hook `stop` does not match: expected bool stop(const "
                               "idas::progress&)");
        static_assert(remaining_ok, "idas: spec hook `remaining` does not match: expected "
                                    "std::int64_t remaining(const idas::progress&)");
        static_assert(initial_ok, "idas: spec hook `initial` does not match: expected void "
                                  "initial(const Mesh&, Push&)");
        static_assert(initial_at_ok, "idas: spec hook `initial_at` does not match: expected void "
                                     "initial_at(const Mesh&, index_t, Push&)");
        static_assert(prepare_ok, "idas: spec hook `prepare` does not match: expected void "
                                  "prepare(Mesh&) or prepare(Mesh&, const idas::exec_options&)");
        static_assert(finish_ok,
                      "idas: spec hook `finish` does not match: expected void finish(Mesh&)");
        static_assert(quiescent_ok, "idas: spec hook `quiescent` does not match: expected void "
                                    "quiescent(Mesh&, const idas::progress&)");
        static_assert(parallel_growth_ok,
                      "idas: spec hook `parallel_growth` does not match: expected index_t or "
                      "std::pair<index_t, index_t> parallel_growth(const Mesh&)");
        static_assert(invariants_ok, "idas: spec hook `invariants` does not match: expected "
                                     "invariant_set<...> invariants() const");
        static_assert(names_ok, "idas: the spec has a member named `operation`, `invariant`, "
                                "`priorities` or `renews`: did you mean `operations`, "
                                "`invariants`, `priority` or `renew`?");
        return ok && (op_hook_check<S, M, Ops>::check() && ...);
    }
};

template <class S, class M, class L = typename S::operations>
struct contract;
template <class S, class M, class... Ops>
struct contract<S, M, op_list<Ops...>> {
    static constexpr bool satisfied =
        spec_hook_check<S, M, Ops...>::ok && (op_hook_check<S, M, Ops>::ok && ...);
    /// Fails to compile, with a message naming the hook, unless the spec is satisfied.
    static constexpr bool check() { return spec_hook_check<S, M, Ops...>::check(); }
};

template <class S>
concept lists_operations = requires {
    typename S::operations;
}
&&op_list_traits<typename S::operations>::is_op_list;

} // namespace detail

/// A spec the executor can run on Mesh: it lists its operation kinds (`using operations =
/// idas::op_list<...>`), and every hook it declares has the hook's signature (see the
/// table at the top of this file).
template <class Spec, class Mesh>
concept spec_for = detail::lists_operations<Spec> && detail::contract<Spec, Mesh>::satisfied;

namespace detail {
/// The executor's check: a static_assert that names what is wrong.
template <class Spec, class Mesh>
constexpr bool check_contract() {
    static_assert(std::is_class_v<Spec>, "idas: a spec is a class type");
    static_assert(lists_operations<Spec>,
                  "idas: the spec must list its operation kinds: using operations = "
                  "idas::op_list<idas::op::...>;");
    if constexpr (lists_operations<Spec>)
        return contract<Spec, Mesh>::check();
    else
        return false;
}
} // namespace detail

} // namespace idas
