// JPEG encoding of the tone-mapped frames viewers wait for.
#include "server/viewer/viewer_frames.h"

#include <algorithm>
#include <exception>

namespace rtpm::server {

ViewerFrames::ViewerFrames(int jpegQuality, std::function<void(const std::string&)> log,
                           ViewerStats& stats)
    : jpeg_(jpegQuality), log_(std::move(log)), stats_(stats) {}

bool ViewerFrames::encode(FrameFeed& feed, const FrameFeed::Waiting& waiting) {
    work_.clear();
    feed.take(waiting, work_);
    if (work_.empty()) return false;
    for (auto& [k, p] : work_) {
        EncodedFrame& e = latest_[k];
        e.message.resize(8);
        for (int i = 0; i < 8; ++i) e.message[size_t(i)] = char((p.frame >> (8 * i)) & 0xff);
        try {
            jpeg_.encodeInto(p.rgb, p.width, p.height, e.message, 8);
            e.frame = p.frame;
        } catch (const std::exception& ex) {
            log_(std::string("viewer: ") + ex.what());
            e.frame = UINT64_MAX;
        }
        feed.recycle(std::move(p.rgb));
        stats_.encoded();
    }
    return true;
}

const EncodedFrame* ViewerFrames::latest(const DisplayKey& key) const {
    auto it = latest_.find(key);
    return it == latest_.end() ? nullptr : &it->second;
}

void ViewerFrames::retain(const std::vector<DisplayKey>& inUse) {
    for (auto it = latest_.begin(); it != latest_.end();)
        it = std::find(inUse.begin(), inUse.end(), it->first) != inUse.end() ? std::next(it)
                                                                             : latest_.erase(it);
}

}  // namespace rtpm::server
