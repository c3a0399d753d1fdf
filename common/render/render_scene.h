// The scene as rendering sees it: the model and its Embree BVH, built once per process and shared by its RenderJobs.
#pragma once

#include <memory>

#include "common/scene/scene.h"
#include "common/scene/scene_edit.h"
#include "common/trace/embree_scene.h"

namespace rtpm {

/// A Scene with the Embree BVH over it. A process holds one: rtpm-render's job, and every set
/// group of a cluster client (their RenderJobs share it through a shared_ptr), so a client keeps
/// one scene copy and one BVH whatever its sets, and applies an edit once.
/// Thread safety: scene(), embree() and the queries on them may run concurrently (every TBB
/// thread of a frame reads it); applyEdit must not overlap any of them (call it between frames).
class RenderScene {
public:
    /// Builds the BVH. Throws SceneError for a scene Embree cannot take (a material index out
    /// of range, a singular transform), std::runtime_error when Embree fails.
    explicit RenderScene(Scene scene);
    ~RenderScene();
    RenderScene(const RenderScene&) = delete;
    RenderScene& operator=(const RenderScene&) = delete;

    const Scene& scene() const { return *scene_; }
    const EmbreeScene& embree() const { return *embree_; }

    /// Applies `edit` to the scene (validated: throws SceneError and changes nothing when it is
    /// refused) and updates the BVH where it changed: a transform recommits the instance, an
    /// emission change rebuilds the emissive triangle list; lights are read at the next batch.
    /// The photon maps of every job sharing the scene are then stale (RenderJob::resetPhotons).
    /// Cost: a transform or emission edit rebuilds the flat BVH (O(triangles log triangles)).
    void applyEdit(const SceneEdit& edit);
    /// Counts the edits that change what an eye ray meets (material, transform; not a punctual
    /// light's): eye-path records of one camera stay valid while it is unchanged.
    uint64_t eyeVersion() const { return eyeVersion_; }

private:
    std::unique_ptr<Scene> scene_;  // stable address: EmbreeScene keeps a pointer to it
    std::unique_ptr<EmbreeScene> embree_;
    uint64_t eyeVersion_ = 0;
};

}  // namespace rtpm
