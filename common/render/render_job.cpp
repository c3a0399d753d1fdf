// RenderJob: per frame, shoot a photon batch per owned set, then trace that set's pixels.
#include "common/render/render_job.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace rtpm {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

RenderJob::RenderJob(Scene scene, const RenderSettings& settings, std::vector<uint32_t> sets)
    : scene_(std::make_unique<Scene>(std::move(scene))), settings_(settings), sets_(std::move(sets)) {
    validateSettings(settings_);
    pattern_ = Interleave{settings_.width, settings_.height, settings_.interleave};
    for (uint32_t s : sets_)
        if (s >= uint32_t(pattern_.setCount()))
            throw std::invalid_argument("set " + std::to_string(s) + " out of range for M = " +
                                        std::to_string(settings_.interleave));
    embree_ = std::make_unique<EmbreeScene>(*scene_);
    photons_ = std::make_unique<PhotonMaps>(settings_.photons, sets_);
}

RenderJob::~RenderJob() = default;

FrameStats RenderJob::renderFrame(const Camera& camera, bool shoot, std::vector<SetPixels>& out) {
    FrameStats stats;
    const auto t0 = std::chrono::steady_clock::now();
    uint64_t pathsBefore = 0;
    for (uint32_t s : sets_) pathsBefore += photons_->stats(s).pathsTraced;
    if (shoot)
        for (uint32_t s : sets_) photons_->shootBatch(*embree_, s);
    stats.shootSeconds = secondsSince(t0);

    const auto t1 = std::chrono::steady_clock::now();
    out.resize(sets_.size());
    for (size_t i = 0; i < sets_.size(); ++i) {
        const int set = int(sets_[i]);
        out[i].set = set;
        out[i].pixels.resize(size_t(pattern_.pixelCount(set)));
        renderSet(*embree_, camera, settings_.eye, pattern_, set, photons_.get(), out[i].pixels,
                  &stats.eye);
    }
    stats.eyeSeconds = secondsSince(t1);

    for (uint32_t s : sets_) {
        stats.photonsStored += photons_->stats(s).photonsStored;
        stats.pathsTraced += photons_->stats(s).pathsTraced;
    }
    stats.pathsThisFrame = stats.pathsTraced - std::min(stats.pathsTraced, pathsBefore);
    stats.walkthrough = !shoot || photons_->walkthrough();
    return stats;
}

void RenderJob::applyEdit(const SceneEdit& edit) {
    Material previous;
    rtpm::applyEdit(*scene_, edit, &previous);  // throws and leaves the scene unchanged if refused
    const Scene& s = *scene_;
    switch (edit.kind) {
        case SceneEdit::Kind::Light: break;  // lights are read from the scene at the next batch
        case SceneEdit::Kind::Material:
            // The emissive triangle list is rebuilt through the mesh path, only if emission changed.
            if (previous.emission != edit.material.emission)
                for (size_t m = 0; m < s.meshes.size(); ++m)
                    if (s.meshes[m].material == edit.index) embree_->setMesh(uint32_t(m), s.meshes[m]);
            break;
        case SceneEdit::Kind::Transform: embree_->setTransform(edit.index, edit.transform); break;
    }
    resetPhotons();
}

void RenderJob::resetPhotons() { photons_->reset(); }

}  // namespace rtpm
