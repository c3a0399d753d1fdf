// Composed frames on their way to viewers: the frame-rate cap, tone mapping per display setting
// (on the output thread) and the handover of the tone-mapped frames to the viewer thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "common/image/frame_image.h"
#include "server/viewer/viewer_command.h"
#include "server/viewer/viewer_stats.h"

namespace rtpm::server {

/// How a viewer shows frames: which layer, at which exposure. Frames are tone-mapped and encoded
/// once per display setting in use, however many viewers share it.
struct DisplayKey {
    ViewerLayer layer = ViewerLayer::Final;
    float exposure = 0.0f;
    bool operator<(const DisplayKey& o) const {
        return layer != o.layer ? layer < o.layer : exposure < o.exposure;
    }
    bool operator==(const DisplayKey&) const = default;
};

/// A frame tone-mapped to 8-bit sRGB for one display setting, not yet encoded.
struct ToneMapped {
    uint64_t frame = 0;
    int width = 0, height = 0;
    std::vector<uint8_t> rgb;  ///< from and back to the feed's pool (FrameFeed::recycle)
};

/// The output thread tone-maps (publish) at most maxFps frames a second, and only while some
/// display setting is wanted; the viewer thread says which settings are wanted (setWanted) and
/// takes the frames it can send (take). Latest wins: a newer frame replaces an untaken one.
/// publish() runs on one thread at a time; the other calls may come from any other thread.
class FrameFeed {
public:
    using Clock = std::chrono::steady_clock;
    using Waiting = std::function<bool(const DisplayKey&, uint64_t frame)>;

    /// `maxFps` 0 = every frame. `wake` is called (on the output thread) when frames are ready
    /// to be taken and the previous wake has not yet been answered by a take().
    FrameFeed(double maxFps, ViewerStats& stats, std::function<void()> wake);

    /// Output thread: frame `frame` was composed into `image`. Tone-maps it for every wanted
    /// display setting, unless the frame-rate cap holds it back. Cost: one mutex when nothing is
    /// wanted; else one tone map per wanted setting.
    void publish(uint64_t frame, const FrameImage& image);
    /// The display settings viewers use; untaken frames of the others are dropped.
    void setWanted(std::vector<DisplayKey> wanted);
    /// Moves into `out` the untaken frames for which `waiting(setting, frame)` (called under the
    /// feed's mutex) is true; the others stay until replaced or taken.
    void take(const Waiting& waiting, std::vector<std::pair<DisplayKey, ToneMapped>>& out);
    /// Gives a taken frame's buffer back for reuse.
    void recycle(std::vector<uint8_t>&& rgb);

private:
    struct Exposure {
        float scale = 1.0f;
        uint64_t frame = 0;
        bool valid = false;
    };

    const double maxFps_;
    ViewerStats& stats_;
    const std::function<void()> wake_;

    // Output thread only.
    std::vector<float> scaleScratch_;  // displayScale's sample
    std::vector<DisplayKey> wantedCopy_;
    std::map<DisplayKey, Exposure> exposures_;  // last automatic exposure per display setting

    // Under mu_.
    std::mutex mu_;
    std::vector<DisplayKey> wanted_;            // display settings some viewer uses
    std::map<DisplayKey, ToneMapped> pending_;  // tone-mapped, not yet taken (latest wins)
    std::vector<std::vector<uint8_t>> pool_;    // 8-bit frame buffers for reuse
    bool woken_ = false;                        // a wake is on its way, not yet answered by take()
    double capTokens_;                          // frame-rate cap
    Clock::time_point lastPublish_{};
};

}  // namespace rtpm::server
