// PhotonRelay: a frame's shots, forwarded with the FrameBegin kSharedPhotonLag frames later.
#include "server/photon_relay.h"

#include "common/photon/set_photons.h"

namespace rtpm::server {

void PhotonRelay::began(uint64_t frame, uint32_t epoch, uint32_t sceneVersion, uint32_t sets) {
    while (!frames_.empty() && frames_.begin()->first + kSharedPhotonLag < frame) frames_.erase(frames_.begin());
    frames_[frame] = Frame{epoch, sceneVersion, sets, {}};
}

void PhotonRelay::record(uint64_t frame, uint32_t set, uint32_t batches, std::vector<proto::PhotonRecord>&& photons) {
    auto it = frames_.find(frame);
    if (it == frames_.end() || batches == 0 || photons.empty() || set >= it->second.sets) return;
    it->second.shots.try_emplace(set, proto::SetShot{set, batches, std::move(photons)});
}

std::vector<proto::SetShot> PhotonRelay::forwardFor(uint64_t frame, bool converging) const {
    std::vector<proto::SetShot> out;
    if (!converging || frame < kSharedPhotonLag) return out;
    const auto now = frames_.find(frame);
    const auto then = frames_.find(frame - kSharedPhotonLag);
    if (now == frames_.end() || then == frames_.end()) return out;
    const Frame& a = now->second;
    const Frame& b = then->second;
    if (a.epoch != b.epoch || a.sceneVersion != b.sceneVersion || a.sets != b.sets) return out;
    size_t total = 0;
    for (const auto& [set, shot] : b.shots) {
        if (total + shot.photons.size() > proto::kMaxSharedPhotons) continue;
        total += shot.photons.size();
        out.push_back(shot);
    }
    return out;
}

}  // namespace rtpm::server
