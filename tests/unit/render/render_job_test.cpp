// RenderJob's choice of estimator per frame: a moving camera's frames take the irradiance points,
// the first frame of a camera that stopped restarts the progression, later ones are passes.
#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "common/render/render_job.h"
#include "tests/support/ring_mirror.h"

namespace rtpm {
namespace {

TEST(RenderJob, AMovingCameraTakesIrradiancePointsAndAStoppedOneRestarts) {
    testscenes::RingMirror rm;
    Scene scene = rm.scene();
    const Camera a = *scene.camera;
    Camera b = a;
    b.position.x += 0.05f;
    RenderSettings rs;
    rs.width = 64;
    rs.height = 48;
    rs.interleave = 2;
    rs.photons.photonsPerBatch = 5000;
    std::vector<uint32_t> sets(4);
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    std::vector<SetPixels> out;

    // First frame: a restart (nothing to compare the camera with), then a pass.
    FrameStats st = job.renderFrame(a, out);
    EXPECT_FALSE(st.moving);
    EXPECT_FALSE(st.converging);
    EXPECT_FALSE(out[0].ownWeights.empty());
    st = job.renderFrame(a, out);
    EXPECT_TRUE(st.converging);
    EXPECT_EQ(st.passes, 1u);
    EXPECT_EQ(job.irradiance().counts().lookups, 0u);

    // The camera moves: caustics from the points (no progression, the box filter alone).
    st = job.renderFrame(b, out);
    EXPECT_TRUE(st.moving);
    EXPECT_FALSE(st.converging);
    EXPECT_EQ(st.passes, 0u);
    for (const SetPixels& p : out) {
        EXPECT_TRUE(p.ownWeights.empty());
        EXPECT_GT(job.irradiance().pointCount(p.set), 0u);
    }
    const uint64_t lookups = job.irradiance().counts().lookups;
    EXPECT_GT(lookups, 0u);
    double caustic = 0.0;
    for (const SetPixels& p : out)
        for (const PixelRadiance& px : p.pixels) caustic += px.caustic.x;
    EXPECT_GT(caustic, 0.0);

    // It stops at b: the first frame restarts there, the next is a pass; no more lookups.
    st = job.renderFrame(b, out);
    EXPECT_FALSE(st.moving);
    EXPECT_FALSE(st.converging);
    st = job.renderFrame(b, out);
    EXPECT_TRUE(st.converging);
    EXPECT_EQ(job.irradiance().counts().lookups, lookups);

    // Back to a: a moving frame again (a's old progression is not resumed).
    st = job.renderFrame(a, out);
    EXPECT_TRUE(st.moving);
}

// The knn estimator stays k-NN on every frame, moving or not.
TEST(RenderJob, TheKnnEstimatorIgnoresMotion) {
    testscenes::RingMirror rm;
    Scene scene = rm.scene();
    const Camera a = *scene.camera;
    Camera b = a;
    b.position.x += 0.05f;
    RenderSettings rs;
    rs.width = 32;
    rs.height = 24;
    rs.interleave = 1;
    rs.photons.photonsPerBatch = 2000;
    rs.photons.estimator = CausticEstimatorKind::Knn;
    RenderJob job(std::move(scene), rs, {0});
    std::vector<SetPixels> out;
    job.renderFrame(a, out);
    const FrameStats st = job.renderFrame(b, out);
    EXPECT_FALSE(st.moving);
    EXPECT_EQ(job.irradiance().counts().lookups, 0u);
}

}  // namespace
}  // namespace rtpm
