// What the frame loop learns about each frame in flight (its data, the clients' Stats, the
// slowest client) and about the run's pace, and what it hands on when a frame retires.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/render/progressive.h"
#include "proto/messages.h"
#include "server/assignment.h"
#include "server/frame_assembler.h"
#include "server/image_output.h"
#include "server/viewer/viewer_model.h"

namespace rtpm::server {

/// Totals of the frame loop over a run.
struct FrameCounts {
    uint64_t framesShown = 0;
    uint64_t framesIncomplete = 0;  ///< shown at their deadline or with sets nobody rendered
    double seconds = 0.0;           ///< first client joined → last frame shown
    uint64_t bytesReceived = 0;     ///< FrameData wire bytes
    uint64_t clientsEvicted = 0;
    bool imageWriteFailed = false;  ///< an image could not be written: the run must not end with 0
};

/// Per-frame records, keyed by frame number, from FrameBegin to retirement. Pure (times are
/// passed in); lives on the I/O thread.
class FrameLedger {
public:
    /// Frames start once enough clients joined: the run's clock starts then.
    void start(TimePoint now);
    bool started() const { return started_; }

    /// Frame `frame` began in `mode` of `epoch` (`still`: at the previous frame's camera), set s
    /// asked of owners[s].
    void began(uint64_t frame, proto::FrameMode mode, bool still, uint32_t epoch, std::vector<ClientId> owners,
               uint32_t passBatches, uint32_t passPeriod);
    /// Data of a frame in flight (already checked).
    void addData(proto::FrameData&& data, size_t wireBytes);
    /// What a client's Stats belonged to: the frame's mode and the sets the client was asked for.
    struct StatsOf {
        proto::FrameMode mode = proto::FrameMode::Accumulate;
        uint32_t sets = 0;
        uint32_t passPeriod = 1;  ///< the frame's FrameBegin.passPeriod
    };
    /// Accepted Stats of `client` (named `name` in logs).
    StatsOf addStats(ClientId client, const std::string& name, const proto::Stats& stats);
    /// The last Stats of `client`, or null.
    const proto::Stats* lastStats(ClientId client) const;
    void clientLeft(ClientId client) { lastStats_.erase(client); }

    /// Frame `r.frame` retires at `now`: its output job (the data moved in) and what the viewer
    /// is told. Counts it as shown.
    std::pair<OutputJob, ViewerFrame> retire(const RetiredFrame& r, TimePoint now, uint32_t setCount);

    FrameCounts& counts() { return counts_; }
    const FrameCounts& counts() const { return counts_; }

private:
    struct FrameInfo {
        proto::FrameMode mode = proto::FrameMode::Accumulate;
        bool still = false;
        uint32_t epoch = 0;
        uint64_t bytes = 0;
        uint64_t photonsStored = 0;
        uint64_t setsReported = 0;  // sets of the clients whose Stats arrived
        float slowestMs = -1.0f;
        std::string slowest = "-";
        proto::Stats slowestStats;
        std::vector<ClientId> owners;  // who was asked for each set
        uint32_t passBatches = 1;
        uint32_t passPeriod = 1;
        std::vector<proto::FrameData> data;
    };

    /// Frames per second over the last few frames shown.
    double fps(TimePoint now);

    std::map<uint64_t, FrameInfo> frames_;
    std::map<ClientId, proto::Stats> lastStats_;
    std::deque<TimePoint> shownTimes_;  // retirement times of the last kFpsWindow + 1 frames
    TimePoint startTime_{};
    bool started_ = false;
    FrameCounts counts_;
};

}  // namespace rtpm::server
