// The executor's policies on their own: every heap-ordered queue pops in one reference
// order (and so decimates identically), and vertex_try_lock keeps claims exclusive with
// more threads than cores.
#include "../test_support.hpp"
#include <algorithm>

#include <idas/algorithms/shortest_edge_collapse.hpp>
#include <idas/mesh/tet_mesh.hpp>

#include <tbb/global_control.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <ranges>
#include <set>
#include <span>
#include <thread>
#include <tuple>

using namespace idas;
using namespace idas::algorithms;

namespace {

using entry = queue_entry<tri_tuple>;
/// What the deterministic engine queues: ties taken in tie-hash order.
struct spread_entry : entry {
    static constexpr bool spreads_ties = true;
};
static_assert(!spreads_ties<entry> && spreads_ties<spread_entry>);

template <class E>
E as(const entry& e) {
    if constexpr (std::is_same_v<E, entry>)
        return e;
    else
        return E{e};
}

/// Random priorities over many octaves and both signs, with exact ties, zeros,
/// infinities and subnormals: every case the bucketed queue maps to buckets.
double random_priority(std::mt19937& rng) {
    switch (rng() % 8) {
    case 0:
        return double(rng() % 5); // exact ties
    case 1:
        return -double(rng() % 3); // includes -0.0, which equals +0.0
    case 2:
        return (rng() % 2 ? 1 : -1) * std::numeric_limits<double>::denorm_min() * double(rng() % 4);
    case 3:
        return rng() % 2 ? std::numeric_limits<double>::infinity()
                         : -std::numeric_limits<double>::infinity();
    default:
        return std::ldexp(std::uniform_real_distribution<double>(-1, 1)(rng), int(rng() % 80) - 40);
    }
}

template <class Policy, class E = entry>
void check_against_reference(unsigned seed) {
    std::mt19937 rng(seed);
    typename Policy::template type<E> q;
    // The order every heap promises: priority, then (entries that spread ties) the hash of
    // the tuple's tie key, then face id and local edge.
    using key = std::tuple<double, std::uint64_t, index_t, std::uint8_t>;
    std::multiset<key> ref;
    auto key_of = [](const E& e) {
        const std::uint64_t h = spreads_ties<E> ? tie_hash(tie_key(e.tuple)) : 0;
        return key{e.priority, h, e.tuple.fid, e.tuple.local_edge};
    };
    for (int round = 0; round < 3; ++round) {
        for (int step = 0; step < 20000; ++step) {
            const unsigned r = rng() % 16;
            auto random_entry = [&] {
                return as<E>({random_priority(rng),
                              {0, index_t(rng() % 500), std::uint8_t(rng() % 3), 0},
                              0,
                              0});
            };
            if (r < 8) {
                const E e = random_entry();
                q.push(e);
                ref.insert(key_of(e));
            } else if (r < 9) {
                // Many at once (a worker's seeds): the heap is rebuilt, the order kept.
                // Also as the executor's seeding gives them (runs of several blocks,
                // joined), and as a range with no common end (pushed one by one).
                std::vector<E> batch(1 + rng() % 40);
                for (E& e : batch) ref.insert(key_of(e = random_entry()));
                const std::size_t cut = rng() % (batch.size() + 1);
                const std::vector<std::span<const E>> runs{std::span<const E>(batch).first(cut),
                                                           std::span<const E>(batch).subspan(cut)};
                if constexpr (requires { q.push_all(std::span<const E>(batch)); }) {
                    const unsigned how = rng() % 3;
                    if (how == 0)
                        q.push_all(std::span<const E>(batch));
                    else if (how == 1)
                        q.push_all(runs | std::views::join);
                    else
                        q.push_all(std::span<const E>(batch) |
                                   std::views::take_while([](const E&) { return true; }));
                } else {
                    for (const E& e : batch) q.push(e);
                }
            } else if (r < 15) {
                E e{};
                const bool got = q.pop(e);
                REQUIRE(got == !ref.empty());
                if (got) {
                    REQUIRE(key_of(e) == *ref.begin());
                    ref.erase(ref.begin());
                }
            } else if (rng() % 64 == 0) {
                // A sweep removes exactly what the predicate names and keeps the order.
                const index_t mod = 2 + rng() % 5;
                q.erase_if([&](const E& e) { return e.tuple.fid % mod == 0; });
                std::erase_if(ref, [&](const key& k) { return std::get<2>(k) % mod == 0; });
            }
            REQUIRE(q.size() == ref.size());
        }
        q.clear();
        ref.clear();
        E e{};
        CHECK_FALSE(q.pop(e));
        CHECK(q.size() == 0);
    }
}

} // namespace

TEST_CASE("queue policies: every heap pops in the reference order, also after sweeps") {
    for (unsigned seed : {1u, 2u, 3u}) {
        CAPTURE(seed);
        check_against_reference<queue::binary_heap>(seed);
        check_against_reference<queue::dary_heap<4>>(seed);
        check_against_reference<queue::bucket_heap<>>(seed);
        check_against_reference<queue::bucket_heap<12>>(seed); // whole octaves per bucket
        check_against_reference<queue::binary_heap, spread_entry>(seed);
        check_against_reference<queue::dary_heap<4>, spread_entry>(seed);
        check_against_reference<queue::bucket_heap<>, spread_entry>(seed);
    }
}

TEST_CASE_TEMPLATE("queue policies: pops depend on what was pushed, not on the order", Q,
                   queue::binary_heap, queue::dary_heap<4>, queue::bucket_heap<>) {
    // Entries that differ only in vertex, version or kind, with tied priorities: what the
    // deterministic rounds rely on when threads push in any order.
    auto check = [](auto kind) {
        using E = decltype(kind);
        std::vector<E> all;
        for (index_t f = 0; f < 40; ++f)
            for (index_t v = 0; v < 3; ++v)
                all.push_back(as<E>({double(f % 3),
                                     {v, f, std::uint8_t(f % 3), version_t(v % 2)},
                                     std::uint8_t(v % 2),
                                     0}));
        std::mt19937 rng(5);
        std::vector<std::vector<E>> popped;
        for (int order = 0; order < 4; ++order) {
            std::shuffle(all.begin(), all.end(), rng);
            typename Q::template type<E> q;
            for (const E& e : all) q.push(e);
            auto& out = popped.emplace_back();
            for (E e{}; q.pop(e);) out.push_back(e);
            REQUIRE(out.size() == all.size());
            for (std::size_t i = 1; i < out.size(); ++i)
                CHECK_FALSE(pops_before(out[i], out[i - 1]));
        }
        for (const auto& out : popped)
            for (std::size_t i = 0; i < out.size(); ++i) {
                CHECK(out[i].tuple == popped[0][i].tuple);
                CHECK(out[i].kind == popped[0][i].kind);
            }
        return popped[0];
    };
    const auto by_slot = check(entry{});
    const auto spread = check(spread_entry{});
    // The two tie-breaks differ: by slot, equal priorities come in face order.
    bool same = true;
    for (std::size_t i = 0; i < by_slot.size(); ++i)
        same = same && by_slot[i].tuple == spread[i].tuple;
    CHECK_FALSE(same);
    for (std::size_t i = 1; i < by_slot.size(); ++i)
        if (by_slot[i].priority == by_slot[i - 1].priority)
            CHECK(by_slot[i - 1].tuple.fid <= by_slot[i].tuple.fid);
}

TEST_CASE("queue policies: fifo pops in push order and sweeps keep it") {
    queue::fifo::type<entry> q;
    for (index_t i = 0; i < 100; ++i) q.push({double(100 - i), {0, i, 0, 0}, 0, 0});
    entry e{};
    for (index_t i = 0; i < 10; ++i) REQUIRE((q.pop(e) && e.tuple.fid == i));
    q.erase_if([](const entry& x) { return x.tuple.fid % 2 == 0; });
    CHECK(q.size() == 45);
    for (index_t i = 11; i < 99; i += 2) REQUIRE((q.pop(e) && e.tuple.fid == i));
    // Many pushed at once come after what was there, in their order.
    const std::vector<entry> batch{{0.0, {0, 200, 0, 0}, 0, 0}, {5.0, {0, 201, 0, 0}, 0, 0}};
    q.push_all(batch);
    for (index_t f : {99u, 200u, 201u}) REQUIRE((q.pop(e) && e.tuple.fid == f));
    CHECK_FALSE(q.pop(e));
    // A thief takes from the far end; the owner's order stays.
    for (index_t i = 0; i < 6; ++i) q.push({0.0, {0, i, 0, 0}, 0, 0});
    REQUIRE((q.pop(e) && e.tuple.fid == 0));
    REQUIRE((q.pop_back(e) && e.tuple.fid == 5));
    REQUIRE((q.pop(e) && e.tuple.fid == 1));
    CHECK(q.size() == 3);
    for (index_t i = 4; i > 1; --i) REQUIRE((q.pop_back(e) && e.tuple.fid == i));
    CHECK_FALSE(q.pop_back(e));
    CHECK_FALSE(q.pop(e));
}

TEST_CASE_TEMPLATE("serial decimation is the same whichever heap orders it", Mesh,
                   IDAS_TRI_MESHES) {
    // The heaps pop equal entries in the same order, so the runs do the same collapses.
    auto run = [](auto queue_policy, std::int64_t& succeeded) {
        using Q = decltype(queue_policy);
        auto m = idas::test::load<Mesh>("bunny.off");
        shortest_edge_collapse_spec<> spec;
        spec.target_faces = std::int64_t(m.n_faces() / 10);
        const auto r = shortest_edge_collapse<true, Mesh, lock::vertex_try_lock, Q>::run(m, spec);
        succeeded = std::int64_t(r.succeeded);
        CHECK(std::int64_t(m.n_faces()) <= spec.target_faces);
        REQUIRE_FALSE(find_inconsistency(m).has_value());
        return m.to_arrays();
    };
    std::int64_t a = 0, b = 0, c = 0, d = 0;
    const auto reference = run(queue::binary_heap{}, a);
    CHECK(run(queue::dary_heap<4>{}, b) == reference);
    CHECK(run(queue::bucket_heap<>{}, c) == reference);
    CHECK(a == b);
    CHECK(a == c);
    // fifo ignores priorities: a different but valid result at the same target.
    run(queue::fifo{}, d);
    CHECK(d > 0);
}

TEST_CASE_TEMPLATE("partitions cover the live vertices of a mesh with many dead slots", Mesh,
                   IDAS_TRI_MESHES) {
    // After a decimation most vertex slots are dead (the executor partitions such meshes
    // in every phase after a collapse phase), and bunny.obj also has 1113 vertices no face
    // uses. Every vertex of a face still gets a part, parts are balanced and coherent.
    auto m = idas::test::load<Mesh>("bunny.obj");
    shortest_edge_collapse_spec<> spec;
    spec.target_faces = std::int64_t(m.n_faces() / 10);
    shortest_edge_collapse<true, Mesh>::run(m, spec);
    REQUIRE(m.n_vertices() * 5 < m.vertex_slots());
    auto check = [&](const std::vector<std::uint32_t>& part) {
        REQUIRE(part.size() == m.vertex_slots());
        std::vector<std::size_t> size(4, 0);
        std::size_t total = 0;
        m.for_each_vertex([&](const tri_tuple& t) { // the vertices with faces
            REQUIRE(part[t.vid] < 4);
            ++size[part[t.vid]], ++total;
        });
        for (std::size_t s : size) CHECK(double(s) > 0.2 * double(total));
        std::size_t edges = 0, cut = 0;
        m.for_each_edge([&](const tri_tuple& t) {
            const auto [a, b] = m.edge_vertices(t);
            ++edges, cut += part[a] != part[b];
        });
        CHECK(double(cut) < 0.1 * double(edges));
    };
    check(partition::metis::assign(m, 4));
    check(partition::morton::assign(m, 4));
}

TEST_CASE("morton partition: the cuts by selection are those of a full sort") {
    const auto m = idas::test::load("bunny.off");
    auto sorted = partition::morton::keys(m);
    REQUIRE(sorted.size() == m.n_vertices());
    std::sort(sorted.begin(), sorted.end());
    for (unsigned parts : {2u, 3u, 4u, 7u, 16u}) {
        CAPTURE(parts);
        const auto part = partition::morton::assign(m, parts);
        std::size_t wrong = 0;
        for (std::size_t i = 0; i < sorted.size(); ++i)
            wrong += part[sorted[i].second] != i * parts / sorted.size();
        CHECK(wrong == 0);
    }
}

static_assert(weighted_partition_policy<partition::morton, tri_mesh<>>);
static_assert(weighted_partition_policy<partition::morton, tet_mesh<>>);
static_assert(partition_policy<partition::metis, tri_mesh<>> &&
              !weighted_partition_policy<partition::metis, tri_mesh<>>);

TEST_CASE("morton partition by weight: contiguous on the curve, each part near its share") {
    // The executor weighs each vertex by the entries it seeds; here the weight sits in a
    // few places (one vertex in 16 weighs 100, and one in a few thousand 5,000, as clusters
    // of bad tets do), so equal vertex counts would be far from equal work.
    const auto m = idas::test::load("bunny.off");
    auto sorted = partition::morton::keys(m);
    std::sort(sorted.begin(), sorted.end());
    std::vector<std::uint32_t> weight(m.vertex_slots(), 0);
    std::uint64_t total = 0, heaviest = 0;
    for (std::size_t i = 0; i < sorted.size(); ++i) {
        const std::uint32_t w = i % 3001 == 7 ? 5000 : i % 16 == 0 ? 100 : 0;
        weight[sorted[i].second] = w, total += w, heaviest = std::max<std::uint64_t>(heaviest, w);
    }
    for (unsigned parts : {2u, 3u, 4u, 7u, 16u}) {
        CAPTURE(parts);
        const auto part = partition::morton::assign(m, parts, weight);
        std::vector<std::uint64_t> share(parts, 0);
        std::size_t descents = 0;
        for (std::size_t i = 0; i < sorted.size(); ++i) {
            REQUIRE(part[sorted[i].second] < parts);
            share[part[sorted[i].second]] += weight[sorted[i].second];
            descents += i > 0 && part[sorted[i].second] < part[sorted[i - 1].second];
        }
        CHECK(descents == 0); // parts follow the curve: each is one piece of it
        for (std::uint64_t got : share) {
            CHECK(double(got) >= double(total) / parts - double(heaviest) - 1);
            CHECK(double(got) <= double(total) / parts + double(heaviest) + 1);
        }
    }
    // Without weight, the cuts of the unweighted partition.
    const std::vector<std::uint32_t> none(m.vertex_slots(), 0);
    CHECK(partition::morton::assign(m, 4, none) == partition::morton::assign(m, 4));
}

TEST_CASE("morton partition by weight: the cuts of a full sort, on any thread count") {
    // The reference: sort by (code, vertex); cut k lies before the vertex whose weight
    // passes the target total * k / parts, or after it if that is nearer the target.
    // Armadillo (many vertices per histogram bucket) after a tenth of its faces went: dead
    // slots (collapsed edges); weights in clusters. Weight on dead slots alone: equal counts.
    auto m = idas::test::load("armadillo.obj");
    shortest_edge_collapse_spec<> spec;
    spec.target_faces = std::int64_t(m.n_faces() * 9 / 10);
    shortest_edge_collapse<>::run(m, spec);
    REQUIRE(m.n_vertices() < m.vertex_slots());
    auto sorted = partition::morton::keys(m);
    std::sort(sorted.begin(), sorted.end());
    std::vector<std::uint32_t> weight(m.vertex_slots(), 0);
    std::uint64_t total = 0;
    for (std::size_t i = 0; i < sorted.size(); ++i) {
        const std::uint32_t w = (i / 500) % 7 == 3 ? 40 : i % 5 == 0 ? 1 : 0;
        weight[sorted[i].second] = w, total += w;
    }
    for (unsigned parts : {2u, 5u, 16u, 64u}) {
        CAPTURE(parts);
        std::vector<std::uint32_t> expected(m.vertex_slots(), 0);
        std::size_t i = 0;
        std::uint64_t before = 0;
        for (unsigned k = 1; k < parts; ++k) {
            const std::uint64_t target = total * k / parts;
            while (before + weight[sorted[i].second] <= target)
                before += weight[sorted[i++].second];
            const bool after = 2 * (target - before) > weight[sorted[i].second];
            for (std::size_t j = i + (after ? 1 : 0); j < sorted.size(); ++j)
                expected[sorted[j].second] = k;
        }
        for (int threads : {1, 2, 5}) {
            CAPTURE(threads);
            const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            CHECK(partition::morton::assign(m, parts, weight) == expected);
        }
    }
    std::vector<std::uint32_t> dead_only(m.vertex_slots(), 0);
    for (index_t v = 0; v < m.vertex_slots(); ++v) dead_only[v] = m.vertex_alive(v) ? 0 : 9;
    CHECK(partition::morton::assign(m, 16, dead_only) == partition::morton::assign(m, 16));
}

TEST_CASE("vertex_try_lock: re-claiming is free for the holder, refused to others") {
    lock::vertex_try_lock locks(4);
    CHECK(locks.try_lock(2, 1));
    CHECK(locks.try_lock(2, 1));
    CHECK_FALSE(locks.try_lock(2, 7));
    locks.unlock(2, 1);
    CHECK(locks.try_lock(2, 7));
    CHECK(lock::none::try_lock(2, 1));
}

TEST_CASE("vertex_try_lock: 4 and 8 threads claiming overlapping regions never share a vertex") {
    // Regions of 32 neighbouring edges (closed stars of both ends, as the executor claims
    // them) overlap heavily. Each thread claims whole regions or backs off; while it holds
    // one, it marks each vertex busy: a second holder would find the mark. More threads
    // than cores, so holders are also preempted mid-claim.
    const auto m = idas::test::load("bunny.off");
    std::vector<std::vector<index_t>> regions;
    {
        index_t seed = 0;
        while (m.is_boundary_vertex(seed)) ++seed;
        std::vector<index_t> ring;
        m.one_ring_vertices(seed, ring);
        ring.push_back(seed);
        for (index_t v : ring)
            for (index_t f : m.vertex_faces(v)) {
                const auto t = m.tuple_in_face(v, f);
                std::vector<index_t> r;
                const auto [a, b] = m.edge_vertices(t);
                for (index_t s : {a, b})
                    for (index_t g : m.vertex_faces(s))
                        for (index_t w : m.face_vertices(g))
                            if (std::find(r.begin(), r.end(), w) == r.end()) r.push_back(w);
                regions.push_back(r);
            }
    }
    REQUIRE(regions.size() >= 32);
    for (unsigned threads : {4u, 8u}) {
        CAPTURE(threads);
        lock::vertex_try_lock locks(m.vertex_slots());
        std::vector<std::atomic<int>> busy(m.vertex_slots());
        std::vector<long> writes(m.vertex_slots(), 0); // plain: only a lock holder writes
        std::atomic<long> overlaps{0}, claimed{0}, refused{0}, expected_writes{0};
        std::vector<std::thread> pool;
        for (unsigned w = 0; w < threads; ++w) {
            pool.emplace_back([&, w] {
                std::mt19937 rng(w);
                const std::uint32_t me = w + 1;
                for (int i = 0; i < 4000; ++i) {
                    const auto& r = regions[rng() % regions.size()];
                    std::size_t got = 0;
                    while (got < r.size() && locks.try_lock(r[got], me)) ++got;
                    if (got == r.size()) {
                        for (index_t v : r) overlaps += busy[v].fetch_add(1) != 0;
                        for (index_t v : r) ++writes[v];
                        if (i % 16 == 0) std::this_thread::yield(); // get preempted holding it
                        for (index_t v : r) busy[v].fetch_sub(1);
                        ++claimed, expected_writes += long(r.size());
                    } else {
                        ++refused;
                    }
                    for (std::size_t k = 0; k < got; ++k) locks.unlock(r[k], me);
                }
            });
        }
        for (auto& t : pool) t.join();
        CHECK(overlaps.load() == 0);
        CHECK(claimed.load() > 0);
        CHECK(claimed.load() + refused.load() == long(threads) * 4000);
        long total = 0;
        for (long x : writes) total += x;
        CHECK(total == expected_writes.load()); // no write lost to a racing holder
        // Every lock word is free again: a new owner can take every vertex.
        bool all_free = true;
        for (index_t v = 0; v < m.vertex_slots(); ++v) all_free &= locks.try_lock(v, 99);
        CHECK(all_free);
    }
}
