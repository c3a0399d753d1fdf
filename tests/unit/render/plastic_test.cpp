// Plastic (glTF's dielectric base) through the renderer: a white plastic sphere under a uniform sky
// is a white furnace at every roughness, the roughness → 0 limit gives the smooth coat's image, a
// rough coat shows a point light's highlight where the Lambertian showed none.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numeric>
#include <vector>

#include "common/core/interleave.h"
#include "common/image/error_metrics.h"
#include "common/image/frame_image.h"
#include "common/render/render_job.h"
#include "common/scene/builtin_scenes.h"
#include "common/trace/eye_pass.h"
#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

using testscenes::addMaterial;
using testscenes::addMesh;
using testscenes::quad;

// UV sphere of radius r at c, smooth normals, outward winding.
Mesh sphere(Vec3 c, float r, uint32_t material, int rings = 48, int segments = 96) {
    Mesh m;
    m.material = material;
    for (int j = 0; j <= rings; ++j)
        for (int i = 0; i <= segments; ++i) {
            const float theta = kPi * float(j) / float(rings), phi = 2.0f * kPi * float(i) / float(segments);
            const Vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
            m.positions.push_back(c + r * n);
            m.normals.push_back(n);
        }
    for (int j = 0; j < rings; ++j)
        for (int i = 0; i < segments; ++i) {
            const uint32_t a = uint32_t(j * (segments + 1) + i), b = a + uint32_t(segments + 1);
            m.indices.insert(m.indices.end(), {a, a + 1, b, a + 1, b + 1, b});
        }
    return m;
}

Material& plasticOf(Scene& s, uint32_t index, float roughness, float metallic = 0.0f) {
    Material& m = s.materials[index];
    m.type = MaterialType::Plastic;
    m.roughness = roughness;
    m.metallic = metallic;
    return m;
}

// Eye pass of one set (no photon map) at w × h.
std::vector<PixelRadiance> eyeImage(const Scene& scene, int w, int h) {
    const EmbreeScene es(scene);
    const Interleave pattern{w, h, 1};
    std::vector<PixelRadiance> out(size_t(w * h));
    renderSet(es, *scene.camera, EyeSettings{}, pattern, 0, nullptr, out);
    return out;
}

// A white plastic sphere under a uniform sky of radiance 1: the coat reflects E(μ) of the sky, the
// base (1 − E(μ)) × the sky's mean light share (1), so every point has radiance 1. A pixel's value
// is a sampled estimate (8 sky directions for the base, 4 visible normals for a rough coat), so
// the mean over the sphere's pixels is checked: within 1.5 % (the table's accuracy plus the
// residual noise of 2000 pixels), and no pixel far above 1.
TEST(Plastic, WhitePlasticSphereUnderAUniformSkyIsAWhiteFurnace) {
    for (float r : {0.0f, 0.3f, 1.0f}) {
        Scene s;
        addMesh(s, sphere(Vec3(0.0f), 1.0f, addMaterial(s, MaterialType::Diffuse, Vec3(1.0f))));
        plasticOf(s, 0, r);
        s.environment = Environment::uniform(Vec3(1.0f));
        s.camera = Camera::lookAt(Vec3(0, 0.5f, 4), Vec3(0.0f), Vec3(0, 1, 0), 0.6f);
        const int w = 64, h = 48;
        const std::vector<PixelRadiance> out = eyeImage(s, w, h);
        double sum = 0.0;
        int n = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const Vec3 d = s.camera->rayDirection(x, y, w, h), o = s.camera->position;
                const float b = glm::dot(o, d), c = glm::dot(o, o) - 0.97f * 0.97f;
                if (!(b * b - c > 0.0f && b < 0.0f)) continue;
                const float v = out[size_t(y * w + x)].direct.x;
                EXPECT_LT(v, 1.3f) << "roughness " << r << " pixel " << x << "," << y;
                sum += v;
                ++n;
            }
        ASSERT_GT(n, 1000);
        std::printf("white plastic, roughness %.1f, under a white sky: mean radiance %.4f\n", r, sum / n);
        EXPECT_NEAR(sum / n, 1.0, 0.015) << "roughness " << r;
    }
}

struct Frame {
    std::vector<float> direct, caustic, final;
};

Frame render(Scene scene, int frames) {
    RenderSettings rs;
    rs.width = 96;
    rs.height = 72;
    rs.photons.photonsPerBatch = 4000;
    rs.photons.selective = false;
    const Camera camera = *scene.camera;
    std::vector<uint32_t> sets(size_t(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    FrameImage image(rs.width, rs.height);
    std::vector<SetPixels> pixels;
    for (int f = 0; f < frames; ++f) {
        const FrameStats st = job.renderFrame(camera, pixels);
        EXPECT_EQ(st.eye.nonFinite, 0u);
        for (const SetPixels& sp : pixels) scatterSet(image, pattern, sp);
    }
    image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
    return Frame{image.direct(), image.causticFiltered(), image.final()};
}

double total(const std::vector<float>& v) { return std::accumulate(v.begin(), v.end(), 0.0); }

// CORNELL with its three diffuse materials turned plastic: a coat just rougher than kSmoothRoughness
// goes through the glossy code (sampled visible normals, the tabulated coat albedo) and must give
// the smooth coat's image: the eye's reflections move by about 10⁻⁴ rad, the coat albedo differs
// by the table's interpolation. Photons choose the coat by E(μ) where the smooth tracer takes the
// exact Fresnel, so the caustic is new noise around the same expectation.
TEST(Plastic, SmoothLimitOfAPlasticCornellBoxIsTheSmoothCoatImage) {
    Scene smooth = buildCornellScene();
    for (uint32_t i = 0; i < smooth.materials.size(); ++i)
        if (smooth.materials[i].type == MaterialType::Diffuse && !smooth.materials[i].isEmissive())
            plasticOf(smooth, i, 0.0f);
    Scene rough = smooth, visiblyRough = smooth;
    for (uint32_t i = 0; i < smooth.materials.size(); ++i)
        if (smooth.materials[i].type == MaterialType::Plastic) {
            rough.materials[i].roughness = 0.011f;
            visiblyRough.materials[i].roughness = 0.3f;
        }
    const Frame a = render(smooth, 3), b = render(rough, 3), c = render(visiblyRough, 3);
    const int w = 96, h = 72;
    const ErrorMetrics fin = compareRgb(b.final, a.final, a.final, w, h);
    const ErrorMetrics dir = compareRgb(b.direct, a.direct, a.direct, w, h);
    std::printf("plastic CORNELL, roughness 0.011 against the smooth coat: final rel. MAE %.5f, direct %.5f, "
                "caustic energy ratio %.4f\n",
                fin.image.relMae, dir.image.relMae, total(b.caustic) / total(a.caustic));
    EXPECT_LT(dir.image.relMae, 0.01);
    EXPECT_LT(fin.image.relMae, 0.03);
    EXPECT_NEAR(total(b.caustic) / total(a.caustic), 1.0, 0.03);
    EXPECT_NEAR(total(b.final) / total(a.final), 1.0, 0.01);
    // The test can fail: a visibly rough coat blurs every reflection.
    EXPECT_GT(compareRgb(c.direct, a.direct, a.direct, w, h).image.relMae, 3.0 * dir.image.relMae);
}

// A red plastic ball of roughness 0.3 under a point light has a highlight: pixels far brighter
// than the Lambertian ball's brightest, and near-white (the coat does not take the base's colour).
TEST(Plastic, RoughCoatShowsAPointLightsHighlight) {
    Scene s;
    addMesh(s, sphere(Vec3(0.0f), 1.0f, addMaterial(s, MaterialType::Diffuse, Vec3(0.8f, 0.05f, 0.05f))));
    testscenes::addPointLight(s, Vec3(2.0f, 3.0f, 4.0f), Vec3(30.0f));
    s.camera = Camera::lookAt(Vec3(0, 0.5f, 4), Vec3(0.0f), Vec3(0, 1, 0), 0.6f);
    const int w = 64, h = 48;
    const std::vector<PixelRadiance> lambert = eyeImage(s, w, h);
    plasticOf(s, 0, 0.3f);
    const std::vector<PixelRadiance> plastic = eyeImage(s, w, h);
    float maxLambertGreen = 0.0f, maxPlasticGreen = 0.0f;
    for (size_t i = 0; i < lambert.size(); ++i) {
        maxLambertGreen = std::max(maxLambertGreen, lambert[i].direct.y);
        maxPlasticGreen = std::max(maxPlasticGreen, plastic[i].direct.y);
    }
    std::printf("red ball: brightest green %.4f Lambertian, %.4f plastic (roughness 0.3)\n", maxLambertGreen,
                maxPlasticGreen);
    EXPECT_GT(maxPlasticGreen, 5.0f * maxLambertGreen);
}

}  // namespace
}  // namespace rtpm
