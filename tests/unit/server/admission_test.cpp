// Pre-authentication admission: per-source and overall budgets, fair-share eviction, the
// failed-authentication allowance, bounded memory and the summary line (clock injected).
#include "server/admission.h"

#include <gtest/gtest.h>

#include <set>

namespace rtpm::server {
namespace {

using namespace std::chrono_literals;
using TP = Admission::TimePoint;

AdmissionLimits small() {
    AdmissionLimits l;
    l.maxPending = 6;
    l.maxPendingPerSource = 3;
    l.failureBurst = 4;
    l.failureRefillPerSecond = 1;
    l.failureDelay = 500ms;
    l.logInterval = 10s;
    l.maxSources = 16;
    return l;
}

TEST(Admission, OneSourceCannotTakeMoreThanItsBudget) {
    Admission a(small());
    const TP t0{};
    for (uint64_t id = 1; id <= 3; ++id) {
        EXPECT_EQ(a.onConnect(id, "10.0.0.9", t0).decision, AdmissionDecision::Admit);
        a.onProgress(id);  // each sent its Hello: none is taken for a newcomer
    }
    const auto v = a.onConnect(4, "10.0.0.9", t0);
    EXPECT_EQ(v.decision, AdmissionDecision::RefuseCapacity);
    EXPECT_NE(v.text.find("retry"), std::string::npos);
    // Another address is unaffected; a finished handshake frees the slot.
    EXPECT_EQ(a.onConnect(5, "10.0.0.1", t0).decision, AdmissionDecision::Admit);
    a.onPendingEnded(1, Admission::End::TimedOut);
    EXPECT_EQ(a.onConnect(6, "10.0.0.9", t0).decision, AdmissionDecision::Admit);
    EXPECT_EQ(a.pendingFrom("10.0.0.9"), 3u);
}

// A real client's Hello may be in its socket, unread, while a flood's accepts come first: a slot
// is then taken from a connection that sent nothing at all, whatever their ages (before: the
// oldest idle slot, here the real client's, whose Hello the master had not read yet).
TEST(Admission, ASlotIsTakenFromAConnectionThatSentNothingBeforeOneWhoseBytesWaitUnread) {
    Admission a(small());
    const TP t0{};
    std::set<uint64_t> sent;
    auto sentBytes = [&](uint64_t id) { return sent.count(id) > 0; };
    ASSERT_EQ(a.onConnect(100, "10.0.0.9", t0, sentBytes).decision, AdmissionDecision::Admit);  // the real client
    sent.insert(100);  // its Hello arrived, not yet read
    for (uint64_t id = 1; id <= 2; ++id) ASSERT_EQ(a.onConnect(id, "10.0.0.9", t0, sentBytes).decision, AdmissionDecision::Admit);
    for (uint64_t id = 3; id <= 40; ++id) {
        const auto v = a.onConnect(id, "10.0.0.9", t0, sentBytes);
        ASSERT_EQ(v.decision, AdmissionDecision::Admit);
        ASSERT_TRUE(v.evict.has_value());
        ASSERT_NE(*v.evict, 100u) << "a peer whose Hello was in lost its slot to one that sent nothing";
    }
    // The same across addresses (fair share) and when only senders are left, the oldest of them.
    Admission b(small());
    std::set<uint64_t> all{1, 2, 3};
    auto allSent = [&](uint64_t id) { return all.count(id) > 0; };
    for (uint64_t id = 1; id <= 3; ++id) ASSERT_EQ(b.onConnect(id, "10.0.0.9", t0, allSent).decision, AdmissionDecision::Admit);
    EXPECT_EQ(b.onConnect(4, "10.0.0.9", t0, allSent).evict, std::optional<uint64_t>(1));
}

TEST(Admission, AnIdleFloodFromAClientsOwnAddressDoesNotKeepItOut) {
    Admission a(small());
    const TP t0{};
    // A flood of idle sockets holds every slot of the address a real client shares (NAT).
    for (uint64_t id = 1; id <= 3; ++id) ASSERT_EQ(a.onConnect(id, "10.0.0.9", t0).decision, AdmissionDecision::Admit);
    // The real client takes the oldest idle slot of its address, and keeps it once its Hello came.
    const auto real = a.onConnect(100, "10.0.0.9", t0);
    ASSERT_EQ(real.decision, AdmissionDecision::Admit);
    EXPECT_EQ(real.evict, std::optional<uint64_t>(1));
    a.onProgress(100);
    for (uint64_t id = 4; id <= 40; ++id) {
        const auto v = a.onConnect(id, "10.0.0.9", t0);
        ASSERT_EQ(v.decision, AdmissionDecision::Admit);
        ASSERT_TRUE(v.evict.has_value());
        ASSERT_NE(*v.evict, 100u) << "a peer that sent its Hello lost its slot to one that sent nothing";
    }
    EXPECT_EQ(a.pendingFrom("10.0.0.9"), 3u);
}

TEST(Admission, APeerThatSentItsHelloIsNeverEvictedForAnotherSource) {
    Admission a(small());
    const TP t0{};
    for (uint64_t id = 1; id <= 3; ++id) ASSERT_EQ(a.onConnect(id, "10.0.0.8", t0).decision, AdmissionDecision::Admit);
    for (uint64_t id = 4; id <= 6; ++id) ASSERT_EQ(a.onConnect(id, "10.0.0.9", t0).decision, AdmissionDecision::Admit);
    a.onProgress(1);
    a.onProgress(4);
    const auto v = a.onConnect(7, "10.0.0.1", t0);
    ASSERT_EQ(v.decision, AdmissionDecision::Admit);
    ASSERT_TRUE(v.evict.has_value());
    EXPECT_TRUE(*v.evict == 2 || *v.evict == 5) << *v.evict;  // the oldest idle, not the oldest
    // When every slot that could be taken has made progress, the newcomer is refused instead.
    Admission b(small());
    for (uint64_t id = 1; id <= 6; ++id) {
        ASSERT_EQ(b.onConnect(id, id <= 3 ? "10.0.0.8" : "10.0.0.9", t0).decision, AdmissionDecision::Admit);
        b.onProgress(id);
    }
    EXPECT_EQ(b.onConnect(7, "10.0.0.1", t0).decision, AdmissionDecision::RefuseCapacity);
}

TEST(Admission, ANewSourceTakesTheOldestSlotOfTheBiggestWhenAllAreTaken) {
    Admission a(small());
    const TP t0{};
    // Two flooding sources fill every slot (3 + 3).
    for (uint64_t id = 1; id <= 3; ++id) ASSERT_EQ(a.onConnect(id, "10.0.0.8", t0).decision, AdmissionDecision::Admit);
    for (uint64_t id = 4; id <= 6; ++id) ASSERT_EQ(a.onConnect(id, "10.0.0.9", t0).decision, AdmissionDecision::Admit);
    ASSERT_EQ(a.pending(), 6u);
    const auto v = a.onConnect(7, "10.0.0.1", t0);
    ASSERT_EQ(v.decision, AdmissionDecision::Admit);
    ASSERT_TRUE(v.evict.has_value());
    EXPECT_TRUE(*v.evict == 1 || *v.evict == 4) << *v.evict;  // the oldest of a source holding 3
    EXPECT_EQ(a.pending(), 6u);
    // A second real client from yet another source gets in too; fair share keeps holding.
    EXPECT_EQ(a.onConnect(8, "10.0.0.2", t0).decision, AdmissionDecision::Admit);
    EXPECT_EQ(a.totals().evicted, 2u);
}

TEST(Admission, TheFloodingSourceLosesItsSlotsNotAHostStartingSeveralClients) {
    AdmissionLimits l = small();
    l.maxPending = 6;
    l.maxPendingPerSource = 4;
    Admission a(l);
    TP t{};
    // A flooder connects many times (each newcomer at its budget takes its own oldest idle
    // slot), holding 3 slots; a host starting three clients at once holds 3 too.
    uint64_t id = 1;
    for (int i = 0; i < 50; ++i) a.onConnect(id++, "10.0.0.9", t);  // it holds 47, 48, 49, 50
    EXPECT_EQ(a.pendingFrom("10.0.0.9"), 4u);
    a.onPendingEnded(47, Admission::End::TimedOut);                  // the flooder holds 48, 49, 50
    for (uint64_t c = 100; c < 103; ++c) ASSERT_EQ(a.onConnect(c, "10.0.0.5", t).decision, AdmissionDecision::Admit);
    ASSERT_EQ(a.pending(), 6u);
    const auto v = a.onConnect(200, "10.0.0.1", t);
    ASSERT_EQ(v.decision, AdmissionDecision::Admit);
    ASSERT_TRUE(v.evict.has_value());
    EXPECT_EQ(*v.evict, 48u);  // the flooder's oldest, not 100
}

TEST(Admission, EvenlySpreadSlotsAreNotTakenFromOthers) {
    AdmissionLimits l = small();
    l.maxPendingPerSource = 1;
    Admission a(l);
    const TP t0{};
    for (uint64_t id = 1; id <= 6; ++id)
        ASSERT_EQ(a.onConnect(id, "10.0.1." + std::to_string(id), t0).decision, AdmissionDecision::Admit);
    const auto v = a.onConnect(7, "10.0.0.1", t0);
    EXPECT_EQ(v.decision, AdmissionDecision::RefuseCapacity);
    EXPECT_FALSE(v.evict.has_value());
}

TEST(Admission, FailedAuthenticationsAreDelayedThenRefusedUntilTheAllowanceRefills) {
    Admission a(small());
    TP t{};
    uint64_t id = 1;
    for (int i = 0; i < 4; ++i) {
        ASSERT_EQ(a.onConnect(id, "10.0.0.9", t).decision, AdmissionDecision::Admit);
        EXPECT_EQ(a.onAuthFailure("10.0.0.9", t), 500ms);
        a.onPendingEnded(id++, Admission::End::FailedAuth);
    }
    const auto v = a.onConnect(id++, "10.0.0.9", t);
    EXPECT_EQ(v.decision, AdmissionDecision::RefuseRateLimited);
    EXPECT_NE(v.text.find("retry in 1 s"), std::string::npos) << v.text;
    // Another address may still try; the guessing one gets one more try per refill period.
    EXPECT_EQ(a.onConnect(id++, "10.0.0.1", t).decision, AdmissionDecision::Admit);
    t += 1100ms;
    EXPECT_EQ(a.onConnect(id++, "10.0.0.9", t).decision, AdmissionDecision::Admit);
    EXPECT_EQ(a.totals().refusedRateLimited, 1u);
    EXPECT_EQ(a.totals().failedAuth, 4u);
}

TEST(Admission, GuessesAdmittedTogetherAreNotEvaluatedBeyondTheAllowance) {
    // Three connections pass onConnect while one attempt is left: only one guess is checked.
    AdmissionLimits l = small();
    l.failureBurst = 1;
    l.failureRefillPerSecond = 0.5;
    Admission a(l);
    const TP t{};
    for (uint64_t id = 1; id <= 3; ++id) ASSERT_EQ(a.onConnect(id, "10.0.0.9", t).decision, AdmissionDecision::Admit);
    EXPECT_FALSE(a.refuseAttempt("10.0.0.9", t));
    a.onAuthFailure("10.0.0.9", t);
    auto second = a.refuseAttempt("10.0.0.9", t);
    ASSERT_TRUE(second);
    EXPECT_NE(second->find("retry in 2 s"), std::string::npos) << *second;
    EXPECT_TRUE(a.refuseAttempt("10.0.0.9", t));
    EXPECT_FALSE(a.refuseAttempt("10.0.0.1", t));
}

TEST(Admission, SummaryIsOneLinePerIntervalAndOnlyWhenSomethingHappened) {
    Admission a(small());
    TP t{};
    EXPECT_FALSE(a.nextSummary());
    for (uint64_t id = 1; id <= 50; ++id) a.onConnect(id, "10.0.0.9", t);  // each past 3 takes its own oldest
    a.onAuthFailure("10.0.0.9", t);
    EXPECT_FALSE(a.summaryLine(t + 5s));  // the interval has not ended
    ASSERT_TRUE(a.nextSummary());
    EXPECT_EQ(*a.nextSummary(), t + 10s);
    auto line = a.summaryLine(t + 10s);
    ASSERT_TRUE(line);
    EXPECT_NE(line->find("50 connections"), std::string::npos) << *line;
    EXPECT_NE(line->find("47 evicted for a newcomer"), std::string::npos) << *line;
    EXPECT_NE(line->find("1 failed authentications (most from 10.0.0.9: 1)"), std::string::npos) << *line;
    EXPECT_EQ(line->find('\n'), std::string::npos);
    EXPECT_FALSE(a.summaryLine(t + 30s));  // a new interval starts with the next event
    // Only successful handshakes: no line.
    a.onPendingEnded(1, Admission::End::Authenticated);
    a.onConnect(100, "10.0.0.1", t + 31s);
    a.onPendingEnded(100, Admission::End::Authenticated);
    EXPECT_FALSE(a.summaryLine(t + 45s));
}

TEST(Admission, PerSourceRecordsStayBounded) {
    Admission a(small());
    TP t{};
    for (uint64_t id = 1; id <= 1000; ++id) {
        const std::string src = "10.1." + std::to_string(id / 256) + "." + std::to_string(id % 256);
        a.onConnect(id, src, t);
        a.onAuthFailure(src, t);
        a.onPendingEnded(id, Admission::End::FailedAuth);
    }
    EXPECT_LE(a.sourcesKept(), 16u);
    EXPECT_EQ(a.pending(), 0u);
}

TEST(Admission, SourceKeyGroupsAnIpv6SlashSixtyFourAndUnmapsIpv4) {
    EXPECT_EQ(Admission::sourceKey("127.0.0.1"), "127.0.0.1");
    EXPECT_EQ(Admission::sourceKey("::ffff:10.1.2.3"), "10.1.2.3");
    EXPECT_EQ(Admission::sourceKey("2001:db8:1:2:aaaa::1"), "2001:db8:1:2::/64");
    EXPECT_EQ(Admission::sourceKey("2001:db8:1:2:bbbb::7"), Admission::sourceKey("2001:db8:1:2::9"));
    EXPECT_NE(Admission::sourceKey("2001:db8:1:3::1"), Admission::sourceKey("2001:db8:1:2::1"));
}

}  // namespace
}  // namespace rtpm::server
