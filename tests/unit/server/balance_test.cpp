// Load balance by measured cost without sockets or clocks: costs per set, greedy shares,
// hysteresis, and moves only where every map restarts.
#include "server/balance.h"

#include <utility>

#include <gtest/gtest.h>

#include "server/frame_policy.h"

namespace rtpm::server {
namespace {

void report(Balance& b, ClientId id, uint32_t sets, double msPerSet, int frames = 3) {
    for (int i = 0; i < frames; ++i) b.measured(id, sets, msPerSet * sets);
}

/// Sets of clients 1 and 2 in the share `b` proposes from `a`; {0, 0} when it proposes none.
std::pair<size_t, size_t> proposedShare(const Balance& b, const Assignment& a) {
    const auto next = b.propose(a, {1, 2});
    return next ? std::pair{next->countOf(1), next->countOf(2)} : std::pair<size_t, size_t>{0, 0};
}

TEST(Balance, CostPerSetIsTheMedianOfTheFiguresAtTheCurrentShare) {
    Balance b;
    b.measured(1, 4, 40.0);
    b.measured(1, 4, 400.0);  // one slow frame (a map rebuilt) does not decide
    EXPECT_FALSE(b.msPerSet(1)) << "three figures are needed";
    b.measured(1, 4, 44.0);
    ASSERT_TRUE(b.msPerSet(1));
    EXPECT_DOUBLE_EQ(*b.msPerSet(1), 11.0);
    b.measured(1, 5, 50.0);  // a new share: measured afresh
    EXPECT_FALSE(b.msPerSet(1));
    b.measured(1, 0, 10.0);  // a frame without sets says nothing
    EXPECT_FALSE(b.msPerSet(1));
}

TEST(Balance, AClientTwiceAsSlowGetsAThirdOfTheSets) {
    Balance b;
    Assignment a = dealSets(9, std::vector<ClientId>{1, 2});  // 5 and 4
    report(b, 1, 5, 10.0);
    report(b, 2, 4, 20.0);  // twice the cost per set
    auto next = b.propose(a, {1, 2});
    ASSERT_TRUE(next);
    EXPECT_EQ(next->countOf(1), 6u);
    EXPECT_EQ(next->countOf(2), 3u);
    // Only the slow client's highest sets moved; the fast one kept its own.
    for (uint32_t s : a.setsOf(1)) EXPECT_EQ(next->owner[s], 1u);
    EXPECT_EQ(movedSets(a, *next), (std::vector<uint32_t>{7}));
}

TEST(Balance, SetsMoveOneAtATimeAndAreMeasuredAgainBeforeTheNext) {
    // A client held to half a core, throttled at four sets of nine (41.6 ms a set): the figures
    // ask for 7/2, but at two sets its frames fit in the quota's burst and it measures as fast as
    // the other, which would ask for 4/5 — the share swung. One set a step instead: 6/3, then
    // only what the figures at 6/3 say.
    Balance b;
    Assignment a = dealSets(9, std::vector<ClientId>{1, 2});
    report(b, 1, 5, 16.8);
    report(b, 2, 4, 41.6);
    EXPECT_EQ(proposedShare(b, a), (std::pair<size_t, size_t>{6, 3}));
    const Assignment step = *b.propose(a, {1, 2});
    EXPECT_EQ(movedSets(a, step), (std::vector<uint32_t>{7}));
    EXPECT_FALSE(b.propose(step, {1, 2})) << "no figures at the new share yet";
    report(b, 1, 6, 16.5);
    report(b, 2, 3, 27.0);  // 6 × 16.5 = 99 ms against 3 × 27 = 81 ms: settled
    EXPECT_FALSE(b.propose(step, {1, 2}));
}

TEST(Balance, EquallySlowClientsEachGiveASetWhereOneAloneWouldGainNothing) {
    // Three clients of nine sets, two of them twice as slow: one set from one slow client leaves
    // the other's 3 × 2 = 6 ms as the frame time; one from each makes it 5 ms.
    Balance b;
    Assignment a = dealSets(9, std::vector<ClientId>{1, 2, 3});
    report(b, 1, 3, 1.0);
    report(b, 2, 3, 2.0);
    report(b, 3, 3, 2.0);
    auto next = b.propose(a, {1, 2, 3});
    ASSERT_TRUE(next);
    EXPECT_EQ(next->countOf(1), 5u);
    EXPECT_EQ(next->countOf(2), 2u);
    EXPECT_EQ(next->countOf(3), 2u);
}

TEST(Balance, SmallGainsAndUnmeasuredClientsMoveNothing) {
    Balance b;
    Assignment a = dealSets(16, std::vector<ClientId>{1, 2});  // 8 and 8
    report(b, 1, 8, 10.0);
    EXPECT_FALSE(b.propose(a, {1, 2})) << "client 2 is not measured";
    report(b, 2, 8, 10.8);  // 8 % slower: moving one set would gain under 10 %
    EXPECT_FALSE(b.propose(a, {1, 2}));
    Balance off(BalanceOptions{.enabled = false});
    report(off, 1, 8, 10.0);
    report(off, 2, 8, 40.0);
    EXPECT_FALSE(off.propose(a, {1, 2}));
}

TEST(Balance, EveryClientKeepsASetSoItStaysMeasured) {
    Balance b;
    Assignment a = dealSets(4, std::vector<ClientId>{1, 2});
    report(b, 1, 2, 1.0);
    report(b, 2, 2, 100.0);
    auto next = b.propose(a, {1, 2});
    ASSERT_TRUE(next);
    EXPECT_EQ(next->countOf(2), 1u);
    EXPECT_EQ(next->countOf(1), 3u);
}

TEST(Balance, ASettledShareDoesNotMoveBack) {
    Balance b;
    Assignment a = dealSets(9, std::vector<ClientId>{1, 2});
    report(b, 1, 5, 10.0);
    report(b, 2, 4, 20.0);
    Assignment settled = *b.propose(a, {1, 2});
    // Measured again at the new share, with the noise of a loaded machine (±10 %).
    report(b, 1, 6, 11.0);
    report(b, 2, 3, 18.0);
    EXPECT_FALSE(b.propose(settled, {1, 2}));
}

auto none = [](ClientId) -> size_t { return 0; };

// Sets move only at an epoch's first frame: every map restarts there, so the image is what one
// process renders whoever renders a set. Within an epoch the share stays.
TEST(FramePolicy, SetsMoveByMeasuredCostOnlyWhereAnEpochBegins) {
    FramePolicy p(9, false, 2, 3);
    FramePlan f0 = p.plan(0, false, {1, 2}, none);
    EXPECT_EQ(f0.sets.at(1).size(), 5u);
    report(p.balance(), 1, 5, 10.0);
    report(p.balance(), 2, 4, 20.0);
    FramePlan f1 = p.plan(1, false, {1, 2}, none);
    EXPECT_FALSE(f1.balanced) << "within the epoch";
    EXPECT_FALSE(f1.reassigned);
    EXPECT_EQ(f1.sets.at(2).size(), 4u);
    FramePlan f2 = p.plan(2, true, {1, 2}, none);  // an edit: a new epoch
    EXPECT_TRUE(f2.balanced);
    EXPECT_EQ(f2.mode, proto::FrameMode::Interaction);
    EXPECT_EQ(f2.sets.at(1).size(), 6u);
    EXPECT_EQ(f2.sets.at(2).size(), 3u);
    // The next epochs keep the measured share rather than dealing round-robin again, also while
    // the costs at the new share are still being measured (fewer figures than minSamples).
    p.balance().measured(1, 6, 60.0);
    p.balance().measured(2, 3, 60.0);
    FramePlan f3 = p.plan(3, true, {1, 2}, none);
    EXPECT_FALSE(f3.balanced);
    EXPECT_EQ(f3.sets.at(2).size(), 3u);
    report(p.balance(), 1, 6, 10.0);
    report(p.balance(), 2, 3, 20.0);
    FramePlan f4 = p.plan(4, true, {1, 2}, none);
    EXPECT_FALSE(f4.balanced) << "settled";
    EXPECT_EQ(f4.sets.at(2).size(), 3u);
    // --static-sets: the round-robin deal at every epoch.
    FramePolicy fixed(9, false, 2, 3, false, BalanceOptions{.enabled = false});
    fixed.plan(0, false, {1, 2}, none);
    report(fixed.balance(), 1, 5, 10.0);
    report(fixed.balance(), 2, 4, 20.0);
    EXPECT_EQ(fixed.plan(1, true, {1, 2}, none).sets.at(2).size(), 4u);
}

}  // namespace
}  // namespace rtpm::server
