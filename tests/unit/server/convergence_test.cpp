// The master's convergence rules without a cluster: pass batches by mode and budget, and the
// target error reached once, only by a Converging frame.
#include "server/convergence.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rtpm::server {
namespace {

using proto::FrameMode;

/// A frame of `mode` at a still camera planned with what `c` says now (no other frame in
/// flight) took `ms`.
void record(Convergence& c, FrameMode mode, double ms, bool still = true) {
    c.recordWork(mode, still, ms, c.periodFor(mode, still));
}

TEST(Convergence, OnlyConvergingFramesShootTheBudgetsBatches) {
    Convergence c(200.0, 0.0);
    EXPECT_EQ(c.batchesFor(FrameMode::Converging), 1u);
    record(c, FrameMode::Converging, 10.0);  // far under half the budget: the passes grow
    EXPECT_EQ(c.batchesFor(FrameMode::Converging), 2u);
    EXPECT_EQ(c.batchesFor(FrameMode::Accumulate), 1u);
    EXPECT_EQ(c.batchesFor(FrameMode::Walkthrough), 1u);
    record(c, FrameMode::Interaction, 10.0);  // any other frame starts the passes again
    EXPECT_EQ(c.batchesFor(FrameMode::Converging), 1u);
    // One batch per set costs more than the budget: the sets take turns (a trial period).
    record(c, FrameMode::Converging, 500.0);
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 2u);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 1u);
}

// Accumulate frames have a budget of their own: over it the sets take turns shooting their one
// batch (never more than one), and any other frame starts it afresh; Walkthrough, Interaction and
// Edit frames never take turns.
TEST(Convergence, AccumulateFramesTakeTurnsOverTheBudgetWithOneBatch) {
    Convergence c(200.0, 0.0);
    for (int i = 0; i < 4; ++i) record(c, FrameMode::Accumulate, 10.0);  // fast: no growth
    EXPECT_EQ(c.batchesFor(FrameMode::Accumulate), 1u);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 1u);
    record(c, FrameMode::Accumulate, 900.0);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 2u);
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 1u) << "the passes' budget is another";
    for (FrameMode m : {FrameMode::Walkthrough, FrameMode::Interaction, FrameMode::Edit})
        EXPECT_EQ(c.periodFor(m, true), 1u);
    record(c, FrameMode::Accumulate, 400.0);
    record(c, FrameMode::Accumulate, 400.0);  // a turn of 2 paid (0.4 s ≤ 0.8 × 0.9 s): over, doubled
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 4u);
    EXPECT_EQ(c.batchesFor(FrameMode::Accumulate), 1u);
    record(c, FrameMode::Walkthrough, 10.0);  // the camera moved without shooting
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 8u)
        << "the 900 ms frame of every set's batch, beyond the orbit's 800 ms: 900 / 200 → 8";
    record(c, FrameMode::Accumulate, 10.0, /*still=*/false);  // an orbit's cheap batches
    record(c, FrameMode::Walkthrough, 10.0);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 1u) << "predicted again: no turns";
}

// An orbit's Accumulate frames grow the map the moving image shows: they take turns only beyond
// 200 ms or kOrbitBudgetFactor × the budget, while a still camera's (the knn estimator's still
// view, whose sets off their turn show their last pixels) follow the budget itself.
TEST(Convergence, AnOrbitKeepsEverySetShootingUpToFourBudgets) {
    EXPECT_DOUBLE_EQ(Convergence::orbitBudgetMs(kDefaultFrameBudgetMs), 200.0);
    EXPECT_DOUBLE_EQ(Convergence::orbitBudgetMs(100.0), 400.0);
    EXPECT_DOUBLE_EQ(Convergence::orbitBudgetMs(0.0), 0.0) << "no budget, no turns";
    Convergence small(kDefaultFrameBudgetMs, 0.0);
    for (int i = 0; i < 4; ++i) record(small, FrameMode::Accumulate, 150.0, /*still=*/false);
    EXPECT_EQ(small.periodFor(FrameMode::Accumulate, false), 1u) << "a small frame budget: still 200 ms";
    Convergence c(50.0, 0.0);
    for (int i = 0; i < 4; ++i) record(c, FrameMode::Accumulate, 150.0, /*still=*/false);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, false), 1u);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 1u) << "the still camera's budget is another";
    record(c, FrameMode::Accumulate, 300.0, /*still=*/false);  // beyond 1.25 × 200 ms
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, false), 2u);
    Convergence d(50.0, 0.0);
    record(d, FrameMode::Accumulate, 150.0, /*still=*/true);  // beyond 1.25 × 50 ms
    EXPECT_EQ(d.periodFor(FrameMode::Accumulate, true), 2u);
    EXPECT_EQ(d.periodFor(FrameMode::Accumulate, false), 1u);
}

// A still frame costs no more than a moving one: after the camera moved at 20 ms a frame, a
// still view's 40 ms passes (within the 50 ms budget of a view that never moved) take turns.
// Epoch starts (Interaction) do not count as motion; a slower motion restores the budget.
TEST(Convergence, AStillViewIsHeldToTheMotionBeforeIt) {
    Convergence cold(50.0, 0.0);
    for (int i = 0; i < 3; ++i) record(cold, FrameMode::Converging, 40.0);
    EXPECT_EQ(cold.periodFor(FrameMode::Converging, true), 1u);
    EXPECT_DOUBLE_EQ(cold.stillBudgetMs(), 50.0);

    Convergence c(50.0, 0.0);
    record(c, FrameMode::Interaction, 5.0);
    EXPECT_DOUBLE_EQ(c.stillBudgetMs(), 50.0) << "an epoch's first frame is no motion";
    for (int i = 0; i < 5; ++i) record(c, FrameMode::Accumulate, 20.0, /*still=*/false);
    EXPECT_DOUBLE_EQ(c.stillBudgetMs(), 20.0);
    record(c, FrameMode::Converging, 40.0);
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 2u) << "over the motion's 20 ms: turns";
    for (int i = 0; i < 5; ++i) record(c, FrameMode::Edit, 300.0, /*still=*/true);
    EXPECT_DOUBLE_EQ(c.stillBudgetMs(), 50.0) << "slower motion: the frame budget again";
    for (int i = 0; i < 5; ++i) record(c, FrameMode::Walkthrough, 2.0, /*still=*/false);
    EXPECT_DOUBLE_EQ(c.stillBudgetMs(), Convergence::kMinStillMs);
    Convergence tight(5.0, 0.0);  // a budget below kMinStillMs stays the budget
    for (int i = 0; i < 5; ++i) record(tight, FrameMode::Walkthrough, 2.0, /*still=*/false);
    EXPECT_DOUBLE_EQ(tight.stillBudgetMs(), 5.0);
    Convergence fixed(0.0, 0.0);  // one batch per pass, whatever the machine
    for (int i = 0; i < 5; ++i) record(fixed, FrameMode::Accumulate, 20.0, /*still=*/false);
    EXPECT_DOUBLE_EQ(fixed.stillBudgetMs(), 0.0);
}

// The slowest client's shooting in a frame where every set shot one batch (an epoch's first, an
// edit, an orbit's Accumulate frame without turns) sets the period the next still view starts at.
TEST(Convergence, AStillViewStartsAtThePeriodTheLastBatchPerSetPredicts) {
    Convergence c(50.0, 0.0);
    c.recordWork(FrameMode::Interaction, true, 390.0, 1, 260.0);
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 8u);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, false), 1u) << "an orbit keeps every set shooting";
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 8u)
        << "the knn still view: 390 ms, beyond the orbit's 200 ms, predicts 390 / 50 → 8";
    c.recordWork(FrameMode::Converging, true, 300.0, 1);  // planned before: not counted
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 8u);
    c.recordWork(FrameMode::Accumulate, false, 60.0, 1, 20.0);  // the camera orbits, cheap batches
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 1u);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 1u);
    c.recordWork(FrameMode::Accumulate, false, 600.0, 2, 500.0);  // with turns: half the sets shot
    c.recordWork(FrameMode::Walkthrough, false, 10.0, 1, 0.0);     // shot nothing
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 1u) << "neither predicts a pass";
    c.recordWork(FrameMode::Edit, true, 300.0, 1, 100.0);  // 100 ms against the 50 ms budget
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 2u);
}

// Frames are planned before the ones in flight are measured: a frame planned before the budget's
// last change of turns (another period than the budget's now) is not counted.
TEST(Convergence, FramesPlannedBeforeAChangeAreNotCounted) {
    Convergence c(200.0, 0.0);
    c.recordWork(FrameMode::Converging, true, 600.0, 1);
    ASSERT_EQ(c.periodFor(FrameMode::Converging, true), 2u) << "a trial of turns";
    c.recordWork(FrameMode::Converging, true, 650.0, 1);  // planned before: would fail the trial
    c.recordWork(FrameMode::Converging, true, 300.0, 2);
    c.recordWork(FrameMode::Converging, true, 380.0, 2);  // the turn: 340 ms ≤ 0.8 × 600 ms, paid
    EXPECT_EQ(c.periodFor(FrameMode::Converging, true), 4u) << "over the budget still: doubled again";
    c.recordWork(FrameMode::Accumulate, true, 900.0, 1);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 2u);
    c.recordWork(FrameMode::Accumulate, true, 950.0, 1);
    c.recordWork(FrameMode::Accumulate, true, 400.0, 2);
    c.recordWork(FrameMode::Accumulate, true, 400.0, 2);
    EXPECT_EQ(c.periodFor(FrameMode::Accumulate, true), 4u);
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
