// Scenes as exporters write them: each glTF feature of issue 14 in a small file written by the
// test, loaded through loadScene and rendered (or its photons traced), checking the picture.
//
// Features: the default light for a scene without lights, EXT_mesh_gpu_instancing,
// KHR_texture_transform, partial transmission (KHR_materials_transmission < 1, with
// KHR_materials_volume), emissive textures and KHR_materials_unlit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "common/image/frame_image.h"
#include "common/photon/photon_tracer.h"
#include "common/render/render_job.h"
#include "common/scene/gltf_export.h"
#include "common/scene/gltf_loader.h"
#include "common/scene/scene_loader.h"
#include "common/trace/eye_pass.h"
#include "tests/support/gltf_builder.h"
#include "tests/support/scratch_dir.h"
#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

namespace fs = std::filesystem;
using testgltf::GltfBuilder;
using testgltf::pngBytes;
using testscenes::addMaterial;
using testscenes::addMesh;
using testscenes::quad;

using testsupport::ScratchDir;

// Rendered buffers of a scene (scene camera), after `frames` frames.
struct Picture {
    int w = 0, h = 0;
    std::vector<float> direct, caustic;
    Vec3 at(const std::vector<float>& buf, int x, int y) const {
        const size_t i = (size_t(y) * size_t(w) + size_t(x)) * 3;
        return Vec3(buf[i], buf[i + 1], buf[i + 2]);
    }
    double sum(const std::vector<float>& buf) const { return std::accumulate(buf.begin(), buf.end(), 0.0); }
};

Picture render(Scene scene, int w, int h, int frames, uint32_t paths, uint32_t diffuseBounces = 1) {
    RenderSettings rs;
    rs.width = w;
    rs.height = h;
    rs.interleave = 2;
    rs.photons.photonsPerBatch = paths;
    rs.photons.diffuseBounces = diffuseBounces;
    std::vector<uint32_t> sets(4);
    std::iota(sets.begin(), sets.end(), 0u);
    const Camera camera = *scene.camera;
    RenderJob job(std::move(scene), rs, sets);
    FrameImage image(w, h);
    const Interleave pattern{w, h, rs.interleave};
    std::vector<SetPixels> pixels;
    for (int f = 0; f < frames; ++f) job.renderFrame(camera, pixels);
    for (const SetPixels& sp : pixels) image.scatter(pattern, sp.set, sp.pixels);
    image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
    Picture p;
    p.w = w;
    p.h = h;
    p.direct = image.direct();
    p.caustic = image.caustic();
    for (float v : p.direct) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f);
    for (float v : p.caustic) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f);
    return p;
}

float maxOf(const std::vector<float>& buf) { return *std::max_element(buf.begin(), buf.end()); }

std::string allWarnings(const Scene& s) {
    std::string all;
    for (const std::string& w : s.warnings) all += w + "\n";
    return all;
}

// Σ power (W, per channel, double sums) of the photons traced from `emitter` over `n` paths.
Vec3 tracedPower(const EmbreeScene& es, const Emitter& emitter, uint32_t n, uint32_t diffuseBounces = 0) {
    const Halton halton(11, 3);
    PhotonSource src;
    src.emitter = &emitter;
    src.halton = &halton;
    src.hashStream = 3;
    src.powerPerPath = emitter.flux / float(n);
    src.dims = dimLayout(emitter.kind, diffuseBounces);
    TraceSettings ts;
    ts.diffuseBounces = diffuseBounces;
    ts.seed = 5;
    std::vector<uint64_t> indices(n);
    std::iota(indices.begin(), indices.end(), uint64_t(0));
    TraceOutput out;
    tracePhotons(es, src, ts, indices, out);
    EXPECT_EQ(out.stats.anomalies, 0u);
    glm::dvec3 sum(0.0);
    for (const TracedPhoton& p : out.photons) sum += glm::dvec3(p.power);
    return Vec3(sum);
}

// The JSON of one node (with optional extra members) and a camera node looking straight down
// from height `y` (local −Z turned onto −Y: −90° about X).
const char* kDownCamera = R"({"camera":0,"translation":[0,%Y%,0],"rotation":[-0.70710678,0,0,0.70710678]})";
std::string downCameraNode(float y) {
    std::string s = kDownCamera;
    s.replace(s.find("%Y%"), 3, GltfBuilder::num(y));
    return s;
}
const char* kCameras = R"("cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.01}}])";

// ---- 1. default light ---------------------------------------------------------------------

// A Blender-style export: a floor and a glass box, no light, no camera.
std::string lightlessGlassScene(GltfBuilder& b, const std::string& glassExtensions) {
    const float c0[3] = {0, 0, 0}, u0[3] = {4, 0, 0}, v0[3] = {0, 0, -4};
    const std::string floor = b.quadPrimitive(c0, u0, v0);
    // Glass: a closed box 1 × 0.5 × 1 standing 1 m above the floor (six outward quads).
    std::string glass;
    const float faces[6][9] = {{0, 1.5f, 0, 0.5f, 0, 0, 0, 0, -0.5f},  {0, 1, 0, 0.5f, 0, 0, 0, 0, 0.5f},
                               {0, 1.25f, 0.5f, 0.5f, 0, 0, 0, 0.25f, 0}, {0, 1.25f, -0.5f, -0.5f, 0, 0, 0, 0.25f, 0},
                               {0.5f, 1.25f, 0, 0, 0, -0.5f, 0, 0.25f, 0}, {-0.5f, 1.25f, 0, 0, 0, 0.5f, 0, 0.25f, 0}};
    for (int f = 0; f < 6; ++f)
        glass += std::string(f ? "," : "") + b.quadPrimitive(faces[f], faces[f] + 3, faces[f] + 6) + R"(,"material":1})";
    return R"("scene":0,"scenes":[{"nodes":[0,1]}],"nodes":[{"mesh":0},{"mesh":1}],
"meshes":[{"primitives":[)" + floor + R"(,"material":0}]},{"primitives":[)" + glass + R"(]}],
"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.8,0.8,0.8,1],"metallicFactor":0}},
 {"pbrMetallicRoughness":{"baseColorFactor":[0.8,0.8,0.8,1],"metallicFactor":0,"roughnessFactor":0},
  "extensions":{)" + glassExtensions + R"(}}],
"extensionsUsed":["KHR_materials_transmission","KHR_materials_ior"])";
}

TEST(GltfFeatures, RoughMetalAndGlassKeepTheirRoughnessAndBadRoughnessIsRefused) {
    ScratchDir dir;
    // A transmissive material: roughness 0.35 is frosted glass; the floor (metallic 0) is glTF's
    // dielectric base, a plastic of the file's roughness (it was a Lambertian before the coat was
    // modelled).
    GltfBuilder b;
    std::string json = lightlessGlassScene(b, R"("KHR_materials_transmission":{"transmissionFactor":1})");
    json.replace(json.find(R"("metallicFactor":0,"roughnessFactor":0)"), 38, R"("metallicFactor":0,"roughnessFactor":0.35)");
    Scene glass = loadScene(dir.write("frosted.gltf", b.json(json)));
    EXPECT_EQ(glass.materials[1].type, MaterialType::Dielectric);
    EXPECT_FLOAT_EQ(glass.materials[1].roughness, 0.35f);
    EXPECT_TRUE(glass.materials[1].isGlossy());
    EXPECT_EQ(glass.materials[0].type, MaterialType::Plastic);
    EXPECT_EQ(glass.materials[0].metallic, 0.0f);
    EXPECT_EQ(glass.materials[0].specular, 1.0f);
    // A metal: roughness 0.5 is a GGX conductor, 0.01 still the perfect mirror.
    for (const char* rough : {"0.5", "0.01"}) {
        GltfBuilder m;
        std::string metal = lightlessGlassScene(m, R"("KHR_materials_ior":{"ior":1.5})");
        metal.replace(metal.find(R"("metallicFactor":0,"roughnessFactor":0)"), 38,
                      std::string(R"("metallicFactor":1,"roughnessFactor":)") + rough);
        Scene s = loadScene(dir.write(std::string("metal") + rough + ".gltf", m.json(metal)));
        EXPECT_EQ(s.materials[1].type, MaterialType::Mirror) << rough;
        EXPECT_FLOAT_EQ(s.materials[1].roughness, std::stof(rough));
        EXPECT_EQ(s.materials[1].isGlossy(), std::string(rough) == "0.5");
    }
    // Outside [0, 1]: refused, naming the material.
    GltfBuilder bad;
    std::string badJson = lightlessGlassScene(bad, R"("KHR_materials_transmission":{"transmissionFactor":1})");
    badJson.replace(badJson.find(R"("metallicFactor":0,"roughnessFactor":0)"), 38, R"("metallicFactor":0,"roughnessFactor":1.5)");
    try {
        loadScene(dir.write("bad.gltf", bad.json(badJson)));
        ADD_FAILURE() << "roughnessFactor 1.5 was accepted";
    } catch (const SceneError& e) {
        EXPECT_NE(e.element.find("materials[1]"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("roughnessFactor"), std::string::npos) << e.what();
    }
}

// metallicFactor < 0.99 is glTF's dielectric base, a plastic with the file's metallic and roughness;
// KHR_materials_specular's specularFactor scales its coat (0: a Lambertian); what the coat does not
// model is warned about, a factor outside [0, 1] refused.
TEST(GltfFeatures, DielectricBaseIsAPlasticAndKhrSpecularScalesItsCoat) {
    ScratchDir dir;
    auto load = [&](const std::string& name, const std::string& factors, const std::string& extensions) {
        GltfBuilder b;
        std::string json = lightlessGlassScene(b, extensions);
        json.replace(json.find(R"("metallicFactor":0,"roughnessFactor":0)"), 38, factors);
        return loadScene(dir.write(name, b.json(json)));
    };
    const Scene satin = load("satin.gltf", R"("metallicFactor":0.5,"roughnessFactor":0.4)", "");
    EXPECT_EQ(satin.materials[1].type, MaterialType::Plastic);
    EXPECT_FLOAT_EQ(satin.materials[1].metallic, 0.5f);
    EXPECT_FLOAT_EQ(satin.materials[1].roughness, 0.4f);
    EXPECT_TRUE(satin.materials[1].isGlossy());
    const Scene half = load("half.gltf", R"("metallicFactor":0,"roughnessFactor":0)",
                            R"("KHR_materials_specular":{"specularFactor":0.5,"specularColorFactor":[1,0.5,0.5]},)"
                            R"("KHR_materials_ior":{"ior":1.45})");
    EXPECT_EQ(half.materials[1].type, MaterialType::Plastic);
    EXPECT_FLOAT_EQ(half.materials[1].specular, 0.5f);
    EXPECT_FALSE(half.materials[1].isGlossy());
    std::string warnings;
    for (const std::string& w : half.warnings) warnings += w + "\n";
    EXPECT_NE(warnings.find("specularColorFactor ignored"), std::string::npos) << warnings;
    EXPECT_NE(warnings.find("KHR_materials_ior 1.45"), std::string::npos) << warnings;
    const Scene matte = load("matte.gltf", R"("metallicFactor":0,"roughnessFactor":0.2)",
                             R"("KHR_materials_specular":{"specularFactor":0})");
    EXPECT_EQ(matte.materials[1].type, MaterialType::Diffuse);
    try {
        load("bad.gltf", R"("metallicFactor":0,"roughnessFactor":0)", R"("KHR_materials_specular":{"specularFactor":2})");
        ADD_FAILURE() << "specularFactor 2 was accepted";
    } catch (const SceneError& e) {
        EXPECT_NE(e.element.find("KHR_materials_specular.specularFactor"), std::string::npos) << e.what();
    }
}

TEST(GltfFeatures, SceneWithoutLightsGetsTheDefaultSpotAndShowsCaustics) {
    ScratchDir dir;
    GltfBuilder b;
    const std::string path = dir.write(
        "nolight.gltf", b.json(lightlessGlassScene(b, R"("KHR_materials_transmission":{"transmissionFactor":1},
"KHR_materials_ior":{"ior":1.5})")));

    // --no-default-light: today's error, naming the file.
    SceneOverrides strict;
    strict.defaultLight = false;
    try {
        loadScene(path, strict);
        ADD_FAILURE() << "a scene without lights loaded with defaultLight = false";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.file, path);
        EXPECT_EQ(e.element, "lights");
    }

    Scene s = loadScene(path);
    ASSERT_EQ(s.lights.size(), 2u);  // the caustic spot, then the key light
    EXPECT_NE(allWarnings(s).find(path), std::string::npos) << allWarnings(s);
    EXPECT_NE(allWarnings(s).find("default"), std::string::npos) << allWarnings(s);
    const Light& l = s.lights[0];
    EXPECT_EQ(l.type, LightType::Spot);
    ASSERT_TRUE(s.camera);
    // Above the geometry, aimed at its centre, tilted away from the (framing) camera.
    Scene geometryOnly = s;
    geometryOnly.lights.clear();
    const Bounds bounds = geometryOnly.bounds();
    EXPECT_GT(l.position.y, bounds.hi.y);
    const Vec3 toCentre = glm::normalize(bounds.centre() - l.position);
    EXPECT_GT(glm::dot(toCentre, l.direction), 0.9999f);
    EXPECT_LT(l.position.z, bounds.centre().z) << "the framing camera is on +Z: the light stands behind";
    // Its cone covers the bounding sphere at full intensity.
    EXPECT_GE(l.innerConeAngle, std::asin(0.5f * bounds.diagonal() / glm::length(bounds.centre() - l.position)));
    // The key light stands on the camera's side, aimed at the centre, half as strong.
    const Light& key = s.lights[1];
    EXPECT_EQ(key.type, LightType::Spot);
    EXPECT_GT(key.position.z, bounds.centre().z);
    EXPECT_GT(glm::dot(glm::normalize(bounds.centre() - key.position), key.direction), 0.9999f);
    EXPECT_NEAR(key.intensity.x, 0.5f * l.intensity.x, 1e-3f * l.intensity.x);

    // The picture: lit floor, and a caustic under the glass.
    // Under the box the caustic replaces the direct light glass blocks: ≈ 0.92 of it.
    const Picture p = render(std::move(s), 48, 36, 2, 20000);
    EXPECT_GT(p.sum(p.direct), 0.0);
    EXPECT_GT(maxOf(p.caustic), 0.3f * maxOf(p.direct)) << "the default light casts no visible caustic";
    EXPECT_GT(p.sum(p.caustic), 0.005 * p.sum(p.direct));
}

TEST(GltfFeatures, DefaultLightFollowsTheSceneCamera) {
    Bounds b;
    b.extend(Vec3(-1.0f));
    b.extend(Vec3(1.0f));
    // Camera looking along +X: the light leans to +X (behind the scene as seen from the camera).
    const Camera cam = Camera::lookAt(Vec3(-5, 1, 0), Vec3(0), Vec3(0, 1, 0), 0.8f);
    const Light l = defaultLight(b, cam);
    EXPECT_GT(l.position.x, 0.0f);
    EXPECT_NEAR(l.position.z, 0.0f, 1e-5f);
    EXPECT_NEAR(glm::length(l.position), 3.0f * std::sqrt(3.0f), 1e-4f);
    // Irradiance π W/m² at the centre, full intensity there.
    EXPECT_NEAR(l.intensity.x / glm::dot(l.position, l.position), kPi, 1e-4f);
    EXPECT_NEAR(spotFalloff(l, 1.0f), 1.0f, 0.0f);
}

// A Khronos-Box-like file: a white unit cube at the origin, no camera, no light.
std::string lightlessBox(GltfBuilder& b) {
    const float faces[6][9] = {{0, 0.5f, 0, 0.5f, 0, 0, 0, 0, -0.5f},  {0, -0.5f, 0, 0.5f, 0, 0, 0, 0, 0.5f},
                               {0, 0, 0.5f, 0.5f, 0, 0, 0, 0.5f, 0},   {0, 0, -0.5f, -0.5f, 0, 0, 0, 0.5f, 0},
                               {0.5f, 0, 0, 0, 0, -0.5f, 0, 0.5f, 0},  {-0.5f, 0, 0, 0, 0, 0.5f, 0, 0.5f, 0}};
    std::string box;
    for (int f = 0; f < 6; ++f)
        box += std::string(f ? "," : "") + b.quadPrimitive(faces[f], faces[f] + 3, faces[f] + 6) + R"(,"material":0})";
    return R"("scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[)" + box +
           R"(]}],"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.8,0.8,0.8,1],"metallicFactor":0}}])";
}

TEST(GltfFeatures, DefaultLightsLightTheBoxFacesTheFramingCameraSees) {
    ScratchDir dir;
    GltfBuilder b;
    Scene s = loadScene(dir.write("box.gltf", b.json(lightlessBox(b))));
    ASSERT_TRUE(s.camera);
    const Camera cam = *s.camera;
    const int w = 64, h = 48;
    const Picture p = render(std::move(s), w, h, 1, 2000);
    // Which face each pixel sees (a ray–box slab test, independent of the renderer), and the
    // mean direct radiance over each face's pixels.
    double sum[6] = {}, count[6] = {};
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const Vec3 d = cam.rayDirection(i, j, w, h), o = cam.position;
            float tNear = -1e30f, tFar = 1e30f;
            int face = -1;
            for (int a = 0; a < 3; ++a) {
                const float t0 = (-0.5f - o[a]) / d[a], t1 = (0.5f - o[a]) / d[a];
                const float lo = std::min(t0, t1), hi = std::max(t0, t1);
                if (lo > tNear) {
                    tNear = lo;
                    face = 2 * a + (d[a] < 0.0f ? 0 : 1);  // 0 +X, 1 −X, 2 +Y, 3 −Y, 4 +Z, 5 −Z
                }
                tFar = std::min(tFar, hi);
            }
            if (tNear > tFar || tNear <= 0.0f) continue;
            // Pixels on an edge may belong to either face: keep those clearly inside one.
            const Vec3 hit = o + tNear * d;
            int inside = 0;
            for (int a = 0; a < 3; ++a) inside += std::abs(hit[a]) < 0.45f;
            if (inside < 2) continue;
            const Vec3 c = p.at(p.direct, i, j);
            sum[face] += (c.x + c.y + c.z) / 3.0;
            count[face] += 1.0;
        }
    const char* names[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    int seen = 0;
    for (int f = 0; f < 6; ++f) {
        if (count[f] < 20.0) continue;
        ++seen;
        // The front (+Z) face sees only the key light, 58° off its normal: radiance ≈ albedo 0.8 ×
        // irradiance (π/2) cos 58° / π ≈ 0.21; the top sees both lights. An unlit face shows 0 (the
        // direct image holds no indirect light): with the caustic spot alone the front was black.
        EXPECT_GT(sum[f] / count[f], 0.1) << names[f] << " face, seen by the camera, is unlit";
    }
    EXPECT_GE(seen, 2) << "the framing camera sees the top and the front: the test would prove little";
}

// ---- 2. EXT_mesh_gpu_instancing -------------------------------------------------------------

// A 20 × 20 grid of instances of one small quad (TRANSLATION, ROTATION about Y, SCALE), 1 m above
// the origin, seen from a camera straight above; `material` is the quad's material JSON.
std::string instancedGrid(GltfBuilder& b, const std::string& material, const std::string& extraNodes,
                          const std::string& extraMeshes, int n = 20, float cameraHeight = 9.0f) {
    const float c[3] = {0, 0, 0}, u[3] = {0.1f, 0, 0}, v[3] = {0, 0, -0.1f};  // 0.2 m square, facing +Y
    const std::string prim = b.quadPrimitive(c, u, v);
    std::vector<float> t, r, s;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const float first = -0.25f * float(n - 1);  // centred on the origin, 0.5 m pitch
            t.insert(t.end(), {first + 0.5f * float(i), 1.0f, first + 0.5f * float(j)});
            const float angle = 0.3f * float((i * n + j) % 5);  // about Y: the footprint turns
            r.insert(r.end(), {0.0f, std::sin(0.5f * angle), 0.0f, std::cos(0.5f * angle)});
            s.insert(s.end(), {1.0f, 1.0f, 1.0f});
        }
    const int ta = b.floats(t, "VEC3"), ra = b.floats(r, "VEC4"), sa = b.floats(s, "VEC3");
    return R"("scene":0,"scenes":[{"nodes":[0,1)" + std::string(extraNodes.empty() ? "" : ",2") + R"(]}],
"nodes":[{"mesh":0,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":)" +
           std::to_string(ta) + R"(,"ROTATION":)" + std::to_string(ra) + R"(,"SCALE":)" + std::to_string(sa) +
           R"(}}}},)" + downCameraNode(cameraHeight) + extraNodes + R"(],
"meshes":[{"primitives":[)" + prim + R"(,"material":0}]})" + extraMeshes + R"(],
"materials":[)" + material + R"(],)" + kCameras + R"(,
"extensionsUsed":["EXT_mesh_gpu_instancing","KHR_lights_punctual"],
"extensionsRequired":["EXT_mesh_gpu_instancing"])";
}

// Connected bright regions (4-neighbourhood) of a luminance image above `threshold`.
int countBlobs(const Picture& p, const std::vector<float>& buf, float threshold) {
    std::vector<uint8_t> seen(size_t(p.w) * size_t(p.h), 0);
    auto bright = [&](int x, int y) {
        const Vec3 c = p.at(buf, x, y);
        return c.x + c.y + c.z > threshold;
    };
    int blobs = 0;
    std::vector<std::pair<int, int>> stack;
    for (int y = 0; y < p.h; ++y)
        for (int x = 0; x < p.w; ++x) {
            if (seen[size_t(y * p.w + x)] || !bright(x, y)) continue;
            ++blobs;
            stack.assign(1, {x, y});
            seen[size_t(y * p.w + x)] = 1;
            while (!stack.empty()) {
                auto [cx, cy] = stack.back();
                stack.pop_back();
                const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
                for (const auto& d : nb) {
                    const int nx = cx + d[0], ny = cy + d[1];
                    if (nx < 0 || ny < 0 || nx >= p.w || ny >= p.h || seen[size_t(ny * p.w + nx)] || !bright(nx, ny))
                        continue;
                    seen[size_t(ny * p.w + nx)] = 1;
                    stack.push_back({nx, ny});
                }
            }
        }
    return blobs;
}

TEST(GltfFeatures, GpuInstancingShowsEveryInstance) {
    ScratchDir dir;
    GltfBuilder b;
    // A sun straight down (node −Z turned onto −Y); no floor: the instances on black.
    const std::string sun = R"(,{"rotation":[-0.70710678,0,0,0.70710678],"extensions":{"KHR_lights_punctual":{"light":0}}})";
    std::string json = instancedGrid(b, R"({"pbrMetallicRoughness":{"baseColorFactor":[0.9,0.9,0.9,1],"metallicFactor":0}})",
                                     sun, "", 20, 15.0f);
    json += R"(,"extensions":{"KHR_lights_punctual":{"lights":[{"type":"directional","intensity":3}]}})";
    const std::string path = dir.write("instanced.gltf", b.json(json));
    Scene s = loadScene(path);
    ASSERT_EQ(s.meshes.size(), 1u);
    ASSERT_EQ(s.instances.size(), 400u);
    for (const Instance& inst : s.instances) EXPECT_EQ(inst.mesh, 0u);
    // Instance 21 (i = 1, j = 1): translation (−4.25, 1, −4.25), turned 0.3·(21 mod 5) = 0.3 rad.
    const Mat4& m = s.instances[21].transform;
    const Vec3 o = Vec3(m * glm::vec4(0, 0, 0, 1));
    EXPECT_NEAR(o.x, -4.25f, 1e-5f);
    EXPECT_NEAR(o.y, 1.0f, 1e-5f);
    EXPECT_NEAR(o.z, -4.25f, 1e-5f);
    const Vec3 xAxis = glm::mat3(m) * Vec3(1, 0, 0);
    EXPECT_NEAR(xAxis.x, std::cos(0.3f), 1e-5f);
    EXPECT_NEAR(xAxis.z, -std::sin(0.3f), 1e-5f);
    EXPECT_EQ(allWarnings(s).find("EXT_mesh_gpu_instancing"), std::string::npos) << allWarnings(s);

    // 200 × 200 from 14 m above (an 11.8 m wide view): a 0.5 m pitch is ≈ 8.4 px, a 0.2 m quad
    // ≈ 3.4 px (≤ 4.8 px turned): 400 separate blobs.
    const Picture p = render(std::move(s), 200, 200, 1, 100);
    EXPECT_EQ(countBlobs(p, p.direct, 0.1f), 400);
}

TEST(GltfFeatures, GpuInstancedGlassCastsTheCausticOfEveryInstance) {
    ScratchDir dir;
    GltfBuilder b;
    // 400 glass tiles (single sheets: one interface, F = 4 % at normal incidence, no bending)
    // over a white floor, a sun straight down: the floor's caustic power is E · A · (1 − F).
    const float c0[3] = {0, 0, 0}, u0[3] = {6, 0, 0}, v0[3] = {0, 0, -6};
    const std::string floorMesh = R"(,{"primitives":[)" + b.quadPrimitive(c0, u0, v0) + R"(,"material":1}]})";
    const std::string extraNodes =
        R"(,{"mesh":1},{"rotation":[-0.70710678,0,0,0.70710678],"extensions":{"KHR_lights_punctual":{"light":0}}})";
    std::string json = instancedGrid(
        b, R"({"pbrMetallicRoughness":{"roughnessFactor":0},"extensions":{"KHR_materials_transmission":{"transmissionFactor":1}}},
{"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1],"metallicFactor":0}})",
        extraNodes, floorMesh);
    json.replace(json.find(R"([0,1,2])"), 7, "[0,1,2,3]");
    json += R"(,"extensions":{"KHR_lights_punctual":{"lights":[{"type":"directional","intensity":2}]}})";
    Scene s = loadScene(dir.write("glass.gltf", b.json(json)));
    ASSERT_EQ(s.instances.size(), 401u);
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 1u);
    const uint32_t n = 200000;
    const Vec3 stored = tracedPower(es, em[0], n);
    const float fresnel = 0.04f;  // ((1.5 − 1) / (1.5 + 1))²
    const float expected = 2.0f * 400.0f * 0.04f * (1.0f - fresnel);
    // Binomial noise of 200k photons hitting a fraction ≈ 0.16 of the disc: ≈ 0.6 %; 3 % bound.
    EXPECT_NEAR(stored.x, expected, 0.03f * expected);
}

// ---- 3. KHR_texture_transform ----------------------------------------------------------------

// An unlit quad filling the view, textured with a 4×1 texture [red, red, green, green]:
// the red→green edge position across the image measures the texture transform.
std::string texturedQuad(GltfBuilder& b, const std::string& textureInfoExtras, bool required,
                         const std::string& extraAttribute = "") {
    const std::vector<uint8_t> rgb = {255, 0, 0, 255, 0, 0, 0, 255, 0, 0, 255, 0};
    const int img = b.image(pngBytes(4, 1, rgb), "image/png");
    const float c[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 0, -1};
    std::string prim = b.quadPrimitive(c, u, v);
    if (!extraAttribute.empty()) prim.insert(prim.find("},\"indices\""), extraAttribute);
    return R"("scene":0,"scenes":[{"nodes":[0,1]}],"nodes":[{"mesh":0},)" + downCameraNode(1.0f) + R"(],
"meshes":[{"primitives":[)" + prim + R"(,"material":0}]}],
"materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0)" + textureInfoExtras + R"(}},
  "extensions":{"KHR_materials_unlit":{}}}],
"textures":[{"source":)" + std::to_string(img) + R"(,"sampler":0}],"samplers":[{}],)" + kCameras + R"(,
"extensionsUsed":["KHR_texture_transform","KHR_materials_unlit"])" +
           (required ? R"(,"extensionsRequired":["KHR_texture_transform","KHR_materials_unlit"])" : "");
}

// Fraction of the middle row's pixels, left to right, at which red gives way to green.
float redGreenEdge(const Picture& p) {
    const int y = p.h / 2;
    for (int x = 0; x < p.w; ++x) {
        const Vec3 c = p.at(p.direct, x, y);
        if (c.y > c.x) return (float(x) + 0.5f) / float(p.w);
    }
    return 1.0f;
}

TEST(GltfFeatures, TextureTransformOffsetMovesTheTexture) {
    ScratchDir dir;
    // yfov 0.8 from 1 m: the view is 2·tan(0.4) ≈ 0.85 m wide, inside the 2 m quad, whose u runs
    // from 0 at x = −1 to 1 at x = +1. Without a transform the edge is at u = 0.5 (x = 0): the
    // image's middle. An offset of −0.1 in u moves it to u = 0.6 (x = +0.2 m): right by
    // 0.2 / 0.85 of the image width.
    GltfBuilder plainB;
    const Picture plain = render(loadScene(dir.write("plain.gltf", plainB.json(texturedQuad(plainB, "", false)))),
                                 64, 64, 1, 10);
    GltfBuilder movedB;
    Scene moved = loadScene(dir.write(
        "moved.gltf", movedB.json(texturedQuad(movedB, R"(,"extensions":{"KHR_texture_transform":{"offset":[-0.1,0]}})",
                                               true))));
    ASSERT_EQ(moved.materials.size(), 1u);
    EXPECT_NEAR(moved.materials[0].baseColorTransform.offset.x, -0.1f, 1e-7f);
    EXPECT_TRUE(moved.materials[0].unlit);
    const Picture shifted = render(std::move(moved), 64, 64, 1, 10);
    const float width = 2.0f * std::tan(0.4f);
    EXPECT_NEAR(redGreenEdge(plain), 0.5f, 1.0f / 64.0f);
    EXPECT_NEAR(redGreenEdge(shifted) - redGreenEdge(plain), 0.2f / width, 1.5f / 64.0f);
}

TEST(GltfFeatures, TextureTransformRotationScaleAndTexCoordFollowTheSpec) {
    // The spec's matrix T · R · S with R = [cos sin; −sin cos] (row-major).
    TextureTransform t;
    t.offset = Vec2(0.25f, -0.5f);
    t.rotation = 0.5f;
    t.scale = Vec2(2.0f, 3.0f);
    const Vec2 uv(0.3f, 0.7f);
    const Vec2 s = uv * t.scale;
    const Vec2 expected(std::cos(0.5f) * s.x + std::sin(0.5f) * s.y + 0.25f,
                        -std::sin(0.5f) * s.x + std::cos(0.5f) * s.y - 0.5f);
    EXPECT_NEAR(t.apply(uv).x, expected.x, 1e-6f);
    EXPECT_NEAR(t.apply(uv).y, expected.y, 1e-6f);

    // texCoord 1 in the transform: the mesh reads TEXCOORD_1 (mirrored in u here), so the texture
    // is flipped left to right: green on the left.
    ScratchDir dir;
    GltfBuilder b;
    const int uv1 = b.floats({1, 0, 0, 0, 0, 1, 1, 1}, "VEC2");
    const std::string json =
        texturedQuad(b, R"(,"extensions":{"KHR_texture_transform":{"texCoord":1}})", true,
                     R"(,"TEXCOORD_1":)" + std::to_string(uv1));
    Scene scene = loadScene(dir.write("texcoord.gltf", b.json(json)));
    ASSERT_EQ(scene.meshes.size(), 1u);
    EXPECT_NEAR(scene.meshes[0].uvs[0].x, 1.0f, 0.0f);
    const Picture p = render(std::move(scene), 32, 32, 1, 10);
    const Vec3 left = p.at(p.direct, 2, 16), right = p.at(p.direct, 29, 16);
    EXPECT_GT(left.y, left.x);
    EXPECT_GT(right.x, right.y);
}

// ---- 4. partial transmission ------------------------------------------------------------------

// A glass sheet (one quad at y = 1, facing +Y) of material `sheet` over a white floor, a point
// light above, the camera looking down at an angle.
Scene sheetScene(const Material& sheet) {
    Scene s;
    const uint32_t floor = addMaterial(s, MaterialType::Diffuse, Vec3(0.9f));
    s.materials.push_back(sheet);
    const uint32_t sheetMat = uint32_t(s.materials.size() - 1);
    addMesh(s, quad(Vec3(0.0f), Vec3(5, 0, 0), Vec3(0, 0, -5), floor));
    addMesh(s, quad(Vec3(0, 1, 0), Vec3(0.6f, 0, 0), Vec3(0, 0, -0.6f), sheetMat));
    testscenes::addPointLight(s, Vec3(0.3f, 3.0f, 0.2f), Vec3(20.0f));
    s.camera = Camera::lookAt(Vec3(0, 3, 3), Vec3(0, 0.5f, 0), Vec3(0, 1, 0), 0.9f);
    return s;
}

Material sheetMaterial(float transmission) {
    Material m;
    m.type = transmission > 0.0f ? MaterialType::Dielectric : MaterialType::Diffuse;
    m.transmission = transmission > 0.0f ? transmission : 1.0f;
    m.baseColor = Vec3(0.7f, 0.5f, 0.3f);
    return m;
}

// Direct-light image (no caustics) of the sheet scene: deterministic, no random numbers.
std::vector<PixelRadiance> eyeImage(const Scene& s, int w, int h) {
    EmbreeScene es(s);
    const Interleave pattern{w, h, 1};
    std::vector<PixelRadiance> out(size_t(w) * size_t(h));
    renderSet(es, *s.camera, EyeSettings{}, pattern, 0, nullptr, out);
    return out;
}

TEST(GltfFeatures, PartialTransmissionEyePassIsTheExactMixOfItsLobes) {
    // Energy conservation of the eye pass' deterministic split: with transmission t the pixel is
    // (1 − t) × the Lambertian picture + t × the clear-glass picture, to float rounding.
    const int w = 40, h = 30;
    const auto diffuse = eyeImage(sheetScene(sheetMaterial(0.0f)), w, h);
    const auto glass = eyeImage(sheetScene(sheetMaterial(1.0f)), w, h);
    const float t = 0.3f;
    const auto mixed = eyeImage(sheetScene(sheetMaterial(t)), w, h);
    double sheetEnergy = 0.0;
    for (size_t i = 0; i < mixed.size(); ++i) {
        const Vec3 expected = (1.0f - t) * diffuse[i].direct + t * glass[i].direct;
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(mixed[i].direct[c], expected[c], 1e-5f * (1.0f + expected[c])) << "pixel " << i;
        sheetEnergy += std::abs(double(diffuse[i].direct.x) - double(glass[i].direct.x));
    }
    EXPECT_GT(sheetEnergy, 1.0) << "the sheet is not in view: the test would prove nothing";
}

TEST(GltfFeatures, PartialTransmissionCausticCarriesTheTransmittedShare) {
    // Photons through the sheet reach the floor only by the dielectric lobe (probability t);
    // with no diffuse bounce the floor's caustic power is t × that of clear glass.
    const uint32_t n = 100000;
    auto floorPower = [&](float t) {
        Scene s = sheetScene(sheetMaterial(t));
        EmbreeScene es(s);
        const std::vector<Emitter> em = buildEmitters(es);
        EXPECT_EQ(em.size(), 1u);
        return tracedPower(es, em[0], n);
    };
    const Vec3 clear = floorPower(1.0f);
    ASSERT_GT(clear.x, 0.0f);
    for (float t : {0.25f, 0.6f}) {
        const Vec3 part = floorPower(t);
        // The sheet subtends ≈ 1/60 of the sphere: ≈ 1 700 photons cross it, of which a share t
        // passes; binomial relative σ = sqrt((1 − t) / (t · 1 700)) ≤ 4.2 %: a 4σ bound.
        const float sigma = std::sqrt((1.0f - t) / (t * 1700.0f));
        EXPECT_NEAR(part.x / clear.x, t, 4.0f * sigma * t) << "t = " << t;
    }
}

TEST(GltfFeatures, PartialTransmissionHonoursVolumeAbsorption) {
    // A 0.5 m thick slab (closed box) of a partly transmissive material with KHR_materials_volume
    // attenuation: the caustic is attenuated by exp(−σ·0.5) at (near) normal incidence.
    ScratchDir dir;
    auto load = [&](const std::string& volume) {
        GltfBuilder b;
        std::string json = lightlessGlassScene(
            b, R"("KHR_materials_transmission":{"transmissionFactor":0.5},"KHR_materials_ior":{"ior":1.5})" + volume);
        return loadScene(dir.write("slab" + std::to_string(volume.size()) + ".gltf", b.json(json)));
    };
    Scene clear = load("");
    Scene tinted = load(R"(,"KHR_materials_volume":{"thicknessFactor":0.5,"attenuationDistance":0.5,
"attenuationColor":[0.5,0.5,0.5]})");
    const Material& glass = tinted.materials[1];
    EXPECT_EQ(glass.type, MaterialType::Dielectric);
    EXPECT_NEAR(glass.transmission, 0.5f, 0.0f);
    EXPECT_NEAR(glass.absorption.x, -std::log(0.5f) / 0.5f, 1e-5f);
    EXPECT_NEAR(glass.baseColor.x, 0.8f, 1e-6f);  // the Lambertian share keeps the base colour
    EXPECT_EQ(allWarnings(tinted).find("partial transmission"), std::string::npos) << allWarnings(tinted);

    // Slab 0.5 m tall (y 1 … 1.5): σ = 2 ln 2 → exp(−σ·0.5) = 0.5.
    auto floorPower = [&](Scene& s) {
        EmbreeScene es(s);
        const std::vector<Emitter> em = buildEmitters(es);
        EXPECT_EQ(em.size(), 3u);  // the default spot light, the key light and the default sky
        return tracedPower(es, em[0], 100000);
    };
    const Vec3 a = floorPower(clear), b = floorPower(tinted);
    ASSERT_GT(a.x, 0.0f);
    // Same photons, same lobe choices (hashed per photon): only the absorption differs; internal
    // reflections (4 % each) and oblique paths of the spot's cone lengthen a few paths: 3 %.
    EXPECT_NEAR(b.x / a.x, 0.5f, 0.03f);
}

// ---- 5. emissive textures ---------------------------------------------------------------------

TEST(GltfFeatures, EmissiveTexturePowerAndSamplingFollowTheTexture) {
    // Two emitter quads sharing one material, emissiveFactor 1 × a 2×1 texture [black, white]; the
    // left quad maps u ∈ [0, 0.5], the right one u ∈ [0.5, 1]. With bilinear repeat the texture is
    // a triangle wave in u: its mean is 1/4 over the left half and 3/4 over the right.
    ScratchDir dir;
    GltfBuilder b;
    const int img = b.image(pngBytes(2, 1, {0, 0, 0, 255, 255, 255}), "image/png");
    auto emitter = [&](float cx, float u0) {
        // Quad facing −Y at y = 2, x ∈ [cx − 0.5, cx + 0.5], z ∈ [−0.5, 0.5].
        const float c[3] = {cx, 2, 0}, u[3] = {0.5f, 0, 0}, v[3] = {0, 0, 0.5f};
        std::string prim = b.quadPrimitive(c, u, v);
        const int uv = b.floats({u0, 0, u0 + 0.5f, 0, u0 + 0.5f, 1, u0, 1}, "VEC2");
        prim.replace(prim.find("\"TEXCOORD_0\":") + 13, prim.find("},\"indices\"") - prim.find("\"TEXCOORD_0\":") - 13,
                     std::to_string(uv));
        return prim + R"(,"material":0})";
    };
    const std::string left = emitter(-0.5f, 0.0f), right = emitter(0.5f, 0.5f);
    const float c0[3] = {0, 0, 0}, u0[3] = {3, 0, 0}, v0[3] = {0, 0, -3};
    const std::string floor = b.quadPrimitive(c0, u0, v0) + R"(,"material":1})";
    const std::string json = R"("scene":0,"scenes":[{"nodes":[0,1]}],"nodes":[{"mesh":0},)" + downCameraNode(1.0f) +
                             R"(],"meshes":[{"primitives":[)" + left + "," + right + "," + floor + R"(]}],
"materials":[{"emissiveFactor":[1,1,1],"emissiveTexture":{"index":0}},
 {"pbrMetallicRoughness":{"baseColorFactor":[0.5,0.5,0.5,1],"metallicFactor":0}}],
"textures":[{"source":)" + std::to_string(img) + R"(}],)" + kCameras;
    Scene s = loadScene(dir.write("emissive.gltf", b.json(json)));
    EXPECT_EQ(allWarnings(s).find("emissiveTexture"), std::string::npos) << allWarnings(s);
    ASSERT_EQ(s.materials[0].emissiveTexture, 0);
    EXPECT_TRUE(s.lights.empty()) << "an emissive texture is a light: no default light";
    // Lit by its emitters alone, the file gets the dim sky as its world; the emitters alone here.
    EXPECT_FALSE(s.environment.empty());
    s.environment = Environment{};

    EmbreeScene es(s);
    // Power: π · Σ A_t · mean_t = π · (1 · 1/4 + 1 · 3/4) = π W per channel.
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 1u);
    EXPECT_NEAR(em[0].flux.x, kPi, 0.02f * kPi);
    // Sampling: the power leaving the right quad is 3/4 of the total.
    const Halton halton(7, 1);
    const DimLayout dims = dimLayout(EmitterKind::Area, 0);
    const int n = 20000;
    double rightPower = 0.0, totalPower = 0.0;
    for (int i = 0; i < n; ++i) {
        const Vec2 uDir(halton.sample(dims.direction, uint64_t(i)), halton.sample(dims.direction + 1, uint64_t(i)));
        const Vec2 uPoint(halton.sample(dims.point, uint64_t(i)), halton.sample(dims.point + 1, uint64_t(i)));
        const EmittedRay r = sampleEmission(em[0], es, uDir, uPoint);
        EXPECT_GT(glm::dot(r.dir, Vec3(0, -1, 0)), 0.0f);
        const double p = double(r.powerScale.x) * double(em[0].flux.x) / n;
        totalPower += p;
        if (r.origin.x > 0.0f) rightPower += p;
    }
    EXPECT_NEAR(totalPower, em[0].flux.x, 1e-3 * kPi);  // grey emission: every photon the same
    EXPECT_NEAR(rightPower / totalPower, 0.75, 0.02);

    // The picture: the floor under the bright half is brighter, and the emitter seen from below
    // shows its texture (camera at y = 1 looking down sees only the floor; look up instead).
    s.camera = Camera::lookAt(Vec3(0, 0.5f, 0), Vec3(0, 2, 0), Vec3(0, 0, 1), 1.6f);
    const Picture up = render(s, 64, 32, 1, 100);
    // The camera's right is +X here: the left image half sees u ∈ [0, 0.5].
    double leftSum = 0.0, rightSum = 0.0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x) (x < 32 ? leftSum : rightSum) += up.at(up.direct, x, y).x;
    EXPECT_GT(rightSum, 2.0 * leftSum);
}

// ---- 6. KHR_materials_unlit ----------------------------------------------------------------------

TEST(GltfFeatures, UnlitMaterialShowsItsBaseColourAndIsNoLight) {
    ScratchDir dir;
    GltfBuilder b;
    const float c[3] = {0, 0, 0}, u[3] = {3, 0, 0}, v[3] = {0, 0, -3};
    const std::string json = R"("scene":0,"scenes":[{"nodes":[0,1]}],"nodes":[{"mesh":0},)" + downCameraNode(1.0f) +
                             R"(],"meshes":[{"primitives":[)" + b.quadPrimitive(c, u, v) + R"(,"material":0}]}],
"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.2,0.4,0.6,1]},"extensions":{"KHR_materials_unlit":{}}}],)" +
                             kCameras + R"(,"extensionsUsed":["KHR_materials_unlit"],"extensionsRequired":["KHR_materials_unlit"])";
    const std::string path = dir.write("unlit.gltf", b.json(json));
    // Not a light: without --no-default-light it gets the default one, with it it is refused.
    SceneOverrides strict;
    strict.defaultLight = false;
    EXPECT_THROW(loadScene(path, strict), SceneError);
    Scene s = loadScene(path);
    ASSERT_TRUE(s.materials[0].unlit);
    const Picture p = render(std::move(s), 16, 16, 1, 2000);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            const Vec3 d = p.at(p.direct, x, y);
            // Exactly the base colour: the light (π W/m² at the centre) adds nothing.
            EXPECT_FLOAT_EQ(d.x, 0.2f);
            EXPECT_FLOAT_EQ(d.y, 0.4f);
            EXPECT_FLOAT_EQ(d.z, 0.6f);
            EXPECT_EQ(p.at(p.caustic, x, y), Vec3(0.0f));
        }
}

TEST(GltfFeatures, UnlitSurfaceAbsorbsPhotons) {
    // A mirror sends the light's photons onto an unlit floor: nothing is stored there.
    Scene s;
    Material unlit;
    unlit.unlit = true;
    s.materials.push_back(unlit);
    const uint32_t mirror = addMaterial(s, MaterialType::Mirror, Vec3(1.0f));
    addMesh(s, quad(Vec3(0.0f), Vec3(5, 0, 0), Vec3(0, 0, -5), 0));
    addMesh(s, quad(Vec3(0, 2, 0), Vec3(1, 0, 0), Vec3(0, 0, 1), mirror));  // faces −Y
    testscenes::addPointLight(s, Vec3(0, 1, 0), Vec3(10.0f));
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    EXPECT_EQ(tracedPower(es, em[0], 20000, 1), Vec3(0.0f));
}

// ---- the issue's "done when": a typical export ----------------------------------------------------

TEST(GltfFeatures, TypicalBlenderExportRendersWithVisibleCaustics) {
    // No light, no camera, Principled-BSDF glass with some transmission (0.8) and GPU instancing:
    // loadScene alone (what `--scene file.glb` does) gives a picture with caustics.
    ScratchDir dir;
    GltfBuilder b;
    const float c0[3] = {0, 0, 0}, u0[3] = {4, 0, 0}, v0[3] = {0, 0, -4};
    const std::string floorMesh = R"(,{"primitives":[)" + b.quadPrimitive(c0, u0, v0) + R"(,"material":1}]})";
    std::string json = instancedGrid(
        b, R"({"pbrMetallicRoughness":{"baseColorFactor":[0.9,0.9,1,1],"roughnessFactor":0},
"extensions":{"KHR_materials_transmission":{"transmissionFactor":0.8},"KHR_materials_ior":{"ior":1.45}}},
{"pbrMetallicRoughness":{"baseColorFactor":[0.8,0.8,0.8,1],"metallicFactor":0}})",
        R"(,{"mesh":1})", floorMesh, 6);
    // No camera node, no lights.
    json.replace(json.find(downCameraNode(9.0f)), downCameraNode(9.0f).size(), R"({"name":"empty"})");
    json.replace(json.find(kCameras), std::string(kCameras).size(), R"("samplers":[])");
    json.replace(json.find(R"(,"KHR_lights_punctual")"), std::string(R"(,"KHR_lights_punctual")").size(), "");
    const std::string path = dir.write("blender.glb.gltf", b.json(json));
    Scene s = loadScene(path);
    EXPECT_EQ(s.lights.size(), 2u);
    EXPECT_EQ(s.instances.size(), 37u);
    const Picture p = render(std::move(s), 64, 48, 2, 20000);
    EXPECT_GT(maxOf(p.caustic), 0.2f * maxOf(p.direct)) << "no visible caustic";
    EXPECT_GT(p.sum(p.caustic), 0.005 * p.sum(p.direct));
}

// ---- the cluster's copy: every new field survives the GLB the master sends ------------------------

TEST(GltfFeatures, NewMaterialFieldsRoundTripThroughTheMastersGlb) {
    Scene s;
    s.name = "fields";
    Texture tex;
    tex.width = 2;
    tex.height = 1;
    tex.rgb = {0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f};
    s.textures = {tex};
    Material partial;
    partial.type = MaterialType::Dielectric;
    partial.transmission = 0.37f;
    partial.baseColor = Vec3(0.3f, 0.6f, 0.9f);
    partial.baseColorTexture = 0;
    partial.baseColorTransform.offset = Vec2(0.1f, 0.2f);
    partial.baseColorTransform.rotation = 0.3f;
    partial.baseColorTransform.scale = Vec2(2.0f, 0.5f);
    partial.absorption = Vec3(0.5f, 1.0f, 2.0f);
    Material unlit;
    unlit.unlit = true;
    unlit.baseColor = Vec3(0.25f);
    Material glow;
    glow.emission = Vec3(3.0f, 2.0f, 1.0f);
    glow.emissiveTexture = 0;
    s.materials = {partial, unlit, glow};
    for (uint32_t m = 0; m < 3; ++m) addMesh(s, quad(Vec3(float(m), 0, 0), Vec3(0.4f, 0, 0), Vec3(0, 0.4f, 0), m));
    s.camera = Camera::lookAt(Vec3(0, 0, 5), Vec3(0), Vec3(0, 1, 0), 0.8f);

    const Scene b = loadGltfFromMemory(encodeGlb(s), "fields.glb", "");
    ASSERT_EQ(b.materials.size(), 3u);
    const Material& p = b.materials[0];
    EXPECT_EQ(p.type, MaterialType::Dielectric);
    EXPECT_EQ(p.transmission, partial.transmission);
    EXPECT_EQ(p.baseColor, partial.baseColor);
    EXPECT_EQ(p.baseColorTexture, 0);
    EXPECT_EQ(p.baseColorTransform, partial.baseColorTransform);
    EXPECT_NEAR(p.absorption.z, partial.absorption.z, 1e-5f);
    EXPECT_TRUE(b.materials[1].unlit);
    EXPECT_EQ(b.materials[1].baseColor, unlit.baseColor);
    EXPECT_EQ(b.materials[2].emissiveTexture, 0);
    EXPECT_EQ(b.materials[2].emission, glow.emission);  // exact: a power-of-two strength
    EXPECT_TRUE(b.warnings.empty()) << allWarnings(b);
}

}  // namespace
}  // namespace rtpm
