// The two radiance values the eye pass computes per pixel, as the renderer and the master hold them.
#pragma once

#include "common/core/math.h"

namespace rtpm {

/// The two values a client streams per pixel (paper §4.2), linear radiance W/(m²·sr).
struct PixelRadiance {
    Vec3 direct{0.0f};   ///< everything except caustics (direct light, emitters seen, through specular chains)
    Vec3 caustic{0.0f};  ///< caustic radiance at the first diffuse hit, times the chain's throughput
};

}  // namespace rtpm
