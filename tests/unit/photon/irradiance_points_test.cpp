// IrradiancePoints: the moving camera's caustic lookup does bounded work whatever the map holds,
// and answers what the k-NN estimate answers where the caustic is smooth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "common/photon/density.h"
#include "common/photon/irradiance_points.h"
#include "common/photon/photon_map.h"
#include "common/trace/embree_scene.h"
#include "tests/support/ring_mirror.h"

namespace rtpm {
namespace {

PhotonSettings mirrorSettings() {
    PhotonSettings ps;
    ps.maxDepth = 2;  // L S D, the reference's transport
    ps.diffuseBounces = 0;
    ps.capPhotons = 100'000'000;
    return ps;
}

// Lookups at a 48 × 48 grid of floor points inside the ring (normal up, albedo 1).
struct Lookups {
    uint64_t lookups = 0, candidates = 0;
    std::vector<Vec3> values;
};
Lookups lookUp(const IrradiancePoints& points, const EmbreeScene& es) {
    const IrradiancePointCounts before = points.counts();
    Lookups out;
    for (int j = 0; j < 48; ++j)
        for (int i = 0; i < 48; ++i) {
            SurfaceHit hit;
            hit.position = Vec3(-0.9f + 1.8f * (float(i) + 0.5f) / 48.0f, 0.0f, -0.9f + 1.8f * (float(j) + 0.5f) / 48.0f);
            hit.geometricNormal = hit.shadingNormal = Vec3(0, 1, 0);
            out.values.push_back(points.radiance(es, 0, hit, Vec3(0, 1, 0), Vec3(1.0f)));
        }
    const IrradiancePointCounts after = points.counts();
    out.lookups = after.lookups - before.lookups;
    out.candidates = after.candidates - before.candidates;
    return out;
}

// The curved mirror's map after four batches, and its points.
struct FourBatches {
    testscenes::RingMirror rm;
    const Scene scene;
    const EmbreeScene es;
    PhotonMaps maps;
    IrradiancePoints points;
    FourBatches() : scene(rm.scene()), es(scene), maps(mirrorSettings(), {0}), points({0}) {
        for (int b = 0; b < 4; ++b) maps.shootBatch(es, 0);
        points.update(es, maps, 0);
    }
};

// A map grown 8× beyond the points' cap (6 → 48 batches, 53 000 → 420 000 photons) costs a
// rebuild at most kMaxPoints gathers, and a lookup searches a tree of at most kMaxPoints points:
// the points offered per lookup stay within 1.5× (measured: 7.5 and 7.4), where a k-NN gather's
// photons within rMax grow with the map. Below the cap the points are every kPointStride-th photon.
TEST(IrradiancePoints, WorkPerFrameDoesNotGrowWithTheMap) {
    testscenes::RingMirror rm;
    const Scene scene = rm.scene();
    const EmbreeScene es(scene);
    PhotonMaps maps(mirrorSettings(), {0});
    IrradiancePoints points({0});

    maps.shootBatch(es, 0);
    points.update(es, maps, 0);
    EXPECT_EQ(points.counts().gathers, points.pointCount(0));
    EXPECT_EQ(points.pointCount(0), maps.stats(0).photonsStored / kPointStride);

    for (int b = 1; b < 6; ++b) maps.shootBatch(es, 0);
    const uint64_t smallMap = maps.stats(0).photonsStored;
    ASSERT_GT(smallMap, uint64_t(kPointStride) * kMaxPoints);
    points.resetCounters();
    points.update(es, maps, 0);
    EXPECT_EQ(points.counts().gathers, points.pointCount(0));
    EXPECT_LE(points.pointCount(0), kMaxPoints);
    const Lookups small = lookUp(points, es);

    for (int b = 6; b < 48; ++b) maps.shootBatch(es, 0);
    const uint64_t largeMap = maps.stats(0).photonsStored;
    ASSERT_GT(largeMap, 7 * smallMap);
    points.resetCounters();
    points.update(es, maps, 0);
    EXPECT_LE(points.pointCount(0), kMaxPoints);
    EXPECT_GE(points.pointCount(0), kMaxPoints / 2);
    EXPECT_EQ(points.counts().gathers, points.pointCount(0));
    const Lookups large = lookUp(points, es);
    ASSERT_EQ(large.lookups, small.lookups);
    std::printf("points offered per lookup: %.1f at %llu photons, %.1f at %llu\n",
                double(small.candidates) / double(small.lookups), (unsigned long long)smallMap,
                double(large.candidates) / double(large.lookups), (unsigned long long)largeMap);
    EXPECT_LE(double(large.candidates), 1.5 * double(small.candidates));

    // An unchanged map is not rebuilt; a reset one is.
    points.resetCounters();
    points.update(es, maps, 0);
    EXPECT_EQ(points.counts().gathers, 0u);
    points.invalidate();
    points.update(es, maps, 0);
    EXPECT_EQ(points.counts().gathers, points.pointCount(0));
}

// A camera orbiting over a growing map rebuilds the points when the map's batches doubled, not at
// every batch: over 16 batches, 5 rebuilds (batches 1, 2, 4, 8, 16), each from the map as it is.
TEST(IrradiancePoints, AGrowingMapIsRebuiltWhenItsBatchesDoubled) {
    testscenes::RingMirror rm;
    const Scene scene = rm.scene();
    const EmbreeScene es(scene);
    PhotonMaps maps(mirrorSettings(), {0});
    IrradiancePoints points({0});
    std::vector<uint32_t> rebuiltAt;
    for (uint32_t b = 1; b <= 16; ++b) {
        maps.shootBatch(es, 0);
        points.resetCounters();
        points.update(es, maps, 0);
        if (points.counts().gathers > 0) {
            rebuiltAt.push_back(b);
            EXPECT_EQ(points.counts().gathers, points.pointCount(0));
        }
    }
    EXPECT_EQ(rebuiltAt, (std::vector<uint32_t>{1, 2, 4, 8, 16}));

    // The rule itself: a reset or replaced map is rebuilt whatever its size.
    EXPECT_FALSE(needsRebuild(4, 1000, 7, 1900, 0));
    EXPECT_TRUE(needsRebuild(4, 1000, 8, 2000, 0));
    EXPECT_TRUE(needsRebuild(4, 1000, 3, 700, 0)) << "reset and regrown";
    EXPECT_TRUE(needsRebuild(4, 1000, 4, 990, 0)) << "same batches, other photons";
    EXPECT_FALSE(needsRebuild(4, 1000, 4, 1000, 0));
    EXPECT_TRUE(needsRebuild(0, 0, 1, 200, 0));
    EXPECT_FALSE(needsRebuild(0, 0, 0, 0, 0));
}

// The sets of an orbit gain a batch every frame; their doublings are offset so that they rebuild
// in different frames: within one doubling (128 to 256 batches) each of nine sets rebuilds once,
// no two in the same frame, and every set's points still lag its map by less than a doubling.
TEST(IrradiancePoints, TheSetsRebuildInDifferentFrames) {
    std::vector<uint64_t> at;
    for (uint32_t set = 0; set < 9; ++set) {
        uint32_t built = 1;
        for (int i = 0; i < 40 && built < 128; ++i) {
            const uint64_t next = nextRebuild(built, set);
            ASSERT_GT(next, built);
            EXPECT_LE(next, 2u * built + 1u) << "set " << set << " after " << built;
            built = uint32_t(next);
        }
        ASSERT_GE(built, 128u);
        ASSERT_LT(built, 256u) << "set " << set;
        at.push_back(built);
        const uint32_t after = uint32_t(nextRebuild(built, set));
        EXPECT_GE(after, 2u * built - 1u) << "set " << set << ": a doubling, not less";
        EXPECT_TRUE(needsRebuild(built, 1, after, 2, set));
        EXPECT_FALSE(needsRebuild(built, 1, after - 1u, 2, set));
    }
    std::sort(at.begin(), at.end());
    EXPECT_EQ(std::adjacent_find(at.begin(), at.end()), at.end()) << "two sets rebuild in one frame";
}

// A row's hint (the previous lookup's farthest point plus the step) bounds the search without
// changing a single answer: the same values bit for bit with and without it along the grid's rows,
// a normal other than the last one's searching unbounded, and fewer points offered to the search.
// (Few are offered either way; what the bound saves is the tree's far cells visited before the
// heap held its points: an orbiting camera's eye pass over RING ran 4 % faster.)
TEST(IrradiancePoints, ARowsHintBoundsTheSearchAndChangesNoAnswer) {
    FourBatches f;
    const EmbreeScene& es = f.es;
    IrradiancePoints& points = f.points;
    const Lookups plain = lookUp(points, es);
    std::vector<Vec3> hinted;
    uint64_t offeredWithout = 0, offeredWith = 0;  // points offered to the searches
    auto offered = [&] { return points.counts().candidates; };
    for (int j = 0; j < 48; ++j) {
        GatherHint hint;  // per row, as the eye pass keeps it
        for (int i = 0; i < 48; ++i) {
            SurfaceHit hit;
            hit.position = Vec3(-0.9f + 1.8f * (float(i) + 0.5f) / 48.0f, 0.0f, -0.9f + 1.8f * (float(j) + 0.5f) / 48.0f);
            hit.geometricNormal = hit.shadingNormal = Vec3(0, 1, 0);
            // Every fifth lookup faces slightly tilted: the hint may not bound it, nor the next.
            const Vec3 normal = i % 5 == 4 ? glm::normalize(Vec3(0.05f, 1.0f, 0.0f)) : Vec3(0, 1, 0);
            const uint64_t before = offered();
            const Vec3 unhinted = points.radiance(es, 0, hit, normal, Vec3(1.0f));
            const uint64_t between = offered();
            hinted.push_back(points.radiance(es, 0, hit, normal, Vec3(1.0f), &hint));
            offeredWithout += between - before;
            offeredWith += offered() - between;
            ASSERT_EQ(hinted.back(), unhinted) << "row " << j << ", column " << i;
            if (i % 5 != 4) {
                ASSERT_EQ(hinted.back(), plain.values[size_t(j * 48 + i)]);
            }
        }
    }
    size_t lit = 0;
    for (const Vec3& v : hinted) lit += v.x > 0.0f ? 1 : 0;
    EXPECT_GT(lit, hinted.size() / 4) << "the grid lies inside the caustic";
    std::printf("points offered per lookup: %.2f without the hint, %.2f with it\n",
                double(offeredWithout) / double(hinted.size()), double(offeredWith) / double(hinted.size()));
    EXPECT_LT(offeredWith, offeredWithout);
}

// Inside the caustic's smooth part the lookup equals the k-NN estimate at the same point within
// the two estimates' noise (k = 64: about 1/√64 = 12 % each): the mean over a patch of the
// floor far from the fold lines agrees within 5 %, and no point of it is off by more than 40 %.
TEST(IrradiancePoints, MatchesTheKnnEstimateWhereTheCausticIsSmooth) {
    FourBatches f;
    const EmbreeScene& es = f.es;
    PhotonMaps& maps = f.maps;
    IrradiancePoints& points = f.points;
    double sumPoints = 0.0, sumKnn = 0.0;
    int n = 0;
    // A patch on the far side of the ring from the light (x < 0): bright and smooth.
    for (int j = 0; j < 16; ++j)
        for (int i = 0; i < 16; ++i) {
            SurfaceHit hit;
            hit.position = Vec3(-0.75f + 0.2f * float(i) / 15.0f, 0.0f, -0.1f + 0.2f * float(j) / 15.0f);
            hit.geometricNormal = hit.shadingNormal = Vec3(0, 1, 0);
            const float a = points.radiance(es, 0, hit, Vec3(0, 1, 0), Vec3(1.0f)).x;
            const float b = maps.radiance(es, 0, hit, Vec3(0, 1, 0), Vec3(1.0f)).x;
            ASSERT_GT(b, 0.0f);
            EXPECT_NEAR(a, b, 0.4f * b) << "at " << hit.position.x << ", " << hit.position.z;
            sumPoints += a;
            sumKnn += b;
            ++n;
        }
    EXPECT_NEAR(sumPoints / sumKnn, 1.0, 0.05);
}

// Between rebuilds the points take in each new batch's photons (PhotonMaps::lastBatch): from 4
// to 7 batches no point is rebuilt, yet the values change, and over the smooth patch their mean
// stays that of the k-NN estimate of the grown map (the flux divided by the batches it holds).
TEST(IrradiancePoints, PointsTakeInTheBatchesBetweenRebuilds) {
    FourBatches f;
    const EmbreeScene& es = f.es;
    PhotonMaps& maps = f.maps;
    IrradiancePoints& points = f.points;
    auto patch = [&](auto&& value) {
        std::vector<float> out;
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i) {
                SurfaceHit hit;
                hit.position = Vec3(-0.75f + 0.2f * float(i) / 15.0f, 0.0f, -0.1f + 0.2f * float(j) / 15.0f);
                hit.geometricNormal = hit.shadingNormal = Vec3(0, 1, 0);
                out.push_back(value(hit));
            }
        return out;
    };
    auto fromPoints = [&](const SurfaceHit& hit) { return points.radiance(es, 0, hit, Vec3(0, 1, 0), Vec3(1.0f)).x; };
    const std::vector<float> before = patch(fromPoints);
    points.resetCounters();
    for (int b = 4; b < 7; ++b) {
        maps.shootBatch(es, 0);
        ASSERT_FALSE(maps.lastBatch(0).empty());
        points.update(es, maps, 0);
    }
    EXPECT_EQ(points.counts().gathers, 0u) << "no rebuild before the map doubled";
    const std::vector<float> after = patch(fromPoints);
    const std::vector<float> knn =
        patch([&](const SurfaceHit& hit) { return maps.radiance(es, 0, hit, Vec3(0, 1, 0), Vec3(1.0f)).x; });
    int changed = 0;
    double sumPoints = 0.0, sumKnn = 0.0;
    for (size_t i = 0; i < after.size(); ++i) {
        changed += after[i] != before[i] ? 1 : 0;
        sumPoints += after[i];
        sumKnn += knn[i];
    }
    EXPECT_GT(changed, int(after.size()) * 9 / 10);
    EXPECT_NEAR(sumPoints / sumKnn, 1.0, 0.05);

    // A pass flushed into the map (4 → 5 batches) is not a batch the points can take in: they
    // keep the batches they hold, unchanged.
    FourBatches g;
    auto fromG = [&](const SurfaceHit& hit) { return g.points.radiance(g.es, 0, hit, Vec3(0, 1, 0), Vec3(1.0f)).x; };
    const std::vector<float> held = patch(fromG);
    g.maps.shootPass(g.es, 0);
    EXPECT_TRUE(g.maps.lastBatch(0).empty());
    g.maps.flushPasses(0);
    EXPECT_TRUE(g.maps.lastBatch(0).empty());
    g.points.resetCounters();
    g.points.update(g.es, g.maps, 0);
    EXPECT_EQ(g.points.counts().gathers, 0u);
    EXPECT_EQ(patch(fromG), held);
}

}  // namespace
}  // namespace rtpm
