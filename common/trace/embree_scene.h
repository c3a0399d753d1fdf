// Embree 3 acceleration structure over a Scene, with world-space surface hits and robust ray offsets.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "common/scene/scene.h"

// Embree's opaque scene handle (same declaration as embree3/rtcore_scene.h), for rtcScene().
typedef struct RTCSceneTy* RTCScene;

namespace rtpm {

/// A ray in world space (metres). `dir` need not be unit; t is measured in units of |dir|.
struct Ray {
    Vec3 origin{0.0f};
    Vec3 dir{0.0f, 0.0f, 1.0f};
    float tMin = 0.0f;
    float tMax = 1e30f;
};

/// Everything the shading code needs about a ray–surface hit, in world space.
struct SurfaceHit {
    float t = 0.0f;
    Vec3 position{0.0f};
    Vec3 geometricNormal{0.0f};  ///< unit, from the triangle's winding (not flipped toward the ray)
    Vec3 shadingNormal{0.0f};    ///< unit, interpolated vertex normal, same hemisphere as geometricNormal
    Vec2 uv{0.0f};               ///< texture coordinates (0 when the mesh has none)
    uint32_t material = 0;
    uint32_t instance = 0;
    uint32_t triangle = 0;
};

/// An emissive triangle in world space, for direct lighting and photon emission.
struct EmissiveTriangle {
    Vec3 p0, p1, p2;
    Vec3 normal;     ///< unit, front face (emits into this hemisphere)
    float area;      ///< m²
    Vec3 radiance;   ///< W/(m²·sr); with an emissive texture, emission × the texture's mean over the triangle
    uint32_t instance, triangle;
    uint32_t material;  ///< Scene::materials index
    bool textured;      ///< radiance varies over the surface (emissive texture)
};

/// Owns the Embree device and scene. One Embree geometry per mesh, one instance per Instance.
/// Thread-safe for concurrent intersect/occluded; edits must not overlap queries.
class EmbreeScene {
public:
    /// Keeps a pointer to `scene` (materials, lights, textures), which must outlive it.
    explicit EmbreeScene(const Scene& scene);
    /// A temporary scene would be gone before the first query: refused at compile time.
    explicit EmbreeScene(Scene&&) = delete;
    ~EmbreeScene();
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;

    /// Closest hit in (tMin, tMax); fills `hit` and returns true, or returns false.
    bool intersect(const Ray& ray, SurfaceHit& hit) const;
    /// Closest hits of rays[0 .. count) (count ≤ 8) as one Embree packet: bit i of the result
    /// is set when rays[i] hit, and then hits[i] is what intersect(rays[i]) fills. Cheaper than
    /// count single queries for coherent rays (neighbouring primary rays). Thread-safe.
    uint32_t intersect8(const Ray* rays, int count, SurfaceHit* hits) const;
    /// True if anything is hit in (tMin, tMax).
    bool occluded(const Ray& ray) const;
    /// Occlusion of rays[0 .. count) (count ≤ 8) as one Embree packet: bit i of the result is
    /// occluded(rays[i]). Cheaper than count single queries when the rays are coherent (shadow
    /// rays from one point toward one light); a lone ray takes the single-ray traversal, which
    /// costs less than a packet with one live lane. Thread-safe like occluded().
    uint32_t occluded8(const Ray* rays, int count) const;

    /// Moves instance `index` (object → world); recommits the top level and rebuilds the flat
    /// scene (embree_scene.cpp).
    void setTransform(uint32_t index, const Mat4& transform);
    /// Replaces mesh `index`'s vertices/indices; recommits that geometry and the top level and
    /// rebuilds the flat scene.
    void setMesh(uint32_t index, const Mesh& mesh);
    /// True when rays are traced in the flat single-BVH copy, false when in the two-level scene
    /// (instancing that would more than double the triangles, or a failed flat build).
    bool flattened() const;

    /// Point just off the surface at `p` on the side of `towards` (a direction), offset scaled to
    /// |p| and the scene size so it works from millimetre to 100 km scenes.
    Vec3 offsetOrigin(Vec3 p, Vec3 geometricNormal, Vec3 towards) const;

    const Scene& scene() const { return *scene_; }
    const Bounds& bounds() const { return bounds_; }
    const std::vector<EmissiveTriangle>& emissiveTriangles() const { return emissive_; }
    /// Scene-size epsilon used for offsets (metres).
    float epsilon() const { return epsilon_; }
    /// The committed top-level Embree scene, for code that calls Embree directly (benchmarks
    /// comparing against raw rtcIntersect1, packet tracing). Valid until the next edit.
    RTCScene rtcScene() const;

private:
    /// Recomputes bounds_, epsilon_ and emissive_ from the current meshes and transforms.
    void refreshDerived();
    /// Fills `hit` from Embree's answer for `ray` (instance `inst`, RTC_INVALID_GEOMETRY_ID for
    /// a miss: returns false).
    bool completeHit(const Ray& ray, float t, uint32_t inst, uint32_t tri, float u, float v,
                     SurfaceHit& hit) const;

    struct Impl;
    std::unique_ptr<Impl> impl_;
    const Scene* scene_;
    Bounds bounds_;
    std::vector<EmissiveTriangle> emissive_;
    float epsilon_ = 1e-4f;
};

}  // namespace rtpm
