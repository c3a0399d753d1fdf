// Set assignment: the round-robin deal, spares, and minimal-movement rebalancing on leave/join.
#include "server/assignment.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace rtpm::server {
namespace {

// Every set owned by exactly one listed client, loads within one set of each other.
void expectBalancedCover(const Assignment& a, uint32_t setCount, const std::vector<ClientId>& clients) {
    ASSERT_EQ(a.owner.size(), setCount);
    for (ClientId o : a.owner)
        EXPECT_NE(std::find(clients.begin(), clients.end(), o), clients.end()) << "owner " << o;
    size_t lo = setCount, hi = 0;
    for (ClientId c : clients) {
        lo = std::min(lo, a.countOf(c));
        hi = std::max(hi, a.countOf(c));
    }
    EXPECT_LE(hi - lo, 1u);
}

TEST(Assignment, DealIsRoundRobinByJoinOrder) {
    std::vector<ClientId> clients{7, 3, 9};
    Assignment a = dealSets(9, clients);
    EXPECT_EQ(a.setsOf(7), (std::vector<uint32_t>{0, 3, 6}));
    EXPECT_EQ(a.setsOf(3), (std::vector<uint32_t>{1, 4, 7}));
    EXPECT_EQ(a.setsOf(9), (std::vector<uint32_t>{2, 5, 8}));
}

TEST(Assignment, UnevenDealGivesFirstClientsOneSetMore) {
    std::vector<ClientId> clients{1, 2, 3, 4};
    Assignment a = dealSets(9, clients);
    EXPECT_EQ(a.countOf(1), 3u);
    EXPECT_EQ(a.countOf(2), 2u);
    EXPECT_EQ(a.countOf(3), 2u);
    EXPECT_EQ(a.countOf(4), 2u);
    expectBalancedCover(a, 9, clients);
}

TEST(Assignment, ClientsBeyondSetCountAreSpares) {
    std::vector<ClientId> clients{1, 2, 3, 4, 5};
    Assignment a = dealSets(4, clients);
    EXPECT_TRUE(a.setsOf(5).empty());
    for (ClientId c : {1u, 2u, 3u, 4u}) EXPECT_EQ(a.countOf(c), 1u);
}

TEST(Assignment, NoClientsLeavesEverySetUnowned) {
    Assignment a = dealSets(4, {});
    EXPECT_EQ(a.owner, std::vector<ClientId>(4, kNoClient));
    EXPECT_EQ(rebalance(a, 4, {}).owner, std::vector<ClientId>(4, kNoClient));
}

TEST(Assignment, LeaverSetsGoToRemainingClientsAndSurvivorsKeepTheirs) {
    std::vector<ClientId> three{1, 2, 3};
    Assignment before = dealSets(9, three);
    std::vector<ClientId> two{1, 3};
    Assignment after = rebalance(before, 9, two);
    expectBalancedCover(after, 9, two);
    for (uint32_t s : before.setsOf(1)) EXPECT_EQ(after.owner[s], 1u);
    for (uint32_t s : before.setsOf(3)) EXPECT_EQ(after.owner[s], 3u);
    // Only the leaver's sets moved.
    EXPECT_EQ(movedSets(before, after), before.setsOf(2));
}

TEST(Assignment, SpareTakesTheLeaversSets) {
    std::vector<ClientId> clients{1, 2, 3};
    Assignment before = dealSets(2, clients);  // 3 is a spare
    ASSERT_TRUE(before.setsOf(3).empty());
    std::vector<ClientId> left{1, 3};
    Assignment after = rebalance(before, 2, left);
    EXPECT_EQ(after.setsOf(3), (std::vector<uint32_t>{1}));
    EXPECT_EQ(after.setsOf(1), (std::vector<uint32_t>{0}));
}

TEST(Assignment, RejoiningClientGetsWorkAgainWithFewMoves) {
    std::vector<ClientId> two{1, 2};
    Assignment a = dealSets(16, two);
    std::vector<ClientId> three{1, 2, 5};
    Assignment b = rebalance(a, 16, three);
    expectBalancedCover(b, 16, three);
    EXPECT_EQ(b.countOf(5), 5u);
    // Exactly the sets the newcomer took moved.
    EXPECT_EQ(movedSets(a, b), b.setsOf(5));
}

TEST(Assignment, RebalanceOfAStableClientListChangesNothing) {
    std::vector<ClientId> clients{4, 2, 8};
    Assignment a = dealSets(25, clients);
    EXPECT_EQ(rebalance(a, 25, clients), a);
    EXPECT_TRUE(movedSets(a, a).empty());
}

TEST(Assignment, RebalanceAfterEveryOwnerLeftIsAFreshDeal) {
    std::vector<ClientId> old{1, 2};
    Assignment a = dealSets(9, old);
    std::vector<ClientId> fresh{3, 4, 5};
    EXPECT_EQ(rebalance(a, 9, fresh), dealSets(9, fresh));
}

TEST(Assignment, RebalanceWithDifferentSetCountIsAFreshDeal) {
    std::vector<ClientId> clients{1, 2};
    Assignment a = dealSets(9, clients);
    EXPECT_EQ(rebalance(a, 16, clients), dealSets(16, clients));
}

TEST(Assignment, ManyJoinsAndLeavesKeepEverySetCoveredAndBalanced) {
    std::vector<ClientId> clients{1};
    Assignment a = dealSets(16, clients);
    ClientId next = 2;
    for (int step = 0; step < 40; ++step) {
        if (step % 3 == 2 && clients.size() > 1)
            clients.erase(clients.begin() + (step % clients.size()));
        else
            clients.push_back(next++);
        a = rebalance(a, 16, clients);
        expectBalancedCover(a, 16, clients);
    }
}

}  // namespace
}  // namespace rtpm::server
