// RenderJob's choice of estimator per frame: a moving camera's frames take the irradiance points,
// the first frame of a camera that stopped restarts the progression, later ones are passes; an
// edit's first frame shows the map's k-NN estimate and the next still frame restarts; a light
// edit's at a still camera re-lights kept eye paths.
#include <gtest/gtest.h>

#include <cstring>
#include <numeric>
#include <vector>

#include "common/render/pass_budget.h"
#include "common/render/render_job.h"
#include "common/scene/builtin_scenes.h"
#include "tests/support/ring_mirror.h"
#include "tests/support/small_settings.h"

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

// An edit per frame (a dragged light) must cost a knn frame, not a restart: the progressive job's
// first frame after an edit is the knn estimator's frame over the same map, bit for bit, with no
// progression; the next still frame restarts and the one after is a pass.
TEST(RenderJob, AnEditFrameShowsTheKnnEstimateAndTheNextStillFrameRestarts) {
    testscenes::RingMirror rm;
    Scene scene = rm.scene();
    ASSERT_FALSE(scene.lights.empty());
    const Camera camera = *scene.camera;
    RenderSettings rs;
    rs.width = 64;
    rs.height = 48;
    rs.interleave = 2;
    rs.photons.photonsPerBatch = 5000;
    RenderSettings knn = rs;
    knn.photons.estimator = CausticEstimatorKind::Knn;
    std::vector<uint32_t> sets(4);
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(scene, rs, sets), reference(scene, knn, sets);
    SceneEdit edit;
    edit.kind = SceneEdit::Kind::Light;
    edit.index = 0;
    edit.light = scene.lights[0];
    edit.light.position.x += 0.02f;

    std::vector<SetPixels> out, ref;
    job.renderFrame(camera, out);
    EXPECT_TRUE(job.renderFrame(camera, out).converging);
    for (int drag = 0; drag < 2; ++drag) {  // two edits in a row: each first frame alike
        edit.light.position.x += 0.02f;
        job.applyEdit(edit);
        reference.applyEdit(edit);
        const FrameStats st = job.renderFrame(camera, out);
        reference.renderFrame(camera, ref);
        EXPECT_FALSE(st.converging);
        EXPECT_EQ(st.passes, 0u);
        ASSERT_EQ(out.size(), ref.size());
        double caustic = 0.0;
        for (size_t i = 0; i < out.size(); ++i) {
            EXPECT_TRUE(out[i].ownWeights.empty()) << "no progression: the box filter alone";
            ASSERT_EQ(out[i].pixels.size(), ref[i].pixels.size());
            EXPECT_EQ(std::memcmp(out[i].pixels.data(), ref[i].pixels.data(),
                                  out[i].pixels.size() * sizeof(PixelRadiance)),
                      0)
                << "set " << out[i].set << ": not the knn estimate";
            for (const PixelRadiance& px : out[i].pixels) caustic += px.caustic.x;
        }
        EXPECT_GT(caustic, 0.0);
    }
    // The light stops: a restart (its own weights, no pass yet), then passes.
    FrameStats st = job.renderFrame(camera, out);
    EXPECT_FALSE(st.converging);
    EXPECT_FALSE(out[0].ownWeights.empty());
    st = job.renderFrame(camera, out);
    EXPECT_TRUE(st.converging);
    EXPECT_EQ(st.passes, 1u);
}

// The ring mirror at 32×24, M = 2 (four sets), 2000 paths per set and frame, the knn estimator.
RenderSettings smallKnnSettings() { return testsupport::smallSettings(32, 24, 2000, 2, CausticEstimatorKind::Knn); }

// A job rendering all four sets of the ring mirror at smallKnnSettings, and the scene's camera.
struct RingKnnJob {
    RingKnnJob() : RingKnnJob(testscenes::RingMirror().scene()) {}
    explicit RingKnnJob(Scene scene) : camera(*scene.camera), job(std::move(scene), rs, sets) {}
    const RenderSettings rs = smallKnnSettings();
    const std::vector<uint32_t> sets{0, 1, 2, 3};
    const Camera camera;
    RenderJob job;
};

// GLASS at 48×36, M = 2 (four sets), 2000 paths per set and frame.
RenderSettings smallGlassSettings() { return testsupport::smallSettings(48, 36, 2000, 2); }

// An Edit frame samples the dielectric splits (one branch each) where the epoch's first frame of
// a still view traces both: GLASS's edit frames trace far fewer secondary rays. (A light edit
// alone makes a Relight frame instead: below.)
TEST(RenderJob, AnEditFrameSamplesTheDielectricSplits) {
    Scene scene = buildGlassScene();
    const Camera camera = *scene.camera;
    ASSERT_FALSE(scene.lights.empty());
    const RenderSettings rs = smallGlassSettings();
    const std::vector<uint32_t> sets{0, 1, 2, 3};
    RenderJob job(scene, rs, sets);
    std::vector<SetPixels> out;
    const FrameStats first = job.renderFrame(camera, out);
    EXPECT_EQ(first.eye.sampledSplits, 0u);
    SceneEdit edit;
    edit.kind = SceneEdit::Kind::Transform;
    edit.index = 0;  // the table, 1 mm lower
    edit.transform[3] = glm::vec4(0.0f, -0.001f, 0.0f, 1.0f);
    job.applyEdit(edit);
    const FrameStats edited = job.renderFrame(camera, out);
    EXPECT_GT(edited.eye.sampledSplits, 0u);
    EXPECT_LT(edited.eye.secondaryRays, first.eye.secondaryRays / 2) << first.eye.secondaryRays;
    EXPECT_EQ(edited.eye.nonFinite, 0u);
}

// A light edit alone at a still camera: the Relight frame traces the deterministic eye paths
// once, without their lights, and re-lights them at the next light edits with shadow rays alone.
// Kept or traced afresh (a job that joins later), the pixels are the same bit for bit, and their
// direct light is the deterministic eye pass's at the moved light (up to the order of the sums).
TEST(RenderJob, ARelightFrameKeepsTheEyePathsAndOnlyRelightsThem) {
    Scene scene = buildGlassScene();
    const Camera camera = *scene.camera;
    ASSERT_FALSE(scene.lights.empty());
    const RenderSettings rs = smallGlassSettings();
    const std::vector<uint32_t> sets{0, 1, 2, 3};
    RenderJob kept(scene, rs, sets), fresh(scene, rs, sets);
    std::vector<SetPixels> out, ref;
    const FrameStats first = kept.renderFrame(camera, out);
    fresh.renderFrame(camera, ref);
    SceneEdit edit;
    edit.kind = SceneEdit::Kind::Light;
    edit.index = 0;
    edit.light = scene.lights[0];
    edit.light.position.x += 0.05f;
    kept.applyEdit(edit);
    const FrameStats traced = kept.renderFrame(camera, out);
    EXPECT_EQ(traced.eye.sampledSplits, 0u) << "the full split trees";
    EXPECT_EQ(traced.eye.secondaryRays, first.eye.secondaryRays);
    edit.light.position.z += 0.05f;
    kept.applyEdit(edit);
    const FrameStats relit = kept.renderFrame(camera, out);
    EXPECT_EQ(relit.eye.primaryRays + relit.eye.secondaryRays, 0u) << "no eye ray: the paths were kept";
    EXPECT_GT(relit.eye.shadowRays, 0u);
    EXPECT_EQ(relit.eye.nonFinite, 0u);
    fresh.applyEdit(edit);
    fresh.renderFrame(camera, ref);
    ASSERT_EQ(out.size(), ref.size());
    for (size_t i = 0; i < out.size(); ++i)
        for (size_t p = 0; p < out[i].pixels.size(); ++p)
            ASSERT_EQ(std::memcmp(&out[i].pixels[p].direct, &ref[i].pixels[p].direct, sizeof(Vec3)), 0)
                << "set " << i << " pixel " << p;

    // The direct light against a deterministic eye pass at the moved light.
    Scene moved = scene;
    moved.lights[0] = edit.light;
    const EmbreeScene es(moved);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    double diff = 0.0, total = 0.0;
    for (size_t i = 0; i < out.size(); ++i) {
        std::vector<PixelRadiance> det(out[i].pixels.size());
        renderSet(es, camera, rs.eye, pattern, out[i].set, nullptr, det);
        for (size_t p = 0; p < det.size(); ++p)
            for (int c = 0; c < 3; ++c) {
                diff += std::abs(double(out[i].pixels[p].direct[c]) - double(det[p].direct[c]));
                total += double(det[p].direct[c]);
            }
    }
    EXPECT_GT(total, 0.0);
    EXPECT_LT(diff / total, 1e-5) << "relit direct light off the deterministic eye pass's";
    // The test can fail: the light where it was before the last edit is another image.
    Scene before = scene;
    before.lights[0].position = edit.light.position - Vec3(0.0f, 0.0f, 0.05f);
    const EmbreeScene esBefore(before);
    double other = 0.0;
    for (size_t i = 0; i < out.size(); ++i) {
        std::vector<PixelRadiance> det(out[i].pixels.size());
        renderSet(esBefore, camera, rs.eye, pattern, out[i].set, nullptr, det);
        for (size_t p = 0; p < det.size(); ++p)
            for (int c = 0; c < 3; ++c) other += std::abs(double(out[i].pixels[p].direct[c]) - double(det[p].direct[c]));
    }
    EXPECT_GT(other / total, 1e-3);
}

// Accumulate frames with a period: a set shoots its batch in the frames passShoots names by the
// frame number, except that a set whose map holds no batch shoots at once; a Walkthrough frame
// shoots nothing whatever the period.
TEST(RenderJob, AccumulateFramesTakeTurnsByTheFrameNumber) {
    RingKnnJob ring;
    auto& [rs, sets, camera, job] = ring;
    std::vector<SetPixels> out;
    constexpr uint32_t kPeriod = 2;
    // Frame 3 names group 1 (sets 2, 3), but every map is empty: all shoot.
    job.renderFrame(camera, FrameMode::Accumulate, out, 1, nullptr, kPeriod, 3);
    for (uint32_t s : sets) EXPECT_EQ(job.photons().stats(s).batches, 1u) << "set " << s;
    for (uint64_t frame = 4; frame < 10; ++frame) {
        std::vector<uint32_t> before;
        for (uint32_t s : sets) before.push_back(job.photons().stats(s).batches);
        job.renderFrame(camera, FrameMode::Accumulate, out, 1, nullptr, kPeriod, frame);
        for (uint32_t s : sets)
            EXPECT_EQ(job.photons().stats(s).batches, before[s] + (passShoots(frame, s, 4, kPeriod) ? 1u : 0u))
                << "set " << s << ", frame " << frame;
    }
    for (uint32_t s : sets) EXPECT_EQ(job.photons().stats(s).batches, 4u) << "once per period";
    job.renderFrame(camera, FrameMode::Walkthrough, out, 1, nullptr, kPeriod, 10);
    for (uint32_t s : sets) EXPECT_EQ(job.photons().stats(s).batches, 4u);
}

// A set off its turn in an Accumulate frame has the map it had: it shows the pixels of its last
// frame, bit for bit, and traces no eye ray, so turns make a still k-NN view's frames cheaper
// (its cost is the eye pass's gathers, not the shooting); a set on its turn, a moved camera or an
// edit trace afresh.
TEST(RenderJob, ASetOffItsTurnShowsItsLastPixelsWithoutTracing) {
    RingKnnJob ring;
    auto& [rs, sets, camera, job] = ring;
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    constexpr uint32_t kPeriod = 2;
    std::vector<SetPixels> out, last;
    for (uint64_t frame = 1; frame <= 2; ++frame) job.renderFrame(camera, FrameMode::Accumulate, out, 1, nullptr, kPeriod, frame);
    for (uint64_t frame = 3; frame < 7; ++frame) {
        last = out;
        const FrameStats st = job.renderFrame(camera, FrameMode::Accumulate, out, 1, nullptr, kPeriod, frame);
        uint64_t traced = 0;
        for (size_t i = 0; i < sets.size(); ++i) {
            if (passShoots(frame, sets[i], 4, kPeriod)) {
                traced += uint64_t(pattern.pixelCount(int(sets[i])));
                continue;
            }
            ASSERT_EQ(out[i].pixels.size(), last[i].pixels.size());
            EXPECT_EQ(std::memcmp(out[i].pixels.data(), last[i].pixels.data(),
                                  out[i].pixels.size() * sizeof(PixelRadiance)), 0)
                << "set " << sets[i] << ", frame " << frame;
        }
        EXPECT_EQ(st.eye.primaryRays, traced) << "frame " << frame << ": only the sets on their turn trace";
    }
    // A moved camera traces every set; its pixels are kept from its second frame on, and shown
    // again from the third.
    Camera moved = camera;
    moved.position.x += 0.01f;
    const uint64_t all = uint64_t(rs.width * rs.height);
    for (uint64_t frame = 7; frame <= 8; ++frame)
        EXPECT_EQ(job.renderFrame(moved, FrameMode::Accumulate, out, 1, nullptr, kPeriod, frame).eye.primaryRays, all);
    FrameStats st = job.renderFrame(moved, FrameMode::Accumulate, out, 1, nullptr, kPeriod, 9);
    EXPECT_LT(st.eye.primaryRays, all);
    SceneEdit edit;
    edit.kind = SceneEdit::Kind::Light;
    edit.index = 0;
    edit.light = job.scene().lights.at(0);
    job.applyEdit(edit);
    job.renderFrame(moved, FrameMode::Interaction, out, 1, nullptr, kPeriod, 10);
    st = job.renderFrame(moved, FrameMode::Accumulate, out, 1, nullptr, kPeriod, 11);
    EXPECT_EQ(st.eye.primaryRays, all) << "an edit forgets the pixels";
}

}  // namespace
}  // namespace rtpm
