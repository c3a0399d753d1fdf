// A stored caustic photon: position, RGB power and incoming direction in 20 bytes.
#pragma once

#include <cmath>
#include <cstdint>

#include "common/core/rgb9e5.h"
#include "common/scene/scene.h"

namespace rtpm {

/// Photon powers are RGB9E5 words with exponent bias 20 (photon.cpp says why).
using PhotonPowerWord = Rgb9e5<20>;

/// Encodes non-negative RGB as a shared-exponent 9:9:9:5 word (relative precision ≈ 2^-9).
uint32_t encodeRgb9e5(Vec3 rgb);
/// Inverse of encodeRgb9e5: three integer-to-float conversions and one multiply by a power of
/// two built from the exponent bits (inline: the density estimate sums it per gathered photon).
inline Vec3 decodeRgb9e5(uint32_t packed) {
    Vec3 v;
    PhotonPowerWord::unpack(packed, &v.x);
    return v;
}
/// Encodes a unit vector as two 16-bit octahedral coordinates (angular error < 0.01°).
uint32_t encodeOctahedral(Vec3 unitDir);

/// The decoded octahedral direction before its normalisation: a positive multiple of
/// decodeOctahedral(packed) (lengths in [1/√3, 1]). Enough for any sign test (front/back of a
/// surface) without the square root and division; no transcendental, no branch.
inline Vec3 decodeOctahedralUnnormalized(uint32_t packed) {
    const float u = static_cast<float>(packed & 0xffffu) * (2.0f / 65534.0f) - 1.0f;
    const float v = static_cast<float>(packed >> 16) * (2.0f / 65534.0f) - 1.0f;
    const float au = std::abs(u), av = std::abs(v);
    const float z = 1.0f - au - av;
    // Lower hemisphere (z < 0): the fold of encodeOctahedral undone; sign(0) counts as +.
    const float fx = std::copysign(1.0f - av, u < 0.0f ? -1.0f : 1.0f);
    const float fy = std::copysign(1.0f - au, v < 0.0f ? -1.0f : 1.0f);
    return Vec3(z < 0.0f ? fx : u, z < 0.0f ? fy : v, z);
}
inline Vec3 decodeOctahedral(uint32_t packed) {
    const Vec3 d = decodeOctahedralUnnormalized(packed);
    return d * (1.0f / std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z));
}
/// True when a photon with encoded incoming direction `packed` arrives from the back of a
/// surface with normal `n` (it travelled away from the front side: dot(incoming, n) > 0).
/// The sign of the dot product is taken on the unnormalised direction (same sign as the
/// normalised one); this is the one front/back rule every gather uses.
inline bool arrivesFromBehind(uint32_t packed, Vec3 n) {
    const Vec3 d = decodeOctahedralUnnormalized(packed);
    return d.x * n.x + d.y * n.y + d.z * n.z > 0.0f;
}

/// Photon as stored in a photon map. Power is the flux it carries per batch, in units of the
/// map's power unit (PhotonMaps::powerUnit, W per unit; PhotonMaps::powerWatts converts);
/// `incoming` is the unit direction the photon travelled *along* when it hit the surface.
struct Photon {
    Vec3 position{0.0f};
    uint32_t power = 0;     ///< RGB9E5
    uint32_t incoming = 0;  ///< octahedral

    static Photon make(Vec3 position, Vec3 powerWatts, Vec3 incomingDir) {
        return Photon{position, encodeRgb9e5(powerWatts), encodeOctahedral(incomingDir)};
    }
    Vec3 powerRgb() const { return decodeRgb9e5(power); }
    Vec3 incomingDir() const { return decodeOctahedral(incoming); }
};
static_assert(sizeof(Photon) == 20, "Photon is the stored working set: keep it 20 bytes");

}  // namespace rtpm
