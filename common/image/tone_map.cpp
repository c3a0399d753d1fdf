// Display tone mapping with a vectorisable fit of the sRGB transfer curve.
#include "common/image/tone_map.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/core/check.h"
#include "common/image/image_io.h"

namespace rtpm {


float displayScale(std::span<const float> rgb, float exposureStops, size_t stride) {
    std::vector<float> scratch;
    return displayScale(rgb, exposureStops, stride, scratch);
}

float displayScale(std::span<const float> rgb, float exposureStops, size_t stride, std::vector<float>& scratch) {
    // autoExposureScale's 99th percentile of luminance over every stride-th pixel, in `scratch`.
    const size_t n = rgb.size() / 3;
    if (stride < 1) stride = 1;
    scratch.clear();
    for (size_t i = 0; i < n; i += stride) {
        const float* p = rgb.data() + 3 * i;
        const float l = 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
        scratch.push_back(std::isfinite(l) ? l : 0.0f);
    }
    float s = 1.0f;
    if (!scratch.empty()) {
        const size_t m = scratch.size();
        const size_t k = std::min(m - 1, size_t(std::floor(0.99 * double(m - 1) + 0.5)));
        std::nth_element(scratch.begin(), scratch.begin() + std::ptrdiff_t(k), scratch.end());
        const float p99 = scratch[k];
        s = p99 > 0.0f && std::isfinite(1.0f / p99) ? 1.0f / p99 : 1.0f;
    }
    s *= std::exp2(exposureStops);
    return std::isfinite(s) && s > 0.0f ? s : 1.0f;
}

// AVX2 doubles the SIMD width where the CPU has it (runtime dispatch); the default is SSE2.
__attribute__((target_clones("avx2", "default")))
void toneMapSrgb8(std::span<const float> rgb, float scale, std::span<uint8_t> out) {
    RTPM_CHECK(out.size() == rgb.size());
    // The sRGB curve above the linear toe as three nested square roots (Ian Taylor's fit of
    // x^(1/2.4)): every operation has a SIMD form, so the loop vectorises (a table lookup does
    // not), and the fit stays within one 8-bit step of the exact curve (tests/unit/image).
    const float* in = rgb.data();
    uint8_t* o = out.data();
    const size_t n = rgb.size();
    for (size_t i = 0; i < n; ++i) {
        float x = in[i] * scale;
        x = x > 0.0f ? x : 0.0f;  // also maps NaN to 0 (the comparison is false)
        x = x < 1.0f ? x : 1.0f;  // and +Inf to 1
        const float s1 = std::sqrt(x), s2 = std::sqrt(s1), s3 = std::sqrt(s2);
        const float curve = 0.585122381f * s1 + 0.783140355f * s2 - 0.368262736f * s3;
        float v = x <= 0.0031308f ? 12.92f * x : curve;
        v = v < 1.0f ? v : 1.0f;
        o[i] = uint8_t(int(255.0f * v + 0.5f));
    }
}

}  // namespace rtpm
