// Conversions between the wire protocol's types and the renderer's.
#include "proto/bridge/bridge.h"

#include <cstddef>
#include <stdexcept>
#include <string>

#include <glm/gtc/type_ptr.hpp>

namespace rtpm::bridge {

// The codec addresses a pixel as six floats: direct RGB, then caustic RGB.
static_assert(sizeof(Vec3) == 3 * sizeof(float), "Vec3 is three packed floats");
static_assert(sizeof(PixelRadiance) == 6 * sizeof(float), "PixelRadiance is six packed floats");
static_assert(offsetof(PixelRadiance, caustic) == 3 * sizeof(float), "caustic follows direct");
static_assert(proto::kMaxPassBatches == kMaxPassBatches, "one limit for a pass's batches");
static_assert(proto::kMaxPassPeriod == kMaxPassPeriod, "one limit for the sets' turns");

proto::Vec3f toWire(Vec3 v) { return {v.x, v.y, v.z}; }
Vec3 fromWire(proto::Vec3f v) { return {v.x, v.y, v.z}; }

// The wire's ids are append-only; common's enum mirrors them, so the conversion is a cast.
static_assert(uint8_t(FrameMode::Interaction) == uint8_t(proto::FrameMode::Interaction) &&
              uint8_t(FrameMode::Accumulate) == uint8_t(proto::FrameMode::Accumulate) &&
              uint8_t(FrameMode::Walkthrough) == uint8_t(proto::FrameMode::Walkthrough) &&
              uint8_t(FrameMode::Converging) == uint8_t(proto::FrameMode::Converging) &&
              uint8_t(FrameMode::Edit) == uint8_t(proto::FrameMode::Edit) &&
              uint8_t(FrameMode::Relight) == uint8_t(proto::FrameMode::Relight) &&
              proto::kMaxFrameMode == uint8_t(FrameMode::Relight));

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
        case MaterialType::Plastic: e.kind = proto::MaterialKind::Plastic; break;
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
            case proto::MaterialKind::Plastic: edit.material.type = MaterialType::Plastic; break;
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
