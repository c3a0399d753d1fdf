// Photon emission from every light type and photon tracing through specular chains; only caustic
// photons are kept.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "common/trace/embree_scene.h"
#include "common/core/halton.h"

namespace rtpm {

enum class EmitterKind : uint8_t { Point, Spot, Directional, Area, Environment };

/// One unit of the photon budget: a punctual light, or all emissive triangles that share one
/// radiance (so every photon of it carries exactly the same power, see buildEmitters).
struct Emitter {
    EmitterKind kind = EmitterKind::Point;
    uint32_t id = 0;   ///< Scene::lights index (punctual) or area-group number; keys the sequence
    Vec3 flux{0.0f};   ///< radiant flux in W per channel, exact (see lightFlux)
    // Point / spot.
    Vec3 position{0.0f};
    Vec3 axis{0.0f, -1.0f, 0.0f};  ///< spot axis / directional travel direction (unit)
    float cosOuter = -1.0f;        ///< spot: cos of the outer cone angle
    float falloffScale = 1.0f;     ///< spot: glTF 1 / max(0.001, cosInner − cosOuter)
    // Directional: a disc perpendicular to `axis` covering the scene's bounding sphere.
    // Environment: that sphere (centre discCentre, radius discRadius); each photon's disc faces
    // its own direction.
    Vec3 discCentre{0.0f};
    float discRadius = 0.0f;
    Vec3 tangent{1.0f, 0.0f, 0.0f};    ///< unit, ⟂ axis
    Vec3 bitangent{0.0f, 0.0f, 1.0f};  ///< unit, ⟂ axis and tangent
    // Area: triangles (indices into EmbreeScene::emissiveTriangles) and their area CDF.
    std::vector<uint32_t> triangles;
    std::vector<double> cdf;  ///< cdf[t] = Σ_{s ≤ t} area_s / Σ area, last entry 1
    Vec3 radiance{0.0f};      ///< W/(m²·sr), common to all triangles of the group (untextured)
    /// Textured group (one emissive-textured material): triangles are chosen ∝ area × Σ_rgb of
    /// their mean radiance (cdf) and a photon from triangle t carries flux/paths × colour[t], so
    /// every photon has the same Σ_rgb power and the expected power is exact. Empty otherwise.
    std::vector<Vec3> colour;
    uint32_t material = 0;    ///< textured group: its Scene::materials index
    bool textured() const { return !colour.empty(); }
};

/// Exact radiant flux (W per channel) of a punctual light: point 4πI, spot I·spotSolidAngle,
/// directional E·πR² with R the radius of `bounds`' bounding sphere (the emission disc).
Vec3 lightFlux(const Light& light, const Bounds& bounds);

/// Every emitter of the scene with positive flux: one per punctual light, one per distinct
/// emissive radiance over the untextured EmbreeScene::emissiveTriangles() and one per
/// emissive-textured material (flux π·L·A per triangle, L its mean radiance; degenerate or
/// non-finite triangles are skipped), then the world light (Scene::environment) if there is one,
/// with the flux πR²·∫L dω crossing the disc of the scene's bounding sphere (radius R) from all
/// directions. Lights with zero or non-finite flux are left out. The budget is shared by flux
/// (splitBudget), the world light's as any other's.
std::vector<Emitter> buildEmitters(const EmbreeScene& scene);

/// Splits `total` paths among emitters proportionally to Σ_rgb flux by largest remainder
/// (deterministic, ties to the lower index); every emitter gets at least one path when
/// total ≥ emitters. Σ result = total.
std::vector<uint32_t> splitBudget(std::span<const Emitter> emitters, uint32_t total);

/// Halton dimensions a photon of this emitter uses. Steering dims come first and get the
/// smallest bases (docs/ARCHITECTURE.md §5.1–§5.2): direction (2), point on an area light (2),
/// first diffuse bounce direction (2, when diffuseBounces > 0). Everything else is hashed.
struct DimLayout {
    int direction = 0;   ///< dims direction, direction+1
    int point = -1;      ///< area lights: dims point, point+1
    int bounce = -1;     ///< first diffuse bounce: dims bounce, bounce+1
    int count = 2;       ///< steering dims in use (all < count)
};
DimLayout dimLayout(EmitterKind kind, uint32_t diffuseBounces);

/// A photon leaving a light: origin, unit direction and the surface normal at the origin (area
/// lights, for the offset; zero otherwise). Every photon of an emitter carries the same power
/// (flux / paths): each sampling density below is exactly proportional to the emission, which is
/// what makes Σ emitted power = flux exact rather than true only on average.
struct EmittedRay {
    Vec3 origin{0.0f};
    Vec3 dir{0.0f, 1.0f, 0.0f};
    Vec3 normal{0.0f};
    Vec3 powerScale{1.0f};  ///< textured area groups: Emitter::colour of the chosen triangle
};

/// Maps steering numbers to an emitted ray. `uDir` drives the direction (point: uniform sphere;
/// spot: cosθ from the exact inverse CDF of the glTF falloff within the outer cone; directional:
/// uniform point on the disc; area: cosine-weighted; environment: Environment::sample, the photon
/// travelling opposite the drawn direction), `uPoint` the point on an area light
/// (triangle ∝ area by the first number, reused after remapping, then uniform on the triangle) or
/// on the environment's disc (uniform on the bounding sphere's cross-section facing the drawn
/// direction, just outside the sphere on the sky's side). An environment photon's powerScale is
/// (L/pdf) ⊘ ∫L dω per channel: 1 on average, so the emitted power is exact in expectation and
/// each photon carries L(ω) of its direction.
/// Pure, thread-safe. `scene` is needed for area lights only.
EmittedRay sampleEmission(const Emitter& emitter, const EmbreeScene& scene, Vec2 uDir, Vec2 uPoint);

/// Tracing controls.
struct TraceSettings {
    uint32_t diffuseBounces = 1;  ///< see PhotonSettings
    uint32_t maxDepth = 16;       ///< ray segments per path
    uint64_t seed = 0;            ///< for hashed (non-Halton) numbers
};

/// A caustic photon before encoding: world position, power in W, unit travel direction.
struct TracedPhoton {
    Vec3 position{0.0f};
    Vec3 power{0.0f};
    Vec3 incoming{0.0f};
};

/// Counters and timings of a traced range.
struct TraceStats {
    uint64_t paths = 0;
    uint64_t productivePaths = 0;  ///< paths that stored ≥ 1 photon
    uint64_t stored = 0;
    uint64_t rays = 0;
    uint64_t anomalies = 0;        ///< paths dropped for a non-finite value
    double wallSeconds = 0.0;
    /// Phase split of wallSeconds (paper Table 3), estimated from timed sample paths.
    double samplingSeconds = 0.0;
    double rayCastSeconds = 0.0;
    double interactionSeconds = 0.0;
    void add(const TraceStats& o);
};

/// One path in every kTimedPathStride is timed phase by phase.
inline constexpr uint64_t kTimedPathStride = 64;

/// Where a photon's numbers come from: the emitter, its rotated Halton sequence, the hash stream
/// of its non-steered numbers, and the power every path of this range starts with (W).
struct PhotonSource {
    const Emitter* emitter = nullptr;
    const Halton* halton = nullptr;
    uint64_t hashStream = 0;
    Vec3 powerPerPath{0.0f};
    DimLayout dims;
};

/// Output of tracePhotons: photons in index order (path by path), and for each traced index the
/// number of photons its path stored (so path j's photons follow those of paths 0 … j−1).
struct TraceOutput {
    std::vector<TracedPhoton> photons;
    std::vector<uint32_t> storedPerPath;
    TraceStats stats;
};

/// Traces the paths with Halton indices `indices` (in that order) and appends their caustic
/// photons to `out` (index order regardless of threads). A photon is stored at a diffuse hit iff
/// the path had a specular interaction since its last diffuse bounce; mirrors multiply by their
/// reflectance; dielectrics choose reflection with probability F (exact Fresnel, TIR) and
/// absorb exp(−σd) over distances travelled inside (hits on the back face); diffuse surfaces
/// continue (Russian roulette with p = max albedo, power × albedo/p, cosine-weighted) at most
/// diffuseBounces times. Non-finite paths are counted and dropped.
/// Thread-safe (reads `scene`); parallel over indices (TBB). Cost: O(|indices| · maxDepth) rays.
void tracePhotons(const EmbreeScene& scene, const PhotonSource& source,
                  const TraceSettings& settings, std::span<const uint64_t> indices,
                  TraceOutput& out);

/// Traces one path (no parallelism, no timing); appends stored photons to `out`, returns the
/// number stored, or −1 if the path was dropped as an anomaly. Used by tracePhotons and tests.
int tracePhotonPath(const EmbreeScene& scene, const PhotonSource& source,
                    const TraceSettings& settings, uint64_t index,
                    std::vector<TracedPhoton>& out, TraceStats& stats, bool timed = false);

}  // namespace rtpm
