// A stored caustic photon: position, RGB power and incoming direction in 20 bytes.
#pragma once

#include <cstdint>

#include "common/scene/scene.h"

namespace rtpm {

/// Encodes non-negative RGB as a shared-exponent 9:9:9:5 word (relative precision ≈ 2^-9).
uint32_t encodeRgb9e5(Vec3 rgb);
Vec3 decodeRgb9e5(uint32_t packed);
/// Encodes a unit vector as two 16-bit octahedral coordinates (angular error < 0.01°).
uint32_t encodeOctahedral(Vec3 unitDir);
Vec3 decodeOctahedral(uint32_t packed);

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
