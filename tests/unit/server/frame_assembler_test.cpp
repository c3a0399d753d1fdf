// Frame assembly bookkeeping: completion, in-order retirement, deadlines, late and hostile data.
#include "server/frame_assembler.h"

#include <gtest/gtest.h>

namespace rtpm::server {
namespace {

using std::chrono::milliseconds;
const TimePoint t0{};  // an injected clock: tests move time by hand

// Sets 0,2 → client 1; sets 1,3 → client 2.
std::vector<ClientId> twoClients() { return {1, 2, 1, 2}; }

void deliver(FrameAssembler& a, ClientId c, uint64_t frame, std::initializer_list<uint32_t> sets) {
    for (uint32_t s : sets) ASSERT_EQ(a.onFrameData(c, frame, s), Verdict::Accept) << "set " << s;
    ASSERT_EQ(a.onStats(c, frame), Verdict::Accept);
}

TEST(FrameAssembler, FrameIsReadyOnlyWhenAllSetsAndStatsArrived) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(0, twoClients(), t0);
    deliver(a, 1, 0, {0, 2});
    EXPECT_TRUE(a.takeReady(t0).empty());
    EXPECT_EQ(a.onFrameData(2, 0, 1), Verdict::Accept);
    EXPECT_EQ(a.onFrameData(2, 0, 3), Verdict::Accept);
    EXPECT_TRUE(a.takeReady(t0).empty()) << "stats of client 2 still missing";
    EXPECT_EQ(a.onStats(2, 0), Verdict::Accept);
    auto r = a.takeReady(t0);
    ASSERT_EQ(r.size(), 1u);
    EXPECT_EQ(r[0].frame, 0u);
    EXPECT_EQ(r[0].arrived, (std::vector<uint32_t>{0, 1, 2, 3}));
    EXPECT_TRUE(r[0].missing.empty());
    EXPECT_FALSE(r[0].deadlineHit);
    EXPECT_EQ(a.inFlight(), 0u);
}

// The adaptive deadline learns from `waited` (time as the oldest frame) and gives each frame its
// own budget, armed when it becomes the oldest.
TEST(FrameAssembler, EachFrameWaitsItsOwnDeadlineFromWhenItBecomesTheOldest) {
    FrameAssembler a(4, milliseconds(10000));
    a.beginFrame(0, twoClients(), t0, milliseconds(100));
    a.beginFrame(1, twoClients(), t0 + milliseconds(10), milliseconds(5000));
    EXPECT_EQ(a.nextDeadline(), t0 + milliseconds(100));
    deliver(a, 1, 0, {0, 2});
    deliver(a, 2, 0, {1, 3});
    auto r = a.takeReady(t0 + milliseconds(40));
    ASSERT_EQ(r.size(), 1u);
    EXPECT_FALSE(r[0].deadlineHit);
    EXPECT_EQ(r[0].waited, milliseconds(40));
    // Frame 1 became the oldest at 40 ms: its own 5 s from then.
    EXPECT_EQ(a.nextDeadline(), t0 + milliseconds(5040));
    EXPECT_TRUE(a.takeReady(t0 + milliseconds(5039)).empty());
    r = a.takeReady(t0 + milliseconds(5040));
    ASSERT_EQ(r.size(), 1u);
    EXPECT_TRUE(r[0].deadlineHit);
    EXPECT_EQ(r[0].waited, milliseconds(5000));
}

TEST(FrameAssembler, FramesRetireInOrderEvenIfALaterOneCompletesFirst) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(0, twoClients(), t0);
    a.beginFrame(1, twoClients(), t0);
    deliver(a, 1, 1, {0, 2});
    deliver(a, 2, 1, {1, 3});
    EXPECT_TRUE(a.takeReady(t0).empty());
    deliver(a, 1, 0, {0, 2});
    deliver(a, 2, 0, {1, 3});
    auto r = a.takeReady(t0);
    ASSERT_EQ(r.size(), 2u);
    EXPECT_EQ(r[0].frame, 0u);
    EXPECT_EQ(r[1].frame, 1u);
}

TEST(FrameAssembler, DeadlineShowsWhatArrivedAndNamesTheLateClient) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(0, twoClients(), t0);
    deliver(a, 1, 0, {0, 2});
    EXPECT_TRUE(a.takeReady(t0 + milliseconds(99)).empty());
    ASSERT_EQ(a.nextDeadline(), t0 + milliseconds(100));
    auto r = a.takeReady(t0 + milliseconds(100));
    ASSERT_EQ(r.size(), 1u);
    EXPECT_TRUE(r[0].deadlineHit);
    EXPECT_EQ(r[0].arrived, (std::vector<uint32_t>{0, 2}));
    EXPECT_EQ(r[0].missing, (std::vector<uint32_t>{1, 3}));
    EXPECT_EQ(r[0].late, (std::vector<ClientId>{2}));
    EXPECT_EQ(a.consecutiveMisses(2), 1u);
    EXPECT_EQ(a.consecutiveMisses(1), 0u);
    // The late client's data for the shown frame is dropped, not treated as hostile.
    EXPECT_EQ(a.onFrameData(2, 0, 1), Verdict::Late);
    EXPECT_EQ(a.onFrameData(2, 0, 3), Verdict::Late);
    EXPECT_EQ(a.outstanding(2), 1u);
    EXPECT_EQ(a.onStats(2, 0), Verdict::Late);
    EXPECT_EQ(a.outstanding(2), 0u);
}

TEST(FrameAssembler, PipelinedFrameDeadlineStartsWhenItBecomesTheOldest) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(0, twoClients(), t0);
    a.beginFrame(1, twoClients(), t0 + milliseconds(10));
    deliver(a, 1, 0, {0, 2});
    deliver(a, 2, 0, {1, 3});
    ASSERT_EQ(a.takeReady(t0 + milliseconds(90)).size(), 1u);
    EXPECT_EQ(a.nextDeadline(), t0 + milliseconds(190));
    EXPECT_TRUE(a.takeReady(t0 + milliseconds(189)).empty());
    EXPECT_EQ(a.takeReady(t0 + milliseconds(190)).size(), 1u);
}

TEST(FrameAssembler, DroppedClientNoLongerHoldsFramesBack) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(0, twoClients(), t0);
    a.beginFrame(1, twoClients(), t0);
    deliver(a, 1, 0, {0, 2});
    deliver(a, 1, 1, {0, 2});
    EXPECT_EQ(a.onFrameData(2, 0, 1), Verdict::Accept);
    a.dropClient(2);
    auto r = a.takeReady(t0);
    ASSERT_EQ(r.size(), 2u);
    EXPECT_EQ(r[0].arrived, (std::vector<uint32_t>{0, 1, 2}));
    EXPECT_EQ(r[0].missing, (std::vector<uint32_t>{3}));
    EXPECT_FALSE(r[0].deadlineHit);
    EXPECT_EQ(r[1].missing, (std::vector<uint32_t>{1, 3}));
    EXPECT_EQ(a.onFrameData(2, 1, 1), Verdict::NotSent);
}

TEST(FrameAssembler, UnownedSetsAreMissingWithoutWaiting) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(0, {1, kNoClient, 1, kNoClient}, t0);
    deliver(a, 1, 0, {0, 2});
    auto r = a.takeReady(t0);
    ASSERT_EQ(r.size(), 1u);
    EXPECT_EQ(r[0].missing, (std::vector<uint32_t>{1, 3}));
    EXPECT_FALSE(r[0].deadlineHit);
}

TEST(FrameAssembler, HostileOrConfusedMessagesAreClassified) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(5, twoClients(), t0);
    EXPECT_EQ(a.onFrameData(1, 4, 0), Verdict::NotSent) << "frame never sent";
    EXPECT_EQ(a.onFrameData(9, 5, 0), Verdict::NotSent) << "unknown client";
    EXPECT_EQ(a.onFrameData(1, 5, 1), Verdict::NotAssigned) << "someone else's set";
    EXPECT_EQ(a.onFrameData(1, 5, 77), Verdict::NotAssigned) << "set out of range";
    EXPECT_EQ(a.onStats(1, 5), Verdict::StatsEarly);
    EXPECT_EQ(a.onFrameData(1, 5, 0), Verdict::Accept);
    EXPECT_EQ(a.onFrameData(1, 5, 0), Verdict::Duplicate);
    EXPECT_EQ(a.onFrameData(1, 5, 2), Verdict::Accept);
    EXPECT_EQ(a.onStats(1, 5), Verdict::Accept);
    EXPECT_EQ(a.onStats(1, 5), Verdict::NotSent) << "frame already finished by this client";
    for (Verdict v : {Verdict::NotSent, Verdict::NotAssigned, Verdict::Duplicate, Verdict::StatsEarly})
        EXPECT_TRUE(isProtocolError(v));
    EXPECT_FALSE(isProtocolError(Verdict::Late));
}

TEST(FrameAssembler, OutstandingCountsFramesUntilStats) {
    FrameAssembler a(4, milliseconds(100));
    a.beginFrame(0, twoClients(), t0);
    a.beginFrame(1, twoClients(), t0);
    EXPECT_EQ(a.outstanding(1), 2u);
    deliver(a, 1, 0, {0, 2});
    EXPECT_EQ(a.outstanding(1), 1u);
    EXPECT_EQ(a.outstanding(2), 2u);
}

TEST(FrameAssembler, MissesCountConsecutivelyAndResetOnATimelyFrame) {
    FrameAssembler a(4, milliseconds(10));
    TimePoint now = t0;
    for (uint64_t f = 0; f < 3; ++f) {
        a.beginFrame(f, twoClients(), now);
        deliver(a, 1, f, {0, 2});
        now += milliseconds(10);
        ASSERT_EQ(a.takeReady(now).size(), 1u);
        // Client 2 finishes late, so it is free for the next frame.
        EXPECT_EQ(a.onFrameData(2, f, 1), Verdict::Late);
        EXPECT_EQ(a.onFrameData(2, f, 3), Verdict::Late);
        EXPECT_EQ(a.onStats(2, f), Verdict::Late);
    }
    EXPECT_EQ(a.consecutiveMisses(2), 3u);
    a.beginFrame(3, twoClients(), now);
    deliver(a, 1, 3, {0, 2});
    deliver(a, 2, 3, {1, 3});
    EXPECT_EQ(a.consecutiveMisses(2), 0u);
}

}  // namespace
}  // namespace rtpm::server
