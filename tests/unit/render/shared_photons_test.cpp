// Shared photons: a still view's pass bins every other set's shot of kSharedPhotonLag frames ago.
// Two jobs that each own half the sets and are handed every set's shots (as the master forwards
// them) compute the pixels one job with every set computes, bit for bit; without the shots they
// do not, and sets that bin the others' photons hold more of them.
#include <cstring>
#include <map>
#include <memory>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "common/render/pass_budget.h"
#include "common/render/render_job.h"
#include "common/scene/builtin_scenes.h"
#include "tests/support/small_settings.h"

namespace rtpm {
namespace {

RenderSettings smallRing() { return testsupport::smallSettings(48, 36, 4000, 2); }

// Byte equality of two arrays; an empty one has no data pointer to hand to memcmp.
template <class T>
bool sameBytes(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool sameShot(const SetPhotons& a, const SetPhotons& b) {
    return a.set == b.set && a.batches == b.batches && sameBytes(a.photons, b.photons);
}

// The mode a master sends for frame f of a still view: decideFrameMode's, as a job without a
// master decides its own.
FrameMode stillViewMode(int f) {
    FrameFacts facts;
    facts.epochStart = f == 0;
    facts.cameraStill = f > 0;
    facts.progressive = true;
    return decideFrameMode(facts);
}

bool samePixels(const SetPixels& a, const SetPixels& b) {
    return a.set == b.set && sameBytes(a.pixels, b.pixels);
}

TEST(SharedPhotons, TwoJobsHandedEveryShotComputeWhatOneJobComputes) {
    const RenderSettings rs = smallRing();
    const Scene scene = buildRingScene();
    const Camera camera = *scene.camera;
    RenderJob all(scene, rs, {0, 1, 2, 3});
    RenderJob first(scene, rs, {0, 2}), second(scene, rs, {1, 3}), alone(scene, rs, {1, 3});
    std::vector<std::vector<SetPhotons>> shots;  // every set's shot, per frame
    const std::vector<SetPhotons> none;
    bool differed = false;
    for (int f = 0; f < 6; ++f) {
        std::vector<SetPixels> a, b, c, d;
        const std::vector<SetPhotons>& shared = f >= int(kSharedPhotonLag) ? shots[size_t(f) - kSharedPhotonLag] : none;
        const FrameMode mode = stillViewMode(f);
        all.renderFrame(camera, a, 1);
        first.renderFrame(camera, mode, b, 1, &shared);
        second.renderFrame(camera, mode, c, 1, &shared);
        alone.renderFrame(camera, mode, d, 1, &none);
        std::vector<SetPhotons>& frame = shots.emplace_back();
        for (const auto* part : {&b, &c})
            for (const SetPixels& p : *part)
                if (p.shot.batches > 0) frame.push_back(p.shot);
        ASSERT_EQ(frame.size(), 4u) << "every set shares its shot at frame " << f;
        for (const SetPixels& p : a) {
            const SetPixels& q = (p.set % 2 == 0 ? b : c)[size_t(p.set / 2)];  // sets {0, 2} and {1, 3}
            EXPECT_TRUE(samePixels(p, q)) << "set " << p.set << " frame " << f;
            EXPECT_TRUE(sameShot(p.shot, q.shot)) << "set " << p.set << " frame " << f;
        }
        // Sets 1 and 3 without the other sets' photons: the same until the first shots arrive.
        for (size_t i = 0; i < d.size(); ++i) {
            const bool same = samePixels(c[i], d[i]);
            if (f < int(kSharedPhotonLag)) {
                EXPECT_TRUE(same) << "frame " << f;
            }
            differed = differed || !same;
        }
    }
    EXPECT_TRUE(differed) << "the other sets' photons never changed a pixel";
}

// The shots of several frames as one per shooting set (photons end to end, batches summed).
std::vector<SetPhotons> mergedShots(const std::vector<std::vector<SetPhotons>>& frames) {
    std::map<uint32_t, SetPhotons> bySet;
    for (const auto& frame : frames)
        for (const SetPhotons& shot : frame) {
            SetPhotons& m = bySet.try_emplace(shot.set, SetPhotons{shot.set, 0, {}}).first->second;
            m.batches += shot.batches;
            m.photons.insert(m.photons.end(), shot.photons.begin(), shot.photons.end());
        }
    std::vector<SetPhotons> merged;
    for (auto& entry : bySet) merged.push_back(std::move(entry.second));
    return merged;
}

// A still view whose frames cost more than the frame budget: the sets take turns (PassBudget::
// period), and two jobs handed the shots compute what one job computes. Period 3 over 4 sets: a
// frame's passes run for one or two sets, each set on every 3rd pass. A pass off its set's turn
// shows the set's last pixels bit for bit and bins nothing; the shots shared with it meanwhile
// are binned at its next turn, none lost: a job of that set alone, handed the shots of every
// frame since its last turn only at its turn, shows the same pixels at every frame.
TEST(SharedPhotons, SetsTakingTurnsShowTheirLastPixelsAndLoseNoSharedPhoton) {
    const RenderSettings rs = smallRing();
    const Scene scene = buildRingScene();
    const Camera camera = *scene.camera;
    constexpr uint32_t kPeriod = 3;
    RenderJob all(scene, rs, {0, 1, 2, 3}), everyFrame(scene, rs, {0, 1, 2, 3});
    RenderJob first(scene, rs, {0, 2}), second(scene, rs, {1, 3});
    std::vector<std::unique_ptr<RenderJob>> alone;
    for (uint32_t set = 0; set < 4; ++set) alone.push_back(std::make_unique<RenderJob>(scene, rs, std::vector{set}));
    std::vector<size_t> sinceTurn(4, 0);  // per set: the first frame's shots not handed to it yet
    std::vector<std::vector<SetPhotons>> shots;
    const std::vector<SetPhotons> none;
    std::vector<SetPixels> previous;
    int skipped = 0, sharedAtTurn = 0;
    for (int f = 0; f < 9; ++f) {
        std::vector<SetPixels> a, b, c, e;
        const std::vector<SetPhotons>& shared = f >= int(kSharedPhotonLag) ? shots[size_t(f) - kSharedPhotonLag] : none;
        const FrameMode mode = stillViewMode(f);
        const FrameStats st = all.renderFrame(camera, a, 1, kPeriod);
        const FrameStats full = everyFrame.renderFrame(camera, e, 1, 1);
        first.renderFrame(camera, mode, b, 1, &shared, kPeriod);
        second.renderFrame(camera, mode, c, 1, &shared, kPeriod);
        for (uint32_t set = 0; set < 4; ++set) {
            const bool turn = f == 0 || passShoots(uint64_t(f), set, 4, kPeriod);
            std::vector<SetPhotons> handed;
            if (turn && f >= int(kSharedPhotonLag)) {
                const size_t upTo = size_t(f) - kSharedPhotonLag + 1;
                handed = mergedShots({shots.begin() + std::ptrdiff_t(sinceTurn[set]), shots.begin() + std::ptrdiff_t(upTo)});
                sharedAtTurn += handed.empty() ? 0 : 1;
                sinceTurn[set] = upTo;
            }
            std::vector<SetPixels> d;
            alone[set]->renderFrame(camera, mode, d, 1, &handed, kPeriod);
            EXPECT_TRUE(samePixels(a[set], d[0])) << "set " << set << " alone, frame " << f;
        }
        std::vector<SetPhotons>& frame = shots.emplace_back();
        for (const auto* part : {&b, &c})
            for (const SetPixels& p : *part)
                if (p.shot.batches > 0) frame.push_back(p.shot);
        if (f == 0) {
            EXPECT_EQ(frame.size(), 4u) << "the restart shoots a batch for every set";
            EXPECT_EQ(st.pathsThisFrame, full.pathsThisFrame);
        } else {
            // Pass t runs for the group g = ⌊3s/4⌋ with (t + g) mod 3 = 0: sets {0, 1}, {2} or {3}.
            size_t expected = 0;
            for (uint32_t set = 0; set < 4; ++set) expected += passShoots(uint64_t(f), set, 4, kPeriod) ? 1 : 0;
            EXPECT_EQ(frame.size(), expected) << "frame " << f;
            EXPECT_LT(st.pathsThisFrame, full.pathsThisFrame) << "frame " << f;
        }
        for (const SetPixels& p : a) {
            const SetPixels& q = (p.set % 2 == 0 ? b : c)[size_t(p.set / 2)];
            EXPECT_TRUE(samePixels(p, q)) << "set " << p.set << " frame " << f;
            EXPECT_TRUE(sameShot(p.shot, q.shot)) << "set " << p.set << " frame " << f;
            // Off its turn a set says its pixels are its last ones (a client then sends none and
            // names the frame that sent them); on its turn, never.
            EXPECT_EQ(p.unchanged, f > 0 && p.shot.batches == 0) << "set " << p.set << " frame " << f;
            EXPECT_EQ(q.unchanged, p.unchanged) << "set " << p.set << " frame " << f;
            if (f > 0 && p.shot.batches == 0) {
                EXPECT_TRUE(samePixels(p, previous[size_t(p.set)])) << "set " << p.set << " off its turn, frame " << f;
                ++skipped;
            }
        }
        previous = a;
    }
    EXPECT_GT(skipped, 0);
    EXPECT_GT(sharedAtTurn, 0) << "no turn binned shots shared while its set was off";
}

TEST(SharedPhotons, ASetsShareIsCappedAtWholeBatches) {
    RenderSettings rs = smallRing();
    rs.interleave = 16;  // 256 sets: kSharedPhotonBudget / 256 = 1024 photons per set and frame
    rs.photons.photonsPerBatch = 200000;
    const Scene scene = buildRingScene();
    RenderJob job(scene, rs, {0});
    std::vector<SetPixels> out;
    job.renderFrame(*scene.camera, out, 1);
    ASSERT_EQ(out.size(), 1u);
    ASSERT_GT(job.photons().stats(0).photonsStored, kSharedPhotonBudget / 256) << "the batch must exceed the share";
    EXPECT_EQ(out[0].shot.batches, 0u);
    EXPECT_TRUE(out[0].shot.photons.empty());
}

}  // namespace
}  // namespace rtpm
