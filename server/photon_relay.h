// The photon relay: every set's shot of a frame, kept until the frame kSharedPhotonLag later
// begins and forwarded to every client with that FrameBegin, so that a still view's passes bin
// every set's photons (common/photon/shared_photons.h; the cluster bins what rtpm-render bins).
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "proto/messages.h"

namespace rtpm::server {

/// Pure (no clock, no sockets); lives on the master's I/O thread.
class PhotonRelay {
public:
    /// Frame `frame` began in `epoch` at `sceneVersion` with `sets` sets. Forgets frames older
    /// than the one forwardFor(frame) forwards.
    void began(uint64_t frame, uint32_t epoch, uint32_t sceneVersion, uint32_t sets);
    /// A FrameData's shot (decoded, so ≤ kMaxSharedPhotons photons): kept when its frame is
    /// known and the set has no shot yet; an empty one is ignored.
    void record(uint64_t frame, uint32_t set, uint32_t batches, std::vector<proto::PhotonRecord>&& photons);
    /// FrameBegin(frame).shared: the shots of frame − kSharedPhotonLag in ascending sets, when
    /// that frame began in the same epoch, scene version and M as `frame` and `converging` (a
    /// still view's pass; other frames bin nothing). At most kMaxSharedPhotons photons in all:
    /// the sets that would go beyond are left out.
    std::vector<proto::SetShot> forwardFor(uint64_t frame, bool converging) const;

private:
    struct Frame {
        uint32_t epoch = 0, sceneVersion = 0, sets = 0;
        std::map<uint32_t, proto::SetShot> shots;  ///< by set
    };
    std::map<uint64_t, Frame> frames_;
};

}  // namespace rtpm::server
