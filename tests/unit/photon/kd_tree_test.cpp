// Brute-force oracle tests of the photon indices: middle-split KdTree, MedianKdTree, PhotonGrid.
#include "common/photon/kd_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

#include "common/photon/median_kd_tree.h"
#include "common/photon/photon_grid.h"

namespace rtpm {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

Photon photonAt(Vec3 p) { return Photon::make(p, Vec3(1.0f), Vec3(0, 0, -1)); }

float dist2(Vec3 a, Vec3 b) {
    const Vec3 d = a - b;  // same expression as the traversals, so distances compare exactly
    return d.x * d.x + d.y * d.y + d.z * d.z;
}

std::vector<Photon> uniformPhotons(size_t n, uint32_t seed, Vec3 lo = Vec3(0), Vec3 hi = Vec3(10)) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Photon> out;
    for (size_t i = 0; i < n; ++i)
        out.push_back(photonAt(lo + (hi - lo) * Vec3(u(rng), u(rng), u(rng))));
    return out;
}

std::vector<Photon> clusteredPhotons(size_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 10.0f);
    std::normal_distribution<float> g(0.0f, 0.01f);
    std::vector<Vec3> centres;
    for (int c = 0; c < 8; ++c) centres.push_back(Vec3(u(rng), u(rng), u(rng)));
    std::vector<Photon> out;
    for (size_t i = 0; i < n; ++i) {
        const Vec3 c = centres[i % centres.size()];
        out.push_back(photonAt(c + Vec3(g(rng), g(rng), g(rng))));
    }
    return out;
}

std::vector<Photon> coincidentPhotons(size_t n) {
    return std::vector<Photon>(n, photonAt(Vec3(1.25f, 2.5f, 3.75f)));
}

std::vector<Photon> collinearPhotons(size_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Photon> out;
    for (size_t i = 0; i < n; ++i) out.push_back(photonAt(Vec3(1, 2, 3) + u(rng) * Vec3(4, 2, 1)));
    return out;
}

std::vector<Photon> largeCoordinatePhotons(size_t n, uint32_t seed) {
    return uniformPhotons(n, seed, Vec3(1e5f, -1e5f, 2e5f), Vec3(1e5f + 10, -1e5f + 10, 2e5f + 10));
}

Bounds boundsOf(const std::vector<Photon>& photons) {
    Bounds b;
    for (const Photon& p : photons) b.extend(p.position);
    return b;
}

std::vector<Vec3> queriesFor(const std::vector<Photon>& photons, size_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    const Bounds b = boundsOf(photons);
    const Vec3 pad = 0.2f * b.extent() + Vec3(0.1f);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Vec3> out;
    for (size_t i = 0; i < n; ++i) {
        if (i % 3 == 0 && !photons.empty())
            out.push_back(photons[(i * 7919) % photons.size()].position);  // on a photon
        else
            out.push_back(b.lo - pad + (b.extent() + 2.0f * pad) * Vec3(u(rng), u(rng), u(rng)));
    }
    return out;
}

std::vector<float> bruteForce(const std::vector<Photon>& photons, Vec3 q, uint32_t k,
                              float maxDist2) {
    std::vector<float> d;
    for (const Photon& p : photons) {
        const float d2 = dist2(p.position, q);
        if (d2 < maxDist2) d.push_back(d2);
    }
    std::sort(d.begin(), d.end());
    if (d.size() > k) d.resize(k);
    return d;
}

// The index must return exactly the brute-force distances, each for a distinct photon whose
// stored position really is at that distance.
template <class Index>
void expectKnnMatchesBruteForce(const Index& index, const std::vector<Photon>& photons,
                                uint32_t k, float maxDist2, uint32_t seed = 3) {
    KnnHeap heap;
    for (const Vec3 q : queriesFor(photons, 150, seed)) {
        knnSearch(index, q, k, maxDist2, heap);
        std::vector<float> got;
        std::set<uint32_t> seen;
        for (const KnnEntry& e : heap.entries()) {
            ASSERT_LT(e.index, index.photons().size());
            ASSERT_TRUE(seen.insert(e.index).second) << "photon returned twice";
            ASSERT_EQ(e.dist2, dist2(index.photons()[e.index].position, q));
            got.push_back(e.dist2);
        }
        std::sort(got.begin(), got.end());
        ASSERT_EQ(got, bruteForce(photons, q, k, maxDist2))
            << "q = " << q.x << ", " << q.y << ", " << q.z << " k = " << k;
    }
}

template <class Index>
void expectAllQueriesMatch(const Index& index, const std::vector<Photon>& photons) {
    const Bounds b = boundsOf(photons);
    const float r = 0.05f * std::max(b.diagonal(), 1.0f);
    for (uint32_t k : {1u, 8u, 50u}) {
        expectKnnMatchesBruteForce(index, photons, k, kInf);
        expectKnnMatchesBruteForce(index, photons, k, r * r);
    }
    expectKnnMatchesBruteForce(index, photons, static_cast<uint32_t>(photons.size()) + 7, kInf);
}

struct Dataset {
    const char* name;
    std::vector<Photon> photons;
};

std::vector<Dataset> datasets() {
    return {{"uniform", uniformPhotons(3000, 1)},
            {"clustered", clusteredPhotons(3000, 2)},
            {"coincident", coincidentPhotons(500)},
            {"collinear", collinearPhotons(2000, 4)},
            {"largeCoordinates", largeCoordinatePhotons(2000, 5)},
            {"plane", uniformPhotons(2000, 6, Vec3(0, 0, 1), Vec3(5, 5, 1))}};
}

TEST(KdTree, NodeIsEightBytes) { EXPECT_EQ(sizeof(detail::KdNode), 8u); }

TEST(KdTree, KnnMatchesBruteForceOnEveryDistribution) {
    for (const Dataset& d : datasets()) {
        SCOPED_TRACE(d.name);
        KdTree tree(boundsOf(d.photons));
        tree.build(d.photons);
        ASSERT_EQ(tree.size(), d.photons.size());
        expectAllQueriesMatch(tree, d.photons);
    }
}

TEST(KdTree, KnnMatchesBruteForceOnCoincidentPhotons) {
    const auto photons = coincidentPhotons(1000);
    KdTree tree(Bounds{Vec3(0), Vec3(10)}, 8);
    tree.build(photons);
    EXPECT_EQ(tree.size(), 1000u);
    EXPECT_LE(tree.depth(), KdTree::kMaxDepth);
    expectAllQueriesMatch(tree, photons);
}

TEST(KdTree, CoincidentPhotonsInsertedOneAtATimeStopAtTheDepthCap) {
    KdTree tree(Bounds{Vec3(0), Vec3(1)}, 4);
    const Photon p = photonAt(Vec3(0.3f));
    for (int i = 0; i < 200; ++i) tree.insert(std::span<const Photon>(&p, 1));
    EXPECT_EQ(tree.size(), 200u);
    EXPECT_LE(tree.depth(), KdTree::kMaxDepth);
    KnnHeap heap;
    knnSearch(tree, Vec3(0.3f), 300, kInf, heap);
    EXPECT_EQ(heap.size(), 200u);
}

TEST(KdTree, EmptyTreeFindsNothing) {
    KdTree tree(Bounds{Vec3(0), Vec3(1)});
    KnnHeap heap;
    knnSearch(tree, Vec3(0.5f), 10, kInf, heap);
    EXPECT_TRUE(heap.empty());
    tree.build({});
    knnSearch(tree, Vec3(0.5f), 10, kInf, heap);
    EXPECT_TRUE(heap.empty());
    KdTree boxless;
    knnSearch(boxless, Vec3(0.5f), 10, kInf, heap);
    EXPECT_TRUE(heap.empty());
}

TEST(KdTree, KZeroFindsNothing) {
    const auto photons = uniformPhotons(100, 9);
    KdTree tree;
    tree.build(photons);
    KnnHeap heap;
    knnSearch(tree, Vec3(5.0f), 0, kInf, heap);
    EXPECT_TRUE(heap.empty());
}

TEST(KdTree, MaxDist2PrunesEverythingOutsideTheRadius) {
    const auto photons = uniformPhotons(2000, 10);
    KdTree tree(boundsOf(photons));
    tree.build(photons);
    KnnHeap heap;
    knnSearch(tree, Vec3(5.0f), 1000, 0.5f * 0.5f, heap);
    EXPECT_GT(heap.size(), 0u);
    EXPECT_LT(heap.size(), 1000u);
    for (const KnnEntry& e : heap.entries()) EXPECT_LT(e.dist2, 0.25f);
    EXPECT_EQ(heap.size(), bruteForce(photons, Vec3(5.0f), 1000, 0.25f).size());
}

TEST(KdTree, RadiusSearchMatchesBruteForce) {
    const auto photons = clusteredPhotons(3000, 12);
    KdTree tree(boundsOf(photons));
    tree.build(photons);
    std::vector<KnnEntry> hits;
    for (const Vec3 q : queriesFor(photons, 50, 13)) {
        radiusSearch(tree, q, 0.04f, hits);
        std::vector<float> got;
        for (const KnnEntry& e : hits) got.push_back(e.dist2);
        std::sort(got.begin(), got.end());
        ASSERT_EQ(got, bruteForce(photons, q, UINT32_MAX, 0.04f));
    }
}

TEST(KdTree, IncrementalInsertionInTenBatchesAnswersLikeABulkBuild) {
    for (const Dataset& d : datasets()) {
        SCOPED_TRACE(d.name);
        const Bounds box = boundsOf(d.photons);
        KdTree bulk(box), incremental(box);
        bulk.build(d.photons);
        const size_t batch = (d.photons.size() + 9) / 10;
        for (size_t first = 0; first < d.photons.size(); first += batch) {
            const size_t n = std::min(batch, d.photons.size() - first);
            incremental.insert(std::span<const Photon>(d.photons).subspan(first, n));
        }
        ASSERT_EQ(incremental.size(), d.photons.size());
        // Cells are fixed bisections of the root box, so the topology is the bulk build's.
        EXPECT_EQ(incremental.nodeCount(), bulk.nodeCount());
        EXPECT_EQ(incremental.depth(), bulk.depth());
        expectAllQueriesMatch(incremental, d.photons);
    }
}

TEST(KdTree, InsertIntoABulkBuiltTreeKeepsEveryPhoton) {
    const auto a = uniformPhotons(1500, 20), b = clusteredPhotons(1500, 21);
    Bounds box = boundsOf(a);
    box.extend(boundsOf(b).lo);
    box.extend(boundsOf(b).hi);
    KdTree tree(box);
    tree.build(a);
    tree.insert(b);
    std::vector<Photon> all = a;
    all.insert(all.end(), b.begin(), b.end());
    EXPECT_EQ(tree.size(), all.size());
    expectAllQueriesMatch(tree, all);
}

TEST(KdTree, PhotonsOutsideTheRootBoxOrNaNAreRejectedAndCounted) {
    KdTree tree(Bounds{Vec3(0), Vec3(1)});
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<Photon> batch = {photonAt(Vec3(0.5f)), photonAt(Vec3(2.0f, 0.5f, 0.5f)),
                                 photonAt(Vec3(nan, 0.5f, 0.5f)), photonAt(Vec3(1.0f)),
                                 photonAt(Vec3(0.0f))};
    tree.insert(batch);
    EXPECT_EQ(tree.size(), 3u);  // the box corners are inside (the box is even inflated)
    EXPECT_EQ(tree.rejectedCount(), 2u);
    tree.build(batch);
    EXPECT_EQ(tree.rejectedCount(), 2u);
    tree.clear();
    EXPECT_EQ(tree.size(), 0u);
    EXPECT_EQ(tree.rejectedCount(), 0u);
}

TEST(KdTree, LeafSizeOneStillMatchesBruteForce) {
    const auto photons = clusteredPhotons(800, 30);
    KdTree tree(boundsOf(photons), 1);
    tree.build(photons);
    expectAllQueriesMatch(tree, photons);
}

TEST(KdTree, MemoryStaysNearTheStoredPhotonSize) {
    const auto photons = uniformPhotons(20000, 31);
    KdTree tree(boundsOf(photons));
    tree.build(photons);
    // 20 bytes of photon plus ~16/B bytes of nodes; a bulk build holds no insertion scratch.
    EXPECT_LE(tree.memoryBytes(), photons.size() * 24);
}

TEST(KdTree, TenBatchInsertionStaysWithin24BytesPerPhotonWithoutReserve) {
    const auto photons = uniformPhotons(20000, 32);
    KdTree tree(boundsOf(photons));
    const size_t batch = photons.size() / 10;
    for (size_t first = 0; first < photons.size(); first += batch)
        tree.insert(std::span<const Photon>(photons).subspan(first, batch));
    ASSERT_EQ(tree.size(), photons.size());
    // Growth is exact plus 1/32 slack (no geometric doubling), and insertion scratch is freed.
    EXPECT_LE(tree.memoryBytes(), photons.size() * 24);
}

TEST(KdTree, PhotonsKeepTheirPowerAndDirectionThroughBuildAndInsert) {
    std::vector<Photon> photons = clusteredPhotons(3000, 33);
    for (size_t i = 0; i < photons.size(); ++i) {
        photons[i].power = static_cast<uint32_t>(i);  // a distinct tag per photon
        photons[i].incoming = static_cast<uint32_t>(i * 7919u);
    }
    const auto key = [](const Photon& p) {
        return std::tuple(p.power, p.incoming, p.position.x, p.position.y, p.position.z);
    };
    std::vector<std::tuple<uint32_t, uint32_t, float, float, float>> want, bulkGot, incGot;
    for (const Photon& p : photons) want.push_back(key(p));
    std::sort(want.begin(), want.end());
    KdTree bulk(boundsOf(photons)), incremental(boundsOf(photons));
    bulk.build(photons);
    incremental.insert(std::span<const Photon>(photons).first(1000));
    incremental.insert(std::span<const Photon>(photons).subspan(1000));
    for (const Photon& p : bulk.photons()) bulkGot.push_back(key(p));
    for (uint32_t i = 0; i < incremental.size(); ++i) {
        const Photon p = incremental.photon(i);
        EXPECT_EQ(incremental.photonPower(i), p.power);
        EXPECT_EQ(incremental.photonIncoming(i), p.incoming);
        incGot.push_back(key(p));
    }
    std::sort(bulkGot.begin(), bulkGot.end());
    std::sort(incGot.begin(), incGot.end());
    EXPECT_EQ(bulkGot, want);
    EXPECT_EQ(incGot, want);
}

// A tagged build (SharedPhotons: the set that shot each photon): every stored photon keeps its
// own tag through the partitions, rejected photons take theirs with them, and a build without
// tags or a clear drops them.
TEST(KdTree, TagsFollowTheirPhotonsThroughABuild) {
    std::vector<Photon> photons = clusteredPhotons(3000, 41);
    std::vector<uint16_t> tags;
    for (size_t i = 0; i < photons.size(); ++i) {
        photons[i].power = static_cast<uint32_t>(i);  // which photon it is
        tags.push_back(static_cast<uint16_t>((i * 7u) % 9u));
    }
    photons[5].position = Vec3(std::nanf(""));  // rejected, with its tag
    photons[6].position = Vec3(1e6f);
    KdTree tree(boundsOf(clusteredPhotons(3000, 41)), KdTree::kRadiusLeafSize);
    tree.build(photons, tags);
    ASSERT_TRUE(tree.tagged());
    EXPECT_EQ(tree.size(), photons.size() - 2);
    EXPECT_EQ(tree.rejectedCount(), 2u);
    for (uint32_t i = 0; i < tree.size(); ++i) {
        const uint32_t original = tree.photonPower(i);
        ASSERT_LT(original, photons.size());
        EXPECT_EQ(tree.photonTag(i), tags[original]) << "photon " << original;
    }
    tree.build(photons);
    EXPECT_FALSE(tree.tagged());
    tree.build(photons, tags);
    tree.clear();
    EXPECT_FALSE(tree.tagged());
}

TEST(KnnHeap, BoundNeverIncreasesAndEndsAtTheKthDistance) {
    std::mt19937 rng(41);
    std::uniform_real_distribution<float> u(0.0f, 100.0f);
    for (uint32_t k : {1u, 7u, 64u}) {
        KnnHeap heap;
        heap.reset(k, 90.0f);
        std::vector<float> kept;
        float bound = heap.worstDist2();
        for (uint32_t i = 0; i < 2000; ++i) {
            const float d = u(rng);
            if (d < 90.0f) kept.push_back(d);
            heap.add(d, i);
            ASSERT_LE(heap.worstDist2(), bound);
            bound = heap.worstDist2();
        }
        std::sort(kept.begin(), kept.end());
        ASSERT_EQ(heap.size(), k);
        EXPECT_EQ(heap.farthestDist2(), kept[k - 1]);
        EXPECT_LE(heap.worstDist2(), 90.0f);
    }
}

TEST(KnnHeap, KeepsTheKSmallestOfAStream) {
    std::mt19937 rng(40);
    std::uniform_real_distribution<float> u(0.0f, 100.0f);
    KnnHeap heap;
    heap.reset(10, 50.0f);
    std::vector<float> all;
    for (uint32_t i = 0; i < 1000; ++i) {
        const float d = u(rng);
        all.push_back(d);
        heap.add(d, i);
    }
    std::sort(all.begin(), all.end());
    heap.sortNearestFirst();
    ASSERT_EQ(heap.size(), 10u);
    for (uint32_t i = 0; i < 10; ++i) EXPECT_EQ(heap.entries()[i].dist2, all[i]);
    EXPECT_LT(heap.entries()[9].dist2, 50.0f);
}

TEST(MedianKdTree, KnnMatchesBruteForceOnEveryDistribution) {
    for (const Dataset& d : datasets()) {
        SCOPED_TRACE(d.name);
        MedianKdTree tree;
        tree.build(d.photons);
        ASSERT_EQ(tree.size(), d.photons.size());
        expectAllQueriesMatch(tree, d.photons);
    }
}

TEST(MedianKdTree, EmptyTreeFindsNothing) {
    MedianKdTree tree;
    tree.build({});
    KnnHeap heap;
    knnSearch(tree, Vec3(0.0f), 5, kInf, heap);
    EXPECT_TRUE(heap.empty());
}

TEST(PhotonGrid, KnnMatchesBruteForceOnEveryDistribution) {
    for (const Dataset& d : datasets()) {
        for (uint32_t res : {1u, 17u, 64u}) {
            SCOPED_TRACE(std::string(d.name) + " resolution " + std::to_string(res));
            PhotonGrid grid(res);
            grid.build(d.photons);
            ASSERT_EQ(grid.size(), d.photons.size());
            expectAllQueriesMatch(grid, d.photons);
        }
    }
}

TEST(PhotonGrid, EmptyGridFindsNothing) {
    PhotonGrid grid(16);
    grid.build({});
    KnnHeap heap;
    knnSearch(grid, Vec3(0.0f), 5, kInf, heap);
    EXPECT_TRUE(heap.empty());
}

}  // namespace
}  // namespace rtpm
