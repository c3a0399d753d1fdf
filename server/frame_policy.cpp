// Frame-loop policy: epochs, modes, assignment, skips, eviction.
#include "server/frame_policy.h"

#include <algorithm>

#include "common/core/frame_mode.h"
#include "proto/bridge/bridge.h"

namespace rtpm::server {

namespace {

/// True when `a` gives every set to one of `clients` and each of them holds one at least.
bool covers(const Assignment& a, const std::vector<ClientId>& clients) {
    for (ClientId o : a.owner)
        if (std::find(clients.begin(), clients.end(), o) == clients.end()) return false;
    for (ClientId c : clients)
        if (a.countOf(c) == 0) return false;
    return true;
}

}  // namespace

FramePolicy::FramePolicy(uint32_t setCount, bool walkthrough, size_t pipeline, uint32_t evictAfter,
                         bool progressive, BalanceOptions balance)
    : setCount_(setCount), walkthrough_(walkthrough), pipeline_(pipeline), evictAfter_(evictAfter),
      progressive_(progressive), balance_(balance) {}

FramePlan FramePolicy::plan(uint64_t frame, bool edited, const std::vector<ClientId>& joinOrder,
                            const std::function<size_t(ClientId)>& outstanding, bool cameraMoved,
                            bool cameraStill, bool sceneEdited, bool relit) {
    for (ClientId id : joinOrder) state_.try_emplace(id);
    // The clients that take sets, in join order; when none does yet, every one does (nobody is
    // rendering for the joiners to wait behind).
    std::vector<ClientId> takers;
    for (ClientId id : joinOrder)
        if (state_[id].ready) takers.push_back(id);
    if (takers.empty()) {
        for (ClientId id : joinOrder) state_[id].ready = true;
        takers = joinOrder;
    }
    bool newEpoch = frame == 0;
    if (edited) {
        ++epoch_;
        newEpoch = true;
    }
    started_ = true;
    if (newEpoch) epochStart_ = frame;
    bool reassigned = false, balanced = false;
    if (newEpoch || assignment_.owner.size() != setCount_) {
        Assignment next = dealSets(setCount_, takers);
        // Every map restarts here, so the share carries over and may change for free by the
        // measured costs (server/balance.h: why only here). It carries over while the costs at
        // a new share are still being measured: dealing round-robin then would undo every move
        // one frame after it was made.
        if (newEpoch && balance_.enabled() && assignment_.owner.size() == setCount_ && covers(assignment_, takers)) {
            next = assignment_;
            if (auto b = balance_.propose(next, takers)) {
                next = std::move(*b);
                balanced = true;
            }
        }
        reassigned = newEpoch || next != assignment_;
        assignment_ = std::move(next);
        for (auto& [id, s] : state_) s.capped = false;
    } else if (clientsChanged_) {
        Assignment next = rebalance(assignment_, setCount_, takers);
        if (!movedSets(assignment_, next).empty()) {
            reassigned = true;
            for (auto& [id, s] : state_) s.capped = false;
        }
        assignment_ = std::move(next);
    }
    clientsChanged_ = false;
    bool allCapped = !takers.empty();
    for (ClientId id : takers)
        if (assignment_.countOf(id) > 0 && !state_[id].capped) allCapped = false;

    FramePlan p;
    p.frame = frame;
    p.epoch = epoch_;
    p.reassigned = reassigned;
    p.balanced = balanced;
    FrameFacts facts;
    facts.epochStart = frame == epochStart_;
    facts.edited = edited && sceneEdited;
    facts.relit = relit;
    facts.cameraMoved = cameraMoved;
    facts.cameraStill = cameraStill;
    facts.progressive = progressive_;
    facts.walkthrough = walkthrough_;
    facts.allCapped = allCapped;
    p.mode = bridge::toWire(decideFrameMode(facts));  // the clients render by it
    p.owners = assignment_.owner;
    for (ClientId& o : p.owners)
        if (o != kNoClient && outstanding(o) >= pipeline_) o = kNoClient;
    for (ClientId id : joinOrder)
        if (!state_[id].ready && outstanding(id) == 0) p.probes.push_back(id);
    for (ClientId id : takers) {
        std::vector<uint32_t> sets = assignment_.setsOf(id);
        if (sets.empty()) continue;
        if (outstanding(id) >= pipeline_) {
            ++state_[id].skips;
            continue;
        }
        p.sets.emplace(id, std::move(sets));
    }
    return p;
}

void FramePolicy::clientJoined(ClientId id) {
    state_[id].ready = !started_;
    clientsChanged_ = true;
}

bool FramePolicy::answered(ClientId id) {
    auto it = state_.find(id);
    if (it == state_.end() || it->second.ready) return false;
    it->second.ready = true;
    clientsChanged_ = true;
    return true;
}

void FramePolicy::clientLeft(ClientId id) {
    state_.erase(id);
    balance_.clientLeft(id);
    clientsChanged_ = true;
}

void FramePolicy::stats(ClientId id, proto::FrameMode mode, uint64_t photonsShot, uint32_t passPeriod) {
    ClientState& s = state_[id];
    // Only an Accumulate frame in which every set shoots asks for photons: Walkthrough frames
    // (camera moving) shoot none by design, and while the sets take turns a client may hold no
    // set whose turn it is; neither says anything about the cap.
    if (mode == proto::FrameMode::Accumulate && passPeriod <= 1) s.capped = photonsShot == 0;
    s.skips = 0;
}

std::vector<uint32_t> FramePolicy::tentativeSets(ClientId id, const std::vector<ClientId>& joinOrder) const {
    const Assignment a = started_ ? rebalance(assignment_, setCount_, joinOrder) : dealSets(setCount_, joinOrder);
    return a.setsOf(id);
}

std::vector<ClientId> FramePolicy::evictions(const std::vector<ClientId>& clients,
                                             const std::function<uint32_t(ClientId)>& misses) const {
    std::vector<ClientId> out;
    for (ClientId id : clients) {
        auto it = state_.find(id);
        const uint32_t skips = it == state_.end() ? 0 : it->second.skips;
        if (misses(id) >= evictAfter_ || skips >= evictAfter_) out.push_back(id);
    }
    return out;
}

}  // namespace rtpm::server
