// What a glTF file's lights do on the surfaces Blender shows glossy: a rough metal (glTF's default
// material is one) and frosted glass show the highlight of a point, spot or sun light; a file
// whose only emitters emit nothing gets the default lights, one lit by emitters alone the sky.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "common/image/frame_image.h"
#include "common/render/render_job.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_export.h"
#include "common/scene/scene_loader.h"
#include "tests/support/gltf_builder.h"
#include "tests/support/scratch_dir.h"
#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

using testgltf::GltfBuilder;
using testsupport::ScratchDir;
using testgltf::pngBytes;
using testscenes::addMaterial;
using testscenes::addMesh;
using testscenes::addPointLight;
using testscenes::quad;

/// The direct layer of the centre pixel of a 3×3 image (its ray is the camera's axis) after one
/// frame, one interleaving set.
Vec3 centreDirect(Scene scene) {
    RenderSettings rs;
    rs.width = 3;
    rs.height = 3;
    rs.interleave = 1;
    rs.photons.photonsPerBatch = 1000;
    const Camera camera = *scene.camera;
    RenderJob job(std::move(scene), rs, {0u});
    FrameImage image(rs.width, rs.height);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    std::vector<SetPixels> pixels;
    job.renderFrame(camera, pixels);
    for (const SetPixels& sp : pixels) image.scatter(pattern, sp.set, sp.pixels);
    image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
    const std::vector<float>& d = image.direct();
    const size_t i = (1 * 3 + 1) * 3;
    return Vec3(d[i], d[i + 1], d[i + 2]);
}

/// A 4 m floor of `type` (base colour 0.9, `roughness`) at y = 0, a point light of 10 W/sr at
/// (0, 1, 0), the camera at (0, 1, 1) looking at the origin. No world light: what the floor
/// reflects from elsewhere is black.
Scene floorUnderAPointLight(MaterialType type, float roughness) {
    Scene s;
    const uint32_t floorMat = addMaterial(s, type, Vec3(0.9f));
    s.materials[floorMat].roughness = roughness;
    addMesh(s, quad(Vec3(0.0f), Vec3(2, 0, 0), Vec3(0, 0, -2), floorMat));
    addPointLight(s, Vec3(0, 1, 0), Vec3(10.0f));
    s.camera = Camera::lookAt(Vec3(0, 1, 1), Vec3(0.0f), Vec3(0, 1, 0), 0.5f);
    return s;
}

// GGX reflection written out again (Walter et al. 2007 with the height-correlated Smith G2 and
// Schlick's Fresnel, glTF's metal BRDF), independent of common/trace/microfacet.cpp.
double ggxConductor(double alpha, double f0, double cosO, double cosI, double cosH, double cosOH) {
    const double a2 = alpha * alpha;
    const double dDen = cosH * cosH * (a2 - 1.0) + 1.0;
    const double d = a2 / (M_PI * dDen * dDen);
    auto lambda = [&](double c) { return 0.5 * (-1.0 + std::sqrt(1.0 + a2 * (1.0 - c * c) / (c * c))); };
    const double g2 = 1.0 / (1.0 + lambda(cosO) + lambda(cosI));
    const double f = f0 + (1.0 - f0) * std::pow(1.0 - cosOH, 5.0);
    return f * d * g2 / (4.0 * cosO * cosI);
}

TEST(GlossyHighlight, RoughMetalShowsThePointLightAsItsGgxLobeReflectsIt) {
    const float roughness = 0.5f;  // α = 0.25
    const Vec3 got = centreDirect(floorUnderAPointLight(MaterialType::Mirror, roughness));
    // At the origin: the light straight above (E = 10 W/m², cos θi = 1), the viewer at 45°.
    const double cosO = std::sqrt(0.5), cosI = 1.0;
    const glm::dvec3 wo(0, std::sqrt(0.5), std::sqrt(0.5)), wi(0, 1, 0), h = glm::normalize(wo + wi);
    const double want = ggxConductor(0.25, 0.9, cosO, cosI, h.y, glm::dot(wo, h)) * 10.0 * cosI;
    std::printf("rough metal under a point light: %.5f, GGX written out %.5f\n", got.x, want);
    EXPECT_NEAR(got.x, want, 1e-3 * want);
    EXPECT_FLOAT_EQ(got.y, got.x);
    // The test can fail: a smooth mirror shows no highlight of a point (it reflects a direction
    // that misses the light), and a blocked light none at all.
    EXPECT_EQ(centreDirect(floorUnderAPointLight(MaterialType::Mirror, 0.0f)), Vec3(0.0f));
    Scene blocked = floorUnderAPointLight(MaterialType::Mirror, roughness);
    addMesh(blocked, quad(Vec3(0, 0.5f, 0), Vec3(0.1f, 0, 0), Vec3(0, 0, -0.1f), 0));
    EXPECT_EQ(centreDirect(std::move(blocked)), Vec3(0.0f));
}

TEST(GlossyHighlight, FrostedGlassReflectsThePointLightAndShowsNothingThroughIt) {
    // The reflection lobe of a rough dielectric (index 1.5) at the same geometry: Fresnel of the
    // microfacet instead of Schlick's F0, the same D and G2.
    Scene s = floorUnderAPointLight(MaterialType::Dielectric, 0.5f);
    const Vec3 got = centreDirect(s);
    const glm::dvec3 wo(0, std::sqrt(0.5), std::sqrt(0.5)), wi(0, 1, 0), h = glm::normalize(wo + wi);
    const double c = glm::dot(wo, h), g = std::sqrt(1.5 * 1.5 - 1.0 + c * c);
    const double fresnel = 0.5 * std::pow((g - c) / (g + c), 2.0) *
                           (1.0 + std::pow((c * (g + c) - 1.0) / (c * (g - c) + 1.0), 2.0));
    const double f1 = ggxConductor(0.25, 1.0, wo.y, 1.0, h.y, c);  // F = 1: D G2 / (4 cos cos)
    const double want = fresnel * f1 * 10.0;
    std::printf("frosted glass under a point light: %.5f, written out %.5f\n", got.x, want);
    EXPECT_NEAR(got.x, want, 2e-3 * want);
    // The light below the glass sends no direct light through it (caustic light, photons).
    Scene below = floorUnderAPointLight(MaterialType::Dielectric, 0.5f);
    below.lights[0].position = Vec3(0, -1, 0);
    EXPECT_EQ(centreDirect(std::move(below)), Vec3(0.0f));
}

TEST(GlossyHighlight, EmittersThatEmitNothingGetTheDefaultLightsAndEmittersAloneTheSky) {
    // A cube-like quad whose emissive factor is multiplied by an all-black emissive texture (as a
    // Blender export can write): no light at all, so the default lights and sky come in.
    ScratchDir dir;
    GltfBuilder b;
    const int img = b.image(pngBytes(2, 2, std::vector<uint8_t>(12, 0)), "image/png");
    const float c[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 0, -1};
    const std::string quadJson = b.quadPrimitive(c, u, v);
    auto write = [&](const std::string& name, const std::string& texture) {
        const std::string json =
            R"("scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[)" + quadJson +
            R"(,"material":0}]}],"materials":[{"emissiveFactor":[1,1,1])" + texture +
            R"(,"pbrMetallicRoughness":{"metallicFactor":0}}],"textures":[{"source":)" + std::to_string(img) + "}]";
        return dir.write(name, b.json(json));
    };
    const Scene black = loadScene(write("black.gltf", R"(,"emissiveTexture":{"index":0})"));
    EXPECT_EQ(black.lights.size(), 2u) << "the default spot and key lights";
    EXPECT_FALSE(black.environment.empty()) << "the default sky";
    SceneOverrides strict;
    strict.defaultLight = false;
    EXPECT_THROW(loadScene(write("strict.gltf", R"(,"emissiveTexture":{"index":0})"), strict), SceneError);
    // The test can fail: the same factor without the black texture is a light. A file lit by its
    // emitters alone gets the dim sky as its world (no lamps); --no-default-light leaves it out.
    const std::string litPath = write("lit.gltf", "");
    const Scene lit = loadScene(litPath);
    EXPECT_TRUE(lit.lights.empty());
    EXPECT_FALSE(lit.environment.empty());
    const Scene bare = loadScene(litPath, strict);
    EXPECT_TRUE(bare.lights.empty());
    EXPECT_TRUE(bare.environment.empty());
}

// A scene rtpm exports without a world light (RING: lit by its emissive lamp alone) says so in
// the file, so loading the file back adds no default sky: the .glb renders as the scene did.
TEST(GlossyHighlight, AnExportedSceneWithoutAWorldLoadsBackWithoutTheDefaultSky) {
    ScratchDir dir;
    const Scene ring = buildBuiltinScene("RING");
    ASSERT_TRUE(ring.environment.empty());
    const std::string path = dir.file("ring.glb");
    exportGlb(ring, path);
    const Scene back = loadScene(path);
    EXPECT_TRUE(back.worldless);
    EXPECT_TRUE(back.environment.empty()) << "the default sky was added to an exported scene";
    // The test can fail: the same scene with a world light exported and loaded back is a file lit
    // by its emitters alone (the world is not written), which gets the default sky.
    Scene withWorld = ring;
    withWorld.environment = Environment::uniform(Vec3(0.1f));
    exportGlb(withWorld, path);
    const Scene skyBack = loadScene(path);
    EXPECT_FALSE(skyBack.worldless);
    EXPECT_FALSE(skyBack.environment.empty());
}

}  // namespace
}  // namespace rtpm
