// VisibleFrom: whether a gathered photon is visible from the shaded point
// (PhotonSettings::gatherVisibility), for PhotonMaps' gathers and the progressive passes.
#pragma once

#include <glm/glm.hpp>

#include "common/photon/photon.h"
#include "common/trace/embree_scene.h"

namespace rtpm {

// Visibility of a gathered photon from the shaded point (PhotonSettings::gatherVisibility): both
// ends are lifted off their surfaces by the same distance, x along its normal, the photon back
// along the direction it arrived from (the side of the surface it lies on). A ray between two
// points of one plane then runs parallel to it, and a photon on the lit face of a
// zero-thickness wall is seen from the lit side only. Always true when disabled.
class VisibleFrom {
public:
    VisibleFrom(bool enabled, const EmbreeScene& scene, const SurfaceHit& hit, Vec3 normal)
        : enabled_(enabled), scene_(scene) {
        if (!enabled_) return;
        origin_ = scene.offsetOrigin(hit.position, hit.geometricNormal, normal);
        lift_ = glm::length(origin_ - hit.position);
    }
    bool enabled() const { return enabled_; }
    bool operator()(const Photon& photon) const {
        if (!enabled_) return true;
        Ray ray;
        ray.origin = origin_;
        ray.dir = photon.position - lift_ * photon.incomingDir() - origin_;
        ray.tMax = 1.0f;
        return glm::dot(ray.dir, ray.dir) == 0.0f || !scene_.occluded(ray);
    }

private:
    bool enabled_;
    const EmbreeScene& scene_;
    Vec3 origin_{0.0f};
    float lift_ = 0.0f;
};

}  // namespace rtpm
