// Per-frame records of the frame loop: data, Stats, the slowest client, the pace of the run.
#include "server/frame_ledger.h"

#include <algorithm>
#include <chrono>

namespace rtpm::server {

namespace {

/// Frames over which the per-frame fps figure is averaged.
constexpr size_t kFpsWindow = 8;

}  // namespace

void FrameLedger::start(TimePoint now) {
    started_ = true;
    startTime_ = now;
}

void FrameLedger::began(uint64_t frame, proto::FrameMode mode, bool still, uint32_t epoch,
                        std::vector<ClientId> owners, uint32_t passBatches, uint32_t passPeriod) {
    FrameInfo& info = frames_[frame];
    info.mode = mode;
    info.still = still;
    info.epoch = epoch;
    info.owners = std::move(owners);
    info.passBatches = passBatches;
    info.passPeriod = passPeriod;
}

void FrameLedger::addData(proto::FrameData&& fd, size_t wireBytes) {
    FrameInfo& info = frames_[fd.frame];
    info.bytes += wireBytes;
    info.data.push_back(std::move(fd));
}

FrameLedger::StatsOf FrameLedger::addStats(ClientId client, const std::string& name, const proto::Stats& st) {
    FrameInfo& info = frames_[st.frame];
    info.photonsStored += st.photonsStored;
    const auto sets = static_cast<uint32_t>(std::count(info.owners.begin(), info.owners.end(), client));
    info.setsReported += sets;
    lastStats_[client] = st;
    if (st.frameMs > info.slowestMs) {
        info.slowestMs = st.frameMs;
        info.slowestStats = st;
        info.slowest = std::to_string(client) + ":" + name;
    }
    return {info.mode, sets, info.passPeriod};
}

const proto::Stats* FrameLedger::lastStats(ClientId client) const {
    auto it = lastStats_.find(client);
    return it == lastStats_.end() ? nullptr : &it->second;
}

// Frames often retire in pairs (pipelining): a rate over the last few frames says more than the
// gap to the previous one.
double FrameLedger::fps(TimePoint now) {
    shownTimes_.push_back(now);
    if (shownTimes_.size() > kFpsWindow + 1) shownTimes_.pop_front();
    const double span =
        std::chrono::duration<double>(now - (shownTimes_.size() > 1 ? shownTimes_.front() : startTime_)).count();
    const double frames = shownTimes_.size() > 1 ? double(shownTimes_.size() - 1) : 1.0;
    return span > 0 ? frames / span : 0.0;
}

std::pair<OutputJob, ViewerFrame> FrameLedger::retire(const RetiredFrame& r, TimePoint now, uint32_t setCount) {
    FrameInfo info = std::move(frames_[r.frame]);
    frames_.erase(r.frame);
    OutputJob job;
    job.frame = r.frame;
    job.mode = info.mode;
    job.fps = fps(now);
    job.bytes = info.bytes;
    job.photonsPerSet = info.setsReported ? double(info.photonsStored) / double(info.setsReported) : 0.0;
    job.slowest = info.slowest;
    job.slowestMs = std::max(0.0f, info.slowestMs);
    job.slowestPhotonMs = info.slowestStats.photonMs;
    job.slowestEyeMs = info.slowestStats.renderMs;
    job.slowestEncodeMs = info.slowestStats.encodeMs;
    job.arrived = r.arrived.size();
    job.setCount = setCount;
    job.deadlineHit = r.deadlineHit;
    job.owners = std::move(info.owners);
    uint32_t passes = UINT32_MAX;
    CausticErrorSums error;
    for (const proto::FrameData& d : info.data) {
        passes = std::min(passes, d.passes);
        error += CausticErrorSums{d.errorSigma, d.errorRadiance, d.errorPixels, d.errorBatches};
    }
    // Only a frame every set arrived for says how the whole image stands.
    job.errorEstimate = r.missing.empty() ? causticErrorEstimate(error) : 0.0;
    job.estimateBatches = r.missing.empty() ? error.batches : 0.0;
    job.passBatches = info.passBatches;
    job.passPeriod = info.passPeriod;
    job.cameraStill = info.still;
    job.data = std::move(info.data);
    ViewerFrame shown{r.frame,        info.epoch, info.mode,  job.fps,    job.photonsPerSet, info.slowestStats,
                      info.slowest,   job.arrived, job.owners, passes == UINT32_MAX ? 0u : passes,
                      job.errorEstimate, info.passBatches};
    ++counts_.framesShown;
    if (!r.missing.empty()) ++counts_.framesIncomplete;
    counts_.seconds = std::chrono::duration<double>(now - startTime_).count();
    return {std::move(job), std::move(shown)};
}

}  // namespace rtpm::server
