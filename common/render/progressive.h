// Per-pixel progressive photon mapping for a still view: the consistent caustic estimator (DESIGN §9).
//
// Stochastic progressive photon mapping (Hachisuka & Jensen 2009) kept on the process that owns a
// set's pixels. Every diffuse end point of a pixel's eye path (EyeHit) carries a radius R, a
// photon count N and an accumulated flux τ (W, summed over batches). A restart (first frame,
// camera move, edit, set taken over) starts from the accumulated map's k-NN gather:
//   R₀² = r_k², N₀ = kRestartCountShare × photons found, τ₀ = Σ Φ_p over them × B₀ (B₀: the
// map's batch count), so the restart image is the map's k-NN image (the walkthrough answers at
// once, and convergence starts from it). N₀ is the evidence against shrinking R: counting all k
// found photons (N₀ = k) while a pass brings about as many (M ≈ k for B₀ = 1) holds the shrink
// factor (N + αM)/(N + M) near 1 for many passes. r_k is not a fixed radius the photons were
// counted in but one chosen by them, so the restart is weighted as a fraction of its photons;
// R₀² and τ₀/(π R₀² B₀) are unchanged, so the image stays continuous across the restart.
// Each pass then gathers only the new batch's M photons (Σ power Φ) within R:
//   N' = N + αM,  R'² = R² (N + αM)/(N + M),  τ' = (τ + Φ)(N + αM)/(N + M),
//   L_c = ρ/π · τ / (π R² (B₀ + t))   after t passes,
// which converges to the true caustic radiance (bias and variance → 0) as t grows. A pass costs
// O(hits · (log b + photons within R)) for a batch of b photons: independent of the map's size.
// Direct light from area lights converges too: each pass adds one more rotated sample set per
// hit (AreaLightSampler) to a running mean; the rest of the direct term is deterministic and
// kept from the restart.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/core/pixel_radiance.h"
#include "common/photon/photon_map.h"
#include "common/scene/scene.h"
#include "common/trace/eye_pass.h"

namespace rtpm {

/// Share of the restart's k-NN photons counted in N₀ (see above). On the curved-mirror
/// reference (tests/bench/ring_mirror_bench, α = 0.7) N₀ = k gave 0.0398 rel. MAE after 32
/// frames, N₀ = k/10 0.0371 and k/50 0.0367: below ~1/8 the first pass's photons dominate N.
inline constexpr double kRestartCountShare = 0.125;

/// The progressive state of one set's pixels. Not thread-safe; each call uses every core (TBB)
/// and its result does not depend on the thread count.
class ProgressiveSet {
public:
    /// True after a restart, until invalidate().
    bool valid() const { return valid_; }
    /// Forgets the state (camera or scene changed); the next frame restarts.
    void invalidate() { valid_ = false; }
    /// Camera of the current progression (meaningful when valid()).
    const Camera& camera() const { return camera_; }
    /// Passes since the restart (0 right after it).
    uint32_t passes() const { return passes_; }
    /// Diffuse end points held (for tests and figures).
    size_t hitCount() const { return records_.hits.size(); }

    /// Restart from a record-mode eye pass of `set` (`records`, and `out` with its direct values
    /// without the area-light term) and `maps`' accumulated map: fills `out` with the map's k-NN
    /// caustic and the eye pass's direct light. Cost: one k-NN gather per hit.
    void restart(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set, const Camera& camera,
                 EyeRecords records, std::span<PixelRadiance> out);
    /// One pass, after maps.shootPass(scene, set): gathers the pass's photons per hit, shrinks the
    /// radii, adds one area-light sample set per hit, and writes every pixel's current estimate
    /// to `out`. Precondition: valid(). Adds the shadow rays cast to `shadowRays`; counts
    /// non-finite pixel values (replaced by 0) in `nonFinite`.
    void pass(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set,
              const AreaLightSampler& areaLights, std::span<PixelRadiance> out, uint64_t& shadowRays,
              uint64_t& nonFinite);

private:
    struct HitState {
        double radius2 = 0.0;      ///< R² (m²)
        double count = 0.0;        ///< N
        glm::dvec3 flux{0.0};      ///< τ (W, summed over batches)
        glm::dvec3 areaSum{0.0};   ///< Σ area-light samples over passes 0 … t
    };
    void compose(std::span<PixelRadiance> out, uint64_t& nonFinite) const;

    bool valid_ = false;
    Camera camera_;
    uint32_t passes_ = 0;
    uint32_t batches0_ = 0;           ///< B₀: the map's batches at the restart
    EyeRecords records_;
    std::vector<HitState> state_;     ///< per hit
    std::vector<Vec3> fixedDirect_;   ///< per pixel: direct light but the area-light term
    float alpha_ = 0.7f;
};

}  // namespace rtpm
