// Everything that decides what a frame looks like, shared by rtpm-render, the master and clients.
#pragma once

#include <string>

#include "common/eye_pass.h"
#include "common/photon_map.h"

namespace rtpm {

/// Image, interleaving, filter, eye-pass and photon settings of one rendering job.
struct RenderSettings {
    int width = 640;
    int height = 480;
    int interleave = 3;  ///< M: the image is split into M×M interleaving sets (DESIGN §3)
    int filter = 0;      ///< F: caustic box filter size; 0 → F = M (every window holds each set once)
    EyeSettings eye;
    PhotonSettings photons;

    int filterSize() const { return filter > 0 ? filter : interleave; }
};

/// Throws std::invalid_argument naming the setting when a value is absurd (zero or negative
/// sizes, M larger than the image, F over 64, k = 0, a non-finite or negative radius, …).
void validateSettings(const RenderSettings& settings);

}  // namespace rtpm
