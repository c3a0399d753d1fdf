// The master's authoritative scene: the scene as loaded, its current state and camera, the edits sent.
#pragma once

#include <vector>

#include "common/scene/scene.h"
#include "proto/messages.h"
#include "server/script/script_edit.h"

namespace rtpm::server {

/// The server's authoritative view of the scene: the scene as loaded, its current state, and the
/// camera. Edits are checked here (index ranges, and the rules of common/scene/scene.h every
/// client applies: validateLight, validateMaterial, validateInstanceTransform, validateCamera)
/// before they are sent, so a client never receives an edit it must refuse. Not thread-safe.
class LiveScene {
public:
    explicit LiveScene(Scene loaded);

    /// Applies one script edit. Camera edits change camera() only; the others change scene() and
    /// append the protocol edit to `out`. Throws SceneError{fileName, "line N", …} when the edit
    /// does not fit the scene (index out of range, colour above 1, zero direction…); nothing
    /// changes then.
    void apply(const ScriptEdit& edit, const std::string& fileName, std::vector<proto::SceneEdit>& out);

    const Scene& loaded() const { return loaded_; }
    const Scene& scene() const { return scene_; }
    const Camera& camera() const { return camera_; }
    void setCamera(const Camera& c) { camera_ = c; }

    /// Records that `e` was sent (for the compacted list late joiners receive) and advances the
    /// scene version.
    void record(const proto::SceneEdit& e);
    /// 1 as loaded, +1 per edit recorded: the sceneVersion of Edit, Scene and FrameBegin.
    uint32_t version() const { return version_; }
    /// Every scene edit so far, compacted to the latest one per light, material and instance, in
    /// order of first change: what Scene.edits carries for a client joining now.
    const std::vector<proto::SceneEdit>& compactedEdits() const { return compacted_; }

private:
    Scene loaded_;
    Scene scene_;
    Camera camera_;
    std::vector<Bounds> meshBoxes_;  // object-space bounds per mesh, for transform checks
    std::vector<proto::SceneEdit> compacted_;
    uint32_t version_ = 1;
};

}  // namespace rtpm::server
