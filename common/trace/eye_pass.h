// The eye pass: primary rays, specular chains, direct light and the caustic lookup per pixel.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

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
    uint64_t sampledSplits = 0;  ///< dielectric splits that traced one branch chosen at random
};

/// One diffuse end point of a pixel's eye path, or a glossy vertex (a rough mirror or dielectric):
/// what a progressive pass needs to refine the pixel without re-tracing it up to there
/// (docs/ARCHITECTURE.md §6.2: a still frame re-traces no eye ray to its recorded hits). A pass
/// samples a glossy vertex's BSDF afresh and traces on from it for direct light
/// (AreaLightSampler::sample); the caustic behind it is refined at the end points its restart
/// reached (Kind::CausticOnly).
struct EyeHit {
    SurfaceHit hit;            ///< as Embree reported it (geometricNormal not flipped)
    Vec3 normal{0.0f};         ///< shading normal facing the viewer
    Vec3 geometricNormal{0.0f};///< geometric normal facing the viewer
    Vec3 albedo{0.0f};         ///< diffuse reflectance (texture applied); 0 at a glossy vertex
    Vec3 throughput{0.0f};     ///< of the specular chain from the camera to here
    Vec3 areaDirect{0.0f};     ///< area-light and world-light radiance here from the eye pass's
                               ///< samples (pass 0); at a glossy vertex, the radiance of its pass-0
                               ///< BSDF sample
    std::array<float, 3> rotation{};  ///< the pixel's Cranley–Patterson rotation at this vertex
    uint32_t pixel = 0;        ///< index of the pixel within its set (row-major)
    Vec3 wo{0.0f};             ///< glossy vertex: unit direction toward the viewer
    uint16_t set = 0;          ///< the pixel's interleaving set
    uint16_t depth = 0;        ///< glossy vertex: specular bounces before it
    enum class Kind : uint8_t {
        EndPoint,     ///< a diffuse end point: direct light and caustic
        Glossy,       ///< a glossy vertex: what arrives there, sampled afresh per pass; no caustic
                      ///< of its own (albedo 0)
        CausticOnly,  ///< a diffuse end point behind a glossy vertex: its caustic only (the
                      ///< glossy vertex's samples carry its direct light)
    };
    Kind kind = Kind::EndPoint;
};

/// The eye-pass records of one set: every diffuse end point, in pixel order.
struct EyeRecords {
    std::vector<EyeHit> hits;
    std::vector<uint32_t> firstHit;  ///< pixel p's hits are [firstHit[p], firstHit[p+1])
};

/// Traces every pixel of interleaving set `set` (row-major within the set) into `out`
/// (size `pattern.pixelCount(set)`). `caustics` may be null (caustic layer zero).
/// Deterministic: the result does not depend on the thread count. Parallel over rows (TBB).
/// `stats`, if given, is incremented with the ray and anomaly counts. Output is always finite.
/// Cost per pixel: one primary ray, ≤ 2^depth specular rays (pruned at throughput 1e-3), and per
/// diffuse end point one shadow ray per punctual light plus, for the emitters, between 1 and
/// areaLightSamples per emissive triangle (at most 16·areaLightSamples in total) chosen by the
/// solid angle they subtend, and with a world light 8 directions from it (see eye_light.cpp); a ray
/// that leaves the scene returns the world light's radiance. A glossy vertex ends the pixel's split
/// path and traces EyeSettings::glossySamples trees on from sampled microfacet normals (eye_glossy.cpp), each
/// split like the pixel's own, to diffuse end points with their direct light and caustic lookup.
/// Primary rays go to Embree in packets of 8, and
/// the caustic lookups of a packet's pixels go to `caustics` as one group (radianceGroup).
/// `sampleSeed` 0 splits every dielectric deterministically (the image above). Any other value
/// samples the splits whose weaker branch carries less than a quarter of the pixel: one branch,
/// reflection with probability F, weighted by 1/F or 1/(1 − F), from a number hashed from
/// (sampleSeed, pixel, split), so the result is still independent of threads and set split.
/// Unbiased: over seeds the mean is the deterministic image (the same branches, pruned alike);
/// the cost is at most one secondary ray per depth below the split threshold instead of up to
/// 2^depth (a moving camera's frames on nested glass).
void renderSet(const EmbreeScene& scene, const Camera& camera, const EyeSettings& settings,
               const Interleave& pattern, int set, const CausticEstimator* caustics,
               std::span<PixelRadiance> out, EyeStats* stats = nullptr,
               EyeRecords* records = nullptr, uint64_t sampleSeed = 0, bool recordLights = true);

/// Record mode (`records` given to renderSet): the diffuse end points and glossy vertices go to
/// `records` (behind a glossy vertex, the end points its restart samples reached, for their
/// caustic only); out[p].direct then holds everything but the area-light term at the end points
/// and what arrives at the glossy vertices (each EyeHit::areaDirect holds it, unweighted by the
/// throughput), and no caustic is looked up (out[p].caustic = 0).
/// With `recordLights` false the records keep no light at all: out[p].direct is only what the
/// eye paths meet on their way (emission, the world light seen, unlit surfaces), every
/// areaDirect is 0 and a glossy vertex is recorded without tracing its trees: what relightSet
/// completes, for any lights.

/// The pixels of `set` from records of renderSet(…, recordLights = false) of the same camera and
/// geometry (`base`: that call's out[p].direct): `base` plus, at each diffuse end point, its
/// direct light by shadow rays (as renderSet's) and its caustic from `caustics` (grouped per 8
/// pixels as renderSet does), and at each glossy vertex its sampled trees (pass 0). The image of
/// renderSet with deterministic splits for the scene's lights now, up to the order of the sums:
/// moving or changing a punctual light needs no eye ray but shadow rays. Parallel over rows,
/// independent of the thread count. Output is always finite.
void relightSet(const EmbreeScene& scene, const EyeSettings& settings, const Interleave& pattern, int set,
                const CausticEstimator* caustics, const EyeRecords& records, std::span<const Vec3> base,
                std::span<PixelRadiance> out, EyeStats* stats = nullptr);

/// The per-pass samples at recorded eye hits, for progressive passes: the area lights
/// (emissive triangles) and the world light at a diffuse end point, fresh BSDF samples and the
/// direct light along the paths on from them at a glossy vertex. Thread-safe (const); holds the
/// scene's triangle-selection table.
class AreaLightSampler {
public:
    AreaLightSampler(const EmbreeScene& scene, const EyeSettings& settings);
    ~AreaLightSampler();
    /// True when every sample is 0: the scene has no emissive triangle, no glossy material and no
    /// world light.
    bool empty() const;
    /// Radiance at `hit` (unweighted by its throughput) from the same sample pattern as the eye
    /// pass, rotated for pass `pass` (pass 0 = EyeHit::areaDirect exactly): area light at a
    /// diffuse end point, the direct light along fresh BSDF samples at a glossy vertex, 0 at a
    /// caustic-only end point. Adds the shadow rays cast to `shadowRays`. Always finite.
    Vec3 sample(const EyeHit& hit, uint32_t pass, uint64_t& shadowRays) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rtpm
