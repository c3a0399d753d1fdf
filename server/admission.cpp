// Pre-authentication admission: per-source and overall pending budgets, fair-share eviction,
// failed-authentication allowance (a token bucket per source) and the interval summary line.
#include "server/admission.h"

#include <arpa/inet.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

namespace rtpm::server {

Admission::Admission(AdmissionLimits limits) : limits_(limits) {
    limits_.maxPending = std::max<size_t>(1, limits_.maxPending);
    limits_.maxPendingPerSource = std::clamp<size_t>(limits_.maxPendingPerSource, 1, limits_.maxPending);
    limits_.maxSources = std::max(limits_.maxSources, limits_.maxPending + 1);
}

std::string Admission::sourceKey(const std::string& address) {
    in6_addr a6{};
    if (inet_pton(AF_INET6, address.c_str(), &a6) != 1) return address;  // IPv4 (or unparsable: as is)
    static const uint8_t kMapped[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
    char text[INET6_ADDRSTRLEN] = {};
    if (std::memcmp(a6.s6_addr, kMapped, sizeof kMapped) == 0) {
        in_addr a4{};
        std::memcpy(&a4, a6.s6_addr + 12, 4);
        return inet_ntop(AF_INET, &a4, text, sizeof text) ? std::string(text) : address;
    }
    std::memset(a6.s6_addr + 8, 0, 8);
    return inet_ntop(AF_INET6, &a6, text, sizeof text) ? std::string(text) + "/64" : address;
}

void Admission::refill(Source& s, TimePoint now) const {
    const double seconds = std::chrono::duration<double>(now - s.refilled).count();
    if (seconds > 0) {
        s.allowance = std::min(limits_.failureBurst, s.allowance + seconds * limits_.failureRefillPerSecond);
        s.refilled = now;
    }
}

Admission::Source& Admission::source(const std::string& key, TimePoint now) {
    auto it = sources_.find(key);
    if (it == sources_.end()) {
        if (sources_.size() >= limits_.maxSources) forgetIdleSources(now);
        Source s;
        s.allowance = limits_.failureBurst;
        s.refilled = now;
        it = sources_.emplace(key, std::move(s)).first;
    }
    refill(it->second, now);
    return it->second;
}

void Admission::forgetIdleSources(TimePoint now) {
    // First those that hold nothing: no pending slot, a full allowance.
    for (auto it = sources_.begin(); it != sources_.end();) {
        refill(it->second, now);
        if (it->second.pending.empty() && it->second.allowance >= limits_.failureBurst) it = sources_.erase(it);
        else ++it;
    }
    if (sources_.size() < limits_.maxSources) return;
    // Then every source without a pending connection (their failure history is lost: bounded memory wins).
    for (auto it = sources_.begin(); it != sources_.end();)
        it = it->second.pending.empty() ? sources_.erase(it) : std::next(it);
}

double Admission::decayed(const Source& s, TimePoint now) {
    const double seconds = std::chrono::duration<double>(now - s.counted).count();
    return seconds > 0 ? s.recentConnections * std::exp(-seconds / 10.0) : s.recentConnections;
}

void Admission::count(uint64_t AdmissionCounts::*field) {
    ++(interval_.*field);
    ++(totals_.*field);
}

size_t Admission::pendingFrom(const std::string& key) const {
    auto it = sources_.find(key);
    return it == sources_.end() ? 0 : it->second.pending.size();
}

std::string Admission::rateLimitText(const std::string& key, const Source& s) const {
    const double wait = limits_.failureRefillPerSecond > 0 ? (1.0 - s.allowance) / limits_.failureRefillPerSecond : 60.0;
    return "too many failed authentications from " + key + "; retry in " +
           std::to_string(std::max(1, static_cast<int>(std::ceil(wait)))) + " s";
}

std::optional<std::string> Admission::refuseAttempt(const std::string& key, TimePoint now) {
    Source& s = source(key, now);
    if (s.allowance >= 1.0) return std::nullopt;
    count(&AdmissionCounts::refusedRateLimited);
    return rateLimitText(key, s);
}

Admission::Verdict Admission::onConnect(uint64_t id, const std::string& key, TimePoint now,
                                        const SentBytes& sentBytes) {
    if (!intervalStart_) intervalStart_ = now;
    count(&AdmissionCounts::connections);
    Verdict v;
    Source& s = source(key, now);
    s.recentConnections = decayed(s, now) + 1.0;
    s.counted = now;
    if (s.allowance < 1.0) {
        v.decision = AdmissionDecision::RefuseRateLimited;
        v.text = rateLimitText(key, s);
        count(&AdmissionCounts::refusedRateLimited);
        return v;
    }
    if (s.pending.size() >= limits_.maxPendingPerSource) {
        // The source's own oldest idle slot (the newcomer may be a real client sharing the
        // address of an idle flood); refused when every one of them has made progress.
        v.evict = oldestIdle(s, sentBytes);
        if (!v.evict) {
            v.decision = AdmissionDecision::RefuseCapacity;
            v.text = "too many handshakes in progress from " + key + " (" + std::to_string(s.pending.size()) +
                     "); retry later";
            count(&AdmissionCounts::refusedCapacity);
            return v;
        }
        onPendingEnded(*v.evict, End::Evicted);
    } else if (pendingById_.size() >= limits_.maxPending) {
        // Fair share: the oldest idle slot of a source holding at least two more than the
        // newcomer's, the one connecting most often (the flooder) among them.
        std::optional<uint64_t> victim;
        double biggestRate = -1.0;
        for (auto& [k, other] : sources_) {
            if (other.pending.size() < s.pending.size() + 2) continue;
            const auto idle = oldestIdle(other, sentBytes);
            if (!idle) continue;
            const double rate = decayed(other, now);
            if (rate > biggestRate) {
                victim = idle;
                biggestRate = rate;
            }
        }
        if (!victim) {
            v.decision = AdmissionDecision::RefuseCapacity;
            v.text = "the server has " + std::to_string(pendingById_.size()) + " handshakes in progress; retry later";
            count(&AdmissionCounts::refusedCapacity);
            return v;
        }
        v.evict = victim;
        onPendingEnded(*v.evict, End::Evicted);
    }
    s.pending.push_back(id);
    pendingById_[id] = Pending{key};
    return v;
}

std::optional<uint64_t> Admission::oldestIdle(const Source& s, const SentBytes& sentBytes) const {
    std::optional<uint64_t> started;  // the oldest idle one whose first bytes are in
    for (uint64_t id : s.pending) {
        auto it = pendingById_.find(id);
        if (it == pendingById_.end() || it->second.progressed) continue;
        if (!sentBytes || !sentBytes(id)) return id;
        if (!started) started = id;
    }
    return started;
}

void Admission::onProgress(uint64_t id) {
    auto it = pendingById_.find(id);
    if (it != pendingById_.end()) it->second.progressed = true;
}

void Admission::onPendingEnded(uint64_t id, End how) {
    auto it = pendingById_.find(id);
    if (it == pendingById_.end()) return;
    auto src = sources_.find(it->second.source);
    if (src != sources_.end()) {
        auto& q = src->second.pending;
        q.erase(std::remove(q.begin(), q.end(), id), q.end());
    }
    pendingById_.erase(it);
    switch (how) {
        case End::Authenticated: count(&AdmissionCounts::admitted); break;
        case End::TimedOut: count(&AdmissionCounts::timedOut); break;
        case End::ProtocolError: count(&AdmissionCounts::protocolErrors); break;
        case End::Evicted: count(&AdmissionCounts::evicted); break;
        case End::FailedAuth:  // counted by onAuthFailure
        case End::Closed: break;
    }
}

std::chrono::milliseconds Admission::onAuthFailure(const std::string& key, TimePoint now) {
    if (!intervalStart_) intervalStart_ = now;
    count(&AdmissionCounts::failedAuth);
    Source& s = source(key, now);
    s.allowance = std::max(0.0, s.allowance - 1.0);
    ++s.failuresInInterval;
    return limits_.failureDelay;
}

std::optional<Admission::TimePoint> Admission::nextSummary() const {
    if (!intervalStart_) return std::nullopt;
    return *intervalStart_ + limits_.logInterval;
}

std::optional<std::string> Admission::summaryLine(TimePoint now, bool final) {
    if (!intervalStart_ || (!final && now < *intervalStart_ + limits_.logInterval)) return std::nullopt;
    const AdmissionCounts c = interval_;
    const double seconds = std::chrono::duration<double>(now - *intervalStart_).count();
    // The addresses that failed most this interval (at most three), then reset the interval.
    std::vector<std::pair<uint64_t, std::string>> failing;
    for (auto& [k, s] : sources_) {
        if (s.failuresInInterval) failing.emplace_back(s.failuresInInterval, k);
        s.failuresInInterval = 0;
    }
    interval_ = AdmissionCounts{};
    intervalStart_.reset();
    if (!c.any()) return std::nullopt;
    std::sort(failing.rbegin(), failing.rend());
    char head[96];
    std::snprintf(head, sizeof head, "admission in the last %.0f s: ", seconds);
    std::string line = head + std::to_string(c.connections) + " connections, " + std::to_string(c.admitted) +
                       " authenticated, " + std::to_string(c.refusedCapacity) + " refused (capacity), " +
                       std::to_string(c.refusedRateLimited) + " refused (rate limit), " + std::to_string(c.evicted) +
                       " evicted for a newcomer, " + std::to_string(c.timedOut) + " handshakes timed out, " +
                       std::to_string(c.protocolErrors) + " protocol errors, " + std::to_string(c.failedAuth) +
                       " failed authentications";
    if (!failing.empty()) {
        line += " (most from";
        for (size_t i = 0; i < failing.size() && i < 3; ++i)
            line += (i ? ", " : " ") + failing[i].second + ": " + std::to_string(failing[i].first);
        line += ")";
    }
    return line;
}

}  // namespace rtpm::server
