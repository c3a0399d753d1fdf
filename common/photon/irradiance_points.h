// Caustic irradiance precomputed at a bounded subset of each photon map's photons, looked up by a
// moving camera's frames instead of a k-NN gather per pixel (Christensen 1999, "Faster photon map
// global illumination").
//
// Once per map change (a reset, a replacement, a doubling of its batches: needsRebuild), every
// n-th photon of a set's map in the index's leaf order (a spatially stratified subset: leaf order
// follows the tree's cells) becomes a point, with n = max(kPointStride, ⌈N / kMaxPoints⌉): every 4th photon of a small map,
// kMaxPoints points of a large one. Each point gets the map's k-NN disc at its photon
// (PhotonMaps::gatherMap, the disc the knn estimator draws at an eye hit there), the flux within
// it and within its inner half, and the shading normal of the surface the photon lies on (one
// short ray). A caustic query at an eye hit then averages the irradiance of the kLookupPoints
// nearest points facing its normal whose k-NN disc holds it, each weighed by the kernel of that
// disc (1 − d²/r²), within the map's gather radius: a
// search over at most kMaxPoints points, whatever the map holds. So a frame's
// caustic work is bounded by kMaxPoints k-NN gathers per set and map change plus one small
// nearest-point search per eye hit, where the k-NN gather per hit grows with the map's density
// (its radius search of the photons within rMax fills as the map grows) and the progressive
// restart gathers kOuterArea · k photons per hit.
// A point's estimate is the whole disc's where the inner half and the ring around it agree within
// their photon noise, the inner half's where they differ (sharpness: a gradient the whole disc
// would blur), blended between: a lookup's average over 4 points takes out much of the noise
// the inner disc adds. On the curved mirror's moving caustic the whole disc everywhere read 1–3 %
// farther from the reference than the gather per pixel at frames 2–7, the inner half everywhere
// 11–16 % closer at every frame but 20–30 % farther than the whole disc on the glass slab's
// smooth caustic; chosen per point, 6.5–18 % closer than the gather on the curved mirror at every
// frame and at most 6.3 % farther than the whole disc on the glass caustics
// (tests/bench/RESULTS.md).
// Between rebuilds each point takes in every batch its map gains (PhotonMaps::lastBatch: one
// radius search per point in a tree of the batch's photons): the flux within its estimate's disc
// and within the inner disc of half that area, over all batches held. A k-NN disc of the
// grown map would have about built/held of the area it had at the build, and a kernel's blur
// grows with its area, so the point shows the two discs' estimates blended to that share of its
// own disc (blendedIrradiance). Rebuilt only at the doublings, a moving camera's caustic read
// 8–12 % farther from the reference than the k-NN gather per pixel at frames 12–31 (the points'
// disc up to twice the gather's area); taking in the batches costs 2–2.5 % more CPU a frame on
// RING's orbit.
// The image is the k-NN estimate blurred by the points' spacing: measured figures (speed, error
// against knn on the curved-mirror reference) are in tests/bench/RESULTS.md.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/photon/kd_tree.h"
#include "common/photon/photon_map.h"
#include "common/trace/caustic_estimator.h"

namespace rtpm {

/// A map's points are every kPointStride-th photon while that gives at most kMaxPoints.
inline constexpr uint32_t kPointStride = 4;
/// The most points one set's map gets: the bound on a rebuild's k-NN gathers and on the size of
/// the tree a lookup searches.
inline constexpr uint32_t kMaxPoints = 8192;
/// Points averaged per lookup.
inline constexpr uint32_t kLookupPoints = 4;
/// A growing map's points are rebuilt once its batch count doubled since they were built, not at
/// every batch: a camera orbiting while the photons accumulate would otherwise pay up to
/// kMaxPoints k-NN gathers per set in every frame (HEADLIGHT, whose dense map made each frame's
/// eye pass 0.8–1 s). Points are per-batch irradiance, and between rebuilds they take in each
/// new batch (update), so a lagging rebuild costs only the blur their discs' fixed radii leave
/// (blendedIrradiance), never a wrong level.
inline constexpr uint32_t kRebuildGrowth = 2;
/// The doublings of each set are offset by a phase of its own, so the sets of an orbit, which all
/// gain a batch a frame, rebuild in different frames: set s at ⌈2^j · (16 + φ)/16⌉ batches, φ =
/// 7s mod 16 (distinct for up to 16 sets, spread over the doubling for any M). Rebuilt together,
/// RING's nine sets added 175 ms of CPU to frame 127 of an orbit (one frame of 2.4 × the others),
/// an 8-frame dip of the cluster to 9.4 fps; spread, a doubling's rebuilds fall one or two sets a
/// frame.
inline constexpr uint32_t kRebuildPhases = 16;
inline constexpr uint32_t kRebuildPhaseStep = 7;

/// The first batch count above `builtBatches` at which `set`'s points are rebuilt as its map grows.
constexpr uint64_t nextRebuild(uint32_t builtBatches, uint32_t set) {
    const uint64_t scale = kRebuildPhases + (uint64_t(set) * kRebuildPhaseStep) % kRebuildPhases;
    uint64_t doubling = 1;
    while ((doubling * scale + kRebuildPhases - 1) / kRebuildPhases <= builtBatches) doubling *= kRebuildGrowth;
    return (doubling * scale + kRebuildPhases - 1) / kRebuildPhases;
}

/// Whether `set`'s points built from a map of `builtBatches` batches and `builtPhotons` photons
/// are rebuilt for the map as it is now: when it was reset or replaced (fewer batches, or the same
/// batches with other photons) or grew to nextRebuild's count.
constexpr bool needsRebuild(uint32_t builtBatches, uint64_t builtPhotons, uint32_t batches, uint64_t photons,
                            uint32_t set) {
    if (batches < builtBatches || builtBatches == 0) return batches != builtBatches || photons != builtPhotons;
    if (batches == builtBatches) return photons != builtPhotons;
    return batches >= nextRebuild(builtBatches, set);
}

/// Counters of the work done (added to, never reset but by resetCounters; thread-safe).
struct IrradiancePointCounts {
    uint64_t gathers = 0;     ///< k-NN gathers over photon maps (one per point built)
    uint64_t lookups = 0;     ///< caustic queries answered
    uint64_t candidates = 0;  ///< points a lookup's search offered to its result set
};

/// Irradiance points of the owned sets of a PhotonMaps; a CausticEstimator answering from them.
/// update() and invalidate() need exclusive access; radiance() may run concurrently with itself.
class IrradiancePoints : public CausticEstimator {
public:
    explicit IrradiancePoints(std::vector<uint32_t> sets);
    ~IrradiancePoints() override;

    /// Rebuilds `set`'s points when its map changed since they were built (needsRebuild: reset,
    /// replaced, or grown to nextRebuild's batches; or invalidate() was called); else, when the
    /// map gained one batch by shootBatch since the last update, adds its photons to every
    /// point (one radius search per point in a tree of the batch; none with gatherVisibility,
    /// whose test needs the scene at each point: the points then keep the batches they hold).
    /// `scene` is the one the photons were shot in. Cost of a rebuild: up to kMaxPoints k-NN
    /// gathers, as many radius searches of half their discs and short rays, O(points log points)
    /// to build their tree; nothing when the map did not change. Parallel (TBB); the points do
    /// not depend on the thread count.
    void update(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set);
    /// Forgets every set's points (the maps were reset: the next update rebuilds).
    void invalidate();
    /// Points of `set` (0 before its first update or for a set not owned).
    size_t pointCount(uint32_t set) const;

    /// Caustic radiance ρ/π · Ē at `hit`, Ē the mean irradiance of the kLookupPoints nearest
    /// points of `set` within the map's gather radius whose normal faces `normal` (fewer when
    /// fewer lie there; 0 when none). `hint` (GatherHint::lastReach) bounds the search from the
    /// previous query's points; the answer is the same without it. Thread-safe.
    Vec3 radiance(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit, Vec3 normal,
                  Vec3 albedo, GatherHint* hint = nullptr) const override;
    /// `radiance` for each of `queries` (the counters are added once per group). Thread-safe.
    void radianceGroup(const EmbreeScene& scene, uint32_t set, std::span<const CausticQuery> queries,
                       std::span<Vec3> out, GatherHint* hint = nullptr) const override;

    IrradiancePointCounts counts() const;
    void resetCounters();

private:
    struct SetPoints;
    const SetPoints* find(uint32_t set) const;
    /// Adds the map's last batch (PhotonMaps::lastBatch) to every point's flux within its
    /// estimate's disc.
    static void addBatch(SetPoints& sp, const PhotonMaps& maps, uint32_t set);
    static Vec3 lookup(const SetPoints& sp, Vec3 position, Vec3 normal, Vec3 albedo, uint64_t& offered,
                       GatherHint* hint);
    std::vector<uint32_t> sets_;
    std::vector<std::unique_ptr<SetPoints>> points_;
    mutable std::atomic<uint64_t> gathers_{0}, lookups_{0}, candidates_{0};
};

}  // namespace rtpm
