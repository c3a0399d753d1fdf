// The frame-loop policy without sockets or clocks: epochs, modes, skips, reassignment, eviction.
#include "server/frame_policy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>

namespace rtpm::server {
namespace {

auto none = [](ClientId) -> size_t { return 0; };

TEST(FramePolicy, FirstFrameIsInteractionThenAccumulateUntilEveryClientIsCapped) {
    FramePolicy p(9, /*walkthrough=*/false, /*pipeline=*/2, /*evictAfter=*/3);
    std::vector<ClientId> clients{1, 2};
    FramePlan f0 = p.plan(0, false, clients, none);
    EXPECT_EQ(f0.mode, proto::FrameMode::Interaction);
    EXPECT_EQ(f0.epoch, 0u);
    EXPECT_EQ(f0.sets.at(1), (std::vector<uint32_t>{0, 2, 4, 6, 8}));
    EXPECT_EQ(f0.sets.at(2), (std::vector<uint32_t>{1, 3, 5, 7}));
    EXPECT_EQ(p.plan(1, false, clients, none).mode, proto::FrameMode::Accumulate);
    p.stats(1, proto::FrameMode::Accumulate, 0);
    EXPECT_EQ(p.plan(2, false, clients, none).mode, proto::FrameMode::Accumulate);  // client 2 still shoots
    p.stats(2, proto::FrameMode::Accumulate, 0);
    EXPECT_EQ(p.plan(3, false, clients, none).mode, proto::FrameMode::Walkthrough);
}

TEST(FramePolicy, EditsStartANewEpochWithAnEditFrameAndResetCapped) {
    FramePolicy p(4, false, 2, 3);
    std::vector<ClientId> clients{1};
    p.plan(0, false, clients, none);
    p.stats(1, proto::FrameMode::Accumulate, 0);
    EXPECT_EQ(p.plan(1, false, clients, none).mode, proto::FrameMode::Walkthrough);
    FramePlan e = p.plan(2, true, clients, none, false, false, /*sceneEdited=*/true);
    EXPECT_EQ(e.mode, proto::FrameMode::Edit);
    EXPECT_EQ(e.epoch, 1u);
    EXPECT_EQ(p.plan(3, false, clients, none).mode, proto::FrameMode::Accumulate);
    // Light edits alone at a still camera: a Relight frame; with the camera moved, an Edit frame.
    FramePlan r = p.plan(4, true, clients, none, false, /*cameraStill=*/true, true, /*relit=*/true);
    EXPECT_EQ(r.mode, proto::FrameMode::Relight);
    EXPECT_EQ(r.epoch, 2u);
    EXPECT_EQ(p.plan(5, true, clients, none, false, /*cameraStill=*/false, true, true).mode, proto::FrameMode::Edit);
}

TEST(FramePolicy, CameraMovesAreWalkthroughFramesAndDoNotMarkClientsCapped) {
    FramePolicy p(4, false, 2, 3);
    std::vector<ClientId> clients{1};
    p.plan(0, false, clients, none);
    FramePlan moved = p.plan(1, false, clients, none, /*cameraMoved=*/true);
    EXPECT_EQ(moved.mode, proto::FrameMode::Walkthrough);
    EXPECT_EQ(moved.epoch, 0u);  // photons kept
    p.stats(1, proto::FrameMode::Walkthrough, 0);  // walkthrough frames shoot nothing by design
    EXPECT_EQ(p.plan(2, false, clients, none).mode, proto::FrameMode::Accumulate);
    // A camera move in the frame a scene edit starts an epoch with stays an Edit frame; settings
    // alone start an Interaction frame.
    EXPECT_EQ(p.plan(3, true, clients, none, true, false, true).mode, proto::FrameMode::Edit);
    EXPECT_EQ(p.plan(4, true, clients, none, true).mode, proto::FrameMode::Interaction);
}

TEST(FramePolicy, StillFramesConvergeOnlyWithTheProgressiveEstimator) {
    FramePolicy p(4, false, 2, 3, /*progressive=*/true);
    std::vector<ClientId> clients{1};
    p.plan(0, false, clients, none);
    EXPECT_EQ(p.plan(1, false, clients, none, false, /*cameraStill=*/true).mode, proto::FrameMode::Converging);
    // A settings edit switches to knn (and starts an epoch): still frames accumulate again.
    p.setProgressive(false);
    EXPECT_EQ(p.plan(2, true, clients, none, false, true).mode, proto::FrameMode::Interaction);
    EXPECT_EQ(p.plan(3, false, clients, none, false, true).mode, proto::FrameMode::Accumulate);
    p.setProgressive(true);
    EXPECT_EQ(p.plan(4, true, clients, none, false, true).mode, proto::FrameMode::Interaction);
    EXPECT_EQ(p.plan(5, false, clients, none, false, true).mode, proto::FrameMode::Converging);
}

// While the sets take turns in Accumulate frames a client may own no set whose turn it is and
// shoot nothing: that says nothing about its cap (the frames would turn into Walkthrough).
TEST(FramePolicy, NoPhotonsInATurnOfAccumulateFramesIsNotACap) {
    FramePolicy p(4, false, 2, 3);
    std::vector<ClientId> clients{1};
    p.plan(0, false, clients, none);
    p.stats(1, proto::FrameMode::Accumulate, 0, /*passPeriod=*/4);
    EXPECT_EQ(p.plan(1, false, clients, none).mode, proto::FrameMode::Accumulate);
    p.stats(1, proto::FrameMode::Accumulate, 0, 1);  // every set's turn, nothing shot: capped
    EXPECT_EQ(p.plan(2, false, clients, none).mode, proto::FrameMode::Walkthrough);
}

TEST(FramePolicy, ResizeDealsTheNewSetsAfresh) {
    FramePolicy p(9, false, 2, 3);
    std::vector<ClientId> clients{1, 2};
    p.plan(0, false, clients, none);
    p.resize(4);
    FramePlan f = p.plan(1, true, clients, none);
    EXPECT_EQ(f.owners.size(), 4u);
    EXPECT_EQ(f.sets.at(1), (std::vector<uint32_t>{0, 2}));
    EXPECT_EQ(f.sets.at(2), (std::vector<uint32_t>{1, 3}));
    EXPECT_EQ(f.epoch, 1u);
}

TEST(FramePolicy, ForcedWalkthroughAfterTheFirstFrameOfAnEpoch) {
    FramePolicy p(4, /*walkthrough=*/true, 2, 3);
    std::vector<ClientId> clients{1};
    EXPECT_EQ(p.plan(0, false, clients, none).mode, proto::FrameMode::Interaction);
    EXPECT_EQ(p.plan(1, false, clients, none).mode, proto::FrameMode::Walkthrough);
}

TEST(FramePolicy, ClientWithFullPipelineIsSkippedItsSetsUnownedAndEvictedAfterRepeatedSkips) {
    FramePolicy p(4, false, 2, 3);
    std::vector<ClientId> clients{1, 2};
    auto busy2 = [](ClientId id) -> size_t { return id == 2 ? 2 : 0; };
    auto noMisses = [](ClientId) -> uint32_t { return 0; };
    for (uint64_t f = 0; f < 3; ++f) {
        FramePlan plan = p.plan(f, false, clients, busy2);
        EXPECT_EQ(plan.sets.count(2), 0u);
        EXPECT_EQ(plan.owners[1], kNoClient);  // client 2's set 1 is shown with previous values
        EXPECT_EQ(plan.owners[0], 1u);
    }
    EXPECT_EQ(p.evictions(clients, noMisses), (std::vector<ClientId>{2}));
    p.stats(2, proto::FrameMode::Accumulate, 10);  // a finished frame clears the skip count
    EXPECT_TRUE(p.evictions(clients, noMisses).empty());
    EXPECT_EQ(p.evictions(clients, [](ClientId id) -> uint32_t { return id == 1 ? 3 : 0; }),
              (std::vector<ClientId>{1}));
}

TEST(FramePolicy, LeavingClientsSetsMoveToSurvivorsWithinTheEpoch) {
    FramePolicy p(4, false, 2, 3);
    p.plan(0, false, {1, 2}, none);
    p.clientLeft(2);
    FramePlan f1 = p.plan(1, false, {1}, none);
    EXPECT_EQ(f1.sets.at(1), (std::vector<uint32_t>{0, 1, 2, 3}));
    EXPECT_EQ(f1.epoch, 0u);
    EXPECT_EQ(f1.mode, proto::FrameMode::Accumulate);
}

// Frames whose sets change owner (or are dealt afresh) say so: their cost is not the last ones'.
TEST(FramePolicy, PlansSayWhenSetsChangeOwner) {
    FramePolicy p(4, true, 2, 3);
    EXPECT_TRUE(p.plan(0, false, {1, 2}, none).reassigned);
    EXPECT_FALSE(p.plan(1, false, {1, 2}, none).reassigned);
    p.clientLeft(2);
    FramePlan f2 = p.plan(2, false, {1}, none);
    EXPECT_TRUE(f2.reassigned);
    EXPECT_EQ(f2.mode, proto::FrameMode::Walkthrough) << "forced walkthrough: the client shoots the moved sets' "
                                                         "first batch itself (FrameRenderer)";
    EXPECT_FALSE(p.plan(3, false, {1}, none).reassigned);
    p.clientJoined(3);  // client 3 joins: once it answered, rebalancing moves sets to it
    EXPECT_FALSE(p.plan(4, false, {1, 3}, none).reassigned) << "the newcomer has not answered yet";
    EXPECT_TRUE(p.answered(3));
    EXPECT_TRUE(p.plan(5, false, {1, 3}, none).reassigned) << "the newcomer takes sets";
    EXPECT_TRUE(p.plan(6, true, {1, 3}, none).reassigned) << "a new epoch";
}

// A joiner holds no set until it answered a frame sent to it without sets, so one that never
// answers never holds a frame up; clients present when frames begin take sets at once, and so
// does a joiner when nobody else holds sets.
TEST(FramePolicy, AJoinerTakesSetsOnlyAfterAnsweringAFrameWithoutSets) {
    FramePolicy p(4, false, 2, 3);
    p.clientJoined(1);
    p.clientJoined(2);
    FramePlan f0 = p.plan(0, false, {1, 2}, none);
    EXPECT_TRUE(f0.probes.empty());
    EXPECT_EQ(f0.sets.size(), 2u);
    p.clientJoined(3);
    std::map<ClientId, size_t> outstanding;
    auto pending = [&](ClientId id) { return outstanding[id]; };
    FramePlan f1 = p.plan(1, false, {1, 2, 3}, pending);
    EXPECT_EQ(f1.probes, std::vector<ClientId>{3});
    EXPECT_FALSE(f1.sets.count(3));
    EXPECT_EQ(std::count(f1.owners.begin(), f1.owners.end(), ClientId(3)), 0);
    EXPECT_FALSE(f1.reassigned);
    outstanding[3] = 1;  // it has not answered: no second frame without sets, still no set
    FramePlan f2 = p.plan(2, true, {1, 2, 3}, pending);  // a new epoch deals only to the answered
    EXPECT_TRUE(f2.probes.empty());
    EXPECT_FALSE(f2.sets.count(3));
    EXPECT_FALSE(p.answered(1)) << "a client that holds sets answers frames as usual";
    outstanding[3] = 0;
    EXPECT_TRUE(p.answered(3));
    FramePlan f3 = p.plan(3, false, {1, 2, 3}, pending);
    EXPECT_TRUE(f3.reassigned);
    EXPECT_EQ(f3.sets.at(3).size(), 1u);
    EXPECT_TRUE(f3.probes.empty());
    // Everyone else left: a new joiner has nobody to wait behind and takes every set at once.
    p.clientLeft(1);
    p.clientLeft(2);
    p.clientLeft(3);
    p.clientJoined(4);
    FramePlan f4 = p.plan(4, false, {4}, none);
    EXPECT_TRUE(f4.probes.empty());
    EXPECT_EQ(f4.sets.at(4).size(), 4u);
}

TEST(FramePolicy, TentativeSetsOfAJoiningClient) {
    FramePolicy p(4, false, 2, 3);
    EXPECT_EQ(p.tentativeSets(1, {1}), (std::vector<uint32_t>{0, 1, 2, 3}));
    p.plan(0, false, {1}, none);
    EXPECT_EQ(p.tentativeSets(2, {1, 2}).size(), 2u);
}

}  // namespace
}  // namespace rtpm::server
