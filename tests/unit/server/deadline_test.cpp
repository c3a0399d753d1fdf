// The adaptive frame deadline without clocks: median, multiple, floor, ceiling, unknown-cost frames.
#include "server/deadline.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace rtpm::server {
namespace {

using std::chrono::milliseconds;

TEST(FrameDeadline, CeilingUntilEnoughFramesAreMeasuredThenAMultipleOfTheMedian) {
    FrameDeadline d;  // 4 x median, [1000, 10000] ms, 3 samples first
    EXPECT_EQ(d.forFrame(false), milliseconds(10000));
    d.completed(milliseconds(400));
    d.completed(milliseconds(500));
    EXPECT_EQ(d.forFrame(false), milliseconds(10000)) << "two samples are not enough";
    d.completed(milliseconds(450));
    EXPECT_EQ(d.median(), milliseconds(450));
    EXPECT_EQ(d.forFrame(false), milliseconds(1801));  // 4 x 450 ms, rounded up
    // A frame whose cost is unknown (new epoch, moved sets, the last frame) waits the ceiling.
    EXPECT_EQ(d.forFrame(true), milliseconds(10000));
}

TEST(FrameDeadline, AFewOutliersDoNotMoveTheMedianAndOldFramesAgeOut) {
    DeadlinePolicy p;
    p.window = 5;
    FrameDeadline d(p);
    for (int i = 0; i < 5; ++i) d.completed(milliseconds(600));
    d.completed(milliseconds(9000));
    d.completed(milliseconds(9000));
    EXPECT_EQ(d.median(), milliseconds(600));
    d.completed(milliseconds(9000));
    EXPECT_EQ(d.median(), milliseconds(9000)) << "the last 5 frames are 3 slow and 2 fast: the job got slower";
    EXPECT_EQ(d.forFrame(false), milliseconds(10000)) << "clamped to the ceiling";
}

TEST(FrameDeadline, FastFramesAreClampedToTheFloor) {
    FrameDeadline d;
    for (int i = 0; i < 10; ++i) d.completed(milliseconds(20));
    EXPECT_EQ(d.forFrame(false), milliseconds(1000));
}

TEST(FrameDeadline, RetracedAndConvergingFramesKeepTheirOwnMeasurements) {
    FrameDeadline d;
    for (int i = 0; i < 3; ++i) d.completed(milliseconds(2000), FrameCost::Retraced);
    for (int i = 0; i < 100; ++i) d.completed(milliseconds(30), FrameCost::Converging);
    EXPECT_EQ(d.median(FrameCost::Converging), milliseconds(30));
    EXPECT_EQ(d.forFrame(false, FrameCost::Converging), milliseconds(1000)) << "cheap still frames: the floor";
    // A walkthrough after a long still period is judged by the re-traced frames, not by the
    // hundred cheap ones since.
    EXPECT_EQ(d.median(FrameCost::Retraced), milliseconds(2000));
    EXPECT_EQ(d.forFrame(false, FrameCost::Retraced), milliseconds(8001));
}

TEST(FrameDeadline, AKindNotYetMeasuredWaitsTheCeiling) {
    FrameDeadline d;
    for (int i = 0; i < 10; ++i) d.completed(milliseconds(40), FrameCost::Converging);
    EXPECT_EQ(d.forFrame(false, FrameCost::Converging), milliseconds(1000));
    EXPECT_EQ(d.forFrame(false, FrameCost::Retraced), milliseconds(10000))
        << "no re-traced frame measured yet: its cost is unknown";
}

TEST(FrameDeadline, AFixedDeadlineIgnoresMeasurements) {
    DeadlinePolicy p;
    p.fixed = milliseconds(250);
    FrameDeadline d(p);
    for (int i = 0; i < 10; ++i) d.completed(milliseconds(5000));
    EXPECT_EQ(d.forFrame(false), milliseconds(250));
    EXPECT_EQ(d.forFrame(true), milliseconds(250));
    EXPECT_FALSE(d.adaptive());
}

TEST(FrameDeadline, NonsensePoliciesAreRefused) {
    DeadlinePolicy p;
    p.fixed = milliseconds(0);
    EXPECT_THROW(FrameDeadline{p}, std::invalid_argument);
    p = DeadlinePolicy{};
    p.floor = milliseconds(20000);  // above the ceiling
    EXPECT_THROW(FrameDeadline{p}, std::invalid_argument);
    p = DeadlinePolicy{};
    p.multiple = 0.5;
    EXPECT_THROW(FrameDeadline{p}, std::invalid_argument);
}

}  // namespace
}  // namespace rtpm::server
