// FrameRenderer: the client's scene, settings, edits and per-set-group RenderJobs, no sockets.
#include "client/frame_renderer.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <glm/gtc/type_ptr.hpp>

#include "common/scene/gltf_loader.h"
#include "common/photon/photon.h"
#include "common/scene/scene_loader.h"
#include "proto/pixel_codec.h"

namespace rtpm::client {

namespace {

Vec3 toVec3(const proto::Vec3f& v) { return Vec3(v.x, v.y, v.z); }

double msSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string upper(std::string s) {
    for (char& c : s) c = char(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

// Only the protocol fields that change what a set's photons or pixels are; f (server-side
// filter) and the encoding (how pixels travel) do not.
bool sameRendering(const proto::Settings& a, const proto::Settings& b) {
    return a.width == b.width && a.height == b.height && a.m == b.m &&
           a.photonsPerSetPerFrame == b.photonsPerSetPerFrame && a.k == b.k && a.rMax == b.rMax &&
           a.maxDepth == b.maxDepth && a.diffuseBounces == b.diffuseBounces &&
           a.capPhotonsPerSet == b.capPhotonsPerSet && a.spt == b.spt && a.tree == b.tree && a.seed == b.seed &&
           a.photonMaxDepth == b.photonMaxDepth && a.areaLightSamples == b.areaLightSamples &&
           a.gatherVisibility == b.gatherVisibility;
}

}  // namespace

RenderSettings toRenderSettings(const proto::Settings& s) {
    RenderSettings rs;
    rs.width = int(s.width);
    rs.height = int(s.height);
    rs.interleave = int(s.m);
    rs.filter = int(s.f);
    rs.eye.maxDepth = int(s.maxDepth);
    rs.eye.areaLightSamples = int(s.areaLightSamples);
    rs.photons.maxDepth = s.photonMaxDepth;
    rs.photons.seed = s.seed;
    rs.photons.photonsPerBatch = s.photonsPerSetPerFrame;
    rs.photons.k = s.k;
    rs.photons.rMax = s.rMax;
    rs.photons.diffuseBounces = s.diffuseBounces;
    rs.photons.capPhotons = s.capPhotonsPerSet;
    rs.photons.selective = s.spt;
    rs.photons.gatherVisibility = s.gatherVisibility;
    switch (s.tree) {  // the decoder refuses values above kMaxTreeVariant
        case proto::TreeVariant::MiddleSplitKdTree: rs.photons.tree = PhotonTree::MiddleSplit; break;
        case proto::TreeVariant::BalancedKdTree: rs.photons.tree = PhotonTree::MedianBalanced; break;
        case proto::TreeVariant::UniformGrid: rs.photons.tree = PhotonTree::UniformGrid; break;
        default: throw ProtocolViolation("settings.tree " + std::to_string(int(s.tree)) + " is not a tree variant");
    }
    try {
        validateSettings(rs);
    } catch (const std::invalid_argument& e) {
        throw ProtocolViolation(std::string("settings refused: ") + e.what());
    }
    return rs;
}

Camera toCamera(const proto::CameraState& c) {
    Camera cam;
    cam.position = toVec3(c.position);
    cam.forward = toVec3(c.forward);
    cam.up = toVec3(c.up);
    cam.yfov = c.yfov;
    // The decoder guarantees finite values; these would still give NaN rays or a mirrored image.
    const float fl = glm::length(cam.forward), ul = glm::length(cam.up);
    if (!(fl > 1e-6f) || !(ul > 1e-6f))
        throw ProtocolViolation("camera: forward and up must be non-zero vectors");
    if (glm::length(glm::cross(cam.forward, cam.up)) <= 1e-6f * fl * ul)
        throw ProtocolViolation("camera: up is parallel to forward");
    if (!(cam.yfov > 0.0f && cam.yfov < 3.14159f))
        throw ProtocolViolation("camera: yfov " + std::to_string(cam.yfov) + " rad not in (0, pi)");
    return cam;
}

std::optional<SceneEdit> applyWireEdit(Scene& scene, const proto::SceneEdit& wire) {
    SceneEdit edit;
    if (std::holds_alternative<proto::CameraEdit>(wire)) return std::nullopt;
    if (auto* l = std::get_if<proto::LightEdit>(&wire)) {
        if (l->index >= scene.lights.size())
            throw ProtocolViolation("edit: light " + std::to_string(l->index) + " does not exist (scene has " +
                                    std::to_string(scene.lights.size()) + ")");
        edit.kind = SceneEdit::Kind::Light;
        edit.index = l->index;
        edit.light = scene.lights[l->index];  // type, cone angles and name are not on the wire
        edit.light.position = toVec3(l->position);
        edit.light.direction = toVec3(l->direction);
        edit.light.intensity = toVec3(l->intensity);
    } else if (auto* m = std::get_if<proto::MaterialEdit>(&wire)) {
        if (m->index >= scene.materials.size())
            throw ProtocolViolation("edit: material " + std::to_string(m->index) + " does not exist (scene has " +
                                    std::to_string(scene.materials.size()) + ")");
        edit.kind = SceneEdit::Kind::Material;
        edit.index = m->index;
        edit.material = scene.materials[m->index];  // name and texture are not on the wire
        switch (m->kind) {
            case proto::MaterialKind::Diffuse: edit.material.type = MaterialType::Diffuse; break;
            case proto::MaterialKind::Mirror: edit.material.type = MaterialType::Mirror; break;
            case proto::MaterialKind::Dielectric: edit.material.type = MaterialType::Dielectric; break;
        }
        edit.material.baseColor = toVec3(m->baseColor);
        edit.material.ior = m->ior;
        edit.material.absorption = toVec3(m->absorption);
        edit.material.emission = toVec3(m->emission);
    } else {
        const auto& t = std::get<proto::TransformEdit>(wire);
        if (t.instance >= scene.instances.size())
            throw ProtocolViolation("edit: instance " + std::to_string(t.instance) + " does not exist (scene has " +
                                    std::to_string(scene.instances.size()) + ")");
        edit.kind = SceneEdit::Kind::Transform;
        edit.index = t.instance;
        edit.transform = glm::make_mat4(t.matrix.data());
    }

    // Same validate-then-roll-back rule as RenderJob::applyEdit, on the client's master copy.
    switch (edit.kind) {
        case SceneEdit::Kind::Light: {
            Light old = scene.lights[edit.index];
            scene.lights[edit.index] = edit.light;
            try {
                scene.validate("edit");
            } catch (const SceneError& e) {
                scene.lights[edit.index] = old;
                throw ProtocolViolation(e.what());
            }
            break;
        }
        case SceneEdit::Kind::Material: {
            Material old = scene.materials[edit.index];
            scene.materials[edit.index] = edit.material;
            try {
                scene.validate("edit");
            } catch (const SceneError& e) {
                scene.materials[edit.index] = old;
                throw ProtocolViolation(e.what());
            }
            break;
        }
        case SceneEdit::Kind::Transform: {
            Mat4 old = scene.instances[edit.index].transform;
            scene.instances[edit.index].transform = edit.transform;
            try {
                scene.validate("edit");
            } catch (const SceneError& e) {
                scene.instances[edit.index].transform = old;
                throw ProtocolViolation(e.what());
            }
            break;
        }
    }
    return edit;
}

struct FrameRenderer::Group {
    std::vector<uint32_t> sets;
    std::unique_ptr<RenderJob> job;
};

FrameRenderer::FrameRenderer(uint32_t threads) : threads_(threads) {}
FrameRenderer::~FrameRenderer() = default;

void FrameRenderer::setSettings(const proto::Settings& s) {
    RenderSettings rs = toRenderSettings(s);
    if (!wire_ || !sameRendering(*wire_, s)) groups_.clear();
    wire_ = s;
    settings_ = rs;
}

void FrameRenderer::setScene(const proto::Scene& msg) {
    Scene scene;
    try {
        if (msg.source == proto::Scene::Source::Builtin) {
            // Only built-in names: loadScene would also open a path, and a server must not make a
            // client read its own files.
            const std::vector<std::string> names = builtinSceneNames();
            if (std::find(names.begin(), names.end(), upper(msg.builtinName)) == names.end())
                throw ProtocolViolation("scene: \"" + msg.builtinName + "\" is not a built-in scene");
            scene = loadScene(msg.builtinName);
        } else {
            if (msg.gltf.empty()) throw ProtocolViolation("scene: empty glTF payload");
            scene = loadGltfFromMemory(msg.gltf, "scene from server", "");
            if (!scene.camera) throw ProtocolViolation("scene: the glTF scene has no camera");
            scene.validate("scene from server");
        }
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
    scene_ = std::move(scene);
    sceneVersion_ = queuedVersion_ = msg.sceneVersion;
    queued_.clear();
    groups_.clear();
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
        g->job = std::make_unique<RenderJob>(*scene_, settings_, missing);
        groups_.push_back(std::move(g));
    }
}

RenderedFrame FrameRenderer::render(const proto::FrameBegin& fb, std::chrono::steady_clock::time_point received) {
    if (!wire_) throw ProtocolViolation("FrameBegin " + std::to_string(fb.frame) + " before any Settings");
    if (!scene_) throw ProtocolViolation("FrameBegin " + std::to_string(fb.frame) + " before any Scene");

    // Edits first (they precede the FrameBegin of their epoch), each on the master copy and on
    // every live group; RenderJob::applyEdit resets that group's photons.
    for (const proto::Edit& e : queued_) {
        std::optional<SceneEdit> edit;
        try {
            edit = applyWireEdit(*scene_, e.edit);
        } catch (const ProtocolViolation& err) {
            queued_.clear();
            throw ProtocolViolation("Edit to scene version " + std::to_string(e.sceneVersion) + ": " + err.what());
        }
        if (edit)
            for (auto& g : groups_) g->job->applyEdit(*edit);
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

    if (epoch_ && *epoch_ != fb.epoch)
        for (auto& g : groups_) g->job->resetPhotons();
    epoch_ = fb.epoch;
    adoptSets(fb.sets);

    RenderedFrame out;
    const bool shoot = fb.mode != proto::FrameMode::Walkthrough;
    double photonMs = 0.0, renderMs = 0.0, encodeMs = 0.0;
    uint64_t shot = 0, stored = 0;
    // Pixels by set id, in the order of FrameBegin.sets.
    std::vector<const SetPixels*> bySet(setCount, nullptr);
    std::vector<std::vector<SetPixels>> results(groups_.size());
    for (size_t gi = 0; gi < groups_.size(); ++gi) {
        FrameStats st = groups_[gi]->job->renderFrame(camera, shoot, results[gi]);
        photonMs += st.shootSeconds * 1e3;
        renderMs += st.eyeSeconds * 1e3;
        shot += st.pathsThisFrame;
        stored += st.photonsStored;
        for (const SetPixels& sp : results[gi]) bySet[size_t(sp.set)] = &sp;
    }

    const auto te = std::chrono::steady_clock::now();
    const Interleave pattern{settings_.width, settings_.height, settings_.interleave};
    std::vector<proto::PixelPair> pairs;
    for (uint32_t s : fb.sets) {
        const SetPixels* sp = bySet[s];
        RTPM_CHECK(sp != nullptr && sp->pixels.size() == size_t(pattern.pixelCount(int(s))));
        pairs.resize(sp->pixels.size());
        for (size_t i = 0; i < pairs.size(); ++i) {
            const PixelRadiance& p = sp->pixels[i];
            pairs[i] = proto::PixelPair{{p.direct.x, p.direct.y, p.direct.z}, {p.caustic.x, p.caustic.y, p.caustic.z}};
        }
        proto::EncodedPixels enc = proto::encodePixels(pairs, wire_->encoding);
        proto::FrameData fd;
        fd.frame = fb.frame;
        fd.set = s;
        fd.encoding = enc.encoding;
        fd.pixelCount = uint32_t(pairs.size());
        fd.pixels = std::move(enc.bytes);
        out.data.push_back(std::move(fd));
    }
    encodeMs = msSince(te);

    uint64_t memory = 0;
    for (auto& g : groups_) {
        const Scene& sc = g->job->scene();
        memory += sc.triangleCount() * 64;  // Embree BVH + vertex data, roughly
        for (const Mesh& m : sc.meshes) memory += m.positions.size() * sizeof(Vec3) * 3 + m.indices.size() * 4;
    }
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
            return g->job->photons().stats(set).batches;
    return 0;
}

}  // namespace rtpm::client
