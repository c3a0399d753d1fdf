// The master's convergence rules without a cluster: pass batches by mode and budget, and the
// target error reached once, only by a Converging frame.
#include "server/convergence.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rtpm::server {
namespace {

using proto::FrameMode;

TEST(Convergence, OnlyConvergingFramesShootTheBudgetsBatchesAndTakeTurns) {
    Convergence c(200.0, 0.0);
    EXPECT_EQ(c.batchesFor(FrameMode::Converging), 1u);
    c.recordWork(FrameMode::Converging, 10.0);  // far under half the budget: the passes grow
    EXPECT_EQ(c.batchesFor(FrameMode::Converging), 2u);
    EXPECT_EQ(c.batchesFor(FrameMode::Accumulate), 1u);
    EXPECT_EQ(c.batchesFor(FrameMode::Walkthrough), 1u);
    c.recordWork(FrameMode::Interaction, 10.0);  // any other frame starts the passes again
    EXPECT_EQ(c.batchesFor(FrameMode::Converging), 1u);
    // One batch per set costs more than the budget: the sets take turns (a trial period).
    c.recordWork(FrameMode::Converging, 500.0);
    EXPECT_EQ(c.periodFor(FrameMode::Converging), 2u);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate), 1u);
}

TEST(Convergence, TheTargetIsReachedOnceByAConvergingFrameAtOrBelowIt) {
    Convergence c(200.0, 0.05);
    EXPECT_FALSE(c.reachesTarget(FrameMode::Accumulate, 0.01)) << "not a still view's estimate";
    EXPECT_FALSE(c.reachesTarget(FrameMode::Converging, 0.0)) << "no estimate yet";
    EXPECT_FALSE(c.reachesTarget(FrameMode::Converging, std::nan("")));
    EXPECT_FALSE(c.reachesTarget(FrameMode::Converging, 0.051));
    EXPECT_FALSE(c.reached());
    EXPECT_TRUE(c.reachesTarget(FrameMode::Converging, 0.05));
    EXPECT_TRUE(c.reached());
    EXPECT_FALSE(c.reachesTarget(FrameMode::Converging, 0.01)) << "reported once";
}

TEST(Convergence, NoTargetIsNeverReached) {
    Convergence c(200.0, 0.0);
    EXPECT_FALSE(c.reachesTarget(FrameMode::Converging, 1e-9));
    EXPECT_FALSE(c.reached());
}

}  // namespace
}  // namespace rtpm::server
