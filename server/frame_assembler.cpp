// Frames in flight: arrival bookkeeping, in-order retirement, deadlines with an injected clock.
#include "server/frame_assembler.h"

#include <algorithm>

#include "common/core/check.h"

namespace rtpm::server {

const char* verdictName(Verdict v) {
    switch (v) {
        case Verdict::Accept: return "accepted";
        case Verdict::Late: return "late";
        case Verdict::NotSent: return "frame not sent to this client or already finished";
        case Verdict::NotAssigned: return "set not assigned to this client in that frame";
        case Verdict::Duplicate: return "set already received for that frame";
        case Verdict::StatsEarly: return "stats before all sets of that frame";
    }
    return "?";
}

FrameAssembler::FrameAssembler(uint32_t setCount, std::chrono::milliseconds deadline)
    : setCount_(setCount), deadline_(deadline) {}

void FrameAssembler::resize(uint32_t setCount) {
    RTPM_CHECK(frames_.empty());
    setCount_ = setCount;
}

FrameAssembler::Frame* FrameAssembler::findFrame(uint64_t frame) {
    for (Frame& f : frames_)
        if (f.frame == frame) return &f;
    return nullptr;
}

void FrameAssembler::beginFrame(uint64_t frame, const std::vector<ClientId>& owner, TimePoint now,
                                std::optional<std::chrono::milliseconds> deadline) {
    RTPM_CHECK(owner.size() == setCount_);
    RTPM_CHECK(frames_.empty() || frame > frames_.back().frame);
    Frame f;
    f.frame = frame;
    f.owner = owner;
    f.arrived.assign(setCount_, 0);
    f.begun = now;
    f.budget = deadline.value_or(deadline_);
    if (frames_.empty()) {
        f.oldestSince = now;
        f.deadline = now + f.budget;
    }
    for (uint32_t s = 0; s < setCount_; ++s) {
        ClientId c = owner[s];
        if (c == kNoClient) continue;
        ++f.pendingSets;
        clients_[c][frame].pendingSets.push_back(s);
        if (std::find(f.pendingStats.begin(), f.pendingStats.end(), c) == f.pendingStats.end())
            f.pendingStats.push_back(c);
    }
    frames_.push_back(std::move(f));
}

void FrameAssembler::probe(ClientId client, uint64_t frame) { clients_[client].try_emplace(frame); }

Verdict FrameAssembler::onFrameData(ClientId client, uint64_t frame, uint32_t set) {
    auto cit = clients_.find(client);
    if (cit == clients_.end()) return Verdict::NotSent;
    auto fit = cit->second.find(frame);
    if (fit == cit->second.end()) return Verdict::NotSent;
    ClientFrame& cf = fit->second;
    auto it = std::lower_bound(cf.pendingSets.begin(), cf.pendingSets.end(), set);
    if (it == cf.pendingSets.end() || *it != set) {
        bool done = std::find(cf.doneSets.begin(), cf.doneSets.end(), set) != cf.doneSets.end();
        return done ? Verdict::Duplicate : Verdict::NotAssigned;
    }
    cf.pendingSets.erase(it);
    cf.doneSets.push_back(set);
    Frame* f = findFrame(frame);
    if (!f) return Verdict::Late;
    // The set may have been given up already if the frame is in flight but was dropped for this
    // client (cannot happen: dropClient erases the client's entries); arrival is counted once.
    f->arrived[set] = 1;
    --f->pendingSets;
    return Verdict::Accept;
}

Verdict FrameAssembler::onStats(ClientId client, uint64_t frame) {
    auto cit = clients_.find(client);
    if (cit == clients_.end()) return Verdict::NotSent;
    auto fit = cit->second.find(frame);
    if (fit == cit->second.end()) return Verdict::NotSent;
    if (!fit->second.pendingSets.empty()) return Verdict::StatsEarly;
    cit->second.erase(fit);
    Frame* f = findFrame(frame);
    if (!f) return Verdict::Late;
    auto it = std::find(f->pendingStats.begin(), f->pendingStats.end(), client);
    if (it != f->pendingStats.end()) f->pendingStats.erase(it);
    misses_[client] = 0;
    return Verdict::Accept;
}

void FrameAssembler::dropClient(ClientId client) {
    auto cit = clients_.find(client);
    if (cit != clients_.end()) {
        for (auto& [frame, cf] : cit->second) {
            Frame* f = findFrame(frame);
            if (!f) continue;
            for (uint32_t s : cf.pendingSets) {
                f->dropped.push_back(s);
                --f->pendingSets;
            }
            auto it = std::find(f->pendingStats.begin(), f->pendingStats.end(), client);
            if (it != f->pendingStats.end()) f->pendingStats.erase(it);
        }
        clients_.erase(cit);
    }
    misses_.erase(client);
}

std::vector<RetiredFrame> FrameAssembler::takeReady(TimePoint now) {
    std::vector<RetiredFrame> out;
    while (!frames_.empty()) {
        Frame& f = frames_.front();
        bool complete = f.pendingSets == 0 && f.pendingStats.empty();
        bool expired = f.deadline && now >= *f.deadline;
        if (!complete && !expired) break;
        RetiredFrame r;
        r.frame = f.frame;
        r.deadlineHit = !complete;
        r.waited = now - f.oldestSince;
        for (uint32_t s = 0; s < setCount_; ++s) (f.arrived[s] ? r.arrived : r.missing).push_back(s);
        if (!complete) {
            // Everyone who still owes this frame anything was late; the client's own bookkeeping
            // stays so its late data is recognised (Verdict::Late) rather than called hostile.
            std::vector<ClientId> late = f.pendingStats;
            for (uint32_t s = 0; s < setCount_; ++s) {
                ClientId c = f.owner[s];
                if (c != kNoClient && !f.arrived[s] &&
                    std::find(f.dropped.begin(), f.dropped.end(), s) == f.dropped.end() &&
                    std::find(late.begin(), late.end(), c) == late.end())
                    late.push_back(c);
            }
            std::sort(late.begin(), late.end());
            for (ClientId c : late) ++misses_[c];
            r.late = std::move(late);
        }
        out.push_back(std::move(r));
        frames_.pop_front();
        if (!frames_.empty()) {
            Frame& next = frames_.front();
            next.oldestSince = std::max(now, next.begun);
            next.deadline = next.oldestSince + next.budget;
        }
    }
    return out;
}

std::optional<TimePoint> FrameAssembler::nextDeadline() const {
    if (frames_.empty()) return std::nullopt;
    return frames_.front().deadline;
}

size_t FrameAssembler::outstanding(ClientId client) const {
    auto it = clients_.find(client);
    return it == clients_.end() ? 0 : it->second.size();
}

uint32_t FrameAssembler::consecutiveMisses(ClientId client) const {
    auto it = misses_.find(client);
    return it == misses_.end() ? 0 : it->second;
}

}  // namespace rtpm::server
