// One process's share of rendering: the photon maps and progressions of owned sets over a shared scene and BVH.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "common/trace/embree_scene.h"
#include "common/photon/irradiance_points.h"
#include "common/photon/photon_map.h"
#include "common/core/frame_mode.h"
#include "common/core/render_settings.h"
#include "common/scene/scene_edit.h"
#include "common/render/progressive.h"
#include "common/render/render_scene.h"
#include "common/trace/eye_pass.h"
#include "common/image/frame_image.h"

namespace rtpm {

/// The pixels of one interleaving set for one frame, row-major within the set.
struct SetPixels {
    int set = 0;
    std::vector<PixelRadiance> pixels;
    /// Progressive passes of this set's current progression (0: a restart, or the knn estimator).
    uint32_t passes = 0;
    /// Progressive estimator: per pixel, the weight of its own caustic against the box filter in
    /// 255ths (progressive.h); empty for knn (the filter alone).
    std::vector<uint8_t> ownWeights;
    /// Progressive estimator: per pixel, the relative noise of its caustic in 64ths
    /// (ProgressiveSet::noise); empty for knn.
    std::vector<uint8_t> noise;
    /// Progressive estimator: the set's caustic error figures (progressive.h).
    CausticErrorSums error;
    /// Progressive estimator: the photons the set shot this frame, for the other sets' passes
    /// kSharedPhotonLag frames later (batches 0: none).
    SetPhotons shot;
    /// The pixels and own weights are this job's previous ones for the set, bit for bit (a pass
    /// off the set's turn, or a still knn view's set whose map did not change): a client sends
    /// none and names the frame that sent them (proto FrameData::unchanged).
    bool unchanged = false;
};

/// Writes one set's pixels into `image` with their own weights (scatterSet is what rtpm-render,
/// the tests and, from the wire, the master do).
void scatterSet(FrameImage& image, const Interleave& pattern, const SetPixels& pixels);

/// One set's eye paths of one camera and geometry without their lights (renderSet with
/// recordLights false: its records, and `base`, what the paths meet besides the lights), kept
/// across Relight frames and re-lit there (relightSet).
struct KeptEyePaths {
    std::optional<Camera> camera;  ///< none: nothing kept
    uint64_t eyeVersion = 0;       ///< RenderScene::eyeVersion when traced
    EyeRecords records;
    std::vector<Vec3> base;
};

/// One set's last k-NN pixels of an Accumulate or Walkthrough frame and what they were made of:
/// while the camera, the geometry and the set's map stay as they were (the set did not shoot: its
/// turn is another frame's, or its map is capped) the next frame's pixels are these, bit for
/// bit, and the set traces no eye ray. Cleared by every edit (RenderJob::resetPhotons).
struct ShownKnnPixels {
    std::optional<Camera> camera;  ///< none: nothing kept
    uint64_t eyeVersion = 0;       ///< RenderScene::eyeVersion when traced
    uint64_t pathsTraced = 0;      ///< the map's PhotonSetStats then
    uint64_t photonsStored = 0;
    std::vector<PixelRadiance> pixels;
};

/// The other sets' shots shared with one set while it was off its turn, which its next
/// progressive pass bins: one index per frame, built once and held by every set that waits for it.
using PendingShots = std::vector<std::shared_ptr<const SharedPhotons>>;

/// What one owned set keeps from frame to frame of one camera.
struct SetMemory {
    KeptEyePaths relight;  ///< Relight frames
    ShownKnnPixels shown;  ///< Accumulate and Walkthrough frames (k-NN estimator)
    PendingShots pending;  ///< Converging frames (progressive estimator)
};

/// Figures of one renderFrame call.
struct FrameStats {
    double shootSeconds = 0.0;     ///< photon shooting + kd-tree insertion, all owned sets
    double eyeSeconds = 0.0;       ///< eye pass (ray tracing + caustic lookups), all owned sets
    uint64_t photonsStored = 0;    ///< Σ over owned sets of photons in their maps
    uint64_t pathsTraced = 0;      ///< Σ over owned sets of paths traced since the last reset
    uint64_t pathsThisFrame = 0;   ///< paths traced in this frame
    bool walkthrough = false;      ///< a Walkthrough frame, or every owned set reached its cap
    bool converging = false;       ///< a progressive pass (no eye pass), for every owned set
    bool moving = false;           ///< progressive: the camera moved, caustics from irradiance points
    uint32_t passes = 0;           ///< progressive passes since the restart (largest over sets)
    /// Progressive: Σ over owned sets of the caustic error figures (progressive.h):
    /// causticErrorEstimate(error) is the estimator's own figure; above 0 it says the progressive
    /// estimator composed the frame, whose shown figure is then the shown caustic's change since a
    /// sixth of the progression's photons (common/image/shown_change.h).
    CausticErrorSums error;
    EyeStats eye;
};

/// Renders frames for a fixed list of interleaving sets. Used by rtpm-render (all sets) and by
/// each cluster client (its assigned sets, a job per set group), so both compute bit-identical
/// pixels for a set. The scene and its BVH are a RenderScene, which jobs of one process share.
/// Not thread-safe; each call uses every core through TBB.
class RenderJob {
public:
    /// A job over a shared scene (read only while a frame renders). Throws std::invalid_argument
    /// for bad settings or set ids.
    RenderJob(std::shared_ptr<RenderScene> scene, const RenderSettings& settings, std::vector<uint32_t> sets);
    /// A job with a scene of its own (rtpm-render, tests): builds the BVH.
    RenderJob(Scene scene, const RenderSettings& settings, std::vector<uint32_t> sets);
    ~RenderJob();

    /// Renders a frame of mode `mode` (the master's, from FrameBegin) into `out` (one entry per
    /// owned set, in ownership order; buffers are reused). Every mode but Walkthrough shoots one
    /// batch per owned set that has not reached its cap, then traces the set's pixels.
    /// Progressive estimator: in a Converging frame a set runs a pass instead (shootPass, no eye
    /// pass; docs/ARCHITECTURE.md §6.2) when it can: its progression holds the eye records of
    /// exactly `camera`, bit for bit. When `camera` differs from the previous frame's (a moving
    /// camera) the sets end their progressions, their caustics come from the maps' irradiance
    /// points (irradiance_points.h: a cost bounded whatever the map holds) and their eye paths
    /// sample dielectric splits (renderSet's sampleSeed, hashed from the camera). Any other set
    /// that cannot pass (the first frame, the first frame of a camera that stopped, the first
    /// still frame after an edit, a set that moved here), and every set in the other modes but
    /// Edit or Relight, restarts its progression from a record-mode eye pass and the accumulated
    /// map. A Relight frame traces each set's deterministic eye paths without lights once per
    /// camera and geometry (kept while only punctual lights change) and re-lights them
    /// (relightSet): the same image whether kept or traced now. An Edit or Relight frame starts none: it shows the map's k-NN estimate, as the knn estimator does, so
    /// that an edit per frame (a dragged light) costs a knn frame. The knn estimator has no passes:
    /// Converging shoots a batch as Accumulate does.
    /// `passBatches` (≥ 1): batches a progressive pass shoots (PassBudget); other frames shoot one.
    /// `passPeriod` (≥ 1): the sets take turns, a pass shooting only every passPeriod-th pass of
    /// its progression (passShoots; PassBudget::period); a pass off its set's turn shows the set's
    /// last pixels (ProgressiveSet::skip) and keeps the other sets' shots shared meanwhile for its
    /// next turn, so turns cost no photon. In an Accumulate frame a set shoots its batch only
    /// when passShoots(`frame`, set, M², passPeriod) (`frame`: the master's frame number) or its
    /// map holds no batch yet.
    /// A pass also bins every other set's shot of kSharedPhotonLag frames ago: `shared` when
    /// given (a cluster client: what the master forwarded, any sets), else the job's own record
    /// of its sets' shots (every set, in rtpm-render). Either must hold only photons shot since
    /// the last edit or reset.
    FrameStats renderFrame(const Camera& camera, FrameMode mode, std::vector<SetPixels>& out,
                           uint32_t passBatches = 1, const std::vector<SetPhotons>* shared = nullptr,
                           uint32_t passPeriod = 1, uint64_t frame = 0);
    /// The next frame without a master (rtpm-render, tests): the mode is decideFrameMode's over
    /// this job's own frames — the first one, and the first after applyEdit or resetPhotons, start
    /// an epoch (an Edit frame after applyEdit); a camera equal to the previous frame's is still; walkthrough is never asked. Its
    /// passes bin the job's own record of its sets' shots.
    FrameStats renderFrame(const Camera& camera, std::vector<SetPixels>& out, uint32_t passBatches = 1,
                           uint32_t passPeriod = 1);

    /// Applies an edit to the scene (RenderScene::applyEdit: throws SceneError if the index or a
    /// value is invalid; nothing changes then) and resets the photon maps. Other jobs sharing the
    /// scene must resetPhotons.
    void applyEdit(const SceneEdit& edit);
    /// Drops every photon; the next frame restarts accumulation.
    void resetPhotons();

    const Scene& scene() const { return scene_->scene(); }
    const RenderSettings& settings() const { return settings_; }
    const PhotonMaps& photons() const { return *photons_; }
    const EmbreeScene& embree() const { return scene_->embree(); }
    const std::vector<uint32_t>& sets() const { return sets_; }
    /// The moving camera's caustic estimator (its counters: the work of the moving frames).
    const IrradiancePoints& irradiance() const { return *irradiance_; }

private:
    /// Paths traced into the owned sets' maps so far.
    uint64_t pathsTraced() const;
    /// Indexes this frame's shared shots `sharedIn` (may be null) once, adds the index to the
    /// pending shots of every converging set off its turn (dropping those of the sets that do not
    /// converge), and hands each set on its turn its pending indexes and this frame's:
    /// `sharedFor[i]`, owned set i's indexes (empty when none), kept alive by `held` for the frame.
    /// With turns of p frames each shot is indexed once, not once per frame of the p (a merged
    /// index per list of frames changed every frame); a set shoots once per turn, so the trees a
    /// pass searches are as many as before.
    void indexPendingShots(const std::vector<SetPhotons>* sharedIn, const std::vector<uint8_t>& converge,
                           const std::vector<uint8_t>& passShot, PendingShots& held,
                           std::vector<std::vector<const SharedPhotons*>>& sharedFor);
    /// The pixels of owned set `i` at `camera` with the map's k-NN caustic: a Relight frame
    /// re-lights the set's KeptEyePaths (traced first when stale), an Edit frame samples the
    /// dielectric splits, any other traces them all, unless the set's ShownKnnPixels still hold.
    /// Returns true when the pixels are the set's kept ShownKnnPixels.
    bool knnPixels(size_t i, const Camera& camera, FrameMode mode, std::span<PixelRadiance> out, EyeStats& eye);

    std::shared_ptr<RenderScene> scene_;
    RenderSettings settings_;
    Interleave pattern_;
    std::vector<uint32_t> sets_;
    std::unique_ptr<PhotonMaps> photons_;
    std::vector<ProgressiveSet> progressive_;  ///< per owned set (progressive estimator)
    std::vector<SetMemory> kept_;              ///< per owned set (Relight, Accumulate frames)
    /// The owned sets' shots of the last kSharedPhotonLag frames, oldest first (renderFrame
    /// without `shared`).
    std::vector<std::vector<SetPhotons>> shots_;
    std::unique_ptr<AreaLightSampler> areaLights_;
    std::unique_ptr<IrradiancePoints> irradiance_;  ///< the moving camera's caustic estimator
    std::optional<Camera> lastCamera_;              ///< the previous frame's camera
    /// No frame since the job began or since applyEdit/resetPhotons (renderFrame without a mode).
    bool epochStart_ = true;
    /// applyEdit began the epoch (renderFrame without a mode: its first frame is an Edit frame).
    bool edited_ = false;
    /// Every edit since the last frame changed a punctual light (its first frame: Relight if still).
    bool relit_ = false;
    /// Frames this job rendered (renderFrame without a mode numbers its frames by it).
    uint64_t framesRendered_ = 0;
};

}  // namespace rtpm
