// What the eye pass's sources share (internal to common/trace/): the per-set context, the ray
// counters, the light at a diffuse end point (eye_light.cpp) and the glossy vertex's sampled
// trees (eye_glossy.cpp).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "common/trace/eye_pass.h"
#include "common/trace/plastic_bsdf.h"

namespace rtpm {
namespace detail {

/// Branches of the split tree whose throughput falls below this are dropped.
constexpr float kMinThroughput = 1e-3f;

/// x mod 1, in [0, 1).
inline float wrap01(float x) {
    x -= std::floor(x);
    return x < 1.0f ? x : 0.0f;
}

/// Per-renderSet data shared by all pixels (read-only inside the parallel loop).
struct Context {
    const EmbreeScene& es;
    const Scene& scene;
    const EyeSettings& settings;
    const CausticEstimator* caustics;
    int set;
    uint64_t sampleSeed;      // 0: deterministic splitting; else sampled splits (renderSet)
    int areaSamples;
    bool sampleEach;          // few triangles: at the full budget each gets areaSamples samples
    int maxAreaSamples;       // N_max, the budget at the full solid angle
    std::vector<float> cdf;   // power-proportional selection: cumulative, last = 1
    Vec3 emitterCentre{0.0f}; // bounding sphere of the emissive triangles
    float emitterRadius2 = 0.0f;
    const Environment* environment = nullptr;  // null when the scene has no world light
    bool recordLights = true;  // record mode: the end points' lights in out and the records (renderSet)
};

struct Counters {
    uint64_t primary = 0, secondary = 0, shadow = 0, nonFinite = 0, stackOverflow = 0, sampledSplits = 0;
};

struct PathState {
    Ray ray;
    Vec3 throughput;  ///< of the deterministic splitting's branch: decides what is pruned
    int depth;
    float weight = 1.0f;  ///< 1 / the probability of the branches chosen at random so far
};

/// Radiance reflected toward the viewer by a Lambertian point from the punctual lights (shadow
/// rays). `n` shading normal and `ng` geometric normal, both facing the viewer. With `coat` (the
/// base of a plastic) each light's share is weighted by coat->lightShare of its cosine; the
/// viewer's share (viewShare) is the caller's, in the throughput.
Vec3 punctualLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                   Counters& count, const PlasticBsdf* coat = nullptr);

/// `sum` plus the radiance reflected from the world light and the emissive triangles, sampled with
/// the Cranley–Patterson rotation `rot` (the pixel's, advanced per progressive pass). `coat` as
/// for punctualLight.
Vec3 areaLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
               const std::array<float, 3>& rot, Counters& count, Vec3 sum, const PlasticBsdf* coat = nullptr);

/// Direct light from every light: punctual first, then the area samples added to that sum (the
/// order the image has always been computed in).
Vec3 directLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                 const std::array<float, 3>& rot, Counters& count, const PlasticBsdf* coat = nullptr);

/// The punctual lights' radiance reflected toward `wo` (unit, toward the viewer) by the rough coat of
/// a plastic at `hit` (shadow rays; `ns`, `ng` facing the viewer): the coat's highlights, which no
/// sampled direction can find (a point has no area). Area lights and the world light are met by the
/// glossy samples instead. 0 for a smooth coat.
Vec3 coatHighlight(const Context& ctx, const SurfaceHit& hit, Vec3 wo, Vec3 ns, Vec3 ng,
                   const PlasticBsdf& coat, Counters& count);

/// The punctual lights' radiance reflected toward `wo` by glossy material `m` (a rough conductor,
/// or a rough dielectric's reflection lobe) at `hit` (shadow rays; `ns`, `ng` facing the viewer):
/// the highlights of point, spot and sun lights, which no sampled direction can find. Light
/// through a dielectric is caustic light (photons), as everywhere in the eye pass.
Vec3 glossyHighlight(const Context& ctx, const SurfaceHit& hit, Vec3 wo, Vec3 ns, Vec3 ng, const Material& m,
                     Counters& count);

/// What arrives at a glossy vertex, times the throughput from it: direct light (and emission met
/// on the way) and, when looked up, the caustic estimate at the diffuse end points.
struct GlossyRadiance {
    Vec3 direct{0.0f};
    Vec3 caustic{0.0f};
};

/// Where the caustic of a glossy tree's diffuse end points goes.
enum class GlossyCaustic : uint8_t {
    Lookup,  ///< asked of ctx.caustics (if any) into GlossyRadiance::caustic
    Record,  ///< each end point appended to `record` as an EyeHit::Kind::CausticOnly hit
    Skip,    ///< not estimated (a progressive pass: the recorded end points refine it)
};

/// The paths on from glossy vertex `hit` of material index hit.material (arriving along `dir`,
/// `ng` and `ns` facing the viewer, at specular depth `depth`; eye_glossy.cpp). `samples`
/// visible normals, stratified in their first number and advanced per pass; each scatters the
/// path: a conductor reflects about it, a dielectric splits into both lobes about it (the smooth
/// dielectric's Fresnel split in the limit). Further on, the tree splits at dielectrics (smooth
/// ones about the normal, glossy ones about one sampled microfacet) and follows mirrors and
/// conductors, as shadePixel does, down to the diffuse end points' direct light. Numbers after
/// the first vertex are hashed from the rotation, the pass and a counter. With Record, `base`
/// gives the recorded end points' pixel, set and the throughput before the vertex.
GlossyRadiance glossyTree(const Context& ctx, uint32_t set, const SurfaceHit& hit, Vec3 dir, Vec3 ng,
                          Vec3 ns, int depth, const std::array<float, 3>& rot, uint32_t pass, int samples,
                          GlossyCaustic caustic, Counters& count, std::vector<EyeHit>* record = nullptr,
                          const EyeHit* base = nullptr);

}  // namespace detail
}  // namespace rtpm
