// Embree 3 acceleration structure over a Scene: two-level BVH (one BLAS per mesh, one instance per
// Instance), world-space surface hits, robust origin offsets and the emissive-triangle list.
//
// Rays are traced in a flat scene when it is built: one world-space triangle geometry per
// instance (geomID = instance index) in a single BVH. Nested objects (a bulb inside a
// reflector, a liquid inside a glass) put several instances' boxes around one ray, and the
// two-level traversal then descends each of their BLASes; one BVH over all triangles does not
// (HEADLIGHT photon shooting 18 % faster, GLASS eye pass 17 %). Instancing is what the flat copy
// gives up: it is built only while the world holds at most kMaxFlatTriangleRatio times the
// meshes' own triangles (every built-in scene: 1×), else rays use the two-level scene. Edits
// rebuild it (setTransform, setMesh). Hits are the same floats as the two-level scene's (the
// transform is applied to the vertices instead of the ray; exact for the identity) except where
// two surfaces coincide and either may be reported.
#include "common/trace/embree_scene.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

#include <glm/gtc/matrix_inverse.hpp>

#include "common/core/check.h"

namespace rtpm {

namespace {

/// The flat scene is built while the instances hold at most this many times the meshes' own
/// triangles (file comment).
constexpr size_t kMaxFlatTriangleRatio = 2;

/// An Embree packet of rays[0 .. count) (count ≤ 8); inactive lanes repeat ray 0 so every lane
/// holds finite values, and are masked off in `valid`.
void fillPacket(const Ray* rays, int count, int* valid, RTCRay8& r) {
    for (int i = 0; i < 8; ++i) {
        const Ray& ray = rays[i < count ? i : 0];
        valid[i] = i < count ? -1 : 0;
        r.org_x[i] = ray.origin.x;
        r.org_y[i] = ray.origin.y;
        r.org_z[i] = ray.origin.z;
        r.dir_x[i] = ray.dir.x;
        r.dir_y[i] = ray.dir.y;
        r.dir_z[i] = ray.dir.z;
        r.tnear[i] = ray.tMin;
        r.tfar[i] = ray.tMax;
        r.time[i] = 0.0f;
        r.mask[i] = 0xFFFFFFFFu;
        r.id[i] = 0;
        r.flags[i] = 0;
    }
}

const char* rtcErrorName(RTCError code) {
    switch (code) {
        case RTC_ERROR_NONE: return "none";
        case RTC_ERROR_UNKNOWN: return "unknown error";
        case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
        case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
        case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
        case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
        case RTC_ERROR_CANCELLED: return "cancelled";
    }
    return "unrecognised error";
}


float maxAbs(Vec3 v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

}  // namespace

// Why copies of the meshes and instance transforms: setMesh/setTransform may be called with data
// that is not (yet) in the Scene the caller passed, and shading must use the same vertices Embree
// intersects. Materials, by contrast, are read live from the Scene (edits need no rebuild).
struct EmbreeScene::Impl {
    /// What completeHit reads of a mesh, per triangle and in triangle order: one or two cache
    /// lines a hit instead of the index triple and three scattered vertices each of positions,
    /// normals and uvs (those misses were 14 % of a HEADLIGHT frame). The same floats as the
    /// mesh's, so hits are bit for bit what they were.
    struct TriangleShading {
        std::vector<Vec3> cross;                   ///< cross(p1 − p0, p2 − p0), object space
        std::vector<std::array<Vec3, 3>> normals;  ///< vertex normals; empty when the mesh has none
        std::vector<std::array<Vec2, 3>> uvs;      ///< texture coordinates; empty when none
    };

    RTCDevice device = nullptr;
    RTCScene top = nullptr;
    RTCScene flat = nullptr;  // null: rays use `top`
    std::vector<RTCScene> meshScenes;      // one per mesh, each holding geometry 0
    std::vector<RTCGeometry> instanceGeoms;  // one per instance, geomID == instance index
    std::vector<Mesh> meshes;
    std::vector<TriangleShading> shading;  // one per mesh, built with its BLAS
    std::vector<Mat4> transforms;          // object → world
    std::vector<glm::mat3> normalMatrices;  // inverse transpose of the upper 3×3
    std::vector<uint8_t> identityLinear;    // upper 3×3 is exactly the identity: skip nm · n per hit
    std::vector<uint32_t> instanceMesh;

    std::mutex errorMutex;
    std::string lastError;

    ~Impl() {
        for (RTCGeometry g : instanceGeoms)
            if (g) rtcReleaseGeometry(g);
        for (RTCScene s : meshScenes)
            if (s) rtcReleaseScene(s);
        if (top) rtcReleaseScene(top);
        if (flat) rtcReleaseScene(flat);
        if (device) rtcReleaseDevice(device);
    }

    static void onError(void* user, RTCError code, const char* message) {
        auto* self = static_cast<Impl*>(user);
        std::lock_guard<std::mutex> lock(self->errorMutex);
        self->lastError = std::string(rtcErrorName(code)) + (message ? std::string(": ") + message : "");
    }

    /// Throws std::runtime_error naming `what` if Embree reported an error since the last check.
    void throwOnError(const std::string& what) {
        const RTCError code = rtcGetDeviceError(device);
        std::string message;
        {
            std::lock_guard<std::mutex> lock(errorMutex);
            message.swap(lastError);
        }
        if (code != RTC_ERROR_NONE || !message.empty())
            throw std::runtime_error("Embree error during " + what + ": " +
                                     (message.empty() ? rtcErrorName(code) : message));
    }

    RTCGeometry buildTriangleGeometry(const Mesh& mesh, uint32_t meshIndex) {
        const size_t vertexCount = mesh.positions.size();
        const size_t triCount = mesh.indices.size() / 3;
        // Validated before any Embree object exists, so a rejected mesh leaks nothing.
        validateMesh(mesh, "<embree>", "mesh " + std::to_string(meshIndex) + " '" + mesh.name + "'");
        RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        if (!geom) throwOnError("rtcNewGeometry(triangle)");
        // Embree allocates with the padding its SIMD loads need; an empty mesh gets one dummy
        // vertex so the buffer is valid (no triangles reference it).
        const size_t vtxAlloc = std::max<size_t>(vertexCount, 1);
        auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                               vtxAlloc));
        auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                                                  RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                                                  triCount));
        if (!vb || (!ib && triCount > 0)) {
            rtcReleaseGeometry(geom);
            throwOnError("rtcSetNewGeometryBuffer");
            throw std::runtime_error("Embree could not allocate geometry buffers");
        }
        for (size_t i = 0; i < vertexCount; ++i) {
            vb[3 * i + 0] = mesh.positions[i].x;
            vb[3 * i + 1] = mesh.positions[i].y;
            vb[3 * i + 2] = mesh.positions[i].z;
        }
        if (vertexCount == 0) vb[0] = vb[1] = vb[2] = 0.0f;
        std::copy(mesh.indices.begin(), mesh.indices.end(), ib);
        rtcCommitGeometry(geom);
        return geom;
    }

    void buildMeshScene(uint32_t meshIndex) {
        // The geometry first: it validates the mesh and may throw, and nothing else is held yet.
        RTCGeometry geom = buildTriangleGeometry(meshes[meshIndex], meshIndex);
        RTCScene s = rtcNewScene(device);
        rtcSetSceneFlags(s, RTC_SCENE_FLAG_ROBUST);
        rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_HIGH);
        rtcAttachGeometryByID(s, geom, 0);
        rtcReleaseGeometry(geom);
        rtcCommitScene(s);
        if (meshScenes[meshIndex]) rtcReleaseScene(meshScenes[meshIndex]);
        meshScenes[meshIndex] = s;
        throwOnError("building mesh " + std::to_string(meshIndex));
        shading[meshIndex] = triangleShading(meshes[meshIndex]);
    }

    static TriangleShading triangleShading(const Mesh& mesh) {
        TriangleShading t;
        const size_t n = mesh.indices.size() / 3;
        const bool normals = mesh.normals.size() == mesh.positions.size() && !mesh.normals.empty();
        const bool uvs = mesh.uvs.size() == mesh.positions.size() && !mesh.uvs.empty();
        t.cross.resize(n);
        if (normals) t.normals.resize(n);
        if (uvs) t.uvs.resize(n);
        for (size_t i = 0; i < n; ++i) {
            const uint32_t i0 = mesh.indices[3 * i + 0], i1 = mesh.indices[3 * i + 1], i2 = mesh.indices[3 * i + 2];
            const Vec3 p0 = mesh.positions[i0], p1 = mesh.positions[i1], p2 = mesh.positions[i2];
            t.cross[i] = glm::cross(p1 - p0, p2 - p0);
            if (normals) t.normals[i] = {mesh.normals[i0], mesh.normals[i1], mesh.normals[i2]};
            if (uvs) t.uvs[i] = {mesh.uvs[i0], mesh.uvs[i1], mesh.uvs[i2]};
        }
        return t;
    }

    /// The scene rays are traced in, and the instance a hit's IDs name.
    RTCScene traceScene() const { return flat ? flat : top; }
    uint32_t hitInstance(uint32_t geomID, uint32_t instID) const {
        if (geomID == RTC_INVALID_GEOMETRY_ID) return RTC_INVALID_GEOMETRY_ID;
        return flat ? geomID : instID;
    }

    /// (Re)builds the flat scene from the current meshes and transforms, or drops it when the
    /// instances would more than kMaxFlatTriangleRatio-fold the meshes' triangles. If the build
    /// fails (a transform that sends vertices to infinity, Embree out of memory), rays fall back
    /// to the two-level scene, which holds the same surfaces.
    void buildFlat() noexcept {
        if (flat) rtcReleaseScene(flat);
        flat = nullptr;
        try {
            flat = newFlatScene();
        } catch (const std::exception&) {
            flat = nullptr;
        }
    }

    RTCScene newFlatScene() {
        size_t meshTriangles = 0, worldTriangles = 0;
        for (const Mesh& m : meshes) meshTriangles += m.indices.size() / 3;
        for (uint32_t mi : instanceMesh) worldTriangles += meshes[mi].indices.size() / 3;
        RTCScene f = nullptr;
        if (worldTriangles <= kMaxFlatTriangleRatio * std::max<size_t>(meshTriangles, 1)) {
            f = rtcNewScene(device);
            if (!f) {
                throwOnError("rtcNewScene(flat)");
                return nullptr;
            }
            rtcSetSceneFlags(f, RTC_SCENE_FLAG_ROBUST);
            rtcSetSceneBuildQuality(f, RTC_BUILD_QUALITY_HIGH);
            try {
                for (uint32_t i = 0; i < transforms.size(); ++i) {
                    Mesh world = meshes[instanceMesh[i]];
                    for (Vec3& p : world.positions) p = Vec3(transforms[i] * glm::vec4(p, 1.0f));
                    RTCGeometry g = buildTriangleGeometry(world, instanceMesh[i]);
                    rtcAttachGeometryByID(f, g, i);
                    rtcReleaseGeometry(g);
                }
                rtcCommitScene(f);
                throwOnError("building the flat scene");
            } catch (...) {
                rtcReleaseScene(f);
                throw;
            }
        }
        return f;
    }

    void setInstanceTransform(uint32_t index, const Mat4& m, const std::string& name) {
        const glm::mat3 linear(m);
        const float det = glm::determinant(linear);
        bool ok = std::isfinite(det) && det != 0.0f;
        for (int c = 0; c < 4 && ok; ++c)
            for (int r = 0; r < 4 && ok; ++r) ok = std::isfinite(m[c][r]);
        if (!ok)
            throw SceneError("<embree>", "instance " + std::to_string(index) + " '" + name + "'",
                             "transform is singular or not finite");
        transforms[index] = m;
        // glTF: a negative determinant flips the winding so front faces stay front faces; the
        // inverse transpose keeps the object-space normal's side, which is what that rule wants.
        normalMatrices[index] = glm::inverseTranspose(linear);
        identityLinear[index] = linear == glm::mat3(1.0f) ? 1 : 0;
        rtcSetGeometryTransform(instanceGeoms[index], 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &m[0][0]);
        rtcCommitGeometry(instanceGeoms[index]);
    }
};

EmbreeScene::EmbreeScene(const Scene& scene) : impl_(std::make_unique<Impl>()), scene_(&scene) {
    Impl& s = *impl_;
    s.device = rtcNewDevice(nullptr);
    if (!s.device)
        throw std::runtime_error(std::string("Embree device creation failed: ") +
                                 rtcErrorName(rtcGetDeviceError(nullptr)));
    rtcSetDeviceErrorFunction(s.device, &Impl::onError, &s);

    s.meshes = scene.meshes;
    s.meshScenes.assign(s.meshes.size(), nullptr);
    s.shading.assign(s.meshes.size(), {});
    for (uint32_t i = 0; i < s.meshes.size(); ++i) {
        if (s.meshes[i].material >= scene.materials.size())
            throw SceneError("<embree>", "mesh " + std::to_string(i) + " '" + s.meshes[i].name + "'",
                             "material index " + std::to_string(s.meshes[i].material) +
                                 " out of range (" + std::to_string(scene.materials.size()) +
                                 " materials)");
        s.buildMeshScene(i);
    }

    s.top = rtcNewScene(s.device);
    // The top level is rebuilt whenever an instance moves: favour build speed there.
    rtcSetSceneFlags(s.top, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_DYNAMIC);
    rtcSetSceneBuildQuality(s.top, RTC_BUILD_QUALITY_LOW);
    const size_t n = scene.instances.size();
    s.instanceGeoms.assign(n, nullptr);
    s.transforms.assign(n, Mat4(1.0f));
    s.normalMatrices.assign(n, glm::mat3(1.0f));
    s.identityLinear.assign(n, 1);
    s.instanceMesh.assign(n, 0);
    for (uint32_t i = 0; i < n; ++i) {
        const Instance& inst = scene.instances[i];
        if (inst.mesh >= s.meshes.size())
            throw SceneError("<embree>", "instance " + std::to_string(i) + " '" + inst.name + "'",
                             "mesh index " + std::to_string(inst.mesh) + " out of range (" +
                                 std::to_string(s.meshes.size()) + " meshes)");
        s.instanceMesh[i] = inst.mesh;
        RTCGeometry g = rtcNewGeometry(s.device, RTC_GEOMETRY_TYPE_INSTANCE);
        if (!g) s.throwOnError("rtcNewGeometry(instance)");
        rtcSetGeometryInstancedScene(g, s.meshScenes[inst.mesh]);
        s.instanceGeoms[i] = g;
        s.setInstanceTransform(i, inst.transform, inst.name);
        rtcAttachGeometryByID(s.top, g, i);
    }
    rtcCommitScene(s.top);
    s.throwOnError("building the top-level scene");
    s.buildFlat();
    refreshDerived();
}

EmbreeScene::~EmbreeScene() = default;

void EmbreeScene::refreshDerived() {
    const Impl& s = *impl_;
    bounds_ = Bounds{};
    emissive_.clear();
    for (uint32_t i = 0; i < s.transforms.size(); ++i) {
        const Mesh& mesh = s.meshes[s.instanceMesh[i]];
        const Mat4& m = s.transforms[i];
        for (const Vec3& p : mesh.positions) bounds_.extend(Vec3(m * glm::vec4(p, 1.0f)));
        if (mesh.material >= scene_->materials.size()) continue;
        const Material& mat = scene_->materials[mesh.material];
        if (!mat.isEmissive()) continue;
        for (uint32_t t = 0; t < mesh.triangleCount(); ++t) {
            const Vec3 o0 = mesh.positions[mesh.indices[3 * t + 0]];
            const Vec3 o1 = mesh.positions[mesh.indices[3 * t + 1]];
            const Vec3 o2 = mesh.positions[mesh.indices[3 * t + 2]];
            EmissiveTriangle e;
            e.p0 = Vec3(m * glm::vec4(o0, 1.0f));
            e.p1 = Vec3(m * glm::vec4(o1, 1.0f));
            e.p2 = Vec3(m * glm::vec4(o2, 1.0f));
            const Vec3 worldCross = glm::cross(e.p1 - e.p0, e.p2 - e.p0);
            e.area = 0.5f * glm::length(worldCross);
            const Vec3 n = s.normalMatrices[i] * glm::cross(o1 - o0, o2 - o0);
            const float len = glm::length(n);
            // Zero-area triangles emit nothing and would give NaN normals: skip them.
            if (!(e.area > 0.0f) || !(len > 0.0f) || !std::isfinite(e.area)) continue;
            e.normal = n / len;
            e.radiance = mat.emission;
            e.textured = false;
            if (mat.emissiveTexture >= 0 && size_t(mat.emissiveTexture) < scene_->textures.size()) {
                // Power and light sampling follow the texture's mean over the triangle; a surface
                // seen directly shows the texture itself (eye_pass.cpp).
                const Texture& tex = scene_->textures[size_t(mat.emissiveTexture)];
                if (tex.width > 0 && tex.height > 0) {
                    const bool uvs = mesh.uvs.size() == mesh.positions.size();
                    const auto uvOf = [&](uint32_t k) {
                        return uvs ? mesh.uvs[mesh.indices[3 * t + k]] : Vec2(0.0f);
                    };
                    e.radiance = mat.emission * tex.meanOverTriangle(uvOf(0), uvOf(1), uvOf(2));
                    e.textured = true;
                    if (!(e.radiance.x > 0.0f || e.radiance.y > 0.0f || e.radiance.z > 0.0f)) continue;
                }
            }
            e.instance = i;
            e.triangle = t;
            e.material = mesh.material;
            emissive_.push_back(e);
        }
    }
    // Scene-size floor of the offset: 1e-6 of the diagonal is far above float rounding at the
    // scene's scale (2^-24 ≈ 6e-8) and far below any feature size a scene meaningfully has.
    const float diag = bounds_.diagonal();
    epsilon_ = diag > 0.0f && std::isfinite(diag) ? 1e-6f * diag : 1e-6f;
}


RTCScene EmbreeScene::rtcScene() const { return impl_->traceScene(); }

bool EmbreeScene::flattened() const { return impl_->flat != nullptr; }

bool EmbreeScene::intersect(const Ray& ray, SurfaceHit& hit) const {
    const Impl& s = *impl_;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    rh.ray.org_x = ray.origin.x;
    rh.ray.org_y = ray.origin.y;
    rh.ray.org_z = ray.origin.z;
    rh.ray.dir_x = ray.dir.x;
    rh.ray.dir_y = ray.dir.y;
    rh.ray.dir_z = ray.dir.z;
    rh.ray.tnear = ray.tMin;
    rh.ray.tfar = ray.tMax;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s.traceScene(), &ctx, &rh);
    const uint32_t inst = s.hitInstance(rh.hit.geomID, rh.hit.instID[0]);
    if (inst == RTC_INVALID_GEOMETRY_ID) return false;
    return completeHit(ray, rh.ray.tfar, inst, rh.hit.primID, rh.hit.u, rh.hit.v, hit);
}

uint32_t EmbreeScene::intersect8(const Ray* rays, int count, SurfaceHit* hits) const {
    RTPM_DCHECK(count >= 0 && count <= 8);
    if (count <= 0) return 0;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(32) int valid[8];
    alignas(32) RTCRayHit8 rh;
    fillPacket(rays, count, valid, rh.ray);
    for (int i = 0; i < 8; ++i) {
        rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    const Impl& s = *impl_;
    rtcIntersect8(valid, s.traceScene(), &ctx, &rh);
    uint32_t found = 0;
    for (int i = 0; i < count; ++i)
        if (completeHit(rays[i], rh.ray.tfar[i], s.hitInstance(rh.hit.geomID[i], rh.hit.instID[0][i]),
                        rh.hit.primID[i], rh.hit.u[i], rh.hit.v[i], hits[i]))
            found |= 1u << i;
    return found;
}

bool EmbreeScene::completeHit(const Ray& ray, float t, uint32_t inst, uint32_t tri, float u, float v,
                              SurfaceHit& hit) const {
    if (inst == RTC_INVALID_GEOMETRY_ID) return false;
    const Impl& s = *impl_;
    const uint32_t meshIndex = s.instanceMesh[inst];
    const Impl::TriangleShading& tris = s.shading[meshIndex];
    const float w = 1.0f - u - v;
    // Most instances are not rotated or scaled; their normals need no matrix product.
    const glm::mat3& nm = s.normalMatrices[inst];
    const bool identity = s.identityLinear[inst] != 0;

    hit.t = t;
    hit.position = ray.origin + hit.t * ray.dir;
    hit.instance = inst;
    hit.triangle = tri;
    hit.material = s.meshes[meshIndex].material;

    // Geometric normal from the winding (counter-clockwise seen from the front), recomputed from
    // the mesh so it does not depend on Embree's Ng convention; degenerate triangles (which a
    // robust traversal may still report) fall back to facing the ray instead of producing NaN.
    Vec3 ng = tris.cross[tri];
    if (!identity) ng = nm * ng;
    float len2 = glm::dot(ng, ng);
    if (len2 > 0.0f && std::isfinite(len2)) {
        ng *= 1.0f / std::sqrt(len2);
    } else {
        const float dl = glm::length(ray.dir);
        ng = dl > 0.0f ? -ray.dir / dl : Vec3(0.0f, 0.0f, 1.0f);
    }
    hit.geometricNormal = ng;

    Vec3 ns = ng;
    if (!tris.normals.empty()) {
        const std::array<Vec3, 3>& n = tris.normals[tri];
        Vec3 interp = w * n[0] + u * n[1] + v * n[2];
        if (!identity) interp = nm * interp;
        const float l2 = glm::dot(interp, interp);
        if (l2 > 0.0f && std::isfinite(l2)) {
            interp *= 1.0f / std::sqrt(l2);
            ns = glm::dot(interp, ng) < 0.0f ? -interp : interp;
        }
    }
    hit.shadingNormal = ns;

    if (!tris.uvs.empty()) {
        const std::array<Vec2, 3>& uv = tris.uvs[tri];
        hit.uv = w * uv[0] + u * uv[1] + v * uv[2];
    } else {
        hit.uv = Vec2(0.0f);
    }
    return true;
}

bool EmbreeScene::occluded(const Ray& ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r;
    r.org_x = ray.origin.x;
    r.org_y = ray.origin.y;
    r.org_z = ray.origin.z;
    r.dir_x = ray.dir.x;
    r.dir_y = ray.dir.y;
    r.dir_z = ray.dir.z;
    r.tnear = ray.tMin;
    r.tfar = ray.tMax;
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(impl_->traceScene(), &ctx, &r);
    // Embree sets tfar to -inf when an occluder is found.
    return r.tfar < 0.0f;
}

uint32_t EmbreeScene::occluded8(const Ray* rays, int count) const {
    RTPM_DCHECK(count >= 0 && count <= 8);
    if (count == 1) return occluded(rays[0]) ? 1u : 0u;  // RING's lamp: one sample per point
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    if (count <= 0) return 0;
    alignas(32) int valid[8];
    alignas(32) RTCRay8 r;
    fillPacket(rays, count, valid, r);
    rtcOccluded8(valid, impl_->traceScene(), &ctx, &r);
    uint32_t bits = 0;
    for (int i = 0; i < count; ++i)
        if (r.tfar[i] < 0.0f) bits |= 1u << i;  // Embree sets tfar to −inf on an occluder
    return bits;
}

void EmbreeScene::setTransform(uint32_t index, const Mat4& transform) {
    Impl& s = *impl_;
    if (index >= s.instanceGeoms.size())
        throw SceneError("<edit>", "instance " + std::to_string(index),
                         "index out of range (" + std::to_string(s.instanceGeoms.size()) +
                             " instances)");
    s.setInstanceTransform(index, transform, "");
    rtcCommitScene(s.top);
    s.throwOnError("setTransform");
    s.buildFlat();
    refreshDerived();
}

void EmbreeScene::setMesh(uint32_t index, const Mesh& mesh) {
    Impl& s = *impl_;
    if (index >= s.meshes.size())
        throw SceneError("<edit>", "mesh " + std::to_string(index),
                         "index out of range (" + std::to_string(s.meshes.size()) + " meshes)");
    if (mesh.material >= scene_->materials.size())
        throw SceneError("<edit>", "mesh " + std::to_string(index) + " '" + mesh.name + "'",
                         "material index " + std::to_string(mesh.material) + " out of range");
    Mesh old = std::move(s.meshes[index]);
    s.meshes[index] = mesh;
    try {
        s.buildMeshScene(index);
    } catch (...) {
        s.meshes[index] = std::move(old);  // the previous BLAS is still in place
        throw;
    }
    // Instances hold a reference to the old scene object: point them at the new one.
    for (uint32_t i = 0; i < s.instanceGeoms.size(); ++i) {
        if (s.instanceMesh[i] != index) continue;
        rtcSetGeometryInstancedScene(s.instanceGeoms[i], s.meshScenes[index]);
        rtcCommitGeometry(s.instanceGeoms[i]);
    }
    rtcCommitScene(s.top);
    s.throwOnError("setMesh");
    s.buildFlat();
    refreshDerived();
}

Vec3 EmbreeScene::offsetOrigin(Vec3 p, Vec3 geometricNormal, Vec3 towards) const {
    // The hit point carries a rounding error of a few ulps of its largest coordinate (from
    // origin + t·dir and from the BVH's own arithmetic); 2^-18 ≈ 32 ulps of max|p| covers that
    // with margin, and epsilon_ covers points near the world origin of a large scene.
    const float magnitude = epsilon_ + maxAbs(p) * 0x1p-18f;
    const Vec3 n = glm::dot(geometricNormal, towards) >= 0.0f ? geometricNormal : -geometricNormal;
    return p + magnitude * n;
}

}  // namespace rtpm
