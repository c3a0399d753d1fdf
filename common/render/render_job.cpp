// RenderJob: per frame, shoot a photon batch per owned set, then trace that set's pixels.
#include "common/render/render_job.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>

#include "common/core/check.h"
#include "common/core/halton.h"
#include "common/render/pass_budget.h"

namespace rtpm {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Bitwise equality: a progression continues only for exactly the camera it started with.
bool sameCamera(const Camera& a, const Camera& b) {
    const float va[10] = {a.position.x, a.position.y, a.position.z, a.forward.x, a.forward.y,
                          a.forward.z,  a.up.x,       a.up.y,       a.up.z,      a.yfov};
    const float vb[10] = {b.position.x, b.position.y, b.position.z, b.forward.x, b.forward.y,
                          b.forward.z,  b.up.x,       b.up.y,       b.up.z,      b.yfov};
    return std::memcmp(va, vb, sizeof(va)) == 0;
}

// The sampled splits' seed of a moving frame (renderSet): a hash of the camera's bits, so every
// process that renders the frame draws the same numbers; never 0 (deterministic splitting).
uint64_t sampleSeedOf(const Camera& c) {
    uint32_t bits[10];
    const float v[10] = {c.position.x, c.position.y, c.position.z, c.forward.x, c.forward.y,
                         c.forward.z,  c.up.x,       c.up.y,       c.up.z,      c.yfov};
    std::memcpy(bits, v, sizeof(v));
    const uint64_t h = hashKeys(uint64_t(bits[0]) << 32 | bits[1], uint64_t(bits[2]) << 32 | bits[3],
                                uint64_t(bits[4]) << 32 | bits[5], uint64_t(bits[6]) << 32 | bits[7],
                                uint64_t(bits[8]) << 32 | bits[9]);
    return h != 0 ? h : 1;
}

}  // namespace

RenderJob::RenderJob(std::shared_ptr<RenderScene> scene, const RenderSettings& settings, std::vector<uint32_t> sets)
    : scene_(std::move(scene)), settings_(settings), sets_(std::move(sets)) {
    RTPM_CHECK(scene_ != nullptr);
    validateSettings(settings_);
    pattern_ = Interleave{settings_.width, settings_.height, settings_.interleave};
    for (uint32_t s : sets_)
        if (s >= uint32_t(pattern_.setCount()))
            throw std::invalid_argument("set " + std::to_string(s) + " out of range for M = " +
                                        std::to_string(settings_.interleave));
    photons_ = std::make_unique<PhotonMaps>(settings_.photons, sets_);
    photons_->setShareCap(kSharedPhotonBudget / size_t(pattern_.setCount()));
    progressive_.resize(sets_.size());
    kept_.resize(sets_.size());
    irradiance_ = std::make_unique<IrradiancePoints>(sets_);
}

RenderJob::RenderJob(Scene scene, const RenderSettings& settings, std::vector<uint32_t> sets)
    : RenderJob(std::make_shared<RenderScene>(std::move(scene)), settings, std::move(sets)) {}

RenderJob::~RenderJob() = default;

FrameStats RenderJob::renderFrame(const Camera& camera, std::vector<SetPixels>& out, uint32_t passBatches,
                                  uint32_t passPeriod) {
    FrameFacts facts;
    facts.epochStart = epochStart_;
    facts.edited = edited_;
    facts.relit = relit_;
    facts.cameraStill = lastCamera_ && sameCamera(*lastCamera_, camera);
    facts.progressive = settings_.photons.estimator == CausticEstimatorKind::Progressive;
    return renderFrame(camera, decideFrameMode(facts), out, passBatches, nullptr, passPeriod, framesRendered_);
}

FrameStats RenderJob::renderFrame(const Camera& camera, FrameMode mode, std::vector<SetPixels>& out,
                                  uint32_t passBatches, const std::vector<SetPhotons>* shared, uint32_t passPeriod,
                                  uint64_t frame) {
    RTPM_CHECK(passBatches >= 1 && passPeriod >= 1);
    const EmbreeScene& embree = scene_->embree();
    FrameStats stats;
    const auto t0 = std::chrono::steady_clock::now();
    const uint64_t pathsBefore = pathsTraced();
    const bool progressive = settings_.photons.estimator == CausticEstimatorKind::Progressive;
    const bool shoot = mode != FrameMode::Walkthrough;
    // A moving camera (another camera than the previous frame's) ends every progression: its
    // frames take their caustics from the irradiance points, and the first frame of a camera
    // that stopped restarts (docs/ARCHITECTURE.md §6.2).
    const bool moving = progressive && lastCamera_ && !sameCamera(*lastCamera_, camera);
    // An Edit frame shows the map's k-NN estimate and starts no progression (the next still
    // frame restarts): an edit being dragged costs a knn frame per frame, not a restart's gathers.
    const bool edit = progressive && (mode == FrameMode::Edit || mode == FrameMode::Relight);
    lastCamera_ = camera;
    epochStart_ = false;
    edited_ = false;
    relit_ = false;
    ++framesRendered_;
    // A pass gathers at the progression's eye records: they must be of this very camera. It shoots
    // only on its set's turn (passShoots over the progression's pass count, which every process
    // rendering the set counts alike). In an Accumulate frame the sets take turns by the frame
    // number (a set whose map holds no batch yet shoots at once, to show caustics from its first).
    const uint32_t setCount = uint32_t(pattern_.setCount());
    std::vector<uint8_t> converge(sets_.size(), 0), passShot(sets_.size(), 0), batchShot(sets_.size(), 0);
    for (size_t i = 0; i < sets_.size(); ++i) {
        if (moving) {
            progressive_[i].invalidate();
            kept_[i] = SetMemory{};  // of another camera: its memory back
        }
        converge[i] = progressive && mode == FrameMode::Converging && progressive_[i].valid() &&
                      sameCamera(progressive_[i].camera(), camera);
        passShot[i] = converge[i] && passShoots(progressive_[i].passes() + 1, sets_[i], setCount, passPeriod);
        batchShot[i] = shoot && !converge[i] &&
                       (mode != FrameMode::Accumulate || photons_->stats(sets_[i]).batches == 0 ||
                        passShoots(frame, sets_[i], setCount, passPeriod));
    }
    // Sets shoot and insert concurrently (a batch's tracing is parallel inside, its kd-tree
    // insertion is not: with several sets per process both cores stay busy through insertion).
    // Each set's photons depend only on its own sequence, so the maps are the same in any order.
    if (shoot) photons_->prepare(embree);
    tbb::parallel_for(size_t(0), sets_.size(), [&](size_t i) {
        if (converge[i]) {
            if (passShot[i]) photons_->shootPass(embree, sets_[i], passBatches);
        } else if (batchShot[i])
            photons_->shootBatch(embree, sets_[i]);  // flushes the ended progression's passes
        else
            photons_->flushPasses(sets_[i]);
    });
    stats.shootSeconds = secondsSince(t0);

    // The other sets' shots of kSharedPhotonLag frames ago, for this frame's passes (indexing them
    // counts in the eye pass's time); a set off its turn keeps them for its next: turns cost no photon.
    const auto t1 = std::chrono::steady_clock::now();
    const std::vector<SetPhotons>* sharedIn = !shared && shots_.size() == kSharedPhotonLag ? &shots_.front() : shared;
    PendingShots sharedHeld;
    std::vector<std::vector<const SharedPhotons*>> sharedFor;
    indexPendingShots(sharedIn, converge, passShot, sharedHeld, sharedFor);

    out.resize(sets_.size());
    stats.converging = !sets_.empty();
    for (size_t i = 0; i < sets_.size(); ++i) {
        const int set = int(sets_[i]);
        out[i].set = set;
        out[i].pixels.resize(size_t(pattern_.pixelCount(set)));
        out[i].unchanged = converge[i] && !passShot[i];
        if (out[i].unchanged) {
            progressive_[i].skip(out[i].pixels);
        } else if (converge[i]) {
            if (!areaLights_) areaLights_ = std::make_unique<AreaLightSampler>(embree, settings_.eye);
            progressive_[i].pass(embree, *photons_, sets_[i], sharedFor[i], *areaLights_, out[i].pixels,
                                 stats.eye.shadowRays, stats.eye.nonFinite);
        } else if (moving) {
            irradiance_->update(embree, *photons_, sets_[i]);
            renderSet(embree, camera, settings_.eye, pattern_, set, irradiance_.get(), out[i].pixels,
                      &stats.eye, nullptr, sampleSeedOf(camera));
        } else if (progressive && !edit) {
            EyeRecords records;
            renderSet(embree, camera, settings_.eye, pattern_, set, nullptr, out[i].pixels,
                      &stats.eye, &records);
            const double f = double(settings_.filterSize());
            progressive_[i].setFilterShare(1.0 / (f * f));
            progressive_[i].setImage(pattern_.m, settings_.filterSize(), pattern_.setColumns(set));
            progressive_[i].restart(embree, *photons_, sets_[i], camera, std::move(records), out[i].pixels);
        } else {
            out[i].unchanged = knnPixels(i, camera, mode, out[i].pixels, stats.eye);
        }
        const bool progression = progressive && !moving && !edit;
        out[i].passes = progression ? progressive_[i].passes() : 0;
        out[i].ownWeights = progression ? progressive_[i].ownWeights() : std::vector<uint8_t>{};
        out[i].noise = progression ? progressive_[i].noise() : std::vector<uint8_t>{};
        out[i].error = progression ? progressive_[i].errorSums() : CausticErrorSums{};
        out[i].shot = progressive ? photons_->takeShot(sets_[i]) : SetPhotons{sets_[i], 0, {}};
        stats.error += out[i].error;
        stats.passes = std::max(stats.passes, out[i].passes);
        stats.converging = stats.converging && converge[i];
    }
    stats.eyeSeconds = secondsSince(t1);
    stats.moving = moving;

    for (uint32_t s : sets_) {
        stats.photonsStored += photons_->stats(s).photonsStored;
        stats.pathsTraced += photons_->stats(s).pathsTraced;
    }
    stats.pathsThisFrame = stats.pathsTraced - std::min(stats.pathsTraced, pathsBefore);
    if (!shared && progressive) {
        if (shots_.size() == kSharedPhotonLag) shots_.erase(shots_.begin());
        std::vector<SetPhotons>& latest = shots_.emplace_back();
        for (const SetPixels& p : out)
            if (p.shot.batches > 0) latest.push_back(p.shot);
    }
    stats.walkthrough = !shoot || photons_->walkthrough();
    return stats;
}

uint64_t RenderJob::pathsTraced() const {
    uint64_t paths = 0;
    for (uint32_t s : sets_) paths += photons_->stats(s).pathsTraced;
    return paths;
}

void scatterSet(FrameImage& image, const Interleave& pattern, const SetPixels& pixels) {
    if (pixels.ownWeights.empty()) image.scatter(pattern, pixels.set, pixels.pixels);
    else image.scatter(pattern, pixels.set, pixels.pixels, pixels.ownWeights, pixels.noise);
}

void RenderJob::applyEdit(const SceneEdit& edit) {
    scene_->applyEdit(edit);
    resetPhotons();
    relit_ = (edited_ ? relit_ : true) && edit.kind == SceneEdit::Kind::Light;
    edited_ = true;
}

bool RenderJob::knnPixels(size_t i, const Camera& camera, FrameMode mode, std::span<PixelRadiance> out,
                          EyeStats& eye) {
    const EmbreeScene& embree = scene_->embree();
    const int set = int(sets_[i]);
    if (mode == FrameMode::Accumulate || mode == FrameMode::Walkthrough) {
        // A set whose map did not change since its last frame of this camera (off its turn, or
        // capped) shows the same pixels: renderSet of a still camera draws no random number.
        // A moving camera's pixels are not kept (the next frame's camera is another): only from
        // a camera's second frame on.
        ShownKnnPixels& shown = kept_[i].shown;
        const PhotonSetStats& map = photons_->stats(sets_[i]);
        const bool still = shown.camera && sameCamera(*shown.camera, camera);
        if (still && shown.eyeVersion == scene_->eyeVersion() && shown.pathsTraced == map.pathsTraced &&
            shown.photonsStored == map.photonsStored && shown.pixels.size() == out.size()) {
            std::copy(shown.pixels.begin(), shown.pixels.end(), out.begin());
            return true;
        }
        renderSet(embree, camera, settings_.eye, pattern_, set, photons_.get(), out, &eye);
        shown.camera = camera;
        shown.eyeVersion = scene_->eyeVersion();
        shown.pathsTraced = map.pathsTraced;
        shown.photonsStored = map.photonsStored;
        if (still) shown.pixels.assign(out.begin(), out.end());
        else shown.pixels.clear();
        return false;
    }
    if (mode != FrameMode::Relight) {
        // An Edit frame's eye paths sample the dielectric splits, as a moving camera's do: a
        // material or object dragged over GLASS paid the full split trees in every frame.
        renderSet(embree, camera, settings_.eye, pattern_, set, photons_.get(), out, &eye, nullptr,
                  mode == FrameMode::Edit ? sampleSeedOf(camera) : 0);
        return false;
    }
    KeptEyePaths& kept = kept_[i].relight;
    if (!kept.camera || !sameCamera(*kept.camera, camera) || kept.eyeVersion != scene_->eyeVersion()) {
        kept = KeptEyePaths{};
        std::vector<PixelRadiance> unlit(out.size());
        renderSet(embree, camera, settings_.eye, pattern_, set, nullptr, unlit, &eye, &kept.records, 0, false);
        kept.base.resize(unlit.size());
        for (size_t p = 0; p < unlit.size(); ++p) kept.base[p] = unlit[p].direct;
        kept.camera = camera;
        kept.eyeVersion = scene_->eyeVersion();
    }
    relightSet(embree, settings_.eye, pattern_, set, photons_.get(), kept.records, kept.base, out, &eye);
    return false;
}

void RenderJob::indexPendingShots(const std::vector<SetPhotons>* sharedIn, const std::vector<uint8_t>& converge,
                                  const std::vector<uint8_t>& passShot, PendingShots& held,
                                  std::vector<std::vector<const SharedPhotons*>>& sharedFor) {
    // This frame's index, built once when a converging set first needs it; the pending lists hold
    // it, and `held` those a pass bins this frame.
    std::shared_ptr<SharedPhotons> current;
    const bool any = sharedIn && !sharedIn->empty();
    auto index = [&]() -> std::shared_ptr<const SharedPhotons> {
        if (!current) {
            current = std::make_shared<SharedPhotons>();
            current->build(scene_->embree().bounds(), *sharedIn);
        }
        return current;
    };
    sharedFor.assign(sets_.size(), {});
    for (size_t i = 0; i < sets_.size(); ++i) {
        PendingShots& pending = kept_[i].pending;
        if (!converge[i]) {
            pending.clear();  // a restart bins the map; what was shared before it is in no pass
            continue;
        }
        if (any && !index()->empty()) pending.push_back(index());
        if (!passShot[i]) continue;
        for (const auto& frame : pending) {
            sharedFor[i].push_back(frame.get());
            held.push_back(frame);
        }
        pending.clear();  // this frame's pass bins them
    }
}

void RenderJob::resetPhotons() {
    photons_->reset();
    shots_.clear();
    for (SetMemory& m : kept_) m.pending.clear();
    epochStart_ = true;
    for (ProgressiveSet& p : progressive_) p.invalidate();
    for (SetMemory& m : kept_) m.shown = ShownKnnPixels{};  // of the old scene or map
    irradiance_->invalidate();
    areaLights_.reset();  // emissive triangles may have changed
}

}  // namespace rtpm
