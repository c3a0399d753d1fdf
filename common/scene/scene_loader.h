// One entry point that turns a built-in scene name or a scene file path into a validated Scene.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/scene/environment_loader.h"
#include "common/scene/scene.h"
#include "common/scene/scene_files.h"

namespace rtpm {

/// Camera given on the command line; replaces the scene's own camera.
struct CameraOverride {
    Vec3 eye{0.0f, 1.0f, 3.0f};     ///< world, metres
    Vec3 target{0.0f};              ///< world, metres
    Vec3 up{0.0f, 1.0f, 0.0f};      ///< rough up hint
    float yfov = 0.8f;              ///< vertical field of view, radians
};

/// Extra point light added to the scene (for OBJ files, which carry no punctual lights).
struct PointLightOverride {
    Vec3 position{0.0f, 2.0f, 0.0f};  ///< world, metres
    Vec3 intensity{10.0f};            ///< radiant intensity W/sr per channel (flux = 4π·intensity)
};

/// Changes applied after a scene is loaded or built.
struct SceneOverrides {
    std::optional<CameraOverride> camera;     ///< replaces the scene's camera when set
    std::optional<PointLightOverride> light;  ///< appended to Scene::lights when set
    /// The world light (--env, --env-color, --env-strength): becomes Scene::environment. It counts
    /// as a light: a scene with it gets no default lights.
    std::optional<EnvironmentOverride> environment;
    /// A scene with no light, no emissive material and no world light gets defaultLight(), keyLight()
    /// and defaultSky() (with a warning); false makes such a scene an error instead (--no-default-light).
    /// A scene file lit by emissive surfaces alone gets defaultSky(); false leaves it out.
    bool defaultLight = true;
    /// glTF KHR_materials_variants: the variant whose materials are used (GltfOptions::variant);
    /// empty: the default materials. Set for a scene other than a glTF file, it is an error.
    std::string variant;
};

/// The light a scene without lights gets: a spot light above the scene, aimed at the centre of
/// `bounds` (Y is up, as in glTF), tilted 15° so that it stands behind the scene as `camera`
/// sees it (caustics are cast towards the viewer). It sits 3 bounding-sphere radii r from the
/// centre, its cone (full intensity within asin(1/3) + 2°, zero beyond 4° more) covers the
/// bounding sphere, and its intensity π·(3r)² W/sr gives irradiance π W/m² at the centre, so a
/// white Lambertian surface there facing the light has radiance 1 W/(m²·sr). Pure, O(1).
Light defaultLight(const Bounds& bounds, const Camera& camera);

/// The second light a scene without lights gets: a key light on the camera's side, so that what
/// the camera sees is lit (defaultLight stands behind the scene and lights only the faces turned
/// away from the viewer and upwards). A spot light 3 bounding-sphere radii r from the centre of
/// `bounds`, in the direction of the camera turned 30° to its right and 30° up (in the camera's
/// frame), aimed at the centre; its cone covers the bounding sphere as defaultLight's does, and its
/// intensity π·(3r)²/2 W/sr gives half defaultLight's irradiance at the centre (π/2 W/m²), so the
/// caustic light stays the stronger. The light is 41° off the view axis, so every surface whose
/// normal is within 48° of the direction to the camera faces it. Pure, O(1).
Light keyLight(const Bounds& bounds, const Camera& camera);

/// Names accepted by loadScene as built-in scenes, upper case: RING, GLASS, EGG, HEADLIGHT, CORNELL.
std::vector<std::string> builtinSceneNames();
/// True when `name` is a built-in scene name (case-insensitive).
bool isBuiltinScene(const std::string& name);

/// Loads a scene.
/// `nameOrPath` is a built-in name (case-insensitive, see builtinSceneNames()) or a file path
/// chosen by extension (case-insensitive): `.gltf`, `.glb` (glTF 2.0) or `.obj` (with its MTL).
/// Overrides are applied after loading. A scene without a camera gets a default one looking at
/// the centre of its bounds from the +Z side (so every returned scene has a camera).
/// A scene with no light, no emissive material and no world light (after `overrides.light` and
/// `overrides.environment`) gets defaultLight() and keyLight() (in that order), defaultSky() as its
/// world light and a warning naming the file, or, with `overrides.defaultLight` false, is an error
/// (SceneError naming the file). A scene file (not a built-in scene) lit by emissive surfaces alone
/// (no punctual light, no world light) gets defaultSky() as its world and a warning, unless
/// `overrides.defaultLight` is false. The world light's file and decoded map count against
/// `input.maxSceneBytes` with the scene's own arrays (loadEnvironment). Warnings (unsupported features) are in Scene::warnings.
/// Throws SceneError{file, element, message} on any bad input; never crashes on malformed files.
/// Files are read through SceneFiles under `input`: the files a scene names must lie in its
/// folder or `input.allowedDirs`, be regular files, and fit `input.maxSceneBytes` with every
/// decoded array (see loadGltf, loadObj).
/// The returned scene passes Scene::validate. Thread-safe (no shared state). Cost: O(file size)
/// for files, O(triangles) for built-ins.
Scene loadScene(const std::string& nameOrPath, const SceneOverrides& overrides = {},
                const SceneInputPolicy& input = {});

}  // namespace rtpm
