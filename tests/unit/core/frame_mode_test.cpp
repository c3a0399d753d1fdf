// decideFrameMode: the one rule for a frame's mode, taken by the master and by rtpm-render.
#include "common/core/frame_mode.h"

#include <gtest/gtest.h>

namespace rtpm {
namespace {

FrameMode decide(bool epochStart, bool cameraMoved, bool cameraStill, bool progressive, bool walkthrough,
                 bool allCapped) {
    FrameFacts f;
    f.epochStart = epochStart;
    f.cameraMoved = cameraMoved;
    f.cameraStill = cameraStill;
    f.progressive = progressive;
    f.walkthrough = walkthrough;
    f.allCapped = allCapped;
    return decideFrameMode(f);
}

TEST(FrameMode, TheFirstFrameOfAnEpochIsInteractionWhateverElseHolds) {
    for (int bits = 0; bits < 32; ++bits)
        EXPECT_EQ(decide(true, bits & 1, bits & 2, bits & 4, bits & 8, bits & 16), FrameMode::Interaction);
}

TEST(FrameMode, AnEpochAnEditBeganStartsWithAnEditFrameWhateverElseHolds) {
    for (int bits = 0; bits < 32; ++bits) {
        FrameFacts f;
        f.epochStart = true;
        f.edited = true;
        f.cameraMoved = bits & 1;
        f.cameraStill = bits & 2;
        f.progressive = bits & 4;
        f.walkthrough = bits & 8;
        f.allCapped = bits & 16;
        EXPECT_EQ(decideFrameMode(f), FrameMode::Edit) << "facts " << bits;
        f.epochStart = false;  // only the epoch's first frame: the rest decide as usual
        EXPECT_NE(decideFrameMode(f), FrameMode::Edit) << "facts " << bits;
    }
}

TEST(FrameMode, AnEpochThatLightEditsAloneBeganAtAStillCameraStartsWithARelightFrame) {
    for (int bits = 0; bits < 32; ++bits) {
        FrameFacts f;
        f.epochStart = true;
        f.edited = true;
        f.relit = true;
        f.cameraMoved = bits & 1;
        f.cameraStill = bits & 2;
        f.progressive = bits & 4;
        f.walkthrough = bits & 8;
        f.allCapped = bits & 16;
        const bool still = f.cameraStill && !f.cameraMoved;
        EXPECT_EQ(decideFrameMode(f), still ? FrameMode::Relight : FrameMode::Edit) << "facts " << bits;
        f.edited = false;  // a settings change alone: relit means nothing
        EXPECT_EQ(decideFrameMode(f), FrameMode::Interaction) << "facts " << bits;
        f.edited = true;
        f.epochStart = false;
        EXPECT_NE(decideFrameMode(f), FrameMode::Relight) << "facts " << bits;
    }
}

TEST(FrameMode, AMovedCameraIsAWalkthrough) {
    EXPECT_EQ(decide(false, true, false, true, false, false), FrameMode::Walkthrough);
    EXPECT_EQ(decide(false, true, true, true, false, false), FrameMode::Walkthrough);
}

TEST(FrameMode, AStillCameraConvergesOnlyWithTheProgressiveEstimatorAndNoWalkthroughAsked) {
    EXPECT_EQ(decide(false, false, true, true, false, false), FrameMode::Converging);
    EXPECT_EQ(decide(false, false, true, true, false, true), FrameMode::Converging) << "passes shoot when capped";
    EXPECT_EQ(decide(false, false, true, false, false, false), FrameMode::Accumulate) << "knn";
    EXPECT_EQ(decide(false, false, true, true, true, false), FrameMode::Walkthrough);
    EXPECT_EQ(decide(false, false, false, true, false, false), FrameMode::Accumulate) << "camera changed";
}

TEST(FrameMode, CappedMapsOrAnAskedWalkthroughShootNothing) {
    EXPECT_EQ(decide(false, false, false, false, false, true), FrameMode::Walkthrough);
    EXPECT_EQ(decide(false, false, true, false, false, true), FrameMode::Walkthrough);
    EXPECT_EQ(decide(false, false, false, false, true, false), FrameMode::Walkthrough);
    EXPECT_EQ(decide(false, false, false, false, false, false), FrameMode::Accumulate);
}

}  // namespace
}  // namespace rtpm
