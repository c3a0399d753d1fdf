// Caustic yield of Selective Photon Tracing vs plain shooting on the paper's scenes (Table 4),
// with photon throughput and the Table 3 time split printed for the record.
#include <cstdio>

#include <gtest/gtest.h>

#include "common/photon/photon_map.h"
#include "common/scene/scene_loader.h"

namespace rtpm {
namespace {

struct YieldRun {
    PhotonSetStats stats;
    Vec3 power{0.0f};  // stored caustic power per batch (W)
};

YieldRun run(const EmbreeScene& es, bool selective, uint32_t diffuseBounces, int batches) {
    PhotonSettings ps;
    ps.photonsPerBatch = 20000;
    ps.selective = selective;
    ps.diffuseBounces = diffuseBounces;
    ps.capPhotons = 0;
    PhotonMaps maps(ps, {0});
    for (int b = 0; b < batches; ++b) maps.shootBatch(es, 0);
    YieldRun r;
    r.stats = maps.stats(0);
    r.power = maps.storedPowerPerBatch(0);
    return r;
}

void print(const char* scene, const char* mode, uint32_t bounces, const YieldRun& r) {
    const PhotonSetStats& s = r.stats;
    const double t = s.seconds.trace > 0.0 ? s.seconds.trace : 1.0;
    std::printf("%-6s %-5s bounces %u: yield %5.1f %%  paths %7llu  stored %6llu  power %.4f W  "
                "%.2f Mpaths/s  %.2f Mrays/s  split sampling %2.0f %% / ray casting %2.0f %% / "
                "interaction %2.0f %%\n",
                scene, mode, bounces, 100.0 * s.yield(), static_cast<unsigned long long>(s.pathsTraced),
                static_cast<unsigned long long>(s.photonsStored), r.power.x + r.power.y + r.power.z,
                1e-6 * static_cast<double>(s.pathsTraced) / t,
                1e-6 * static_cast<double>(s.raysCast) / t, 100.0 * s.seconds.sampling / t,
                100.0 * s.seconds.rayCast / t, 100.0 * s.seconds.interaction / t);
}

// SPT must raise the share of paths that store a caustic photon (paper Table 4: ≈ 4×). Measured
// on these built-in scenes with 3 batches of 20 000 paths: 1.8× (RING, 6-D boxes with one bounce)
// to 30× (GLASS, 2-D boxes); the bound 1.5× holds for every scene with margin and fails if the
// refinement does not follow the productive boxes (plain-like yield, ratio ≈ 1).
TEST(SptYield, SelectiveTracingRaisesTheCausticYieldOnPaperScenes) {
    for (const char* name : {"RING", "GLASS", "EGG"}) {
        const Scene scene = loadScene(name);
        EmbreeScene es(scene);
        for (uint32_t bounces : {0u, 1u}) {
            const YieldRun plain = run(es, false, bounces, 3);
            const YieldRun spt = run(es, true, bounces, 3);
            print(name, "plain", bounces, plain);
            print(name, "SPT", bounces, spt);
            EXPECT_EQ(spt.stats.anomalies, 0u) << name;
            EXPECT_EQ(plain.stats.anomalies, 0u) << name;
            ASSERT_GT(plain.stats.productivePaths, 0u) << name << ": the scene has no caustic";
            EXPECT_GT(spt.stats.yield(), 1.5 * plain.stats.yield()) << name << " bounces " << bounces;
        }
    }
}

}  // namespace
}  // namespace rtpm
