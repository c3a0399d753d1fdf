// What one interleaving set shot in one frame, as the sets share it (shared_photons.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/photon/photon.h"

namespace rtpm {

/// Frames between shooting a set's photons and the other sets binning them. A cluster's master
/// forwards a frame's photons with the FrameBegin of the frame after next (it begins frame t+1
/// while t is still rendering), and one process keeps the same delay, so both bin the same
/// photons in the same passes.
inline constexpr uint64_t kSharedPhotonLag = 2;
/// Photons of all sets together one frame shares at most (a set's share: this / M², whole
/// batches; PhotonMaps::setShareCap): 5 MB on the wire to each client, a few hundred kB at the
/// built-in scenes' defaults.
inline constexpr size_t kSharedPhotonBudget = size_t(1) << 18;

/// What one interleaving set shot in one frame (a batch, or a progressive pass of `batches`
/// batches): stored photons in the maps' power unit, per batch like every stored power.
struct SetPhotons {
    uint32_t set = 0;
    uint32_t batches = 0;
    std::vector<Photon> photons;
};

}  // namespace rtpm
