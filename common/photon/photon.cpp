// Photon power and direction encodings: shared-exponent RGB9E5 and 2×16-bit octahedral.
#include "common/photon/photon.h"

#include <algorithm>
#include <cmath>

namespace rtpm {

namespace {

// RGB9E5 layout of EXT_texture_shared_exponent (9-bit mantissas, 5-bit exponent), but with the
// exponent bias 20 instead of 15. The relative error stays ≤ 2^-9 for a largest channel in
// [2^-20 ≈ 9.5e-7, 2044]; below that the absolute step is 2^-29 ≈ 1.9e-9, and anything above
// 2044 is clamped. A fixed range cannot hold photon powers in W (they scale with the scene:
// 1e-9 W per photon in a 1 mm scene, 1e7 W in a 100 km one), so PhotonMaps stores them in units
// of a power of two near the largest path power: stored values are < 2, and the 2^-20 of range
// below keeps SPT weights, absorption and colour ratios at full relative precision.
constexpr int kMantissaBits = 9;
constexpr int kExpBias = 20;
constexpr int kMaxBiasedExp = 31;
constexpr float kMaxRgb9e5 = static_cast<float>((1 << kMantissaBits) - 1) /
                             (1 << kMantissaBits) * (1 << (kMaxBiasedExp - kExpBias));  // 2044

float sanitize(float c) {
    // NaN and negatives → 0 (a photon never carries negative flux); +Inf and huge → max.
    if (!(c > 0.0f)) return 0.0f;
    return std::min(c, kMaxRgb9e5);
}

float signNotZero(float v) { return v < 0.0f ? -1.0f : 1.0f; }

uint32_t quantizeUnit16(float v) {  // [-1, 1] → [0, 65534], round to nearest
    // 65534 steps (not 65535) so that 0 is a code (32767): the axes and the fold round-trip exactly.
    const float t = std::clamp(v, -1.0f, 1.0f) * 0.5f + 0.5f;
    return static_cast<uint32_t>(std::lround(t * 65534.0f));
}

float dequantizeUnit16(uint32_t q) { return static_cast<float>(q) * (2.0f / 65534.0f) - 1.0f; }

}  // namespace

uint32_t encodeRgb9e5(Vec3 rgb) {
    const float r = sanitize(rgb.x);
    const float g = sanitize(rgb.y);
    const float b = sanitize(rgb.z);
    const float maxc = std::max({r, g, b});
    if (maxc < std::ldexp(1.0f, -kExpBias - kMantissaBits - 1)) return 0;  // rounds to zero

    // Shared exponent e: maxc < 2^(e - bias), mantissa = c / 2^(e - bias - 9).
    int exp2 = 0;
    std::frexp(maxc, &exp2);  // maxc = f · 2^exp2, f in [0.5, 1)
    int biased = std::max(-kExpBias - 1, exp2 - 1) + 1 + kExpBias;
    float scale = std::ldexp(1.0f, kExpBias + kMantissaBits - biased);
    // Rounding the largest channel may carry into bit 9: move to the next exponent.
    if (std::lround(maxc * scale) >= (1 << kMantissaBits)) {
        ++biased;
        scale *= 0.5f;
    }
    biased = std::min(biased, kMaxBiasedExp);
    const auto mant = [&](float c) {
        return static_cast<uint32_t>(
            std::min<long>(std::lround(c * scale), (1 << kMantissaBits) - 1));
    };
    return mant(r) | (mant(g) << 9) | (mant(b) << 18) | (static_cast<uint32_t>(biased) << 27);
}

Vec3 decodeRgb9e5(uint32_t packed) {
    const int biased = static_cast<int>(packed >> 27);
    const float scale = std::ldexp(1.0f, biased - kExpBias - kMantissaBits);
    return Vec3(static_cast<float>(packed & 0x1ffu), static_cast<float>((packed >> 9) & 0x1ffu),
                static_cast<float>((packed >> 18) & 0x1ffu)) *
           scale;
}

uint32_t encodeOctahedral(Vec3 dir) {
    const float l1 = std::abs(dir.x) + std::abs(dir.y) + std::abs(dir.z);
    // Zero or non-finite directions have no meaning; store +Z so decoding stays a unit vector.
    if (!(l1 > 0.0f) || !std::isfinite(l1)) return encodeOctahedral(Vec3(0.0f, 0.0f, 1.0f));
    float u = dir.x / l1;
    float v = dir.y / l1;
    if (dir.z < 0.0f) {  // fold the lower hemisphere onto the outer triangles
        const float fu = (1.0f - std::abs(v)) * signNotZero(u);
        const float fv = (1.0f - std::abs(u)) * signNotZero(v);
        u = fu;
        v = fv;
    }
    return quantizeUnit16(u) | (quantizeUnit16(v) << 16);
}

Vec3 decodeOctahedral(uint32_t packed) {
    const float u = dequantizeUnit16(packed & 0xffffu);
    const float v = dequantizeUnit16(packed >> 16);
    Vec3 d(u, v, 1.0f - std::abs(u) - std::abs(v));
    if (d.z < 0.0f) {
        d.x = (1.0f - std::abs(v)) * signNotZero(u);
        d.y = (1.0f - std::abs(u)) * signNotZero(v);
    }
    return d * (1.0f / std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z));
}

}  // namespace rtpm
