// Tests of the grouped k-NN gather against the per-query gather and a brute-force oracle.
#include "common/photon/group_gather.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "common/photon/kd_tree.h"
#include "common/photon/photon_grid.h"

namespace rtpm {
namespace {

const Bounds kBox{Vec3(-2, -2, -1), Vec3(2, 2, 1)};

// A floor (z = 0) with a dense caustic blob, a sparse background, some photons arriving from
// below (must be ignored by up-facing queries) and a cluster of coincident photons.
std::vector<Photon> floorPhotons(uint32_t seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<float> blob(0.0f, 0.05f);
    std::uniform_real_distribution<float> uni(-1.5f, 1.5f), pw(0.1f, 1.0f);
    std::vector<Photon> out;
    for (int i = 0; i < 20000; ++i)
        out.push_back(Photon::make(Vec3(0.2f + blob(rng), -0.1f + blob(rng), 0.0f),
                                   Vec3(pw(rng), pw(rng), pw(rng)) * 1e-3f,
                                   Vec3(0.3f, 0.1f, -1.0f) * (1.0f / std::sqrt(1.1f))));
    for (int i = 0; i < 3000; ++i)
        out.push_back(
            Photon::make(Vec3(uni(rng), uni(rng), 0.0f), Vec3(pw(rng)) * 1e-3f, Vec3(0, 0, -1)));
    for (int i = 0; i < 500; ++i)  // from behind an up-facing floor
        out.push_back(Photon::make(Vec3(0.2f + blob(rng), -0.1f + blob(rng), 0.0f), Vec3(1e-3f),
                                   Vec3(0, 0, 1)));
    for (int i = 0; i < 100; ++i)  // coincident
        out.push_back(Photon::make(Vec3(-0.6f, 0.6f, 0.0f), Vec3(2e-3f), Vec3(0, 0, -1)));
    return out;
}

// Rows of query points like a set's pixels: 100 per row centred on the blob, so groups of 8
// neighbours along x with spacing `step` cross the blob, its edge and the sparse background.
std::vector<GatherQuery> rowQueries(float step) {
    std::vector<GatherQuery> q;
    for (float y = -0.5f; y <= 0.5f; y += 0.077f)
        for (int i = -50; i < 50; ++i)
            q.push_back(GatherQuery{Vec3(0.2f + float(i) * step, y, 0.0f), Vec3(0, 0, 1)});
    q.push_back(GatherQuery{Vec3(-0.6f, 0.6f, 0.0f), Vec3(0, 0, 1)});  // on the coincident cluster
    q.push_back(
        GatherQuery{Vec3(5.0f, 5.0f, 0.0f), Vec3(0, 0, 1)});  // outside every photon's reach
    return q;
}

// The k nearest front-facing photons strictly within rMax by sorting all of them.
DensityGather bruteForce(const std::vector<Photon>& photons, const GatherQuery& q, uint32_t k,
                         float rMax, float rMin) {
    std::vector<std::pair<float, size_t>> d;
    for (size_t i = 0; i < photons.size(); ++i) {
        const Vec3 e = photons[i].position - q.position;
        const float d2 = e.x * e.x + e.y * e.y + e.z * e.z;
        if (d2 < rMax * rMax && !arrivesFromBehind(photons[i].incoming, q.normal))
            d.push_back({d2, i});
    }
    std::sort(d.begin(), d.end());
    DensityGather g;
    if (d.empty()) return g;
    const size_t n = std::min<size_t>(k, d.size());
    PowerSum sum;
    for (size_t i = 0; i < n; ++i) sum.add(photons[d[i].second].power);
    g.power = sum.value();
    g.count = uint32_t(n);
    g.radius2 = n == k ? std::max(d[n - 1].first, rMin * rMin) : rMax * rMax;
    return g;
}

// The index's photons in its own order (query results index into it).
template <class Index>
std::vector<Photon> photonsOf(const Index& index) {
    const auto view = index.photons();
    return std::vector<Photon>(view.begin(), view.end());
}

template <class Index>
void expectGroupsMatch(const Index& index, const std::vector<Photon>& photons, float step,
                       uint32_t k, float rMax, std::initializer_list<float> guessScales) {
    const auto queries = rowQueries(step);
    const float rMin = kMinDensityRadiusRelative * index.bounds().diagonal();
    std::vector<DensityGather> oracles;
    for (const GatherQuery& q : queries) oracles.push_back(bruteForce(photons, q, k, rMax, rMin));
    GroupGatherScratch scratch;
    KnnHeap heap;
    for (const float guessScale : guessScales) {
        SCOPED_TRACE(testing::Message() << "guess " << guessScale);
        float hint2 = 0.0f;
        int groups = 0;
        for (size_t q0 = 0; q0 < queries.size(); q0 += 8) {
            const size_t n = std::min<size_t>(8, queries.size() - q0);
            std::vector<DensityGather> out(n);
            gatherKnnGroup(index, std::span(queries).subspan(q0, n), k, rMax, guessScale * hint2,
                           scratch, std::span(out));
            ++groups;
            hint2 = 0.0f;
            for (size_t i = 0; i < n; ++i) {
                const GatherQuery& q = queries[q0 + i];
                const DensityGather single = gatherKnn(index, q.position, q.normal, k, rMax, heap,
                                                       [](const Photon&) { return true; });
                const DensityGather& oracle = oracles[q0 + i];
                SCOPED_TRACE(testing::Message() << "query " << q0 + i << " at " << q.position.x
                                                << ", " << q.position.y);
                EXPECT_EQ(out[i].count, oracle.count);
                EXPECT_EQ(out[i].radius2, oracle.radius2);
                // Same photons (no ties at the k-th distance in these sets apart from the cluster,
                // where all tied photons carry the same power): bit-identical power, also to
                // gatherKnn.
                EXPECT_EQ(out[i].power, oracle.power);
                EXPECT_EQ(out[i].power, single.power);
                EXPECT_EQ(out[i].radius2, single.radius2);
                if (out[i].count == k) hint2 = std::max(hint2, out[i].radius2);
            }
        }
        EXPECT_GT(groups, 150);
    }
}

TEST(GroupGather, MatchesBruteForceAndTheSingleQueryGatherOnAKdTree) {
    const auto photons = floorPhotons(1);
    KdTree tree(kBox);
    tree.insert(photons);
    // Dense rows (groups well inside one gather radius), sparse ones (groups split), without a
    // guess, with the neighbour's, a tight one (queries repeat their search) and one far too
    // large (the candidate search overflows its cap and the group gathers per query); k = 64
    // and a small k.
    for (float step : {0.004f, 0.03f, 0.2f})
        for (uint32_t k : {64u, 5u}) {
            SCOPED_TRACE(testing::Message() << "step " << step << " k " << k);
            expectGroupsMatch(tree, photonsOf(tree), step, k, 0.1f, {0.0f, 1.25f, 0.3f, 50.0f});
        }
}

TEST(GroupGather, MatchesBruteForceOnTheGrid) {
    const auto photons = floorPhotons(2);
    PhotonGrid grid(32);
    grid.build(photons);
    expectGroupsMatch(grid, photonsOf(grid), 0.01f, 64, 0.08f, {1.25f});
}

TEST(GroupGather, SelectNearestKeepsTheKNearestOfAnyDistanceSpread) {
    // Distances spread evenly, crowded into one bucket, all equal (coincident photons), in two
    // clumps, and one bound so small the buckets cannot be scaled; k from 1 to m − 1.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const float bounds[] = {1.0f, 1.0f, 1.0f, 1.0f, 1e-38f};
    for (int spread = 0; spread < 5; ++spread)
        for (size_t m : {2u, 65u, 80u, 300u})
            for (uint32_t k : {1u, 5u, 64u, 79u})
                if (k < m) {
                    SCOPED_TRACE(testing::Message() << "spread " << spread << " m " << m << " k " << k);
                    const float bound2 = bounds[spread];
                    std::vector<KnnEntry> kept(m), tied(m + 1);
                    std::vector<uint32_t> buckets(m);
                    for (size_t j = 0; j < m; ++j) {
                        const float u = unit(rng);
                        const float d2 = spread == 0   ? u
                                         : spread == 1 ? 0.5f + 1e-4f * u
                                         : spread == 2 ? 0.25f
                                         : spread == 3 ? (j % 2 ? 0.9f : 0.1f) + 1e-3f * u
                                                       : 0.5f * u * bound2;
                        kept[j] = KnnEntry{std::min(d2, std::nextafter(bound2, 0.0f)), uint32_t(j)};
                    }
                    std::vector<float> want;
                    for (const KnnEntry& e : kept) want.push_back(e.dist2);
                    std::sort(want.begin(), want.end());
                    want.resize(k);
                    std::vector<KnnEntry> before = kept;
                    detail::selectNearest(kept.data(), m, k, bound2, tied.data(), buckets.data());
                    std::vector<float> got;
                    for (uint32_t e = 0; e < k; ++e) got.push_back(kept[e].dist2);
                    std::sort(got.begin(), got.end());
                    EXPECT_EQ(got, want);
                    // The front holds distinct entries of the input, unchanged.
                    std::vector<uint32_t> ids;
                    for (uint32_t e = 0; e < k; ++e) {
                        ids.push_back(kept[e].index);
                        EXPECT_EQ(kept[e].dist2, before[kept[e].index].dist2);
                    }
                    std::sort(ids.begin(), ids.end());
                    EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end()), ids.end());
                }
}

TEST(GroupGather, SquaredDistancesAreTheScalarFormulaBitForBit) {
    // The AVX2 clone (when the CPU has it) must give the bits of the baseline loop, any n.
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-3.0f, 3.0f);
    for (size_t n : {0u, 1u, 7u, 8u, 9u, 31u, 1000u}) {
        std::vector<float> x(n), y(n), z(n), d2(n, -1.0f);
        for (size_t j = 0; j < n; ++j) x[j] = u(rng), y[j] = u(rng), z[j] = 1e-3f * u(rng);
        const Vec3 q(u(rng), u(rng), u(rng));
        detail::squaredDistances(x.data(), y.data(), z.data(), n, q, d2.data());
        for (size_t j = 0; j < n; ++j) {
            volatile float ex = x[j] - q.x, ey = y[j] - q.y, ez = z[j] - q.z;
            volatile float xx = ex * ex, yy = ey * ey, zz = ez * ez;
            volatile float sum = xx + yy;
            const float want = sum + zz;
            EXPECT_EQ(d2[j], want) << "n " << n << " j " << j;
        }
    }
}

TEST(GroupGather, DegenerateArgumentsGiveEmptyGathers) {
    KdTree tree(kBox);
    tree.insert(floorPhotons(3));
    const auto queries = rowQueries(0.1f);
    GroupGatherScratch scratch;
    std::vector<DensityGather> out(8, DensityGather{Vec3(1.0f), 1.0f, 1});
    const auto q = std::span(queries).first(8);
    gatherKnnGroup(tree, q, 0, 0.1f, 0.0f, scratch, std::span(out));
    for (const DensityGather& g : out) EXPECT_EQ(g.radius2, 0.0f);
    out.assign(8, DensityGather{Vec3(1.0f), 1.0f, 1});
    gatherKnnGroup(tree, q, 64, 0.0f, 0.0f, scratch, std::span(out));
    for (const DensityGather& g : out) EXPECT_EQ(g.count, 0u);
    KdTree empty(kBox);
    out.assign(8, DensityGather{Vec3(1.0f), 1.0f, 1});
    gatherKnnGroup(empty, q, 64, 0.1f, 0.0f, scratch, std::span(out));
    for (const DensityGather& g : out) EXPECT_EQ(g.count, 0u);
}

}  // namespace
}  // namespace rtpm
