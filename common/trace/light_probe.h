// How much of what the camera sees the scene's punctual lights reach, and the dim sky a file gets
// when they reach almost none of it.
#pragma once

#include <string>

#include "common/scene/scene.h"
#include "common/scene/scene_loader.h"

namespace rtpm {

/// Share, in [0, 1], of the camera's view that some punctual light lights directly: of the primary
/// rays through a columns × rows grid (the default image's 4:3), the share that hits a surface a
/// point, spot or directional light stands in front of (facing the camera) at more than a grazing
/// 3°, inside its spot cone, unshadowed; a hit on an emissive surface counts as lit (it shows
/// itself), what emissive surfaces light does not, and a ray that hits nothing is dark (there is
/// no world light to show). Builds its own Embree scene; `scene` needs a camera.
float directlyLitShare(const Scene& scene, int columns = 64, int rows = 48);

/// The share below which a file's view counts as unlit (directlyLitShare): its lights leave three
/// quarters of what the camera sees dark.
inline constexpr float kUnlitViewShare = 0.25f;

/// A scene file (not a built-in scene) with no world light, not marked worldless by our own
/// export, whose punctual lights reach less than kUnlitViewShare of its camera's view, gets
/// defaultSky() as its world and a warning naming the share: Blender shows such a file under its
/// world, which glTF cannot carry (a sun grazing the floor the camera looks down on). Nothing
/// when `overrides` (what loadScene was given) refuse default light (--no-default-light) or name
/// a world light of their own (--env, --env-color, black included). Returns true when the sky
/// was added.
bool addSkyWhereLightsMissTheView(Scene& scene, const std::string& nameOrPath, const SceneOverrides& overrides);

/// loadScene, then addSkyWhereLightsMissTheView with the same overrides: the scene rtpm-render and
/// the master render (the sky rule needs rays, which the scene library below cannot trace).
Scene loadSceneToRender(const std::string& nameOrPath, const SceneOverrides& overrides,
                        const SceneInputPolicy& input);

}  // namespace rtpm
