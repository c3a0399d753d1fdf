// The eye pass: primary rays, specular chains, direct light and the caustic lookup per pixel.
#pragma once

#include <cstdint>
#include <span>

#include "common/trace/embree_scene.h"
#include "common/core/interleave.h"
#include "common/core/pixel_radiance.h"
#include "common/core/render_settings.h"
#include "common/trace/caustic_estimator.h"

namespace rtpm {

/// Counters of one or more renderSet calls (added to, never reset by renderSet).
struct EyeStats {
    uint64_t primaryRays = 0;    ///< camera rays
    uint64_t secondaryRays = 0;  ///< rays along specular chains (both branches of dielectric splits)
    uint64_t shadowRays = 0;     ///< occlusion rays toward lights
    uint64_t nonFinite = 0;      ///< pixel values that were NaN/Inf and were replaced by 0
    uint64_t stackOverflows = 0; ///< dielectric branches dropped because the split stack was full
};

/// Traces every pixel of interleaving set `set` (row-major within the set) into `out`
/// (size `pattern.pixelCount(set)`). `caustics` may be null (caustic layer zero).
/// Deterministic: the result does not depend on the thread count. Parallel over rows (TBB).
/// `stats`, if given, is incremented with the ray and anomaly counts. Output is always finite.
/// Cost per pixel: one primary ray, ≤ 2^depth specular rays (pruned at throughput 1e-3), and per
/// diffuse end point one shadow ray per punctual light plus areaLightSamples per emissive
/// triangle (at most 16·areaLightSamples in total, see eye_pass.cpp).
void renderSet(const EmbreeScene& scene, const Camera& camera, const EyeSettings& settings,
               const Interleave& pattern, int set, const CausticEstimator* caustics,
               std::span<PixelRadiance> out, EyeStats* stats = nullptr);

}  // namespace rtpm
