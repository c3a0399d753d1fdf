// The world light in pictures and photons: a white furnace under a uniform sky (exact) and under a
// constant map (importance-sampled, through the progressive passes), the sky seen in a mirror and
// through glass, a sun region of a map lighting a floor and throwing its caustic through a glass
// slab (photon energy against the slab's transmittance), and the photon budget's share by flux.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <numeric>
#include <vector>

#include "common/image/frame_image.h"
#include "common/photon/photon_tracer.h"
#include "common/render/render_job.h"
#include "common/trace/eye_pass.h"
#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

using testscenes::addMaterial;
using testscenes::addMesh;
using testscenes::box;
using testscenes::quad;

constexpr double kPiD = std::numbers::pi;

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

// Renders `scene` through RenderJob (all sets) for `frames` still frames.
FrameImage renderJob(Scene scene, int w, int h, int frames, CausticEstimatorKind estimator) {
    RenderSettings rs;
    rs.width = w;
    rs.height = h;
    rs.interleave = 2;
    rs.photons.photonsPerBatch = 4000;
    rs.photons.estimator = estimator;
    std::vector<uint32_t> sets(4);
    std::iota(sets.begin(), sets.end(), 0u);
    const Camera camera = *scene.camera;
    RenderJob job(std::move(scene), rs, sets);
    FrameImage image(w, h);
    const Interleave pattern{w, h, rs.interleave};
    std::vector<SetPixels> pixels;
    for (int f = 0; f < frames; ++f) job.renderFrame(camera, pixels);
    for (const SetPixels& sp : pixels) scatterSet(image, pattern, sp);
    image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
    return image;
}

Vec3 pixel(const std::vector<float>& buf, int w, int x, int y) {
    const size_t i = (size_t(y) * size_t(w) + size_t(x)) * 3;
    return Vec3(buf[i], buf[i + 1], buf[i + 2]);
}

Scene furnaceScene(Environment env, float albedo) {
    Scene s;
    addMesh(s, sphere(Vec3(0.0f), 1.0f, addMaterial(s, MaterialType::Diffuse, Vec3(albedo))));
    s.environment = std::move(env);
    s.camera = Camera::lookAt(Vec3(0, 0.5f, 4), Vec3(0.0f), Vec3(0, 1, 0), 0.6f);
    return s;
}

// Which pixels see the sphere (its silhouette shrunk by a pixel: an edge pixel's ray may graze).
std::vector<bool> spherePixels(const Camera& cam, int w, int h) {
    std::vector<bool> in(size_t(w) * size_t(h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3 d = cam.rayDirection(x, y, w, h);
            const Vec3 oc = cam.position;
            const float b = glm::dot(oc, d), c = glm::dot(oc, oc) - 0.97f * 0.97f;
            in[size_t(y * w + x)] = b * b - c > 0.0f && b < 0.0f;
        }
    return in;
}

// A diffuse sphere of albedo a under a uniform sky L is a white furnace: every visible point has
// radiance a·L (the sphere is convex, nothing shadows it), the background L. Cosine-weighted
// sampling of a uniform sky makes each unoccluded sample exactly a·L/8, so a pixel is a·L up to
// float rounding, or 7/8 of it when one of its 8 directions (drawn about the smooth shading normal)
// falls below its facet's true plane, within 2° of a 48 × 96 sphere's facets: rare, so the mean
// stays within 0.3 %.
TEST(EnvironmentRender, FurnaceUnderAUniformSkyGivesAlbedoTimesRadiance) {
    const Vec3 sky(0.4f, 0.6f, 0.8f);
    const float albedo = 0.7f;
    const Scene scene = furnaceScene(Environment::uniform(sky), albedo);
    const EmbreeScene es(scene);
    const int w = 64, h = 48;
    Interleave pattern{w, h, 1};
    std::vector<PixelRadiance> out(size_t(w * h));
    renderSet(es, *scene.camera, EyeSettings{}, pattern, 0, nullptr, out);
    const std::vector<bool> in = spherePixels(*scene.camera, w, h);
    glm::dvec3 sum(0.0);
    int n = 0;
    for (int p = 0; p < w * h; ++p) {
        if (!in[size_t(p)]) continue;
        for (int c = 0; c < 3; ++c) {
            EXPECT_LE(out[size_t(p)].direct[c], 1.0001f * albedo * sky[c]) << p;
            EXPECT_GE(out[size_t(p)].direct[c], 0.8749f * albedo * sky[c]) << p;
        }
        sum += glm::dvec3(out[size_t(p)].direct);
        ++n;
    }
    ASSERT_GT(n, 300);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum[c] / n, albedo * sky[c], 0.003 * albedo * sky[c]);
    EXPECT_EQ(out[0].direct, sky) << "a camera ray that leaves the scene sees the sky";
}

// The same furnace lit by a constant map: the map's importance sampling (8 directions a point,
// half below the horizon) and the progressive passes that refine it (AreaLightSampler). After 6
// still frames each visible point holds 6 · 8 samples: one sample's relative deviation is 1.29
// (4·cos on the upper hemisphere, 0 below), 48 independent ones 0.19, less with the samples'
// stratification. The mean over ~1400 points is within 2.5 % (5 standard errors of independent
// pixels), and fewer than 5 % of the pixels stray beyond 40 %.
TEST(EnvironmentRender, FurnaceUnderAConstantMapConvergesOverStillFrames) {
    Texture map;
    map.width = 32;
    map.height = 16;
    map.rgb.assign(32 * 16 * 3, 0.5f);
    const float albedo = 0.8f;
    const Scene scene = furnaceScene(Environment::fromMap(map), albedo);
    const int w = 64, h = 48;
    const FrameImage image = renderJob(scene, w, h, 6, CausticEstimatorKind::Progressive);
    const std::vector<bool> in = spherePixels(*scene.camera, w, h);
    double sum = 0.0;
    int n = 0, stray = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!in[size_t(y * w + x)]) continue;
            const float v = pixel(image.final(), w, x, y).y;
            stray += std::abs(v - albedo * 0.5f) > 0.4f * albedo * 0.5f;
            sum += v;
            ++n;
        }
    ASSERT_GT(n, 1000);
    EXPECT_NEAR(sum / n, albedo * 0.5, 0.025 * albedo * 0.5);
    EXPECT_LT(stray, n / 20);
    EXPECT_FLOAT_EQ(pixel(image.final(), w, 0, 0).x, 0.5f);
}

// Rays that leave the scene off a mirror or through glass return the sky: a 45° mirror shows the
// zenith (a map whose polar cap is (3, 2, 1)) times its reflectance, a glass pane in front of a
// uniform sky shows the sky again (reflected plus transmitted branches: Fresnel's split sums to 1
// up to the pruned branches, < 0.5 %).
TEST(EnvironmentRender, SkyIsSeenInMirrorsAndThroughGlass) {
    Texture map;
    map.width = 32;
    map.height = 16;
    map.rgb.assign(32 * 16 * 3, 0.1f);
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 32; ++i)
            for (int c = 0; c < 3; ++c) map.rgb[size_t((j * 32 + i) * 3 + c)] = float(3 - c);
    {
        Scene s;
        const uint32_t mirror = addMaterial(s, MaterialType::Mirror, Vec3(0.9f));
        // Normal (0, 1, 1)/√2: the camera's −Z ray reflects to +Y.
        addMesh(s, quad(Vec3(0, 0, -2), Vec3(1, 0, 0), Vec3(0, -0.7071f, 0.7071f), mirror));
        s.environment = Environment::fromMap(map);
        s.camera = Camera::lookAt(Vec3(0.0f), Vec3(0, 0, -1), Vec3(0, 1, 0), 0.2f);
        const EmbreeScene es(s);
        Interleave pattern{9, 9, 1};
        std::vector<PixelRadiance> out(81);
        renderSet(es, *s.camera, EyeSettings{}, pattern, 0, nullptr, out);
        const Vec3 centre = out[4 * 9 + 4].direct;
        EXPECT_NEAR(centre.x, 2.7f, 1e-5f);
        EXPECT_NEAR(centre.y, 1.8f, 1e-5f);
        EXPECT_NEAR(centre.z, 0.9f, 1e-5f);
    }
    {
        Scene s;
        const uint32_t glass = addMaterial(s, MaterialType::Dielectric, Vec3(1.0f));
        addMesh(s, box(Vec3(-1, -1, -2.1f), Vec3(1, 1, -2), glass));
        s.environment = Environment::uniform(Vec3(1.0f, 0.5f, 0.25f));
        s.camera = Camera::lookAt(Vec3(0.0f), Vec3(0, 0, -1), Vec3(0, 1, 0), 0.2f);
        const EmbreeScene es(s);
        Interleave pattern{9, 9, 1};
        std::vector<PixelRadiance> out(81);
        renderSet(es, *s.camera, EyeSettings{}, pattern, 0, nullptr, out);
        for (const PixelRadiance& p : out) {
            EXPECT_NEAR(p.direct.x, 1.0f, 0.005f);
            EXPECT_NEAR(p.direct.z, 0.25f, 0.005f * 0.25f);
        }
    }
}

// A 3 × 3 m floor (albedo 0.8) under a sun: a map black but for its top row, a polar cap of
// half-angle θc = π/32 and radiance L, so the floor's irradiance is E = L·π·sin²θc. A glass slab
// (1 × 0.1 × 1 m, n = 1.5) 0.5 m above the floor's centre passes T = (1 − R)/(1 + R) of the
// light falling on it (R = ((n − 1)/(n + 1))² at normal incidence, every internal reflection
// summed; the cap's 5.6° changes R by < 0.1 %).
struct SunSlab {
    Scene scene;
    float sunRadiance = 100.0f;
    double irradiance = 0.0;
    double transmittance = 0.0;
    SunSlab() {
        Texture map;
        map.width = 64;
        map.height = 32;
        map.rgb.assign(64 * 32 * 3, 0.0f);
        for (int i = 0; i < 64 * 3; ++i) map.rgb[size_t(i)] = sunRadiance;
        scene.environment = Environment::fromMap(map);
        const double capSin = std::sin(kPiD / 32.0);
        irradiance = sunRadiance * kPiD * capSin * capSin;
        const double r = 0.04;
        transmittance = (1.0 - r) / (1.0 + r);
        const uint32_t floor = addMaterial(scene, MaterialType::Diffuse, Vec3(0.8f));
        const uint32_t glass = addMaterial(scene, MaterialType::Dielectric, Vec3(1.0f));
        addMesh(scene, quad(Vec3(0.0f), Vec3(0, 0, 1.5f), Vec3(1.5f, 0, 0), floor));  // faces +Y
        addMesh(scene, box(Vec3(-0.5f, 0.5f, -0.5f), Vec3(0.5f, 0.6f, 0.5f), glass));
        scene.camera = Camera::lookAt(Vec3(0, 4, 0.001f), Vec3(0.0f), Vec3(0, 0, -1), 0.8f);
    }
};

// The caustic: photons from the sun region through the slab, stored on the floor under it
// (|x|, |z| < 0.4 m, clear of the slab's edges and their 6 cm of penumbra), carry T·E·A. 200 000
// QMC paths put ≈ 9 000 photons there: 3 % covers their sampling error.
TEST(EnvironmentRender, SunRegionThrowsTheSlabsCausticWithTheTransmittedEnergy) {
    const SunSlab sun;
    const EmbreeScene es(sun.scene);
    const std::vector<Emitter> emitters = buildEmitters(es);
    ASSERT_EQ(emitters.size(), 1u);
    const Emitter& e = emitters[0];
    ASSERT_EQ(e.kind, EmitterKind::Environment);
    const uint32_t n = 200000;
    const Halton halton(7, 3);
    PhotonSource src;
    src.emitter = &e;
    src.halton = &halton;
    src.hashStream = 3;
    src.powerPerPath = e.flux / float(n);
    src.dims = dimLayout(e.kind, 0);
    TraceSettings ts;
    ts.diffuseBounces = 0;
    ts.seed = 5;
    std::vector<uint64_t> indices(n);
    std::iota(indices.begin(), indices.end(), uint64_t(0));
    TraceOutput out;
    tracePhotons(es, src, ts, indices, out);
    EXPECT_EQ(out.stats.anomalies, 0u);
    double inside = 0.0;
    size_t count = 0;
    for (const TracedPhoton& p : out.photons) {
        EXPECT_NEAR(p.position.y, 0.0f, 1e-4f) << "caustic photons land on the floor only";
        if (std::abs(p.position.x) < 0.4f && std::abs(p.position.z) < 0.4f) {
            inside += p.power.x;
            ++count;
        }
    }
    EXPECT_GT(count, 5000u);
    const double expected = sun.transmittance * sun.irradiance * 0.8 * 0.8;
    EXPECT_NEAR(inside, expected, 0.03 * expected) << count << " photons";
}

// The sun's direct light on the floor, seen from above, away from the slab and its shadow:
// albedo/π · E, sampled from the map (every sample falls in the cap: 2 % per pixel after 2 frames).
TEST(EnvironmentRender, SunRegionLightsTheFloorDirectly) {
    const SunSlab sun;
    const int w = 48, h = 48;
    const FrameImage image = renderJob(sun.scene, w, h, 2, CausticEstimatorKind::Knn);
    const Camera& cam = *sun.scene.camera;
    const double want = 0.8 / kPiD * sun.irradiance;
    int n = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3 d = cam.rayDirection(x, y, w, h);
            const Vec3 p = cam.position + d * (-cam.position.y / d.y);
            const bool onFloor = std::abs(p.x) < 1.4f && std::abs(p.z) < 1.4f;
            const bool clear = std::abs(p.x) > 0.75f || std::abs(p.z) > 0.75f;
            if (!onFloor || !clear) continue;
            EXPECT_NEAR(pixel(image.direct(), w, x, y).x, want, 0.02 * want) << x << ", " << y;
            ++n;
        }
    EXPECT_GT(n, 500);
}

// The photon budget is shared by flux: a world light's is πR²·∫L dω (R the bounding sphere's
// radius), set against a point light's 4πI.
TEST(EnvironmentRender, PhotonShareOfTheWorldLightIsByFlux) {
    Scene s;
    addMesh(s, box(Vec3(-1.0f), Vec3(1.0f), addMaterial(s, MaterialType::Mirror, Vec3(0.9f))));
    testscenes::addPointLight(s, Vec3(0, 3, 0), Vec3(1.0f));
    s.environment = Environment::uniform(Vec3(0.25f));
    const EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 2u);
    EXPECT_EQ(em[1].kind, EmitterKind::Environment);
    const float r = 0.5f * es.bounds().diagonal();
    EXPECT_NEAR(em[1].flux.x, kPi * r * r * 4.0f * kPi * 0.25f, 1e-3f);
    const std::vector<uint32_t> split = splitBudget(em, 10000);
    const double share = em[1].flux.x / double(em[0].flux.x + em[1].flux.x);
    EXPECT_NEAR(double(split[1]) / 10000.0, share, 1e-3);
}

}  // namespace
}  // namespace rtpm
