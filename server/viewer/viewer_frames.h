// The viewer thread's JPEGs: the newest encoded frame of each display setting in use.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "server/viewer/frame_feed.h"
#include "server/viewer/jpeg_encoder.h"
#include "server/viewer/viewer_stats.h"

namespace rtpm::server {

/// One display setting's newest encoded frame, as sent: the frame number (8 bytes, little
/// endian) then the JPEG. `frame` is UINT64_MAX while there is none (or its encoding failed).
struct EncodedFrame {
    uint64_t frame = UINT64_MAX;
    std::string message;  ///< the buffer is reused from frame to frame
};

/// Encodes the frames the feed hands over, once per frame and display setting. Viewer thread
/// only (one JPEG compressor, reused).
class ViewerFrames {
public:
    /// `log` takes encoding failures (a line each).
    ViewerFrames(int jpegQuality, std::function<void(const std::string&)> log, ViewerStats& stats);

    /// Takes from `feed` the frames `waiting` wants and encodes them; true if any was taken.
    bool encode(FrameFeed& feed, const FrameFeed::Waiting& waiting);
    /// The newest frame of `key`, or null if none was encoded.
    const EncodedFrame* latest(const DisplayKey& key) const;
    /// Forgets the frames of display settings not in `inUse`.
    void retain(const std::vector<DisplayKey>& inUse);

private:
    JpegEncoder jpeg_;
    std::function<void(const std::string&)> log_;
    ViewerStats& stats_;
    std::map<DisplayKey, EncodedFrame> latest_;
    std::vector<std::pair<DisplayKey, ToneMapped>> work_;  // being encoded (capacity reused)
};

}  // namespace rtpm::server
