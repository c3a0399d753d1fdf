// ShownChange: the shown caustic's change since half the progression's photons (shown_change.h).
#include "common/image/shown_change.h"

#include <algorithm>
#include <cmath>

#include "common/core/check.h"
#include "common/image/error_metrics.h"

namespace rtpm {

bool ShownChange::kept(uint64_t n) {
    if (n == 0) return false;
    while (n % 2 == 0) n /= 2;
    return n < 8;
}

double ShownChange::add(bool converging, uint32_t period, double work, std::span<const float> caustic, int width,
                        int height) {
    RTPM_CHECK(caustic.size() == size_t(width) * size_t(height) * 3);
    if (!converging || frame_ == 0 || width != width_ || height != height_) {
        width_ = width;
        height_ = height;
        frame_ = 0;
        figure_ = 0.0;
        images_.clear();
    }
    const uint64_t n = ++frame_;
    if (!kept(n) || !(work > 0.0) || !std::isfinite(work)) return figure_;
    // The half: the kept image with the most work at most half this one's, `period` frames back.
    const double half = 0.5 * work;
    const Kept* best = nullptr;
    for (const Kept& k : images_)
        if (k.work <= half && n - k.frame >= uint64_t(std::max<uint32_t>(period, 1)) && (!best || k.work > best->work))
            best = &k;
    if (best && best->work >= kHalfTolerance * half) {
        const ErrorMetrics m = compareRgb(caustic, best->image, caustic, width, height);
        if (m.caustic.pixels > 0 && std::isfinite(m.caustic.relMae)) figure_ = m.caustic.relMae;
    }
    // Work never falls within a progression: no later frame takes a half below this one's.
    std::erase_if(images_, [&](const Kept& k) { return k.work < kHalfTolerance * half; });
    images_.push_back(Kept{n, work, std::vector<float>(caustic.begin(), caustic.end())});
    return figure_;
}

}  // namespace rtpm
