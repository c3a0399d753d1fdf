// Display tone mapping through a table of the sRGB transfer curve.
#include "common/image/tone_map.h"

#include <array>
#include <cmath>
#include <vector>

#include "common/core/check.h"
#include "common/image/image_io.h"

namespace rtpm {

namespace {

constexpr int kTableSize = 16384;

const std::array<uint8_t, kTableSize>& srgbTable() {
    static const std::array<uint8_t, kTableSize> table = [] {
        std::array<uint8_t, kTableSize> t{};
        for (int i = 0; i < kTableSize; ++i)
            t[size_t(i)] = static_cast<uint8_t>(std::lround(255.0f * linearToSrgb(float(i) / float(kTableSize - 1))));
        return t;
    }();
    return table;
}

}  // namespace

float displayScale(std::span<const float> rgb, float exposureStops, size_t stride) {
    const size_t n = rgb.size() / 3;
    if (stride < 1) stride = 1;
    std::vector<float> sample;
    sample.reserve(3 * (n / stride + 1));
    for (size_t i = 0; i < n; i += stride) sample.insert(sample.end(), rgb.begin() + 3 * i, rgb.begin() + 3 * i + 3);
    const float s = autoExposureScale(sample) * std::exp2(exposureStops);
    return std::isfinite(s) && s > 0.0f ? s : 1.0f;
}

void toneMapSrgb8(std::span<const float> rgb, float scale, std::span<uint8_t> out) {
    RTPM_CHECK(out.size() == rgb.size());
    const auto& table = srgbTable();
    constexpr float kMax = float(kTableSize - 1);
    for (size_t i = 0; i < rgb.size(); ++i) {
        const float x = rgb[i] * scale * kMax;
        // !(x > 0) also catches NaN; x ≥ kMax catches +Inf.
        const int idx = !(x > 0.0f) ? 0 : x >= kMax ? kTableSize - 1 : int(x + 0.5f);
        out[i] = table[size_t(idx)];
    }
}

}  // namespace rtpm
