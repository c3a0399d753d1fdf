// Photon power and direction encodings: shared-exponent RGB9E5 and 2×16-bit octahedral.
#include "common/photon/photon.h"

#include <algorithm>
#include <cmath>

#include "common/core/rgb9e5.h"

namespace rtpm {

namespace {

// Photon powers are RGB9E5 words with exponent bias 20 instead of OpenGL's 15 (core/rgb9e5.h).
// The relative error stays ≤ 2^-9 for a largest channel in [2^-20 ≈ 9.5e-7, 2044]; below that
// the absolute step is 2^-29 ≈ 1.9e-9, and anything above 2044 is clamped. A fixed range cannot
// hold photon powers in W (they scale with the scene: 1e-9 W per photon in a 1 mm scene, 1e7 W in
// a 100 km one), so PhotonMaps stores them in units of a power of two near the largest path
// power: stored values are < 2, and the 2^-20 of range below keeps SPT weights, absorption and
// colour ratios at full relative precision.
using PowerWord = PhotonPowerWord;

float signNotZero(float v) { return v < 0.0f ? -1.0f : 1.0f; }

uint32_t quantizeUnit16(float v) {  // [-1, 1] → [0, 65534], round to nearest
    // 65534 steps (not 65535) so that 0 is a code (32767): the axes and the fold round-trip exactly.
    const float t = std::clamp(v, -1.0f, 1.0f) * 0.5f + 0.5f;
    return static_cast<uint32_t>(std::lround(t * 65534.0f));
}

}  // namespace

uint32_t encodeRgb9e5(Vec3 rgb) { return PowerWord::pack(rgb.x, rgb.y, rgb.z); }

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


}  // namespace rtpm
