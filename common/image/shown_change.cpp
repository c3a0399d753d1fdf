// ShownChange: the shown caustic's change since a sixth of the progression's photons
// (shown_change.h).
#include "common/image/shown_change.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "common/core/check.h"
#include "common/image/error_metrics.h"

namespace rtpm {

namespace {

/// n without its factors of two: frame b·2^k gives b.
uint64_t oddPart(uint64_t n) { return n >> std::countr_zero(n); }

}  // namespace

bool ShownChange::kept(uint64_t n) { return n != 0 && oddPart(n) < 8; }

bool ShownChange::keptLong(uint64_t n) { return n != 0 && (oddPart(n) == 1 || oddPart(n) == 3); }

double ShownChange::add(bool converging, uint32_t period, double work, std::span<const float> caustic, int width,
                        int height) {
    RTPM_CHECK(caustic.size() == size_t(width) * size_t(height) * 3);
    if (!converging || frame_ == 0 || width != width_ || height != height_) {
        width_ = width;
        height_ = height;
        frame_ = 0;
        figure_ = 0.0;
        figureWork_ = 0.0;
        images_.clear();
    }
    const uint64_t n = ++frame_;
    if (!kept(n) || !(work > 0.0) || !std::isfinite(work)) return figure_;
    // The baseline: the kept image with the least work in [tolerance / ratio, 1 / kBaselineMost]
    // of this one's, `period` frames back.
    const double half = 0.5 * work, least = kBaselineTolerance * work / kBaselineRatio;
    const Kept* base = nullptr;
    for (const Kept& k : images_)
        if (k.work <= work / kBaselineMost && k.work >= least && n - k.frame >= uint64_t(std::max<uint32_t>(period, 1)) &&
            (!base || k.work < base->work))
            base = &k;
    if (base) {
        const ErrorMetrics m = compareRgb(caustic, base->image, caustic, width, height);
        // base->work ≤ work / 3: the scale is at least √2.
        if (m.caustic.pixels > 0 && std::isfinite(m.caustic.relMae)) {
            const double change = m.caustic.relMae / std::sqrt(work / base->work - 1.0);
            // Falling no faster than photon noise from the last figure (shown_change.h).
            const double floor = figure_ > 0.0 && figureWork_ > 0.0 ? figure_ * std::sqrt(figureWork_ / work) : 0.0;
            figure_ = std::max(change, floor);
            figureWork_ = work;
        }
    }
    // Work never falls within a progression: no later frame takes a baseline below this one's
    // least, and below half of it only two images per doubling stay.
    std::erase_if(images_, [&](const Kept& k) {
        return k.work < least || (k.work < kBaselineTolerance * half && !keptLong(k.frame));
    });
    if (n >= firstBaseline_) images_.push_back(Kept{n, work, std::vector<float>(caustic.begin(), caustic.end())});
    return figure_;
}

}  // namespace rtpm
