// Validate-then-roll-back application of scene edits.
#include "common/scene/scene_edit.h"

#include <string>
#include <utility>

namespace rtpm {

namespace {

// Replaces `slot` with `value`, validates the scene, and restores the old value on failure.
template <class T>
T replaceValidated(Scene& scene, T& slot, const T& value) {
    T old = std::exchange(slot, value);
    try {
        scene.validate("edit");
    } catch (...) {
        slot = std::move(old);
        throw;
    }
    return old;
}

}  // namespace

void applyEdit(Scene& scene, const SceneEdit& edit, Material* previous) {
    switch (edit.kind) {
        case SceneEdit::Kind::Light:
            if (edit.index >= scene.lights.size())
                throw SceneError("edit", "light " + std::to_string(edit.index),
                                 "no such light (scene has " + std::to_string(scene.lights.size()) + ")");
            replaceValidated(scene, scene.lights[edit.index], edit.light);
            break;
        case SceneEdit::Kind::Material: {
            if (edit.index >= scene.materials.size())
                throw SceneError("edit", "material " + std::to_string(edit.index),
                                 "no such material (scene has " + std::to_string(scene.materials.size()) + ")");
            Material old = replaceValidated(scene, scene.materials[edit.index], edit.material);
            if (previous) *previous = std::move(old);
            break;
        }
        case SceneEdit::Kind::Transform:
            if (edit.index >= scene.instances.size())
                throw SceneError("edit", "instance " + std::to_string(edit.index),
                                 "no such instance (scene has " + std::to_string(scene.instances.size()) + ")");
            replaceValidated(scene, scene.instances[edit.index].transform, edit.transform);
            break;
    }
}

}  // namespace rtpm
