// Tests of photon emission and tracing: exact power conservation per light type, specular
// interactions (mirror, Fresnel, Beer–Lambert), the caustic storage rule, determinism and
// robustness against degenerate input.
#include "common/photon/photon_tracer.h"

#include <cmath>
#include <numbers>
#include <numeric>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "common/photon/photon_map.h"
#include "common/trace/optics.h"
#include "common/trace/plastic_bsdf.h"

namespace rtpm {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

uint32_t addMaterial(Scene& s, MaterialType type, Vec3 color, float ior = 1.5f, Vec3 absorption = Vec3(0.0f),
                     Vec3 emission = Vec3(0.0f)) {
    Material m;
    m.type = type;
    m.baseColor = color;
    m.ior = ior;
    m.absorption = absorption;
    m.emission = emission;
    s.materials.push_back(m);
    return static_cast<uint32_t>(s.materials.size() - 1);
}

void addMesh(Scene& s, Mesh mesh) {
    s.meshes.push_back(std::move(mesh));
    Instance inst;
    inst.mesh = static_cast<uint32_t>(s.meshes.size() - 1);
    s.instances.push_back(inst);
}

// Horizontal quad at height y, [x0,x1] × [z0,z1], counter-clockwise seen from `up` (+1 or −1).
void addQuadY(Scene& s, uint32_t material, float y, float x0, float x1, float z0, float z1, float up) {
    Mesh m;
    m.positions = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
    m.indices = up > 0 ? std::vector<uint32_t>{0, 2, 1, 0, 3, 2} : std::vector<uint32_t>{0, 1, 2, 0, 2, 3};
    m.material = material;
    addMesh(s, std::move(m));
}

// Closed axis-aligned box (12 triangles), outward winding.
void addBox(Scene& s, uint32_t material, Vec3 lo, Vec3 hi) {
    Mesh m;
    for (int i = 0; i < 8; ++i)
        m.positions.push_back(Vec3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z));
    m.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    m.material = material;
    addMesh(s, std::move(m));
}

// Light inside an index-1 dielectric shell inside a diffuse box: every emitted photon passes the
// shell (one specular interaction, F = 0, no bending) and is stored exactly once on the box.
Scene shellScene() {
    Scene s;
    const uint32_t wall = addMaterial(s, MaterialType::Diffuse, Vec3(0.5f));
    const uint32_t shell = addMaterial(s, MaterialType::Dielectric, Vec3(1.0f), 1.0f);
    addBox(s, wall, Vec3(-4.0f), Vec3(4.0f));
    addBox(s, shell, Vec3(-1.0f), Vec3(1.0f));
    return s;
}

struct Traced {
    Vec3 power{0.0f};
    TraceOutput out;
};

Traced traceAll(const EmbreeScene& es, const Emitter& e, uint32_t n, uint32_t diffuseBounces = 0,
                uint64_t first = 0, uint32_t maxDepth = TraceSettings{}.maxDepth) {
    const Halton h(11, 3);
    PhotonSource src;
    src.emitter = &e;
    src.halton = &h;
    src.hashStream = 3;
    src.powerPerPath = e.flux / static_cast<float>(n);
    src.dims = dimLayout(e.kind, diffuseBounces);
    TraceSettings ts;
    ts.diffuseBounces = diffuseBounces;
    ts.maxDepth = maxDepth;
    ts.seed = 5;
    std::vector<uint64_t> idx(n);
    std::iota(idx.begin(), idx.end(), first);
    Traced t;
    tracePhotons(es, src, ts, idx, t.out);
    // Sum in double: 20 000 float additions would lose ~1e-4 of the total to rounding.
    glm::dvec3 sum(0.0);
    for (const TracedPhoton& p : t.out.photons) sum += glm::dvec3(p.power);
    t.power = Vec3(sum);
    return t;
}

void expectVecNear(Vec3 a, Vec3 b, float rel) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], rel * std::abs(b[c]) + 1e-9f) << "channel " << c;
}

TEST(PhotonTracer, PointLightStoresExactlyFourPiIntensity) {
    Scene s = shellScene();
    Light l;
    l.type = LightType::Point;
    l.position = Vec3(0.1f, -0.2f, 0.3f);
    l.intensity = Vec3(2.0f, 1.0f, 0.5f);
    s.lights.push_back(l);
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 1u);
    expectVecNear(em[0].flux, 4.0f * kPi * l.intensity, 1e-6f);
    const Traced t = traceAll(es, em[0], 5000);
    EXPECT_EQ(t.out.photons.size(), 5000u);
    EXPECT_EQ(t.out.stats.anomalies, 0u);
    expectVecNear(t.power, 4.0f * kPi * l.intensity, 1e-4f);
}

TEST(PhotonTracer, SpotFluxIsTheIntegralOfTheGltfFalloff) {
    Light l;
    l.type = LightType::Spot;
    l.innerConeAngle = 0.3f;
    l.outerConeAngle = 0.7f;
    // Midpoint rule over cosθ of 2π ∫ a(cosθ) dcosθ.
    double sum = 0.0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        const double c = -1.0 + 2.0 * (i + 0.5) / n;
        sum += spotFalloff(l, static_cast<float>(c)) * (2.0 / n);
    }
    EXPECT_NEAR(spotSolidAngle(l), 2.0 * std::numbers::pi * sum, 1e-4);
    EXPECT_FLOAT_EQ(spotFalloff(l, std::cos(0.2f)), 1.0f);
    EXPECT_FLOAT_EQ(spotFalloff(l, std::cos(0.8f)), 0.0f);
    // Degenerate cone (inner = outer): glTF's 0.001 floor keeps it finite and exact.
    l.innerConeAngle = l.outerConeAngle;
    EXPECT_GT(spotSolidAngle(l), 0.0f);
    EXPECT_TRUE(std::isfinite(spotSolidAngle(l)));
}

TEST(PhotonTracer, SpotLightStoresItsFluxWithTheFalloffProfile) {
    Scene s = shellScene();
    Light l;
    l.type = LightType::Spot;
    l.position = Vec3(0.0f);
    l.direction = Vec3(0.0f, 0.0f, 1.0f);
    l.intensity = Vec3(3.0f);
    l.innerConeAngle = 0.2f;
    l.outerConeAngle = 0.6f;
    s.lights.push_back(l);
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 1u);
    const Traced t = traceAll(es, em[0], 20000);
    expectVecNear(t.power, spotSolidAngle(l) * l.intensity, 1e-4f);
    // Power per angular band equals I ∫_band falloff dω (QMC: well within 2 % per band).
    const int bands = 6;
    std::vector<double> measured(bands, 0.0), expected(bands, 0.0);
    const double cosO = std::cos(0.6);
    for (const TracedPhoton& p : t.out.photons) {
        const double c = glm::dot(glm::normalize(p.position - l.position), l.direction);
        ASSERT_GE(c, cosO - 1e-4);
        const int b = std::min(bands - 1, static_cast<int>((c - cosO) / (1.0 - cosO) * bands));
        measured[static_cast<size_t>(b)] += p.power.x;
    }
    for (int b = 0; b < bands; ++b) {
        const int steps = 2000;
        for (int i = 0; i < steps; ++i) {
            const double c = cosO + (1.0 - cosO) * (b + (i + 0.5) / steps) / bands;
            expected[static_cast<size_t>(b)] += 2.0 * std::numbers::pi * 3.0 *
                                                spotFalloff(l, static_cast<float>(c)) *
                                                (1.0 - cosO) / bands / steps;
        }
        EXPECT_NEAR(measured[static_cast<size_t>(b)], expected[static_cast<size_t>(b)],
                    0.02 * expected[static_cast<size_t>(b)] + 1e-6)
            << "band " << b;
    }
}

TEST(PhotonTracer, AreaLightStoresPiRadianceAreaCosineDistributed) {
    Scene s = shellScene();
    const Vec3 radiance(1.5f, 1.0f, 0.25f);
    const uint32_t lamp = addMaterial(s, MaterialType::Diffuse, Vec3(0.0f), 1.5f, Vec3(0.0f), radiance);
    addQuadY(s, lamp, 0.0f, -0.5f, 0.5f, -0.25f, 0.25f, +1.0f);  // area 0.5 m², facing +y
    addQuadY(s, lamp, -0.2f, -0.1f, 0.1f, -0.1f, 0.1f, +1.0f);   // area 0.04 m², same radiance
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 1u);  // one group: equal radiance
    EXPECT_EQ(em[0].triangles.size(), 4u);
    const Vec3 flux = kPi * radiance * 0.54f;
    expectVecNear(em[0].flux, flux, 1e-5f);
    // A second radiance makes a second group.
    s.materials[lamp].emission = radiance * 2.0f;
    const uint32_t lamp2nd = addMaterial(s, MaterialType::Diffuse, Vec3(0.0f), 1.5f, Vec3(0.0f), radiance);
    addQuadY(s, lamp2nd, -0.5f, -0.1f, 0.1f, -0.1f, 0.1f, +1.0f);
    EmbreeScene esTwo(s);
    EXPECT_EQ(buildEmitters(esTwo).size(), 2u);

    // Power and direction distribution with one quad.
    Scene s2 = shellScene();
    const uint32_t lamp2 = addMaterial(s2, MaterialType::Diffuse, Vec3(0.0f), 1.5f, Vec3(0.0f), radiance);
    addQuadY(s2, lamp2, 0.0f, -0.5f, 0.5f, -0.25f, 0.25f, +1.0f);
    EmbreeScene es2(s2);
    const std::vector<Emitter> em2 = buildEmitters(es2);
    ASSERT_EQ(em2.size(), 1u);
    const Traced t2 = traceAll(es2, em2[0], 20000);
    expectVecNear(t2.power, kPi * radiance * 0.5f, 1e-4f);
    // Cosine distribution: mean cosθ of the emitted directions is 2/3.
    double meanCos = 0.0;
    for (const TracedPhoton& p : t2.out.photons) meanCos += p.incoming.y;
    meanCos /= static_cast<double>(t2.out.photons.size());
    EXPECT_NEAR(meanCos, 2.0 / 3.0, 2e-3);
}

// Diffuse plane y = 0 with an index-1 slab above it covering it exactly.
Scene slabScene(float ior, Vec3 absorption, float thickness, MaterialType slabType = MaterialType::Dielectric,
                Vec3 slabColor = Vec3(1.0f)) {
    Scene s;
    const uint32_t floor = addMaterial(s, MaterialType::Diffuse, Vec3(0.5f));
    const uint32_t slab = addMaterial(s, slabType, slabColor, ior, absorption);
    addQuadY(s, floor, 0.0f, -2.0f, 2.0f, -2.0f, 2.0f, +1.0f);
    addBox(s, slab, Vec3(-2.0f, 1.0f, -2.0f), Vec3(2.0f, 1.0f + thickness, 2.0f));
    return s;
}

Light sun(Vec3 irradiance) {
    Light l;
    l.type = LightType::Directional;
    l.direction = Vec3(0.0f, -1.0f, 0.0f);
    l.intensity = irradiance;
    return l;
}

TEST(PhotonTracer, DirectionalLightFluxCoversTheBoundingSphereDisc) {
    Scene s = slabScene(1.0f, Vec3(0.0f), 0.5f);
    s.lights.push_back(sun(Vec3(2.0f)));
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 1u);
    const float r = 0.5f * es.bounds().diagonal();
    expectVecNear(em[0].flux, Vec3(2.0f) * kPi * r * r, 1e-6f);
    // Every photon through the slab lands on the 4 × 4 m floor: E · 16 m².
    const Traced t = traceAll(es, em[0], 40000);
    expectVecNear(t.power, Vec3(2.0f * 16.0f), 0.01f);
}

TEST(PhotonTracer, BeerLambertAttenuatesInsideTheMedium) {
    const Vec3 sigma(0.0f, 1.0f, 3.0f);
    Scene s = slabScene(1.0f, sigma, 0.5f);
    s.lights.push_back(sun(Vec3(1.0f)));
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    const Traced t = traceAll(es, em[0], 40000);
    const Vec3 expected = 16.0f * Vec3(1.0f, std::exp(-0.5f), std::exp(-1.5f));
    expectVecNear(t.power, expected, 0.01f);
}

TEST(PhotonTracer, FresnelSplitsAtGlassAsTheSeriesOfInternalReflections) {
    // Normal incidence on an n = 1.5 slab: R = 0.04 per face; all orders of internal reflection
    // transmit (1 − R)/(1 + R). Fresnel choices are random: 40 000 paths give σ ≈ 0.0013, bound 5σ.
    // This checks the Fresnel split; the orders themselves add only 0.16 % here, so
    // InternalReflectionsAddUpInAHighIndexSlab checks them where they differ.
    Scene s = slabScene(1.5f, Vec3(0.0f), 0.5f);
    s.lights.push_back(sun(Vec3(1.0f)));
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    const Traced t = traceAll(es, em[0], 40000);
    const float transmit = 0.96f / 1.04f;
    EXPECT_NEAR(t.power.x / 16.0f, transmit, 0.007f);
}

TEST(PhotonTracer, InternalReflectionsAddUpInAHighIndexSlab) {
    // At n = 1.5 the orders of internal reflection add 0.16 % (under the tolerance above), so that
    // test cannot tell them from a tracer that drops them. At n = 3, R = ((n−1)/(n+1))² = 0.25 per
    // face: all orders transmit (1 − R)/(1 + R) = 0.6, the direct pass alone (1 − R)² = 0.5625.
    // Landing is a Bernoulli(0.6) per path: 40 000 paths give σ ≈ 0.0025, bound 4σ = 0.01, and the
    // two values differ by 15σ.
    Scene s = slabScene(3.0f, Vec3(0.0f), 0.5f);
    s.lights.push_back(sun(Vec3(1.0f)));
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    const float r = 0.25f;
    const Traced all = traceAll(es, em[0], 40000);
    EXPECT_NEAR(all.power.x / 16.0f, (1.0f - r) / (1.0f + r), 0.01f);
    // The same paths cut after three segments (sun → top, top → bottom, bottom → floor) keep the
    // direct pass only: what a tracer without internal reflection would give, 15σ away.
    const Traced direct = traceAll(es, em[0], 40000, 0, 0, 3);
    EXPECT_NEAR(direct.power.x / 16.0f, (1.0f - r) * (1.0f - r), 0.01f);
    EXPECT_GT(std::abs(all.power.x - direct.power.x) / 16.0f, 0.03f);
}

TEST(PhotonTracer, MirrorMultipliesByReflectance) {
    // A mirror tilted 45° sends the sun's photons sideways onto a wall.
    Scene s;
    const uint32_t wall = addMaterial(s, MaterialType::Diffuse, Vec3(0.5f));
    const uint32_t mirror = addMaterial(s, MaterialType::Mirror, Vec3(0.9f, 0.5f, 0.1f));
    Mesh m;
    m.positions = {{-1, -1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, -1, 1}};
    m.indices = {0, 1, 2, 0, 2, 3};
    m.material = mirror;
    addMesh(s, m);
    Mesh w;  // wall x = −3 facing +x, large
    w.positions = {{-3, -10, -10}, {-3, 10, -10}, {-3, 10, 10}, {-3, -10, 10}};
    w.indices = {0, 2, 1, 0, 3, 2};
    w.material = wall;
    addMesh(s, w);
    s.lights.push_back(sun(Vec3(1.0f)));
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    const Traced t = traceAll(es, em[0], 40000);
    // Mirror's projection onto the horizontal plane: 2 × 2 m.
    expectVecNear(t.power, 4.0f * Vec3(0.9f, 0.5f, 0.1f), 0.01f);
    for (const TracedPhoton& p : t.out.photons) {
        EXPECT_NEAR(p.position.x, -3.0f, 1e-3f);
        EXPECT_NEAR(p.incoming.x, -1.0f, 1e-4f);
    }
}

// A plastic tilted 45° in the sun throws a reflected caustic onto a diffuse wall (the mirror test's
// geometry, in a scene small enough that an eighth of the sun's photons hit the plastic): the wall
// receives the coat's share of the 4 W falling on it, F(cos 45°) = 0.0502 of index 1.5 for a
// smooth coat (the lobe is chosen with that probability and keeps the power), the coat's albedo
// E(0.3, cos 45°) less what passes the wall for a rough one, and the metal lobe's Schlick share on
// top for metallic 0.5. The base has no bounce here, so it stores nothing. Tolerances: 3σ of the
// coat's binary choices (about 5000 reflected photons of 100 000 on the plastic: 4 %).
TEST(PhotonTracer, PlasticCoatThrowsItsFresnelShare) {
    auto traceWith = [](float roughness, float metallic) {
        Scene s;
        const uint32_t wall = addMaterial(s, MaterialType::Diffuse, Vec3(0.5f));
        const uint32_t coat = addMaterial(s, MaterialType::Plastic, Vec3(0.9f, 0.5f, 0.1f));
        s.materials[coat].roughness = roughness;
        s.materials[coat].metallic = metallic;
        Mesh m;
        m.positions = {{-1, -1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, -1, 1}};
        m.indices = {0, 1, 2, 0, 2, 3};
        m.material = coat;
        addMesh(s, m);
        Mesh w;  // wall x = −2 facing +x
        w.positions = {{-2, -2, -2}, {-2, 2, -2}, {-2, 2, 2}, {-2, -2, 2}};
        w.indices = {0, 2, 1, 0, 3, 2};
        w.material = wall;
        addMesh(s, w);
        s.lights.push_back(sun(Vec3(1.0f)));
        EmbreeScene es(s);
        const std::vector<Emitter> em = buildEmitters(es);
        return traceAll(es, em[0], 800000).power;
    };
    const float c = std::sqrt(0.5f);
    const float f = fresnelDielectric(c, 1.0f, 1.5f);
    expectVecNear(traceWith(0.0f, 0.0f), Vec3(4.0f * f), 0.04f);
    const Vec3 rough = traceWith(0.3f, 0.0f);
    std::printf("rough coat: %.4f W on the wall of %.4f W its albedo reflects\n", rough.x, 4.0f * coatAlbedo(0.3f, c));
    EXPECT_LE(rough.x, 4.0f * coatAlbedo(0.3f, c) * 1.04f);
    EXPECT_GE(rough.x, 4.0f * coatAlbedo(0.3f, c) * 0.85f);
    const Vec3 schlick = Vec3(0.9f, 0.5f, 0.1f) + (Vec3(1.0f) - Vec3(0.9f, 0.5f, 0.1f)) * std::pow(1.0f - c, 5.0f);
    expectVecNear(traceWith(0.0f, 0.5f), 4.0f * (0.5f * Vec3(f) + 0.5f * schlick), 0.02f);
}

TEST(PhotonTracer, DiffuseOnlyPathsStoreNothingWithoutBounces) {
    Scene s = slabScene(1.0f, Vec3(0.0f), 0.5f);
    s.instances.pop_back();  // no slab: the sun lights the floor directly
    s.lights.push_back(sun(Vec3(1.0f)));
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    const Traced t = traceAll(es, em[0], 5000, 0);
    EXPECT_TRUE(t.out.photons.empty());
    EXPECT_EQ(t.out.stats.productivePaths, 0u);
}

TEST(PhotonTracer, OneDiffuseBounceGivesIndirectCausticsOnly) {
    // Sun → floor (diffuse) → mirror ceiling → floor: L D S D. With 0 bounces nothing is stored.
    Scene s;
    const uint32_t floor = addMaterial(s, MaterialType::Diffuse, Vec3(0.5f));
    const uint32_t mirror = addMaterial(s, MaterialType::Mirror, Vec3(1.0f));
    addQuadY(s, floor, 0.0f, -2.0f, 2.0f, -2.0f, 2.0f, +1.0f);
    addQuadY(s, mirror, 1.0f, -0.5f, 0.5f, -0.5f, 0.5f, -1.0f);
    Light l;
    l.type = LightType::Point;
    l.position = Vec3(0.0f, 0.5f, 0.0f);
    l.intensity = Vec3(1.0f);
    s.lights.push_back(l);
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    const Traced direct = traceAll(es, em[0], 20000, 0);
    const Traced indirect = traceAll(es, em[0], 20000, 1);
    EXPECT_GT(direct.out.photons.size(), 0u);  // L S D
    EXPECT_GT(indirect.out.photons.size(), direct.out.photons.size());
    for (const TracedPhoton& p : indirect.out.photons) {
        EXPECT_NEAR(p.position.y, 0.0f, 1e-4f);
        EXPECT_LT(p.incoming.y, 0.0f);  // arrived from above, i.e. from the mirror
    }
}

TEST(PhotonTracer, ResultDoesNotDependOnThreadCount) {
    Scene s = slabScene(1.5f, Vec3(0.2f), 0.5f);
    Light l;
    l.type = LightType::Point;
    l.position = Vec3(0.3f, 3.0f, 0.1f);
    l.intensity = Vec3(1.0f);
    s.lights.push_back(l);
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    Traced many = traceAll(es, em[0], 3000, 1);
    Traced one;
    {
        tbb::global_control only(tbb::global_control::max_allowed_parallelism, 1);
        one = traceAll(es, em[0], 3000, 1);
    }
    ASSERT_EQ(many.out.photons.size(), one.out.photons.size());
    for (size_t i = 0; i < one.out.photons.size(); ++i) {
        EXPECT_EQ(many.out.photons[i].position, one.out.photons[i].position);
        EXPECT_EQ(many.out.photons[i].power, one.out.photons[i].power);
    }
    EXPECT_EQ(many.out.storedPerPath, one.out.storedPerPath);
}

TEST(PhotonTracer, SplitBudgetIsProportionalAndExact) {
    std::vector<Emitter> em(3);
    em[0].flux = Vec3(1.0f);
    em[1].flux = Vec3(2.0f);
    em[2].flux = Vec3(1e-9f);
    const std::vector<uint32_t> b = splitBudget(em, 1000);
    EXPECT_EQ(b[0] + b[1] + b[2], 1000u);
    EXPECT_GE(b[2], 1u);  // a dim light still gets a path, or its flux would vanish
    EXPECT_NEAR(static_cast<double>(b[1]) / b[0], 2.0, 0.02);
}

TEST(PhotonTracer, DegenerateTrianglesAndZeroLightsGiveNoNaN) {
    Scene s = slabScene(1.5f, Vec3(0.0f), 0.5f);
    const uint32_t lamp = addMaterial(s, MaterialType::Diffuse, Vec3(0.5f), 1.5f, Vec3(0.0f), Vec3(3.0f));
    Mesh d;  // collinear and coincident vertices, emissive: zero area, must be skipped
    d.positions = {{0, 3, 0}, {1, 3, 0}, {2, 3, 0}, {0, 3, 0}};
    d.indices = {0, 1, 2, 0, 0, 3};
    d.material = lamp;
    addMesh(s, d);
    Mesh m = d;  // the same degenerate mesh as mirror geometry in the photons' way
    m.material = 1;
    addMesh(s, m);
    Light dark;
    dark.type = LightType::Point;
    dark.position = Vec3(0.0f, 2.5f, 0.0f);
    dark.intensity = Vec3(0.0f);
    s.lights.push_back(dark);
    Light spot;
    spot.type = LightType::Spot;
    spot.position = Vec3(0.0f, 2.5f, 0.0f);
    spot.intensity = Vec3(1.0f);
    spot.innerConeAngle = spot.outerConeAngle = 0.5f;
    s.lights.push_back(spot);
    EmbreeScene es(s);
    const std::vector<Emitter> em = buildEmitters(es);
    ASSERT_EQ(em.size(), 1u);  // only the spot: zero light and zero-area emitter are dropped
    EXPECT_EQ(em[0].kind, EmitterKind::Spot);

    PhotonSettings ps;
    ps.photonsPerBatch = 4000;
    ps.diffuseBounces = 2;
    PhotonMaps maps(ps, {0});
    maps.shootBatch(es, 0);
    maps.shootBatch(es, 0);
    EXPECT_EQ(maps.stats(0).anomalies, 0u);
    EXPECT_GT(maps.stats(0).photonsStored, 0u);
    for (const Photon& p : maps.index<KdTree>(0)->photons()) {
        const Vec3 pw = p.powerRgb();
        EXPECT_TRUE(std::isfinite(pw.x) && std::isfinite(pw.y) && std::isfinite(pw.z));
    }
    SurfaceHit hit;
    hit.position = Vec3(0.0f, 0.0f, 0.0f);
    const Vec3 L = maps.radiance(es, 0, hit, Vec3(0, 1, 0), Vec3(0.5f));
    EXPECT_TRUE(std::isfinite(L.x) && std::isfinite(L.y) && std::isfinite(L.z));
    EXPECT_EQ(maps.radiance(es, 7, hit, Vec3(0, 1, 0), Vec3(0.5f)), Vec3(0.0f));  // not owned

    // A scene without any light: batches are empty and the maps go straight to walkthrough.
    Scene empty = slabScene(1.5f, Vec3(0.0f), 0.5f);
    EmbreeScene ee(empty);
    PhotonMaps none(ps, {0, 1});
    none.shootBatch(ee, 0);
    none.shootBatch(ee, 1);
    EXPECT_TRUE(none.walkthrough());
    EXPECT_EQ(none.radiance(ee, 0, hit, Vec3(0, 1, 0), Vec3(0.5f)), Vec3(0.0f));
}

TEST(PhotonMaps, BatchesAdvanceTheSequenceAndResetRestartsIt) {
    Scene s = slabScene(1.5f, Vec3(0.0f), 0.5f);
    Light l;
    l.type = LightType::Point;
    l.position = Vec3(0.3f, 3.0f, 0.1f);
    l.intensity = Vec3(1.0f);
    s.lights.push_back(l);
    EmbreeScene es(s);
    for (bool selective : {false, true}) {
        PhotonSettings ps;
        ps.photonsPerBatch = 3000;
        ps.selective = selective;
        ps.diffuseBounces = 0;
        ps.capPhotons = 0;
        PhotonMaps maps(ps, {0, 1});
        maps.shootBatch(es, 0);
        const size_t first = maps.index<KdTree>(0)->size();
        maps.shootBatch(es, 0);
        const KdTree& t = *maps.index<KdTree>(0);
        ASSERT_GT(first, 0u);
        // No photon of batch 2 duplicates one of batch 1 (the indices advanced).
        size_t duplicates = 0;
        std::vector<Vec3> pos;
        for (const Photon& p : t.photons()) pos.push_back(p.position);
        std::sort(pos.begin(), pos.end(), [](Vec3 a, Vec3 b) {
            return a.x != b.x ? a.x < b.x : a.z != b.z ? a.z < b.z : a.y < b.y;
        });
        for (size_t i = 1; i < pos.size(); ++i) duplicates += pos[i] == pos[i - 1];
        EXPECT_EQ(duplicates, 0u) << "selective " << selective;
        EXPECT_EQ(maps.stats(0).batches, 2u);
        // Sets draw different photons.
        maps.shootBatch(es, 1);
        EXPECT_NE(maps.index<KdTree>(1)->photons()[0].position, t.photons()[0].position);
        maps.reset();
        EXPECT_EQ(maps.index<KdTree>(0), nullptr);
        maps.shootBatch(es, 0);
        EXPECT_EQ(maps.index<KdTree>(0)->size(), first);
        EXPECT_EQ(maps.stats(0).batches, 1u);
    }
}

TEST(PhotonMaps, CapSwitchesToWalkthrough) {
    Scene s = slabScene(1.5f, Vec3(0.0f), 0.5f);
    s.lights.push_back(sun(Vec3(1.0f)));
    EmbreeScene es(s);
    PhotonSettings ps;
    ps.photonsPerBatch = 2000;
    ps.capPhotons = 3000;
    PhotonMaps maps(ps, {0});
    int batches = 0;
    while (!maps.walkthrough() && batches < 100) {
        maps.shootBatch(es, 0);
        ++batches;
    }
    EXPECT_TRUE(maps.walkthrough());
    EXPECT_GE(maps.stats(0).photonsStored, 3000u);
    const size_t size = maps.index<KdTree>(0)->size();
    maps.shootBatch(es, 0);  // no-op in walkthrough
    EXPECT_EQ(maps.index<KdTree>(0)->size(), size);
}

}  // namespace
}  // namespace rtpm
