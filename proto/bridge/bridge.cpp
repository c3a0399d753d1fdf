// Conversions between the wire protocol's types and the renderer's.
#include "proto/bridge/bridge.h"

#include <cstddef>
#include <stdexcept>
#include <string>

#include <glm/gtc/type_ptr.hpp>

#include "common/core/knobs.h"

namespace rtpm::bridge {

// The codec addresses a pixel as six floats: direct RGB, then caustic RGB.
// The wire's limits of the live knobs are their rows' (common/core/knobs.h): one ceiling each.
static_assert(knobRow(Knob::Interleave).max == proto::kMaxInterleave, "M: knob row and Settings.m differ");
static_assert(knobRow(Knob::Filter).max == proto::kMaxFilterWidth, "F: knob row and Settings.f differ");
static_assert(knobRow(Knob::K).max == proto::kMaxK, "k: knob row and Settings.k differ");
static_assert(knobRow(Knob::Photons).max == proto::kMaxPhotonsPerBatch, "P: knob row and Settings.photonsPerBatch differ");
static_assert(knobRow(Knob::Confidence).max == proto::kMaxProgressiveGamma,
              "confidence: knob row and Settings.progressiveGamma differ");
// The fixed settings' rows are the flags' limits; the wire's ceilings (which bound what a decoder
// accepts from a peer) hold at least every value the rows allow.
constexpr const SettingRow& fixedRow(std::string_view flag) {
    for (const SettingRow& r : kFixedSettings)
        if (r.flag == flag) return r;
    throw "no such fixed setting";  // not a constant expression: fails the static_assert below
}
static_assert(fixedRow("--width").max == proto::kMaxImageSide && fixedRow("--height").max == proto::kMaxImageSide,
              "image size: rows and Settings.width/height differ");
static_assert(fixedRow("--depth").max <= proto::kMaxDepthLimit && fixedRow("--photon-depth").max <= proto::kMaxDepthLimit,
              "depths: the wire cannot carry the rows' limits");
static_assert(fixedRow("--diffuse-bounces").max <= proto::kMaxDiffuseBounces, "diffuse bounces: wire below the row");
static_assert(fixedRow("--area-samples").max <= proto::kMaxAreaLightSamples, "area samples: wire below the row");
static_assert(fixedRow("--cap").max <= double(UINT32_MAX), "cap: Settings.capPhotonsPerSet is 32 bits");
static_assert(sizeof(Vec3) == 3 * sizeof(float), "Vec3 is three packed floats");
static_assert(sizeof(PixelRadiance) == 6 * sizeof(float), "PixelRadiance is six packed floats");
static_assert(offsetof(PixelRadiance, caustic) == 3 * sizeof(float), "caustic follows direct");
static_assert(proto::kMaxPassBatches == kMaxPassBatches, "one limit for a pass's batches");
static_assert(proto::kMaxPassPeriod == kMaxPassPeriod, "one limit for the sets' turns");

proto::Vec3f toWire(Vec3 v) { return {v.x, v.y, v.z}; }
Vec3 fromWire(proto::Vec3f v) { return {v.x, v.y, v.z}; }

proto::Settings toWire(const RenderSettings& rs, proto::PixelEncoding encoding) {
    if (rs.photons.capPhotons > (uint64_t{1} << 30))
        throw std::invalid_argument("--cap must be at most 2^30 in a cluster");
    proto::Settings s;
    s.width = static_cast<uint32_t>(rs.width);
    s.height = static_cast<uint32_t>(rs.height);
    s.m = static_cast<uint32_t>(rs.interleave);
    s.f = static_cast<uint32_t>(rs.filterSize());
    s.photonsPerBatch = rs.photons.photonsPerBatch;
    s.k = rs.photons.k;
    s.rMax = rs.photons.rMax;
    s.maxDepth = static_cast<uint32_t>(rs.eye.maxDepth);
    s.diffuseBounces = rs.photons.diffuseBounces;
    s.capPhotonsPerSet = static_cast<uint32_t>(rs.photons.capPhotons);
    s.spt = rs.photons.selective;
    switch (rs.photons.tree) {
        case PhotonTree::MiddleSplit: s.tree = proto::TreeVariant::MiddleSplitKdTree; break;
        case PhotonTree::MedianBalanced: s.tree = proto::TreeVariant::BalancedKdTree; break;
        case PhotonTree::UniformGrid: s.tree = proto::TreeVariant::UniformGrid; break;
    }
    s.encoding = encoding;
    s.seed = rs.photons.seed;
    s.photonMaxDepth = rs.photons.maxDepth;
    s.areaLightSamples = static_cast<uint32_t>(rs.eye.areaLightSamples);
    s.gatherVisibility = rs.photons.gatherVisibility;
    s.estimator = rs.photons.estimator == CausticEstimatorKind::Knn ? proto::CausticEstimator::Knn
                                                                   : proto::CausticEstimator::Progressive;
    s.progressiveGamma = rs.photons.progressiveGamma;
    return s;
}

RenderSettings fromWire(const proto::Settings& s) {
    RenderSettings rs;
    rs.width = int(s.width);
    rs.height = int(s.height);
    rs.interleave = int(s.m);
    rs.filter = int(s.f);
    rs.eye.maxDepth = int(s.maxDepth);
    rs.eye.areaLightSamples = int(s.areaLightSamples);
    rs.photons.maxDepth = s.photonMaxDepth;
    rs.photons.seed = s.seed;
    rs.photons.photonsPerBatch = s.photonsPerBatch;
    rs.photons.k = s.k;
    rs.photons.rMax = s.rMax;
    rs.photons.diffuseBounces = s.diffuseBounces;
    rs.photons.capPhotons = s.capPhotonsPerSet;
    rs.photons.selective = s.spt;
    rs.photons.gatherVisibility = s.gatherVisibility;
    rs.photons.progressiveGamma = s.progressiveGamma;
    switch (s.estimator) {  // the decoder refuses values above kMaxCausticEstimator
        case proto::CausticEstimator::Progressive: rs.photons.estimator = CausticEstimatorKind::Progressive; break;
        case proto::CausticEstimator::Knn: rs.photons.estimator = CausticEstimatorKind::Knn; break;
        default: throw std::invalid_argument("settings.estimator " + std::to_string(int(s.estimator)) + " is not an estimator");
    }
    switch (s.tree) {  // the decoder refuses values above kMaxTreeVariant
        case proto::TreeVariant::MiddleSplitKdTree: rs.photons.tree = PhotonTree::MiddleSplit; break;
        case proto::TreeVariant::BalancedKdTree: rs.photons.tree = PhotonTree::MedianBalanced; break;
        case proto::TreeVariant::UniformGrid: rs.photons.tree = PhotonTree::UniformGrid; break;
        default: throw std::invalid_argument("settings.tree " + std::to_string(int(s.tree)) + " is not a tree variant");
    }
    validateSettings(rs);
    return rs;
}

// The wire's ids are append-only; common's enum mirrors them, so the conversion is a cast.
static_assert(uint8_t(FrameMode::Interaction) == uint8_t(proto::FrameMode::Interaction) &&
              uint8_t(FrameMode::Accumulate) == uint8_t(proto::FrameMode::Accumulate) &&
              uint8_t(FrameMode::Walkthrough) == uint8_t(proto::FrameMode::Walkthrough) &&
              uint8_t(FrameMode::Converging) == uint8_t(proto::FrameMode::Converging) &&
              uint8_t(FrameMode::Edit) == uint8_t(proto::FrameMode::Edit) &&
              proto::kMaxFrameMode == uint8_t(FrameMode::Edit));

proto::FrameMode toWire(FrameMode mode) { return proto::FrameMode(uint8_t(mode)); }
FrameMode fromWire(proto::FrameMode mode) { return FrameMode(uint8_t(mode)); }

proto::CameraState toWire(const Camera& c) {
    return proto::CameraState{toWire(c.position), toWire(c.forward), toWire(c.up), c.yfov};
}

Camera fromWire(const proto::CameraState& c) {
    Camera cam;
    cam.position = fromWire(c.position);
    cam.forward = fromWire(c.forward);
    cam.up = fromWire(c.up);
    cam.yfov = c.yfov;
    // The rule the server checked before sending (validateCamera, common/scene/scene.h): zero
    // or parallel axes would give NaN rays, an eye at 1e38 overflows inside Embree.
    try {
        validateCamera(cam, "FrameBegin");
    } catch (const SceneError& e) {
        throw std::invalid_argument(e.what());
    }
    return cam;
}

proto::LightEdit lightToWire(const Scene& scene, uint32_t index) {
    const Light& l = scene.lights.at(index);
    return proto::LightEdit{index, toWire(l.position), toWire(l.direction), toWire(l.intensity)};
}

proto::MaterialEdit materialToWire(const Scene& scene, uint32_t index) {
    const Material& m = scene.materials.at(index);
    proto::MaterialEdit e;
    e.index = index;
    switch (m.type) {
        case MaterialType::Mirror: e.kind = proto::MaterialKind::Mirror; break;
        case MaterialType::Dielectric: e.kind = proto::MaterialKind::Dielectric; break;
        default: e.kind = proto::MaterialKind::Diffuse; break;
    }
    e.baseColor = toWire(m.baseColor);
    e.ior = m.ior;
    e.absorption = toWire(m.absorption);
    e.emission = toWire(m.emission);
    return e;
}

proto::TransformEdit transformToWire(const Scene& scene, uint32_t instance) {
    const Mat4& m = scene.instances.at(instance).transform;
    proto::TransformEdit e;
    e.instance = instance;
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) e.matrix[size_t(c * 4 + r)] = m[c][r];
    return e;
}

namespace {

void requireIndex(uint32_t index, size_t count, const char* what) {
    if (index >= count)
        throw std::invalid_argument(std::string("edit: ") + what + " " + std::to_string(index) +
                                    " does not exist (scene has " + std::to_string(count) + ")");
}

}  // namespace

std::optional<SceneEdit> fromWire(const Scene& scene, const proto::SceneEdit& wire) {
    SceneEdit edit;
    if (std::holds_alternative<proto::CameraEdit>(wire)) return std::nullopt;
    if (auto* l = std::get_if<proto::LightEdit>(&wire)) {
        requireIndex(l->index, scene.lights.size(), "light");
        edit.kind = SceneEdit::Kind::Light;
        edit.index = l->index;
        edit.light = scene.lights[l->index];  // type, cone angles and name are not on the wire
        edit.light.position = fromWire(l->position);
        edit.light.direction = fromWire(l->direction);
        edit.light.intensity = fromWire(l->intensity);
    } else if (auto* m = std::get_if<proto::MaterialEdit>(&wire)) {
        requireIndex(m->index, scene.materials.size(), "material");
        edit.kind = SceneEdit::Kind::Material;
        edit.index = m->index;
        edit.material = scene.materials[m->index];  // name and texture are not on the wire
        switch (m->kind) {
            case proto::MaterialKind::Diffuse: edit.material.type = MaterialType::Diffuse; break;
            case proto::MaterialKind::Mirror: edit.material.type = MaterialType::Mirror; break;
            case proto::MaterialKind::Dielectric: edit.material.type = MaterialType::Dielectric; break;
        }
        edit.material.baseColor = fromWire(m->baseColor);
        edit.material.ior = m->ior;
        edit.material.absorption = fromWire(m->absorption);
        edit.material.emission = fromWire(m->emission);
    } else {
        const auto& t = std::get<proto::TransformEdit>(wire);
        requireIndex(t.instance, scene.instances.size(), "instance");
        edit.kind = SceneEdit::Kind::Transform;
        edit.index = t.instance;
        edit.transform = glm::make_mat4(t.matrix.data());
    }
    return edit;
}

void environmentToWire(const Environment& environment, proto::Scene& m) {
    m.environmentColour = proto::Vec3f{};
    m.environmentWidth = m.environmentHeight = 0;
    m.environmentTexels.clear();
    if (environment.empty()) {
        m.environment = proto::Scene::Environment::None;
    } else if (!environment.hasMap()) {
        m.environment = proto::Scene::Environment::Uniform;
        m.environmentColour = toWire(environment.uniformRadiance());
    } else {
        m.environment = proto::Scene::Environment::Map;
        m.environmentWidth = uint32_t(environment.width());
        m.environmentHeight = uint32_t(environment.height());
        m.environmentTexels = environment.texels();
    }
}

Environment environmentFromWire(const proto::Scene& m) {
    switch (m.environment) {
        case proto::Scene::Environment::None: return Environment{};
        case proto::Scene::Environment::Uniform: return Environment::uniform(fromWire(m.environmentColour));
        case proto::Scene::Environment::Map: break;
    }
    Texture map;
    map.width = int(m.environmentWidth);
    map.height = int(m.environmentHeight);
    map.rgb = m.environmentTexels;
    validateEnvironmentMap(map, "scene from server");
    return Environment::fromMap(map);
}

proto::ConstPixelView pixelView(std::span<const PixelRadiance> pixels) {
    return {pixels.empty() ? nullptr : &pixels[0].direct.x, pixels.size(), 6};
}

proto::PixelView pixelView(std::span<PixelRadiance> pixels) {
    return {pixels.empty() ? nullptr : &pixels[0].direct.x, pixels.size(), 6};
}

static_assert(proto::kMaxSharedPhotons == kSharedPhotonBudget, "the wire carries one frame's shared photons");
static_assert(sizeof(Photon) == 20 && sizeof(proto::PhotonRecord) == 20);

proto::PhotonRecord toWire(const Photon& photon) {
    return proto::PhotonRecord{photon.position.x, photon.position.y, photon.position.z, photon.power,
                               photon.incoming};
}

Photon fromWire(const proto::PhotonRecord& photon) {
    return Photon{Vec3(photon.x, photon.y, photon.z), photon.power, photon.incoming};
}

std::vector<proto::PhotonRecord> toWire(const std::vector<Photon>& photons) {
    std::vector<proto::PhotonRecord> out;
    out.reserve(photons.size());
    for (const Photon& p : photons) out.push_back(toWire(p));
    return out;
}

std::vector<Photon> fromWire(const std::vector<proto::PhotonRecord>& photons) {
    std::vector<Photon> out;
    out.reserve(photons.size());
    for (const proto::PhotonRecord& p : photons) out.push_back(fromWire(p));
    return out;
}

std::vector<SetPhotons> fromWire(const std::vector<proto::SetShot>& shots) {
    std::vector<SetPhotons> out;
    out.reserve(shots.size());
    for (const proto::SetShot& s : shots) out.push_back(SetPhotons{s.set, s.batches, fromWire(s.photons)});
    return out;
}

std::vector<proto::SetShot> toWire(const std::vector<SetPhotons>& shots) {
    std::vector<proto::SetShot> out;
    for (const SetPhotons& s : shots)
        if (s.batches > 0 && !s.photons.empty()) out.push_back(proto::SetShot{s.set, s.batches, toWire(s.photons)});
    return out;
}

}  // namespace rtpm::bridge
