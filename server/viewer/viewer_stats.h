// The viewer's lag and cost figures: what viewers were shown how late, and the CPU it took.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <mutex>
#include <utility>

namespace rtpm::server {

/// Lag and cost figures, for the summary line and tests.
struct ViewerReport {
    uint64_t framesPublished = 0;  ///< frames tone-mapped for at least one viewer
    uint64_t framesEncoded = 0;    ///< JPEGs made (one per frame and display setting)
    uint64_t framesShown = 0;      ///< acknowledged by a page (drawn)
    double meanLagFrames = 0.0;    ///< newest composed frame − drawn frame, when the page drew it
    uint64_t maxLagFrames = 0;
    double meanLatencyMs = 0.0;  ///< composed → drawn (acknowledged)
    double maxLatencyMs = 0.0;
    double cpuSeconds = 0.0;         ///< all of the below
    double toneMapCpuSeconds = 0.0;  ///< tone mapping (and auto exposure) on the output thread
    double threadCpuSeconds = 0.0;   ///< the viewer thread: JPEG, WebSocket and HTTP I/O, controls
    double statusCpuSeconds = 0.0;   ///< building the status JSON on the frame loop (chargeCpu)
};

/// CPU seconds the calling thread has used (CLOCK_THREAD_CPUTIME_ID).
double threadCpuSeconds();

/// Collects the ViewerReport's figures from the output thread, the viewer thread and the frame
/// loop. Thread-safe (one mutex, held for a few additions).
class ViewerStats {
public:
    using Clock = std::chrono::steady_clock;

    /// Frame `frame` was composed at `now` (the newest frame, from which lag is counted).
    void composed(uint64_t frame, Clock::time_point now);
    /// A frame was tone-mapped for viewers, costing `toneMapCpuSeconds` of the output thread.
    void published(double toneMapCpuSeconds);
    /// A JPEG was made.
    void encoded();
    /// A page acknowledged (drew) frame `frame` at `now`.
    void shown(uint64_t frame, Clock::time_point now);
    /// `seconds` of another thread's CPU spent for viewers (building the status).
    void chargeStatus(double seconds);
    /// The viewer thread ended, having used `cpuSeconds`.
    void threadEnded(double cpuSeconds);
    ViewerReport report() const;

private:
    mutable std::mutex mu_;
    ViewerReport r_;  // counts, maxima and CPU; the means are made in report()
    double lagSum_ = 0.0, latencySum_ = 0.0;
    uint64_t newestFrame_ = 0;
    std::deque<std::pair<uint64_t, Clock::time_point>>
        composedAt_;  // the last frames' composition times
};

}  // namespace rtpm::server
