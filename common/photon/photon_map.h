// Per-interleaving-set caustic photon maps: batch shooting (plain or SPT), accumulation, lookup.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string_view>
#include <span>
#include <vector>

#include "common/core/render_settings.h"
#include "common/trace/caustic_estimator.h"
#include "common/photon/density.h"
#include "common/photon/photon_index.h"
#include "common/photon/photon_occupancy.h"
#include "common/photon/photon_tracer.h"
#include "common/photon/shared_photons.h"

namespace rtpm {

/// A set stops shooting after this many traced paths per capped photon (see capPhotons).
inline constexpr uint64_t kCapPathsPerPhoton = 64;
/// Upper bound on SPT refinements per cell and batch (bounds structured noise from few pilots).
inline constexpr uint32_t kMaxSptRefinements = 64;

/// Selective Photon Tracing's figures of the last batch (all 0 without SPT).
struct SptBatchStats {
    uint64_t cells = 0;         ///< Σ over lights of N_g
    uint64_t refinedCells = 0;  ///< boxes refined (Σ over lights)
    uint32_t refinements = 0;   ///< R (largest over lights)
};

/// Where a set's shooting time went, in seconds summed over batches. `trace` is the tracing wall
/// time; `sampling`, `rayCast` and `interaction` split it as in paper Table 3 (light sampling / ray
/// casting / surface interaction), estimated from timed sample paths (1 in kTimedPathStride)
/// scaled to the measured wall time.
struct PhotonPhaseSeconds {
    double trace = 0.0;
    double sampling = 0.0;
    double rayCast = 0.0;
    double interaction = 0.0;
    double insert = 0.0;  ///< kd-tree insertion (median tree, grid: the rebuild)
};

/// Figures of one interleaving set's photon map since the last reset.
struct PhotonSetStats {
    uint32_t batches = 0;          ///< batches in the map (the accumulation count)
    uint32_t passes = 0;           ///< progressive passes shot (shootPass), in the map or not
    uint32_t pendingBatches = 0;   ///< passes kept for the map, inserted at the next flushPasses
    uint64_t pathsTraced = 0;      ///< light paths traced: pilots, refinements, classification
    uint64_t productivePaths = 0;  ///< paths that stored ≥ 1 caustic photon
    uint64_t photonsStored = 0;    ///< photons in the map
    uint64_t raysCast = 0;         ///< closest-hit queries issued while shooting
    uint64_t anomalies = 0;        ///< paths dropped for a non-finite power or direction
    SptBatchStats spt;             ///< of the last batch
    PhotonPhaseSeconds seconds;    ///< summed over batches
    /// Caustic yield: productive paths / traced paths (paper Table 4).
    double yield() const {
        return pathsTraced ? static_cast<double>(productivePaths) / static_cast<double>(pathsTraced)
                           : 0.0;
    }
};

/// One caustic photon map per owned interleaving set, grown batch by batch.
/// Photon powers are stored relative to one batch; `radiance` divides by the batch count
/// (docs/ARCHITECTURE.md §5.3), so the estimate is consistent at every accumulation stage.
/// Stored powers are also in units of powerUnit() (not W): the RGB9E5 code has relative
/// precision only over a fixed range (photon.cpp), and a photon's power in W scales with the
/// scene (a 1 mm scene with the same irradiance has 10⁻⁶ × the flux). Relative to the unit,
/// stored values are below 2 and only SPT weights, absorption and colour make them smaller.
/// Read photon powers in W through powerWatts() / storedPowerPerBatch(), never powerRgb().
/// A batch runs in four stages per light: plan (the Halton indices and path power; SPT chooses
/// them from the previous batch's outcomes), trace, weight (SPT refinement shares) and insert.
/// Thread safety: `radiance` may be called concurrently; after `prepare(scene)`, shootBatch,
/// shootPass and flushPasses of *different* sets may run concurrently with each other; `reset`
/// and `prepare` must not overlap any other call. `shootBatch` itself runs in parallel (TBB)
/// and its result does not depend on the thread count.
class PhotonMaps : public CausticEstimator {
public:
    /// `ownedSets`: interleaving set ids this process renders (distinct).
    PhotonMaps(const PhotonSettings& settings, std::vector<uint32_t> ownedSets);
    ~PhotonMaps() override;

    /// Shoots the next batch of `set` (batch number = batches shot so far since the reset) into
    /// its map. The first batch after a reset takes the lights and bounds from `scene`; the scene
    /// must not change between batches without a reset. No-op when the set reached its cap.
    /// Cost: O(photonsPerBatch · maxDepth) ray casts + O(stored · log) insertion.
    void shootBatch(const EmbreeScene& scene, uint32_t set);
    /// A progressive pass of `set` (docs/ARCHITECTURE.md §6.2): shoots its next batch even when the
    /// set is capped and keeps the batch alone as the set's pass index (passTree), replacing the
    /// previous pass. Unless the set is capped, the batch is also kept for the map (up to the
    /// cap) and inserted by the next flushPasses, so a pass costs the batch's tracing and an
    /// O(b log b) build, independent of the map's size.
    /// `batches` > 1 makes one pass of that many consecutive batches (the same photons the
    /// batches would shoot one by one; a still view's growing passes).
    void shootPass(const EmbreeScene& scene, uint32_t set, uint32_t batches = 1);
    /// Inserts the photons of the passes since the last flush into `set`'s map as that many
    /// batches (the map then holds what batch-by-batch shooting would have stored, in another
    /// order). Call when a progression ends, before the map answers a query (a restart);
    /// shootBatch calls it. Cost: one insertion, O(stored + pending).
    void flushPasses(uint32_t set);
    /// Forgets every photon and restarts every set's sequence (scene edit: geometry, light,
    /// material). Settings changes other than k also need a reset.
    void reset();
    /// True when every owned set reached its cap: no more shooting, only queries.
    bool walkthrough() const;
    /// True when `set` reached its cap.
    bool capped(uint32_t set) const;

    /// Caustic radiance L_c = ρ/π · Σ Φ_p/(π r_k²) / batches at `hit` from `set`'s map
    /// (density.h causticRadiance with powerScale = powerUnit() / batches; photons from behind
    /// `normal` are ignored). `scene` is the one the photons were shot in; it is read only with
    /// settings().gatherVisibility (one shadow ray per gathered photon). Zero for a set that is
    /// not owned or has no batch yet. Thread-safe; a thread_local heap avoids allocation.
    /// With a `hint`, the k-NN search first tries a bound of 1.25 × the hint's r² (density.h
    /// gatherKnn's guess: same result, found sooner when neighbouring pixels see similar
    /// densities) and leaves this estimate's r² in it.
    Vec3 radiance(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit, Vec3 normal,
                  Vec3 albedo, GatherHint* hint = nullptr) const override;

    /// `radiance` for a group of nearby hits (one primary-ray packet's diffuse hits): density.h
    /// gatherKnnGroup shares one radius search between them (group_gather.h), with the same
    /// photons, radius and power per hit as `radiance`. The hint carries the group's largest r²
    /// to the next group. With gatherVisibility each hit is gathered alone. Thread-safe.
    void radianceGroup(const EmbreeScene& scene, uint32_t set, std::span<const CausticQuery> queries,
                       std::span<Vec3> out, GatherHint* hint = nullptr) const override;

    /// The k-NN gather `radiance` makes, unconverted: power in W per batch (Σ stored power ×
    /// powerUnit() / batches), r_k² and the photon count. Empty (radius2 = 0) when nothing can
    /// be estimated. Thread-safe.
    DensityGather gatherMap(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit,
                            Vec3 normal) const;
    /// gatherMap for a group of nearby hits (gatherKnnGroup: same photons, radius and power per
    /// hit), `hint` carried as in radianceGroup. `out` has the size of `queries`. Thread-safe.
    void gatherMapGroup(const EmbreeScene& scene, uint32_t set, std::span<const CausticQuery> queries,
                        std::span<DensityGather> out, GatherHint* hint = nullptr) const;

    /// What `set` traced in its last shootBatch or shootPass since the previous takeShot, for
    /// the other sets (SharedPhotons): the leading whole batches holding at most setShareCap
    /// photons (batches 0 and no photon when nothing, when they stored no photon, or when one
    /// batch holds more).
    SetPhotons takeShot(uint32_t set);
    /// The photons `set`'s last shootBatch inserted into its map as its batch number
    /// stats(set).batches, as it inserted them (stored powers, in the maps' power unit); empty
    /// when the map's last batch came otherwise (passes flushed, a reset) or stored no photon.
    /// Valid until the set's next shootBatch, shootPass, flushPasses or reset.
    std::span<const Photon> lastBatch(uint32_t set) const;
    /// Photons per set and frame takeShot hands over at most (default: no limit).
    void setShareCap(size_t photons) { shareCap_ = photons; }
    /// The same over `set`'s accumulated map (any index variant); powers in W per batch of the
    /// map (sum them and divide by the returned batch count for the flux of one batch).
    uint32_t gatherMapPhotons(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit, Vec3 normal,
                              float radius2, std::vector<FoundPhoton>& out) const;
    /// gatherMapPhotons within `reach2` (0 or at least rMax²: just beyond rMax², all of rMax) and,
    /// from the same photons, the k-NN radius and count gatherMap finds (power not summed): r_k²
    /// (at least the index's minimum density radius²) and k when k photons lie within reach and
    /// rMax; else a second search over all of rMax, whose photons replace the first's in `out`,
    /// and rMax² with the count strictly within it (an empty gather when none). `reach2` returns
    /// the squared radius `out` holds every photon strictly within.
    /// One radius search where a caller needs the k-NN disc and the photons around it (the
    /// progressive restart) instead of a k-NN search and a radius search. Thread-safe.
    DensityGather gatherMapKnnWithin(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit, Vec3 normal,
                                     float& reach2, std::vector<FoundPhoton>& out) const;

    /// Batches in `set`'s last progressive pass (0 before its first pass).
    uint32_t passBatches(uint32_t set) const;
    /// The tree of `set`'s last progressive pass's photons (null before its first pass), for a
    /// caller's own radius search (ProgressiveSet::binWithin). Stored powers in units of
    /// powerUnit().
    const KdTree* passTree(uint32_t set) const;

    const PhotonSettings& settings() const { return settings_; }
    /// Changes k (no reset needed: the stored photons do not depend on k).
    void setK(uint32_t k) { settings_.k = k; }
    const std::vector<uint32_t>& ownedSets() const { return ownedSets_; }
    /// Stats of an owned set. Precondition: `set` is owned.
    const PhotonSetStats& stats(uint32_t set) const;
    /// The index of an owned set if it is an `Index` (KdTree, MedianKdTree, PhotonGrid: the
    /// variant settings().tree selects), else null; null before the set's first batch.
    /// Precondition: `set` is owned. Stored photon powers are in units of powerUnit().
    template <class Index>
    const Index* index(uint32_t set) const {
        const PhotonIndex* i = indexOf(set);
        return i ? i->get<Index>() : nullptr;
    }
    /// The index of an owned set whatever its variant; null before its first batch.
    const PhotonIndex* indexOf(uint32_t set) const;
    /// Copy of every photon of an owned set's map, any variant (powers in units of powerUnit()).
    /// O(photons); for tests and tools.
    std::vector<Photon> photons(uint32_t set) const;

    /// W per unit of stored photon power: a power of two (so dividing by it is exact), fixed at
    /// the first batch after a reset: the largest initial path power of any light's first batch
    /// (Φ_l / P_l plain, Φ_l / N_g SPT; largest channel) rounded down to a power of two. 1 before.
    float powerUnit() const { return powerUnit_; }
    /// A stored photon's power in W (per batch, like the stored value).
    Vec3 powerWatts(const Photon& p) const { return p.powerRgb() * powerUnit_; }
    /// Σ stored photon power of an owned set in W divided by its batch count: the flux per batch
    /// the density estimate integrates. 0 before the first batch. O(photons), double sums.
    Vec3 storedPowerPerBatch(uint32_t set) const;
    /// Gather radius in use (metres): settings.rMax or the automatic one of the last scene.
    float gatherRadius() const { return rMax_; }

    /// Emitters, gather radius and power unit from `scene`, once after a reset (later calls do
    /// nothing). The first batch calls it; call it first to shoot several sets concurrently.
    void prepare(const EmbreeScene& scene);

private:
    struct LightSequence;
    struct LightPlan;
    struct SetState;
    SetState* find(uint32_t set);
    const SetState* find(uint32_t set) const;

    /// Plan, trace and weight stages of `state`'s next batch (stored units); advances its
    /// sequences and counters, but inserts nothing.
    std::vector<Photon> traceBatch(const EmbreeScene& scene, SetState& state);
    /// Insert stage: the batch into the set's map; updates the count and the cap.
    void insertBatch(SetState& state, std::span<const Photon> batch);
    /// Plan stage, first SPT batch only: traces one pilot period (not stored) to choose the
    /// refine set; adds its cost to `traced`.
    void probeRefineSet(const EmbreeScene& scene, const TraceSettings& ts, const PhotonSource& source,
                        LightSequence& ls, TraceStats& traced) const;
    /// Plan stage: the indices and path power of light `e`'s next batch (`budget` paths);
    /// advances a plain sequence.
    LightPlan planLight(LightSequence& ls, const Emitter& e, uint64_t budget) const;
    /// Weight stage: members of refined SPT boxes share their box's power (× 1/(1+R)).
    static void weightRefinedBoxes(const LightPlan& plan, const LightSequence& ls, TraceOutput& out);
    /// The next batch's refine set from this batch's outcomes; advances an SPT sequence.
    static void advanceLight(const LightPlan& plan, const TraceOutput& out, LightSequence& ls);
    /// The k-NN gathers of `queries` from `st`'s map into `out`, in stored units per batch
    /// (power not yet scaled): the occupancy test, then gatherKnnGroup; updates `hint`.
    void gatherGroup(const SetState& st, std::span<const CausticQuery> queries, std::span<DensityGather> out,
                     GatherHint* hint) const;
    /// Traced photons → stored photons in units of powerUnit(), appended to `batch`.
    void toStored(const TraceOutput& out, std::vector<Photon>& batch) const;

    PhotonSettings settings_;
    std::vector<uint32_t> ownedSets_;
    std::vector<std::unique_ptr<SetState>> sets_;
    std::vector<Emitter> emitters_;  ///< built at the first batch after a reset
    bool emittersReady_ = false;
    float rMax_ = 0.0f;
    float powerUnit_ = 1.0f;
    size_t shareCap_ = SIZE_MAX;  ///< setShareCap
    /// Only the progressive estimator's passes bin other sets' shots: knn keeps no copy.
    bool sharesShots() const { return settings_.estimator == CausticEstimatorKind::Progressive; }
};

}  // namespace rtpm
