// loadScene: dispatch by built-in name or file extension, apply overrides, add defaults, validate.
#include "common/scene/scene_loader.h"
#include "common/core/strings.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>

#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_loader.h"
#include "common/scene/obj_loader.h"

namespace rtpm {

namespace {

// A camera that sees the whole scene: from the +Z side, slightly above, bounding sphere in view.
Camera defaultCamera(const Bounds& b) {
    Vec3 centre = b.empty() ? Vec3(0.0f) : b.centre();
    float radius = std::max(0.5f * (b.empty() ? 1.0f : b.diagonal()), 1e-3f);
    const float yfov = 0.8f;
    float dist = radius / std::sin(0.5f * yfov);
    Vec3 eye = centre + glm::normalize(Vec3(0.0f, 0.35f, 1.0f)) * dist;
    return Camera::lookAt(eye, centre, Vec3(0, 1, 0), yfov);
}

// A light of zero intensity lights nothing.
bool emits(const Light& l) { return maxComponent(l.intensity) > 0.0f; }

// True when some light or emissive surface of `s` emits: a light of zero intensity, or an emissive
// material whose emissive texture is black everywhere (factor × texture = 0), lights nothing.
bool hasLightOrEmitter(const Scene& s) {
    if (std::any_of(s.lights.begin(), s.lights.end(), emits)) return true;
    for (const Instance& inst : s.instances) {
        if (inst.mesh >= s.meshes.size() || s.meshes[inst.mesh].material >= s.materials.size()) continue;
        const Material& m = s.materials[s.meshes[inst.mesh].material];
        if (!m.isEmissive()) continue;
        if (m.emissiveTexture < 0 || size_t(m.emissiveTexture) >= s.textures.size()) return true;
        const Texture& tex = s.textures[size_t(m.emissiveTexture)];
        if (tex.width <= 0 || tex.height <= 0) return true;  // no texels: the factor alone (emissionAt)
        if (std::any_of(tex.rgb.begin(), tex.rgb.end(), [](float v) { return v > 0.0f; })) return true;
    }
    return false;
}

// Bytes of the scene's decoded arrays: what its load charged to --max-scene-bytes, near enough
// (the files' own bytes were read and released), for the world light's share of the budget.
uint64_t decodedBytes(const Scene& s) {
    uint64_t bytes = 0;
    for (const Mesh& m : s.meshes)
        bytes += m.positions.size() * sizeof(Vec3) + m.normals.size() * sizeof(Vec3) +
                 m.uvs.size() * sizeof(Vec2) + m.indices.size() * sizeof(uint32_t);
    for (const Texture& t : s.textures) bytes += t.rgb.size() * sizeof(float);
    return bytes;
}

}  // namespace

Light defaultLight(const Bounds& b, const Camera& camera) {
    const Vec3 centre = b.empty() ? Vec3(0.0f) : b.centre();
    const float radius = std::max(0.5f * (b.empty() ? 1.0f : b.diagonal()), 1e-3f);
    const float distance = 3.0f * radius;
    // Tilt 15° from the zenith towards the far side of the scene as the camera looks at it (its
    // forward direction projected on the ground); a camera looking straight down gets no tilt.
    Vec3 away(camera.forward.x, 0.0f, camera.forward.z);
    const float awayLen = glm::length(away);
    away = awayLen > 1e-6f && std::isfinite(awayLen) ? away / awayLen : Vec3(0.0f);
    const float tilt = 15.0f * kPi / 180.0f;
    const Vec3 toLight = std::cos(tilt) * Vec3(0.0f, 1.0f, 0.0f) + std::sin(tilt) * away;
    Light l;
    l.name = "default light";
    l.type = LightType::Spot;
    l.position = centre + distance * toLight;
    l.direction = glm::normalize(centre - l.position);
    const float halfAngle = std::asin(radius / distance);  // the bounding sphere as seen from the light
    l.innerConeAngle = halfAngle + 2.0f * kPi / 180.0f;
    l.outerConeAngle = l.innerConeAngle + 4.0f * kPi / 180.0f;
    l.intensity = Vec3(kPi * distance * distance);
    return l;
}

Light keyLight(const Bounds& b, const Camera& camera) {
    const Vec3 centre = b.empty() ? Vec3(0.0f) : b.centre();
    const float radius = std::max(0.5f * (b.empty() ? 1.0f : b.diagonal()), 1e-3f);
    const float distance = 3.0f * radius;
    // From the centre towards the camera, turned 30° to the camera's right and 30° up: the classic
    // key position, lighting the faces the camera sees with a shading gradient across them.
    const Vec3 back = -camera.forward;
    const Vec3 right = glm::normalize(glm::cross(camera.forward, camera.up));
    const float turn = 30.0f * kPi / 180.0f;
    const Vec3 toLight = glm::normalize(std::cos(turn) * (std::cos(turn) * back + std::sin(turn) * right) +
                                        std::sin(turn) * camera.up);
    Light l;
    l.name = "default key light";
    l.type = LightType::Spot;
    l.position = centre + distance * toLight;
    l.direction = glm::normalize(centre - l.position);
    const float halfAngle = std::asin(radius / distance);
    l.innerConeAngle = halfAngle + 2.0f * kPi / 180.0f;
    l.outerConeAngle = l.innerConeAngle + 4.0f * kPi / 180.0f;
    l.intensity = Vec3(0.5f * kPi * distance * distance);
    return l;
}

std::vector<std::string> builtinSceneNames() { return {"RING", "GLASS", "EGG", "HEADLIGHT", "CORNELL"}; }

bool isBuiltinScene(const std::string& name) {
    const auto names = builtinSceneNames();
    return std::find(names.begin(), names.end(), toUpper(name)) != names.end();
}

Scene loadScene(const std::string& nameOrPath, const SceneOverrides& overrides,
                const SceneInputPolicy& input) {
    Scene scene;
    const std::string ext = toLower(std::filesystem::path(nameOrPath).extension().string());
    const bool gltf = !isBuiltinScene(nameOrPath) && (ext == ".gltf" || ext == ".glb");
    if (!overrides.variant.empty() && !gltf)
        throw SceneError(nameOrPath, "variant",
                         "material variants (KHR_materials_variants) exist only in glTF files; this scene "
                         "has none to choose from");
    if (isBuiltinScene(nameOrPath)) {
        scene = buildBuiltinScene(toUpper(nameOrPath));
    } else {
        if (gltf) {
            GltfOptions options;
            options.variant = overrides.variant;
            scene = loadGltf(nameOrPath, input, options);
        } else if (ext == ".obj") {
            scene = loadObj(nameOrPath, input);
        } else {
            std::string known;
            for (const auto& n : builtinSceneNames()) known += n + " ";
            throw SceneError(nameOrPath, "scene",
                             "neither a built-in scene (" + known +
                                 ") nor a file with extension .gltf, .glb or .obj");
        }
    }
    if (overrides.camera) {
        const CameraOverride& c = *overrides.camera;
        if (glm::length(c.target - c.eye) < 1e-9f)
            throw SceneError(nameOrPath, "camera override", "eye and target coincide");
        scene.camera = Camera::lookAt(c.eye, c.target, c.up, c.yfov);
    }
    if (overrides.light) {
        Light l;
        l.name = "override point light";
        l.type = LightType::Point;
        l.position = overrides.light->position;
        l.intensity = overrides.light->intensity;
        scene.lights.push_back(l);
    }
    // An empty scene (Blender exports one when "Selected only" selects nothing) shows its world,
    // as Blender renders it: the default sky below, since it has no light either.
    if (scene.triangleCount() == 0)
        scene.warnings.push_back(nameOrPath + ": no triangles (nothing to render but the world; check the "
                                              "exporter's selection)");
    if (overrides.environment)
        scene.environment = loadEnvironment(*overrides.environment,
                                            input.maxSceneBytes - std::min(input.maxSceneBytes, decodedBytes(scene)));
    if (!hasLightOrEmitter(scene) && scene.environment.empty()) {
        if (!overrides.defaultLight)
            throw SceneError(nameOrPath, "lights",
                             "scene has no light and no emissive material that emits; give one (e.g. --light "
                             "x y z or --env FILE) or drop --no-default-light to get the default lights");
        // The framing camera first: it must frame the geometry, not the light above it.
        if (!scene.camera) scene.camera = defaultCamera(scene.bounds());
        const Bounds bounds = scene.bounds();
        const Light light = defaultLight(bounds, *scene.camera), key = keyLight(bounds, *scene.camera);
        scene.lights.push_back(light);
        scene.lights.push_back(key);
        scene.environment = defaultSky();
        auto at = [](Vec3 p) {
            return std::to_string(p.x) + ", " + std::to_string(p.y) + ", " + std::to_string(p.z);
        };
        scene.warnings.push_back(
            nameOrPath + ": no light and no emissive material that emits; added the default spot light (at " + at(light.position) +
            ", behind the scene, for caustics) and a key light from the camera's side (at " + at(key.position) +
            "), both aimed at the scene's centre, and a dim grey sky; see README. --no-default-light refuses such scenes");
    } else if (overrides.defaultLight && !overrides.environment && scene.environment.empty() && !scene.worldless &&
               !isBuiltinScene(nameOrPath) &&
               std::none_of(scene.lights.begin(), scene.lights.end(), emits)) {
        // A file lit by its emissive surfaces alone: what they do not reach would be black, where
        // Blender (and a glTF viewer) shows the world it always has, which glTF cannot carry.
        scene.environment = defaultSky();
        scene.warnings.push_back(nameOrPath +
                                 ": lit by emissive surfaces only; added the dim grey sky as its world, as "
                                 "Blender's default world; --no-default-light leaves it out");
    }
    if (!scene.camera) scene.camera = defaultCamera(scene.bounds());
    scene.validate(nameOrPath);
    return scene;
}

}  // namespace rtpm
