// The viewer's frame feed: frame-rate cap, automatic exposure, tone mapping, latest-wins handover.
#include "server/viewer/frame_feed.h"

#include <algorithm>

#include "common/image/tone_map.h"

namespace rtpm::server {

namespace {

/// Frames the frame-rate cap lets through at once (see publish).
constexpr double kCapBurst = 2.0;

/// Frames between two estimates of the automatic exposure (~0.13 s at 30 fps).
constexpr uint64_t kExposureEvery = 4;

}  // namespace

FrameFeed::FrameFeed(double maxFps, ViewerStats& stats, std::function<void()> wake)
    : maxFps_(maxFps), stats_(stats), wake_(std::move(wake)), capTokens_(kCapBurst) {}

void FrameFeed::publish(uint64_t frame, const FrameImage& image) {
    const auto now = Clock::now();
    stats_.composed(frame, now);
    {
        std::lock_guard lock(mu_);
        if (wanted_.empty()) return;
        if (maxFps_ > 0.0) {
            // Frame-rate cap: a token bucket filled at maxFps a second holding at most
            // kCapBurst frames. The master retires frames in bursts (pipelining: often two
            // at once), so a plain minimum interval would drop one of each pair of a master
            // running at the cap's rate; the bucket passes them and holds the average.
            const double dt = std::chrono::duration<double>(now - lastPublish_).count();
            lastPublish_ = now;
            capTokens_ = std::min(kCapBurst, capTokens_ + dt * maxFps_);
            if (capTokens_ < 1.0) return;
            capTokens_ -= 1.0;
        }
        wantedCopy_ = wanted_;
    }
    const double cpu0 = threadCpuSeconds();
    for (const DisplayKey& k : wantedCopy_) {
        const std::vector<float>& buf = k.layer == ViewerLayer::Direct    ? image.direct()
                                        : k.layer == ViewerLayer::Caustic ? image.causticFiltered()
                                        : k.layer == ViewerLayer::CausticUnfiltered
                                            ? image.caustic()
                                            : image.final();
        ToneMapped p;
        p.frame = frame;
        p.width = image.width();
        p.height = image.height();
        {
            std::lock_guard lock(mu_);
            if (!pool_.empty()) {
                p.rgb = std::move(pool_.back());
                pool_.pop_back();
            }
        }
        p.rgb.resize(buf.size());
        // Auto exposure from every 17th pixel (a stride prime to common widths: a lattice,
        // not a few columns), ~18 k samples at 640×480, renewed every kExposureEvery frames:
        // its strided reads cost half as much as the tone map itself.
        Exposure& e = exposures_[k];
        if (!e.valid || frame < e.frame || frame - e.frame >= kExposureEvery) {
            e.scale = displayScale(buf, k.exposure, 17, scaleScratch_);
            e.frame = frame;
            e.valid = true;
        }
        toneMapSrgb8(buf, e.scale, p.rgb);
        std::lock_guard lock(mu_);
        auto [it, fresh] = pending_.try_emplace(k);
        if (!fresh)
            pool_.push_back(
                std::move(it->second.rgb));  // latest wins: the untaken older frame is dropped
        it->second = std::move(p);
    }
    for (auto it = exposures_.begin(); it != exposures_.end();)  // bounded by the settings in use
        it = std::find(wantedCopy_.begin(), wantedCopy_.end(), it->first) == wantedCopy_.end()
                 ? exposures_.erase(it)
                 : std::next(it);
    stats_.published(threadCpuSeconds() - cpu0);
    bool wake = false;
    {
        std::lock_guard lock(mu_);
        wake = !woken_;
        woken_ = true;
    }
    if (wake) wake_();
}

void FrameFeed::setWanted(std::vector<DisplayKey> wanted) {
    std::lock_guard lock(mu_);
    wanted_ = std::move(wanted);
    for (auto it = pending_.begin(); it != pending_.end();) {
        if (std::find(wanted_.begin(), wanted_.end(), it->first) != wanted_.end()) {
            ++it;
            continue;
        }
        pool_.push_back(std::move(it->second.rgb));
        it = pending_.erase(it);
    }
}

void FrameFeed::take(const Waiting& waiting, std::vector<std::pair<DisplayKey, ToneMapped>>& out) {
    std::lock_guard lock(mu_);
    woken_ = false;
    for (auto it = pending_.begin(); it != pending_.end();) {
        if (!waiting(it->first, it->second.frame)) {
            ++it;
            continue;
        }
        out.emplace_back(it->first, std::move(it->second));
        it = pending_.erase(it);
    }
}

void FrameFeed::recycle(std::vector<uint8_t>&& rgb) {
    std::lock_guard lock(mu_);
    pool_.push_back(std::move(rgb));
}

}  // namespace rtpm::server
