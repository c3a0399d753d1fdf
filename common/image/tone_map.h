// Display tone mapping: linear RGB → 8-bit sRGB, fast enough for every frame shown live.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace rtpm {

/// The linear scale for showing `rgb` (width·height·3 floats) at `exposureStops` above the
/// automatic exposure of writePng (1 / 99th-percentile luminance), estimated from every
/// `stride`-th pixel so it costs O(W·H / stride) rather than a full nth_element. Pure.
float displayScale(std::span<const float> rgb, float exposureStops, size_t stride = 8);
/// The same, with the sample kept in `scratch` (reused across calls: no allocation per frame).
float displayScale(std::span<const float> rgb, float exposureStops, size_t stride, std::vector<float>& scratch);

/// out[i] = 8-bit sRGB of clamp(rgb[i] · scale, 0, 1) — writePng's operator, with the transfer
/// curve from a vectorisable fit (within one 8-bit step of the exact curve) instead of a pow()
/// per channel. NaN and negative values become 0, +Inf 255. Precondition (checked): out.size() ==
/// rgb.size(). Thread-safe. Cost: three approximate square roots per channel (AVX2 rsqrt where the
/// CPU has AVX2 and FMA, full square roots otherwise), SIMD.
void toneMapSrgb8(std::span<const float> rgb, float scale, std::span<uint8_t> out);

}  // namespace rtpm
