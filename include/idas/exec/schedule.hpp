// Schedules of phases: multi-phase algorithms (remeshing: split, collapse, swap, smooth,
// repeated; harmonic: flips, then smoothing and flips) written as a type,
//
//   using remeshing_schedule = schedule::repeat<schedule::phase<split_spec>,
//                                               schedule::phase<collapse_spec>,
//                                               schedule::phase<swap_spec>,
//                                               schedule::phase<smooth_spec, queue::fifo>>;
//
// and run by one driver on the algorithm's mesh, lock and partition policies. Each phase
// is one executor run of its spec; the driver hands each phase the spec object of its
// type (specs share state by reference, never through a pointer) and sums the reports.
#pragma once

#include <idas/exec/executor.hpp>

#include <array>
#include <cstddef>
#include <tuple>
#include <type_traits>

namespace idas::schedule {

/// The algorithm's queue policy (the driver's Queue argument).
struct default_queue {};

/// One executor run of Spec. `MaxThreads` (0: the run's) caps its threads: a phase with
/// little work is cheaper on one thread than starting workers.
template <class Spec, class Queue = default_queue, unsigned MaxThreads = 0>
struct phase {
    using spec_type = Spec;
    using queue = Queue;
    static constexpr unsigned max_threads = MaxThreads;
};

/// Phases one after the other, once.
template <class... Steps>
struct sequence {};

/// Phases in turn, up to the driver's iteration count, until an iteration whose
/// connectivity-changing operations all did nothing (moves alone do not count).
template <class... Steps>
struct repeat {};

/// Phases in turn, up to the driver's iteration count, until an iteration in which no
/// operation succeeded.
template <class... Steps>
struct repeat_while_busy {};

/// Sums of each phase's runs, in the order the phases are written.
template <std::size_t N>
struct report {
    std::array<run_report, N> phases{};
    unsigned iterations = 0; // of the (last) repeat
    double seconds = 0;
};

namespace detail {

template <class T>
struct phase_count {
    static constexpr std::size_t value = 1;
};
template <template <class...> class Group, class... Steps>
requires(std::is_same_v<Group<Steps...>, sequence<Steps...>> ||
         std::is_same_v<Group<Steps...>, repeat<Steps...>> ||
         std::is_same_v<Group<Steps...>,
                        repeat_while_busy<Steps...>>) struct phase_count<Group<Steps...>> {
    static constexpr std::size_t value = (phase_count<Steps>::value + ... + 0);
};

template <class T>
struct is_phase : std::false_type {};
template <class S, class Q, unsigned T>
struct is_phase<phase<S, Q, T>> : std::true_type {};

} // namespace detail

/// The number of phases a schedule writes out.
template <class Schedule>
inline constexpr std::size_t phase_count_v = detail::phase_count<Schedule>::value;

/// Runs Schedule on one mesh type with the algorithm's lock, queue and partition
/// policies. `observer(position, iteration, const run_report&)` hears of every phase run
/// that ends (a progress display, a log); position counts phases as written.
template <class Schedule, class Mesh, class Lock, class Queue, class Partition>
struct driver {
    using report_type = report<phase_count_v<Schedule>>;

    template <class Observer, class... Specs>
    static report_type run(Mesh& m, const exec_options& options, unsigned iterations,
                           Observer&& observer, Specs&... specs) {
        const auto start = std::chrono::steady_clock::now();
        report_type r;
        std::tuple<Specs&...> bound(specs...);
        context<Observer, Specs...> ctx{m, options, iterations, observer, bound, r};
        step<0>(ctx, static_cast<Schedule*>(nullptr));
        r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return r;
    }

private:
    template <class Observer, class... Specs>
    struct context {
        Mesh& m;
        const exec_options& options;
        unsigned iterations;
        Observer& observer;
        std::tuple<Specs&...>& specs;
        report_type& report;
    };

    /// What one pass over some steps did: successes, and those that changed connectivity.
    struct pass {
        std::uint64_t succeeded = 0, edited = 0;
        pass& operator+=(const pass& o) {
            succeeded += o.succeeded, edited += o.edited;
            return *this;
        }
    };

    template <std::size_t At, class Ctx, class Spec, class Q, unsigned T>
    static pass step(Ctx& c, phase<Spec, Q, T>*) {
        using queue = std::conditional_t<std::is_same_v<Q, default_queue>, Queue, Q>;
        // A phase held to one thread runs on one thread at every thread count of the run,
        // so a deterministic run may take it serially: the same mesh whatever the threads,
        // without the rounds (harmonic triangulation's seeded flips: four times the
        // serial executor's time in rounds; bench/RESULTS.md, "Session 36").
        using phase_lock =
            std::conditional_t<T == 1 && deterministic_policy<Lock>, lock::none, Lock>;
        using algorithm = executor<Spec, Mesh, phase_lock, queue, Partition>;
        exec_options o = c.options;
        if (T > 0 && o.threads > T) o.threads = T;
        const run_report rr = algorithm::run(c.m, spec_of<Spec>(c.specs), o);
        c.report.phases[At] += rr;
        c.report.phases[At].faces = rr.faces, c.report.phases[At].vertices = rr.vertices;
        c.observer(At, c.report.iterations, rr);
        constexpr bool edits =
            idas::detail::op_list_traits<typename Spec::operations>::changes_connectivity;
        return {rr.succeeded, edits ? rr.succeeded : 0};
    }

    template <std::size_t At, class Ctx, class... Steps>
    static pass step(Ctx& c, sequence<Steps...>*) {
        return steps_in_turn<At, Steps...>(c);
    }
    template <std::size_t At, class Ctx, class... Steps>
    static pass step(Ctx& c, repeat<Steps...>*) {
        return iterate<At, false, Steps...>(c);
    }
    template <std::size_t At, class Ctx, class... Steps>
    static pass step(Ctx& c, repeat_while_busy<Steps...>*) {
        return iterate<At, true, Steps...>(c);
    }

    template <std::size_t At, bool WhileBusy, class... Steps, class Ctx>
    static pass iterate(Ctx& c) {
        pass total;
        for (unsigned it = 0; it < c.iterations; ++it) {
            const pass p = steps_in_turn<At, Steps...>(c);
            total += p;
            c.report.iterations = it + 1;
            if ((WhileBusy ? p.succeeded : p.edited) == 0) break; // settled
        }
        return total;
    }

    template <std::size_t At, class First, class... Rest, class Ctx>
    static pass steps_in_turn(Ctx& c) {
        pass p = step<At>(c, static_cast<First*>(nullptr));
        if constexpr (sizeof...(Rest) > 0)
            p += steps_in_turn<At + detail::phase_count<First>::value, Rest...>(c);
        return p;
    }

    /// The spec object of type Spec among those the caller passed.
    template <class Spec, class... Specs>
    static Spec& spec_of(std::tuple<Specs&...>& specs) {
        static_assert((std::is_same_v<Spec, Specs> || ...),
                      "idas: the schedule has a phase of a spec type that was not passed to "
                      "schedule::driver::run");
        return std::get<Spec&>(specs);
    }
};

/// An observer that hears nothing.
struct no_observer {
    constexpr void operator()(std::size_t, unsigned, const run_report&) const noexcept {}
};

} // namespace idas::schedule
