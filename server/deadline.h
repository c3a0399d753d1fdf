// The frame deadline: how long the oldest frame in flight waits for its data, adapted to the
// frame time the master measures, so a frozen client costs a few frame times, not 10 s a frame.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>

namespace rtpm::server {

/// How FrameDeadline chooses a deadline (rtpm-server --deadline-ms).
struct DeadlinePolicy {
    /// A fixed deadline (--deadline-ms N); nullopt = adaptive (the default, --deadline-ms auto).
    std::optional<std::chrono::milliseconds> fixed;
    /// Adaptive: multiple × the median of the last `window` measured frame times, clamped to
    /// [floor, ceiling]. The floor keeps scheduling jitter on a loaded machine from cutting frames
    /// short; the ceiling is the old fixed default, so nothing waits longer than it used to.
    double multiple = 4.0;
    std::chrono::milliseconds floor{1000};
    std::chrono::milliseconds ceiling{10000};
    size_t window = 15;
    /// Below this many measurements the ceiling applies (clients are still loading scenes).
    size_t minSamples = 3;
};

/// What a frame costs its clients, as far as the deadline is concerned. The two differ by an order
/// of magnitude and alternate as a person moves and stops, so each keeps its own measurements:
/// a walkthrough frame right after a hundred cheap converging frames must not get their deadline.
enum class FrameCost : uint8_t {
    Retraced,    ///< every pixel traced again (interaction, accumulate, walkthrough)
    Converging,  ///< a still progressive frame: one new photon batch gathered at kept records
};

/// Measures frame times and answers the deadline of each new frame. Pure: no clock, no sockets
/// (the master passes the durations it measured). Not thread-safe.
class FrameDeadline {
public:
    explicit FrameDeadline(DeadlinePolicy policy = {});

    /// A frame of kind `cost` completed (every set and Stats arrived) `took` after it became the
    /// oldest frame in flight — the time a deadline measures. Frames retired at their deadline
    /// are not measured (their time is unknown, only bounded below). Cost O(window log window).
    void completed(std::chrono::nanoseconds took, FrameCost cost = FrameCost::Retraced);

    /// Deadline for a frame of kind `cost` about to begin. `costUnknown`: its cost cannot be
    /// predicted from the frames before (first frame of an epoch, sets that changed owner, new
    /// settings — clients load scenes, build maps or shoot more) or it must not be cut short
    /// (the last frame of a finite run is the image written): the ceiling. So is a kind with
    /// fewer than `minSamples` measurements. Otherwise the adaptive value from that kind's frames.
    std::chrono::milliseconds forFrame(bool costUnknown, FrameCost cost = FrameCost::Retraced) const;

    /// Median of the measured frame times of one kind (zero before the first).
    std::chrono::nanoseconds median(FrameCost cost = FrameCost::Retraced) const;
    bool adaptive() const { return !policy_.fixed.has_value(); }
    const DeadlinePolicy& policy() const { return policy_; }

private:
    const std::deque<std::chrono::nanoseconds>& samples(FrameCost c) const { return samples_[size_t(c)]; }

    DeadlinePolicy policy_;
    std::deque<std::chrono::nanoseconds> samples_[2];  // indexed by FrameCost
};

}  // namespace rtpm::server
