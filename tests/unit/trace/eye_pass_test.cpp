// Tests of the eye pass against analytic radiance: point-lit plane, mirror, glass slab, area light,
// plus the camera convention, determinism across threads and sets, and NaN safety.
#include "common/trace/eye_pass.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

constexpr float kPi = 3.14159265358979f;

using testscenes::addMesh;
using testscenes::box;
using testscenes::quad;

std::vector<PixelRadiance> render(const EmbreeScene& es, const Camera& cam, int w, int h,
                                  EyeSettings settings = {}, const CausticEstimator* caustics = nullptr,
                                  EyeStats* stats = nullptr, int m = 1) {
    Interleave pattern{w, h, m};
    std::vector<PixelRadiance> image(size_t(w) * size_t(h));
    for (int set = 0; set < pattern.setCount(); ++set) {
        std::vector<PixelRadiance> out(size_t(pattern.pixelCount(set)));
        renderSet(es, cam, settings, pattern, set, caustics, out, stats);
        for (int n = 0; n < pattern.pixelCount(set); ++n)
            image[size_t(pattern.pixelY(set, n)) * size_t(w) + size_t(pattern.pixelX(set, n))] = out[size_t(n)];
    }
    return image;
}

/// Diffuse floor z = 0 (albedo rho), 40 m wide, facing +z; material 0.
Scene floorScene(Vec3 rho) {
    Scene s;
    Material floor;
    floor.baseColor = rho;
    s.materials.push_back(floor);
    addMesh(s, quad(Vec3(0.0f), Vec3(20, 0, 0), Vec3(0, 20, 0), 0));
    return s;
}

Vec3 pointLitFloor(Vec3 p, const Light& light, Vec3 rho) {
    const Vec3 d = light.position - p;
    const float r2 = glm::dot(d, d);
    const float cosTheta = d.z / std::sqrt(r2);
    return light.intensity * cosTheta / r2 * rho / kPi;
}

void expectRelNear(Vec3 actual, Vec3 expected, float rel, const std::string& where) {
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(actual[c], expected[c], rel * std::abs(expected[c]) + 1e-7f) << where << " channel " << c;
}

TEST(EyePass, CameraCentrePixelOfOddImageLooksForward) {
    const Camera cam = Camera::lookAt(Vec3(1, 2, 3), Vec3(1, 2, -7), Vec3(0, 1, 0), 0.9f);
    const Vec3 d = cam.rayDirection(4, 3, 9, 7);
    EXPECT_NEAR(d.z, -1.0f, 1e-6f);
    // Top-left pixel: up (+y) and to the left (−x) of the forward axis; bottom-right the opposite.
    const Vec3 tl = cam.rayDirection(0, 0, 9, 7);
    EXPECT_GT(tl.y, 0.0f);
    EXPECT_LT(tl.x, 0.0f);
    const Vec3 br = cam.rayDirection(8, 6, 9, 7);
    EXPECT_LT(br.y, 0.0f);
    EXPECT_GT(br.x, 0.0f);
    // The top edge of the image is at yfov/2 above the axis (row 0's centre half a pixel below).
    const float halfPixel = 0.5f * 2.0f * std::tan(0.45f) / 7.0f;
    EXPECT_NEAR(cam.rayDirection(4, 0, 9, 7).y / -cam.rayDirection(4, 0, 9, 7).z,
                std::tan(0.45f) - halfPixel, 1e-5f);
}

TEST(EyePass, RenderedImageIsNotMirrored) {
    // A small bright emitter up and to the left of the view axis shows in the top-left quadrant.
    Scene s;
    Material emitter;
    emitter.baseColor = Vec3(0.0f);
    emitter.emission = Vec3(1.0f);
    s.materials.push_back(emitter);
    addMesh(s, quad(Vec3(-1.0f, 1.0f, -5.0f), Vec3(0.3f, 0, 0), Vec3(0, 0.3f, 0), 0));
    EmbreeScene es(s);
    const Camera cam = Camera::lookAt(Vec3(0.0f), Vec3(0, 0, -1), Vec3(0, 1, 0), 0.8f);
    const int w = 21, h = 21;
    const auto img = render(es, cam, w, h);
    float quadrant[4] = {0, 0, 0, 0};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            quadrant[(y < h / 2 ? 0 : 2) + (x < w / 2 ? 0 : 1)] += img[size_t(y * w + x)].direct.x;
    EXPECT_GT(quadrant[0], 0.0f);
    EXPECT_EQ(quadrant[1] + quadrant[2] + quadrant[3], 0.0f);
}

TEST(EyePass, DiffusePlaneUnderPointLightMatchesInverseSquareCosineLaw) {
    const Vec3 rho(0.5f, 0.7f, 0.3f);
    Scene s = floorScene(rho);
    Light light;
    light.type = LightType::Point;
    light.position = Vec3(0.5f, -0.3f, 1.5f);
    light.intensity = Vec3(10.0f, 5.0f, 2.0f);
    s.lights.push_back(light);
    EmbreeScene es(s);
    const Camera cam = Camera::lookAt(Vec3(0.3f, -4.0f, 5.0f), Vec3(0.0f), Vec3(0, 0, 1), 0.7f);
    const int w = 17, h = 13;
    const auto img = render(es, cam, w, h);
    int checked = 0;
    for (int y = 0; y < h; y += 3)
        for (int x = 0; x < w; x += 4) {
            const Vec3 d = cam.rayDirection(x, y, w, h);
            const Vec3 p = cam.position + (-cam.position.z / d.z) * d;
            expectRelNear(img[size_t(y * w + x)].direct, pointLitFloor(p, light, rho), 0.005f,
                          "pixel " + std::to_string(x) + "," + std::to_string(y));
            EXPECT_EQ(img[size_t(y * w + x)].caustic, Vec3(0.0f));
            ++checked;
        }
    EXPECT_GT(checked, 10);
}

TEST(EyePass, SpotAndDirectionalLightsFollowGltfConventions) {
    const Vec3 rho(0.6f);
    Scene s = floorScene(rho);
    Light sun;
    sun.type = LightType::Directional;
    sun.direction = glm::normalize(Vec3(0.0f, 0.6f, -0.8f));  // travels down, cosθ = 0.8 on the floor
    sun.intensity = Vec3(2.0f);
    s.lights.push_back(sun);
    Light spot;
    spot.type = LightType::Spot;
    spot.position = Vec3(0, 0, 2);
    spot.direction = Vec3(0, 0, -1);
    spot.intensity = Vec3(8.0f, 0.0f, 0.0f);
    spot.innerConeAngle = 0.2f;
    spot.outerConeAngle = 0.4f;
    s.lights.push_back(spot);
    EmbreeScene es(s);
    // Orthographic-like check: look straight down at chosen points with a narrow camera.
    auto radianceAt = [&](Vec3 p) {
        const Camera cam = Camera::lookAt(p + Vec3(0, 0, 1), p, Vec3(0, 1, 0), 0.01f);
        return render(es, cam, 1, 1)[0].direct;
    };
    const Vec3 sunPart = sun.intensity * 0.8f * rho / kPi;
    // Inside the inner cone: full intensity.
    expectRelNear(radianceAt(Vec3(0.1f, 0, 0)),
                  sunPart + pointLitFloor(Vec3(0.1f, 0, 0), spot, rho), 0.005f, "inner");
    // Between the cones: the glTF smooth falloff.
    const Vec3 mid(2.0f * std::tan(0.3f), 0.0f, 0.0f);
    const float cosO = std::cos(0.4f), cosI = std::cos(0.2f);
    const float cd = 2.0f / glm::length(mid - spot.position);
    const float att = std::pow((cd - cosO) / (cosI - cosO), 2.0f);
    expectRelNear(radianceAt(mid), sunPart + att * pointLitFloor(mid, spot, rho), 0.005f, "falloff");
    // Outside the outer cone: the sun only.
    expectRelNear(radianceAt(Vec3(2.0f, 0, 0)), sunPart, 0.005f, "outside");
}

TEST(EyePass, MirrorReflectsThePlane) {
    const Vec3 rho(0.5f);
    Scene s = floorScene(rho);
    Material mirror;
    mirror.type = MaterialType::Mirror;
    mirror.baseColor = Vec3(0.9f, 0.8f, 0.7f);
    s.materials.push_back(mirror);
    // Vertical mirror at x = 3 facing −x, 2 m high, 4 m wide.
    addMesh(s, quad(Vec3(3.0f, 0.0f, 1.0f), Vec3(0, 0, 1), Vec3(0, 2, 0), 1));
    Light light;
    light.position = Vec3(0.0f, 0.0f, 2.0f);
    light.intensity = Vec3(20.0f);
    s.lights.push_back(light);
    EmbreeScene es(s);
    const Camera cam = Camera::lookAt(Vec3(0.0f, 0.0f, 1.5f), Vec3(3.0f, 0.0f, 0.8f), Vec3(0, 0, 1), 0.5f);
    const int w = 15, h = 15;
    const auto img = render(es, cam, w, h);
    int mirrored = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3 d = cam.rayDirection(x, y, w, h);
            const float tm = (3.0f - cam.position.x) / d.x;
            const Vec3 pm = cam.position + tm * d;
            if (pm.z <= 0.01f || pm.z >= 1.99f || std::abs(pm.y) > 1.99f) continue;  // not on the mirror
            const Vec3 r(-d.x, d.y, d.z);
            if (r.z >= 0.0f) continue;  // reflected ray misses the floor
            const Vec3 pf = pm + (-pm.z / r.z) * r;
            if (pf.x >= 2.99f || pf.x < -19.0f || std::abs(pf.y) > 19.0f) continue;  // off the floor
            expectRelNear(img[size_t(y * w + x)].direct, mirror.baseColor * pointLitFloor(pf, light, rho),
                          0.005f, "pixel " + std::to_string(x) + "," + std::to_string(y));
            ++mirrored;
        }
    EXPECT_GT(mirrored, 20);
}

/// Returns a constant caustic radiance, scaled by the albedo to show it is passed through.
class ConstantCaustics : public CausticEstimator {
public:
    Vec3 radiance(const EmbreeScene&, uint32_t, const SurfaceHit&, Vec3 normal, Vec3 albedo,
                  GatherHint*) const override {
        EXPECT_NEAR(glm::length(normal), 1.0f, 1e-4f);
        return Vec3(2.0f) * albedo;
    }
};

TEST(EyePass, CausticValueIsScaledBySpecularThroughput) {
    const Vec3 rho(0.5f, 0.25f, 1.0f);
    Scene s = floorScene(rho);
    Material mirror;
    mirror.type = MaterialType::Mirror;
    mirror.baseColor = Vec3(0.5f);
    s.materials.push_back(mirror);
    addMesh(s, quad(Vec3(0.0f, 0.0f, 1.0f), Vec3(0.2f, 0, 0), Vec3(0, 0.2f, 0), 1));  // facing up
    EmbreeScene es(s);
    ConstantCaustics caustics;
    // Straight down onto the floor, and straight down onto the mirror, which sends the ray up.
    const Camera toFloor = Camera::lookAt(Vec3(5, 0, 3), Vec3(5, 0, 0), Vec3(0, 1, 0), 0.01f);
    EXPECT_EQ(render(es, toFloor, 1, 1, {}, &caustics)[0].caustic, 2.0f * rho);
    // Looking up from below at the floor's back side: two-sided diffuse, still the full value.
    const Camera fromBelow = Camera::lookAt(Vec3(5, 0, -3), Vec3(5, 0, 0), Vec3(0, 1, 0), 0.01f);
    EXPECT_EQ(render(es, fromBelow, 1, 1, {}, &caustics)[0].caustic, 2.0f * rho);
    // A mirror facing down under a camera looking up reflects the ray back down to the floor.
    Scene s2 = floorScene(rho);
    s2.materials.push_back(mirror);
    addMesh(s2, quad(Vec3(0.0f, 0.0f, 3.0f), Vec3(0, 0.2f, 0), Vec3(0.2f, 0, 0), 1));  // facing down
    EmbreeScene es2(s2);
    const Camera up = Camera::lookAt(Vec3(0, 0, 1), Vec3(0, 0, 4), Vec3(0, 1, 0), 0.01f);
    const PixelRadiance px = render(es2, up, 1, 1, {}, &caustics)[0];
    expectRelNear(px.caustic, 0.5f * 2.0f * rho, 1e-6f, "through mirror");
}

TEST(EyePass, GlassSlabTransmitsFresnelSeriesWithBeerLambert) {
    Scene s;
    Material backdrop;
    backdrop.baseColor = Vec3(0.0f);
    backdrop.emission = Vec3(1.0f, 2.0f, 3.0f);
    s.materials.push_back(backdrop);
    Material glass;
    glass.type = MaterialType::Dielectric;
    glass.ior = 1.5f;
    glass.absorption = Vec3(0.0f, 1.0f, 4.0f);
    s.materials.push_back(glass);
    addMesh(s, quad(Vec3(0, 0, -10), Vec3(10, 0, 0), Vec3(0, 10, 0), 0));  // faces +z
    const float thickness = 0.5f;
    addMesh(s, box(Vec3(-2, -2, -3), Vec3(2, 2, -3 + thickness), 1));
    EmbreeScene es(s);
    const Camera cam = Camera::lookAt(Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(0, 1, 0), 0.01f);
    const Vec3 px = render(es, cam, 1, 1)[0].direct;
    // Normal incidence: F = 0.04 at each face; internal reflections form a geometric series.
    const float f = 0.04f;
    for (int c = 0; c < 3; ++c) {
        const float a = std::exp(-glass.absorption[c] * thickness);
        const float expected = backdrop.emission[c] * (1 - f) * (1 - f) * a / (1 - f * f * a * a);
        EXPECT_NEAR(px[c], expected, 0.005f * expected) << "channel " << c;
    }
}

TEST(EyePass, DielectricsBlockShadowRays) {
    Scene s = floorScene(Vec3(0.5f));
    Material glass;
    glass.type = MaterialType::Dielectric;
    s.materials.push_back(glass);
    addMesh(s, box(Vec3(-0.5f, -0.5f, 1.0f), Vec3(0.5f, 0.5f, 1.2f), 1));
    Light light;
    light.position = Vec3(0, 0, 3);
    light.intensity = Vec3(10.0f);
    s.lights.push_back(light);
    EmbreeScene es(s);
    const Camera under = Camera::lookAt(Vec3(0.0f, -3.0f, 0.5f), Vec3(0.0f, 0.0f, 0.0f), Vec3(0, 0, 1), 0.01f);
    EXPECT_EQ(render(es, under, 1, 1)[0].direct, Vec3(0.0f));  // caustic light comes from photons
    const Camera beside = Camera::lookAt(Vec3(3.0f, -3.0f, 0.5f), Vec3(3.0f, 0.0f, 0.0f), Vec3(0, 0, 1), 0.01f);
    EXPECT_GT(render(es, beside, 1, 1)[0].direct.x, 0.0f);
}

/// Irradiance at a point a distance c below the corner of a parallel a × b emitter of radiance 1
/// (the classic point-to-rectangle form factor, times π).
double cornerIrradiance(double a, double b, double c) {
    const double x = a / c, y = b / c;
    return 0.5 * (x / std::sqrt(1 + x * x) * std::atan(y / std::sqrt(1 + x * x)) +
                  y / std::sqrt(1 + y * y) * std::atan(x / std::sqrt(1 + y * y)));
}

/// The floor scene under a `size` × `size` m emitter of radiance 4 at `height`, facing down,
/// split into tessellation² quads.
Scene floorUnderSquareEmitter(Vec3 rho, int tessellation, float size, float height) {
    Scene s = floorScene(rho);
    Material light;
    light.baseColor = Vec3(0.0f);
    light.emission = Vec3(4.0f);
    s.materials.push_back(light);
    Mesh m;
    m.material = 1;
    const int n = tessellation;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i)
            m.positions.push_back(Vec3(size * (-0.5f + float(i) / float(n)),
                                       size * (-0.5f + float(j) / float(n)), height));
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
            m.indices.insert(m.indices.end(), {a, c, b, b, c, d});  // clockwise from above: faces −z
        }
    addMesh(s, m);
    return s;
}

void checkAreaLight(int tessellation, int samples, float tolerance) {
    const Vec3 rho(0.5f);
    // A 1 × 1 m emitter at height 1.5 facing down, split into tessellation² quads.
    const Scene s = floorUnderSquareEmitter(rho, tessellation, 1.0f, 1.5f);
    const int n = tessellation;
    EmbreeScene es(s);
    ASSERT_EQ(es.emissiveTriangles().size(), size_t(2 * n * n));
    ASSERT_LT(es.emissiveTriangles()[0].normal.z, 0.0f);
    EyeSettings settings;
    settings.areaLightSamples = samples;
    // Average over a patch of pixels: the per-pixel rotations make each pixel an unbiased
    // estimate, the mean must match the analytic value tightly.
    const Camera cam = Camera::lookAt(Vec3(0, 0, 1.0f), Vec3(0, 0, 0), Vec3(0, 1, 0), 0.002f);
    const auto img = render(es, cam, 8, 8, settings);
    Vec3 mean(0.0f);
    for (const auto& p : img) mean += p.direct / float(img.size());
    const double e = 4.0 * cornerIrradiance(0.5, 0.5, 1.5);  // four corners meet below the centre
    const float expected = float(4.0 * e * 0.5 / kPi);
    EXPECT_NEAR(mean.x, expected, tolerance * expected) << "tessellation " << n;
    for (const auto& p : img) EXPECT_NEAR(p.direct.x, expected, 0.05f * expected);
}

TEST(EyePass, AreaLightMatchesRectangleFormFactorSampledPerTriangle) { checkAreaLight(1, 16, 0.005f); }

TEST(EyePass, AreaLightMatchesRectangleFormFactorSampledByPower) { checkAreaLight(8, 16, 0.01f); }

// The sample count follows the emitters' solid angle: a 10 cm lamp 2 m above the floor (Ω ≈
// 0.004 sr) takes one shadow ray per pixel instead of areaLightSamples per triangle, and the
// mean over pixels (each with its own rotation) is still the analytic irradiance; a large near
// lamp keeps the full budget.
TEST(EyePass, AreaLightSampleCountFollowsTheSolidAngle) {
    const Vec3 rho(0.5f);
    const Camera cam = Camera::lookAt(Vec3(0, 0, 1.0f), Vec3(0, 0, 0), Vec3(0, 1, 0), 0.002f);
    EyeSettings settings;
    settings.areaLightSamples = 4;
    {
        const Scene small = floorUnderSquareEmitter(rho, 1, 0.1f, 2.0f);
        EmbreeScene es(small);
        EyeStats stats;
        const auto img = render(es, cam, 16, 16, settings, nullptr, &stats);
        EXPECT_EQ(stats.shadowRays, 256u);  // one per pixel, not 2 triangles × 4
        Vec3 mean(0.0f);
        for (const auto& p : img) mean += p.direct / float(img.size());
        const double e = 4.0 * cornerIrradiance(0.05, 0.05, 2.0);
        const float expected = float(4.0 * e * 0.5 / kPi);
        EXPECT_NEAR(mean.x, expected, 0.01f * expected);
        for (const auto& p : img) EXPECT_NEAR(p.direct.x, expected, 0.05f * expected);
    }
    {
        const Scene large = floorUnderSquareEmitter(rho, 1, 1.0f, 1.0f);  // Ω ≈ 1.6 sr
        EmbreeScene es(large);
        EyeStats stats;
        const Camera low = Camera::lookAt(Vec3(0, 0, 0.5f), Vec3(0, 0, 0), Vec3(0, 1, 0), 0.002f);
        render(es, low, 16, 16, settings, nullptr, &stats);
        EXPECT_EQ(stats.shadowRays, 256u * 8u);
    }
}

TEST(EyePass, EmitterSeenDirectlyOnlyFromTheFront) {
    Scene s;
    Material light;
    light.baseColor = Vec3(0.0f);
    light.emission = Vec3(3.0f);
    s.materials.push_back(light);
    addMesh(s, quad(Vec3(0.0f), Vec3(1, 0, 0), Vec3(0, 1, 0), 0));  // faces +z
    EmbreeScene es(s);
    EXPECT_EQ(render(es, Camera::lookAt(Vec3(0, 0, 2), Vec3(0.0f), Vec3(0, 1, 0), 0.1f), 3, 3)[4].direct, Vec3(3.0f));
    EXPECT_EQ(render(es, Camera::lookAt(Vec3(0, 0, -2), Vec3(0.0f), Vec3(0, 1, 0), 0.1f), 3, 3)[4].direct, Vec3(0.0f));
}

/// A scene exercising every path kind: area light, point light, mirror, glass, textured floor.
Scene mixedScene() {
    Scene s = floorScene(Vec3(0.6f));
    Texture tex;
    tex.width = 2;
    tex.height = 2;
    tex.rgb = {1, 1, 1, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f, 1, 1, 1};
    s.textures.push_back(tex);
    s.materials[0].baseColorTexture = 0;
    Material mirror;
    mirror.type = MaterialType::Mirror;
    s.materials.push_back(mirror);
    Material glass;
    glass.type = MaterialType::Dielectric;
    glass.absorption = Vec3(0.5f, 0.1f, 0.0f);
    s.materials.push_back(glass);
    Material light;
    light.emission = Vec3(5.0f);
    s.materials.push_back(light);
    addMesh(s, quad(Vec3(-1.5f, 0.0f, 0.7f), Vec3(0, 0.7f, 0), Vec3(0.3f, 0, 0.7f), 1));
    addMesh(s, box(Vec3(-0.5f, -0.5f, 0.2f), Vec3(0.5f, 0.5f, 1.0f), 2));
    addMesh(s, quad(Vec3(0.0f, 0.0f, 3.0f), Vec3(0, 0.5f, 0), Vec3(0.5f, 0, 0), 3));
    Light point;
    point.position = Vec3(2, 1, 2);
    point.intensity = Vec3(3.0f);
    s.lights.push_back(point);
    return s;
}

TEST(EyePass, OutputIdenticalForOneAndTwoThreadsAndAnySetSplit) {
    Scene s = mixedScene();
    EmbreeScene es(s);
    const Camera cam = Camera::lookAt(Vec3(3, -4, 3), Vec3(0, 0, 0.5f), Vec3(0, 0, 1), 0.8f);
    ConstantCaustics caustics;
    const int w = 48, h = 36;
    std::vector<PixelRadiance> one, two, split;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        one = render(es, cam, w, h, {}, &caustics);
    }
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
        two = render(es, cam, w, h, {}, &caustics);
    }
    split = render(es, cam, w, h, {}, &caustics, nullptr, 5);
    double total = 0.0;
    for (size_t i = 0; i < one.size(); ++i) {
        ASSERT_EQ(one[i].direct, two[i].direct) << "pixel " << i;
        ASSERT_EQ(one[i].caustic, two[i].caustic) << "pixel " << i;
        ASSERT_EQ(one[i].direct, split[i].direct) << "pixel " << i;
        total += one[i].direct.x;
    }
    EXPECT_GT(total, 0.0);
}

TEST(EyePass, DegenerateTrianglesProduceNoNaN) {
    Scene s = mixedScene();
    // Zero-area triangles in every material, including an emitter, and zero vertex normals.
    for (uint32_t mat = 0; mat < s.materials.size(); ++mat) {
        Mesh m;
        m.material = mat;
        m.positions = {{0, 0, 0.5f}, {0.5f, 0.5f, 0.5f}, {1, 1, 0.5f}, {0, 0, 0.5f}};
        m.normals.assign(4, Vec3(0.0f));
        m.indices = {0, 1, 2, 0, 3, 1, 2, 2, 2};
        addMesh(s, m);
    }
    EmbreeScene es(s);
    // Below the emitter quad at z = 3 (a camera on its corner would start every ray on its
    // surface, where either answer is right and the BVH's order picks one).
    const Camera cam = Camera::lookAt(Vec3(0.5f, 0.5f, 2.5f), Vec3(0.5f, 0.5f, 0.5f), Vec3(0, 1, 0), 1.2f);
    EyeStats stats;
    ConstantCaustics caustics;
    const auto img = render(es, cam, 40, 40, {}, &caustics, &stats);
    for (const auto& p : img) {
        ASSERT_TRUE(std::isfinite(p.direct.x + p.direct.y + p.direct.z));
        ASSERT_TRUE(std::isfinite(p.caustic.x + p.caustic.y + p.caustic.z));
    }
    EXPECT_EQ(stats.nonFinite, 0u);
    EXPECT_EQ(stats.primaryRays, 1600u);
    EXPECT_GT(stats.shadowRays, 1600u);
}

TEST(EyePass, MirrorHallOfMirrorsStopsAtMaxDepth) {
    Scene s;
    Material mirror;
    mirror.type = MaterialType::Mirror;
    mirror.baseColor = Vec3(1.0f);
    s.materials.push_back(mirror);
    addMesh(s, quad(Vec3(0, 0, 1), Vec3(0, 5, 0), Vec3(5, 0, 0), 0));  // faces −z
    addMesh(s, quad(Vec3(0, 0, -1), Vec3(5, 0, 0), Vec3(0, 5, 0), 0));  // faces +z
    EmbreeScene es(s);
    EyeSettings settings;
    settings.maxDepth = 5;
    EyeStats stats;
    const Camera cam = Camera::lookAt(Vec3(0, 0, 0), Vec3(0, 0.01f, 1), Vec3(0, 1, 0), 0.01f);
    render(es, cam, 1, 1, settings, nullptr, &stats);
    EXPECT_EQ(stats.primaryRays, 1u);
    EXPECT_EQ(stats.secondaryRays, 5u);
}

}  // namespace
}  // namespace rtpm
