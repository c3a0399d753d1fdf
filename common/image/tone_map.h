// Display tone mapping: linear RGB → 8-bit sRGB through a table, for frames shown live.
#pragma once

#include <cstdint>
#include <span>

namespace rtpm {

/// The linear scale for showing `rgb` (width·height·3 floats) at `exposureStops` above the
/// automatic exposure of writePng (1 / 99th-percentile luminance), estimated from every
/// `stride`-th pixel so it costs O(W·H / stride) rather than a full nth_element. Pure.
float displayScale(std::span<const float> rgb, float exposureStops, size_t stride = 8);

/// out[i] = 8-bit sRGB of clamp(rgb[i] · scale, 0, 1) — writePng's operator, with the transfer
/// curve read from a 16384-entry table (≤ 0.25 of an 8-bit step from the exact curve) instead of
/// a pow() per channel. Non-finite values become 0. Precondition (checked): out.size() ==
/// rgb.size(). Thread-safe. Cost: one multiply and one table read per channel.
void toneMapSrgb8(std::span<const float> rgb, float scale, std::span<uint8_t> out);

}  // namespace rtpm
