// A scene edit (light, material or instance transform) and the one rule that applies it.
#pragma once

#include <cstdint>

#include "common/scene/scene.h"

namespace rtpm {

/// A scene edit applied between frames. Camera changes are not edits (photons are
/// view-independent); every edit here resets the photon maps (docs/ARCHITECTURE.md §2.1).
struct SceneEdit {
    enum class Kind { Light, Material, Transform } kind = Kind::Light;
    uint32_t index = 0;  ///< light, material or instance index
    Light light;
    Material material;
    Mat4 transform{1.0f};
};

/// Applies `edit` to `scene` and validates the result (Scene::validate); on any failure (index
/// out of range, a value the scene refuses) throws SceneError naming it and leaves `scene`
/// exactly as it was. Returns the replaced value's kind-specific predecessor only through
/// `previous` (may be null): the material before the edit, so a caller can tell whether emission
/// changed. Cost O(scene validation).
void applyEdit(Scene& scene, const SceneEdit& edit, Material* previous = nullptr);

}  // namespace rtpm
