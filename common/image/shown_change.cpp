// ShownChange: the shown caustic's change since half the progression's frames (shown_change.h).
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

double ShownChange::add(bool converging, uint32_t period, std::span<const float> caustic, int width, int height) {
    RTPM_CHECK(caustic.size() == size_t(width) * size_t(height) * 3);
    if (!converging || frame_ == 0 || width != width_ || height != height_) {
        width_ = width;
        height_ = height;
        frame_ = 0;
        figure_ = 0.0;
        images_.clear();
    }
    const uint64_t n = ++frame_;
    if (!kept(n)) return figure_;
    if (n >= 2 && n % 2 == 0 && n / 2 >= uint64_t(std::max<uint32_t>(period, 1))) {
        const auto half = std::find_if(images_.begin(), images_.end(), [&](const auto& i) { return i.first == n / 2; });
        if (half != images_.end()) {
            const ErrorMetrics m = compareRgb(caustic, half->second, caustic, width, height);
            if (m.caustic.pixels > 0 && std::isfinite(m.caustic.relMae)) figure_ = m.caustic.relMae;
        }
    }
    // No later kept frame m > n takes a half below n/2 + 1 (m/2 > n/2).
    std::erase_if(images_, [&](const auto& i) { return 2 * i.first <= n; });
    images_.emplace_back(n, std::vector<float>(caustic.begin(), caustic.end()));
    return figure_;
}

}  // namespace rtpm
