// RenderScene: a scene, its BVH, and the one path by which an edit reaches both.
#include "common/render/render_scene.h"

namespace rtpm {

RenderScene::RenderScene(Scene scene)
    : scene_(std::make_unique<Scene>(std::move(scene))), embree_(std::make_unique<EmbreeScene>(*scene_)) {}

RenderScene::~RenderScene() = default;

void RenderScene::applyEdit(const SceneEdit& edit) {
    Material previous;
    rtpm::applyEdit(*scene_, edit, &previous);  // throws and leaves the scene unchanged if refused
    const Scene& s = *scene_;
    if (edit.kind != SceneEdit::Kind::Light) ++eyeVersion_;
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
}

}  // namespace rtpm
