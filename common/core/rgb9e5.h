// Shared-exponent RGB9E5 words (EXT_texture_shared_exponent layout) with a chosen exponent bias.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

namespace rtpm {

/// RGB9E5 with exponent bias `kBias`: bits [8:0] R, [17:9] G, [26:18] B mantissas, [31:27] the
/// shared exponent e, value = mantissa · 2^(e − kBias − 9). The relative error is ≤ 2^-9 of the
/// largest channel for largest channels in [2^-kBias, max()]; the wire's pixels use bias 15
/// (OpenGL's, up to 65408), photon powers bias 20 (up to 2044, finer below: common/photon/photon.cpp).
template <int kBias>
struct Rgb9e5 {
    static constexpr int kMantissaBits = 9;
    static constexpr int kMaxExp = 31;
    static_assert(kBias + kMantissaBits < 126 && kMaxExp - kBias - kMantissaBits > -126,
                  "every scale must be a normal float");

    /// Largest representable channel value: (511/512) · 2^(31 − kBias).
    static constexpr float max() {
        return static_cast<float>((1 << kMantissaBits) - 1) / (1 << kMantissaBits) *
               static_cast<float>(uint64_t{1} << (kMaxExp - kBias));
    }

    /// Packs three channels. NaN and values ≤ 0 become 0, values above max() (+Inf included)
    /// become max(); each mantissa is rounded to nearest (ties away from zero). Pure, O(1).
    static uint32_t pack(float r, float g, float b) {
        r = clampChannel(r);
        g = clampChannel(g);
        b = clampChannel(b);
        const float maxc = std::max({r, g, b});
        if (maxc < pow2(-kBias - kMantissaBits - 1)) return 0;  // every mantissa rounds to zero
        // Shared exponent e: maxc < 2^(e − bias), mantissa = c / 2^(e − bias − 9). maxc is a
        // normal float here, so its exponent field is floor(log2 maxc).
        const int floorLog2 = static_cast<int>((std::bit_cast<uint32_t>(maxc) >> 23) & 0xff) - 127;
        int e = std::max(-kBias - 1, floorLog2) + 1 + kBias;
        float scale = pow2(kBias + kMantissaBits - e);
        // Rounding the largest channel may carry into bit 9: move to the next exponent.
        if (round(maxc * scale) >= (1u << kMantissaBits)) {
            ++e;
            scale *= 0.5f;
        }
        e = std::min(e, kMaxExp);
        const auto mant = [scale](float c) { return std::min(round(c * scale), (1u << kMantissaBits) - 1); };
        return mant(r) | (mant(g) << 9) | (mant(b) << 18) | (static_cast<uint32_t>(e) << 27);
    }

    /// Inverse of pack: three finite values in [0, max()]. Pure, O(1).
    static void unpack(uint32_t word, float rgb[3]) {
        const float scale = pow2(static_cast<int>(word >> 27) - kBias - kMantissaBits);
        rgb[0] = static_cast<float>(word & 0x1ffu) * scale;
        rgb[1] = static_cast<float>((word >> 9) & 0x1ffu) * scale;
        rgb[2] = static_cast<float>((word >> 18) & 0x1ffu) * scale;
    }

private:
    static float clampChannel(float c) { return c > 0.0f ? std::min(c, max()) : 0.0f; }
    static float pow2(int k) { return std::bit_cast<float>(static_cast<uint32_t>(k + 127) << 23); }
    // Round half away from zero for x ≥ 0 (= std::lround): x + 0.5 is exact in double wherever
    // the sum can reach an integer boundary, and the conversion truncates, which for x + 0.5 ≥ 0
    // is the floor (without a call to floor: baseline x86-64 has no rounding instruction).
    static uint32_t round(float x) { return static_cast<uint32_t>(static_cast<double>(x) + 0.5); }
};

}  // namespace rtpm
