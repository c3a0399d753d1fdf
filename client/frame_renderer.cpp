// FrameRenderer: the client's scene, settings, edits and per-set-group RenderJobs, no sockets.
#include "client/frame_renderer.h"

#include <tbb/parallel_for.h>
#include "common/core/strings.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <thread>
#include <glm/gtc/type_ptr.hpp>

#include "common/core/knobs.h"
#include "common/scene/gltf_loader.h"
#include "common/photon/photon.h"
#include "common/scene/scene_loader.h"
#include "proto/bridge/bridge.h"
#include "proto/pixel_codec.h"

namespace rtpm::client {

namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}


// Whether the rows a client renders by are equal: every fixed setting and every knob whose change
// resets more than the master's output stage (the filter F does not; nor does the encoding, which
// is how pixels travel).
bool sameRendering(const RenderSettings& a, const RenderSettings& b) {
    for (const SettingRow& row : kFixedSettings)
        if (row.get(a) != row.get(b)) return false;
    for (const KnobRow& row : kKnobs)
        if (row.resets != KnobReset::Output && row.get(a) != row.get(b)) return false;
    return true;
}

}  // namespace

RenderSettings toRenderSettings(const proto::Settings& s) {
    try {
        validateSettings(s.render);
        return s.render;
    } catch (const std::invalid_argument& e) {
        throw ProtocolViolation(std::string("settings refused: ") + e.what());
    }
}

Camera toCamera(const proto::CameraState& c) {
    try {
        return bridge::fromWire(c);
    } catch (const std::invalid_argument& e) {
        throw ProtocolViolation(e.what());
    }
}

namespace {

/// bridge::fromWire for an edit, with its refusal (an index `scene` lacks) as ProtocolViolation.
std::optional<SceneEdit> wireEdit(const Scene& scene, const proto::SceneEdit& wire) {
    try {
        return bridge::fromWire(scene, wire);
    } catch (const std::invalid_argument& e) {
        throw ProtocolViolation(e.what());
    }
}

}  // namespace

std::optional<SceneEdit> applyWireEdit(Scene& scene, const proto::SceneEdit& wire) {
    std::optional<SceneEdit> edit = wireEdit(scene, wire);
    try {
        if (edit) applyEdit(scene, *edit);  // validates; leaves the scene unchanged if refused
    } catch (const SceneError& e) {
        throw ProtocolViolation(e.what());
    }
    return edit;
}

/// One set's last pixels sent: in which frame, asked for in which encoding and sent in which.
struct SentPixels {
    bool valid = false;
    proto::PixelEncoding requested = proto::PixelEncoding::Rgb9e5;
    proto::PixelEncoding encoding = proto::PixelEncoding::Rgb9e5;
    uint64_t frame = 0;
};

namespace {

/// Fills `fd`'s pixels: encoded as `requested` asks, straight from the renderer's buffer (no
/// intermediate copy), or, where they did not change since the set's last frame (a pass off its
/// turn) and were sent then in that encoding, none: `fd` names the frame that carried them.
void encodeOrRefer(const SetPixels& pixels, SentPixels& sent, proto::PixelEncoding requested, proto::FrameData& fd) {
    if (pixels.unchanged && sent.valid && sent.requested == requested) {
        fd.encoding = sent.encoding;
        fd.unchanged = true;
        fd.sameAs = sent.frame;
        return;
    }
    proto::EncodedPixels enc = proto::encodePixels(bridge::pixelView(std::span(pixels.pixels)), requested);
    fd.encoding = enc.encoding;
    fd.pixels = std::move(enc.bytes);
    fd.ownWeights = pixels.ownWeights;
    fd.noise = pixels.noise;
    sent = SentPixels{true, requested, enc.encoding, fd.frame};
}

}  // namespace

struct FrameRenderer::Group {
    std::vector<uint32_t> sets;
    std::unique_ptr<RenderJob> job;
    std::vector<SentPixels> sent;  ///< per set of `sets`, what its last frame sent
};

FrameRenderer::FrameRenderer(uint32_t threads, double slowdown) : threads_(threads), slowdown_(slowdown) {}
FrameRenderer::~FrameRenderer() = default;

void FrameRenderer::setSettings(const proto::Settings& s) {
    RenderSettings rs = toRenderSettings(s);
    if (!wire_ || !sameRendering(wire_->render, rs)) groups_.clear();
    wire_ = s;
    settings_ = rs;
}

void FrameRenderer::setScene(const proto::Scene& msg) {
    Scene scene;
    try {
        if (msg.source == proto::Scene::Source::Builtin) {
            // Only built-in names: loadScene would also open a path, and a server must not make a
            // client read its own files.
            if (!isBuiltinScene(msg.builtinName))
                throw ProtocolViolation("scene: \"" + msg.builtinName + "\" is not a built-in scene");
            scene = loadScene(msg.builtinName);
        } else {
            if (msg.gltf.empty()) throw ProtocolViolation("scene: empty glTF payload");
            scene = loadGltfFromMemory(msg.gltf, "scene from server", "");
            if (!scene.camera) throw ProtocolViolation("scene: the glTF scene has no camera");
            scene.validate("scene from server");
        }
        scene.environment = bridge::environmentFromWire(msg);
    } catch (const SceneError& e) {
        throw ProtocolViolation(std::string("scene: ") + e.what());
    }
    for (size_t i = 0; i < msg.edits.size(); ++i) {
        try {
            applyWireEdit(scene, msg.edits[i]);
        } catch (const ProtocolViolation& e) {
            throw ProtocolViolation("scene edit " + std::to_string(i) + ": " + e.what());
        }
    }
    groups_.clear();  // they share the old scene: freed before the new BVH is built
    scene_.reset();
    try {
        scene_ = std::make_shared<RenderScene>(std::move(scene));
    } catch (const SceneError& e) {
        throw ProtocolViolation(std::string("scene: ") + e.what());
    }
    sceneVersion_ = queuedVersion_ = msg.sceneVersion;
    queued_.clear();
}

void FrameRenderer::queueEdit(const proto::Edit& edit) {
    if (!scene_) throw ProtocolViolation("Edit received before any Scene");
    if (edit.sceneVersion <= queuedVersion_)
        throw ProtocolViolation("Edit to scene version " + std::to_string(edit.sceneVersion) +
                                " does not follow version " + std::to_string(queuedVersion_));
    queuedVersion_ = edit.sceneVersion;
    queued_.push_back(edit);
}

void FrameRenderer::adoptSets(const std::vector<uint32_t>& sets) {
    std::vector<bool> wanted(size_t(settings_.interleave * settings_.interleave), false);
    for (uint32_t s : sets) wanted[s] = true;
    std::vector<bool> covered(wanted.size(), false);
    std::vector<std::unique_ptr<Group>> kept;
    for (auto& g : groups_) {
        const bool allWanted = std::all_of(g->sets.begin(), g->sets.end(), [&](uint32_t s) { return wanted[s]; });
        if (!allWanted) continue;  // dropped: its still-wanted sets restart in the new group
        for (uint32_t s : g->sets) covered[s] = true;
        kept.push_back(std::move(g));
    }
    groups_ = std::move(kept);
    std::vector<uint32_t> missing;
    for (uint32_t s : sets)
        if (!covered[s]) missing.push_back(s);
    if (!missing.empty()) {
        auto g = std::make_unique<Group>();
        g->sets = missing;
        g->job = std::make_unique<RenderJob>(scene_, settings_, missing);
        g->sent.resize(missing.size());
        groups_.push_back(std::move(g));
    }
}

RenderedFrame FrameRenderer::render(const proto::FrameBegin& fb, std::chrono::steady_clock::time_point received) {
    if (!wire_) throw ProtocolViolation("FrameBegin " + std::to_string(fb.frame) + " before any Settings");
    if (!scene_) throw ProtocolViolation("FrameBegin " + std::to_string(fb.frame) + " before any Scene");

    // Edits first (they precede the FrameBegin of their epoch), each applied once to the scene
    // every group shares (no frame is rendering); the groups' photons are then stale.
    for (const proto::Edit& e : queued_) {
        try {
            if (std::optional<SceneEdit> edit = wireEdit(scene_->scene(), e.edit)) {
                scene_->applyEdit(*edit);
                for (auto& g : groups_) g->job->resetPhotons();
            }
        } catch (const ProtocolViolation& err) {
            queued_.clear();
            throw ProtocolViolation("Edit to scene version " + std::to_string(e.sceneVersion) + ": " + err.what());
        } catch (const SceneError& err) {  // refused by validation: the scene is unchanged
            queued_.clear();
            throw ProtocolViolation("Edit to scene version " + std::to_string(e.sceneVersion) + ": " + err.what());
        }
        sceneVersion_ = e.sceneVersion;
    }
    queued_.clear();
    if (fb.sceneVersion != sceneVersion_)
        throw ProtocolViolation("FrameBegin " + std::to_string(fb.frame) + " is for scene version " +
                                std::to_string(fb.sceneVersion) + " but the client has version " +
                                std::to_string(sceneVersion_));
    const uint32_t setCount = uint32_t(settings_.interleave * settings_.interleave);
    for (uint32_t s : fb.sets)
        if (s >= setCount)
            throw ProtocolViolation("FrameBegin " + std::to_string(fb.frame) + ": set " + std::to_string(s) +
                                    " out of range for M = " + std::to_string(settings_.interleave));
    const Camera camera = toCamera(fb.camera);
    const FrameMode frameMode = bridge::fromWire(fb.mode);

    if (epoch_ && *epoch_ != fb.epoch)
        for (auto& g : groups_) g->job->resetPhotons();
    epoch_ = fb.epoch;
    adoptSets(fb.sets);

    RenderedFrame out;
    double photonMs = 0.0, renderMs = 0.0, encodeMs = 0.0;
    uint64_t shot = 0, stored = 0;
    // Pixels by set id, in the order of FrameBegin.sets.
    std::vector<const SetPixels*> bySet(setCount, nullptr);
    std::vector<SentPixels*> sentBySet(setCount, nullptr);
    std::vector<std::vector<SetPixels>> results(groups_.size());
    // Every set's shot of two frames ago, as the master forwarded it (the passes bin it).
    const std::vector<SetPhotons> shared = bridge::fromWire(fb.shared);
    for (size_t gi = 0; gi < groups_.size(); ++gi) {
        // The master's mode, with one exception: a Walkthrough frame shoots nothing, except into
        // a group with no batch yet (sets that moved here, or maps dropped by new settings), which
        // renders it as Accumulate: a walkthrough would otherwise show those sets without
        // caustics for the rest of the epoch (PROTOCOL.md §5.6).
        const Group& g = *groups_[gi];
        const bool empty = g.job->photons().stats(g.sets.front()).batches == 0;
        const FrameMode mode = fb.mode == proto::FrameMode::Walkthrough && empty ? FrameMode::Accumulate : frameMode;
        FrameStats st = groups_[gi]->job->renderFrame(camera, mode, results[gi], fb.passBatches, &shared,
                                                      fb.passPeriod, fb.frame);
        photonMs += st.shootSeconds * 1e3;
        renderMs += st.eyeSeconds * 1e3;
        shot += st.pathsThisFrame;
        stored += st.photonsStored;
        for (size_t i = 0; i < results[gi].size(); ++i) {
            bySet[size_t(results[gi][i].set)] = &results[gi][i];
            sentBySet[size_t(results[gi][i].set)] = &groups_[gi]->sent[i];
        }
    }

    if (slowdown_ > 1.0) {
        const double extraMs = (slowdown_ - 1.0) * (photonMs + renderMs);
        std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(extraMs));
        renderMs += extraMs;
    }
    const auto te = std::chrono::steady_clock::now();
    const Interleave pattern{settings_.width, settings_.height, settings_.interleave};
    // Sets encode in parallel (one task each, in FrameBegin order in `out.data`).
    out.data.resize(fb.sets.size());
    tbb::parallel_for(size_t(0), fb.sets.size(), [&](size_t i) {
        const uint32_t s = fb.sets[i];
        const SetPixels* sp = bySet[s];
        RTPM_CHECK(sp != nullptr && sp->pixels.size() == size_t(pattern.pixelCount(int(s))));
        proto::FrameData& fd = out.data[i];
        fd.frame = fb.frame;
        fd.set = s;
        fd.pixelCount = uint32_t(sp->pixels.size());
        encodeOrRefer(*sp, *sentBySet[s], wire_->encoding, fd);
        fd.passes = sp->passes;
        fd.errorSigma = sp->error.sigma;
        fd.errorRadiance = sp->error.radiance;
        fd.errorPixels = uint32_t(sp->error.pixels);
        fd.errorBatches = sp->error.batches;
        fd.shotBatches = sp->shot.batches;
        fd.shot = bridge::toWire(sp->shot.photons);
    });
    encodeMs = msSince(te);

    // One scene and BVH whatever the groups.
    const Scene& sc = scene_->scene();
    uint64_t memory = sc.triangleCount() * 64;  // Embree BVH + vertex data, roughly
    for (const Mesh& m : sc.meshes) memory += m.positions.size() * sizeof(Vec3) * 3 + m.indices.size() * 4;
    memory += stored * (sizeof(Photon) + 8);  // photons + kd-tree nodes, roughly

    out.stats.frame = fb.frame;
    out.stats.photonMs = float(photonMs);
    out.stats.renderMs = float(renderMs);
    out.stats.encodeMs = float(encodeMs);
    out.stats.frameMs = float(msSince(received));
    out.stats.photonsShot = shot;
    out.stats.photonsStored = stored;
    out.stats.memoryBytes = memory;
    out.stats.threads = threads_;
    return out;
}

std::vector<uint32_t> FrameRenderer::currentSets() const {
    std::vector<uint32_t> sets;
    for (const auto& g : groups_) sets.insert(sets.end(), g->sets.begin(), g->sets.end());
    return sets;
}

uint32_t FrameRenderer::batches(uint32_t set) const {
    for (const auto& g : groups_)
        if (std::find(g->sets.begin(), g->sets.end(), set) != g->sets.end())
            return g->job->photons().stats(set).batches + g->job->photons().stats(set).pendingBatches;
    return 0;
}

}  // namespace rtpm::client
