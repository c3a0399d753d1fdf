// The interface through which the eye pass asks for caustic radiance; photon maps implement it.
#pragma once

#include <cstdint>

#include "common/core/math.h"
#include "common/trace/embree_scene.h"

namespace rtpm {

/// Caustic radiance at a diffuse hit of `scene` from the photon map of interleaving set `set`.
/// `normal` is the shading normal facing the viewer; `albedo` the diffuse reflectance there.
/// `scene` is passed on every call (an estimator keeps no scene of its own) for estimators that
/// cast rays, e.g. a visibility test per gathered photon.
/// Must be thread-safe (called from many TBB threads at once).
class CausticEstimator {
public:
    virtual ~CausticEstimator() = default;
    virtual Vec3 radiance(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit, Vec3 normal,
                         Vec3 albedo) const = 0;
};

}  // namespace rtpm
