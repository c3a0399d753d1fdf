// Tests of the plastic BSDF (a Lambertian base under a dielectric coat): the white furnace (energy
// ≤ 1 at every roughness, 1 for a white base), reciprocity, the coat's albedo table against an
// independent quadrature of the coat's own formula, the sampler against the evaluated BRDF, and the
// limits (smooth coat = Fresnel, no coat = Lambertian).
#include "common/trace/plastic_bsdf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "common/core/halton.h"
#include "common/trace/optics.h"

namespace rtpm {
namespace {

Vec3 direction(float cosTheta, float phi) {
    const float s = std::sqrt(std::max(0.0f, 1.0f - cosTheta * cosTheta));
    return Vec3(s * std::cos(phi), s * std::sin(phi), cosTheta);
}

Material plastic(float roughness, float metallic = 0.0f, Vec3 base = Vec3(1.0f), float specular = 1.0f) {
    Material m;
    m.type = MaterialType::Plastic;
    m.roughness = roughness;
    m.metallic = metallic;
    m.baseColor = base;
    m.specular = specular;
    return m;
}

// ∫ g(w) dω over the upper hemisphere, midpoint rule in (θ, φ): fine near the pole, where the
// narrow lobes of small α sit.
template <typename F>
glm::dvec3 integrateHemisphere(F g, int ntheta, int nphi) {
    glm::dvec3 sum(0.0);
    const double dt = 0.5 * M_PI / ntheta, dphi = 2.0 * M_PI / nphi;
    for (int i = 0; i < ntheta; ++i) {
        const double t = (i + 0.5) * dt;
        for (int j = 0; j < nphi; ++j)
            sum += glm::dvec3(g(direction(float(std::cos(t)), float((j + 0.5) * dphi)))) * std::sin(t);
    }
    return sum * dt * dphi;
}

// The coat's albedo by its sampler: the mean of sampleCoat's weights over a stratified grid of
// visible normals (its expectation is ∫ coatEval cos θi dωi, or the Fresnel for a smooth coat).
glm::dvec3 sampledCoatAlbedo(const PlasticBsdf& b, Vec3 wo, int n = 128) {
    glm::dvec3 sum(0.0);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            BsdfSample s;
            if (b.sampleCoat(wo, Vec2((i + 0.5f) / float(n), (j + 0.5f) / float(n)), s)) sum += glm::dvec3(s.weight);
        }
    return sum / double(n * n);
}

// The base's albedo seen from wo (white or coloured `albedo`), by quadrature of diffuseEval.
glm::dvec3 diffuseAlbedo(const PlasticBsdf& b, Vec3 wo, Vec3 albedo) {
    return integrateHemisphere([&](Vec3 wi) { return b.diffuseEval(wo, wi, albedo) * wi.z; }, 256, 8);
}

TEST(PlasticBsdf, WhiteFurnaceIsOneForAWhiteBaseAndAtMostOneForAny) {
    // A white base under a coat: the coat reflects E(μo), the base returns the rest, so the sum is
    // 1 (to the table's and the quadratures' accuracy: 1e-3 smooth, 1e-2 rough). Coloured bases and
    // metallic mixes stay below 1. The base's own albedo is checked against (1 − m)(1 − E(μo)).
    for (float r : {0.0f, 0.005f, 0.02f, 0.1f, 0.3f, 0.6f, 1.0f}) {
        for (float mu : {0.03f, 0.2f, 0.5f, 0.8f, 1.0f}) {
            const Vec3 wo = direction(mu, 0.3f);
            const PlasticBsdf white(plastic(r));
            const double coat = sampledCoatAlbedo(white, wo).x;
            const double base = diffuseAlbedo(white, wo, Vec3(1.0f)).x;
            EXPECT_NEAR(base, 1.0 - coatAlbedo(r, mu), 2e-3) << "roughness " << r << " μ " << mu;
            const double total = coat + base;
            EXPECT_LE(total, r <= kSmoothRoughness ? 1.0 + 2e-3 : 1.0 + 1e-2) << "roughness " << r << " μ " << mu;
            EXPECT_GT(total, r <= kSmoothRoughness ? 1.0 - 2e-3 : 1.0 - 1e-2) << "roughness " << r << " μ " << mu;
            for (const Material& m : {plastic(r, 0.0f, Vec3(0.8f, 0.3f, 0.1f)), plastic(r, 0.5f, Vec3(0.9f)),
                                      plastic(r, 0.9f, Vec3(1.0f)), plastic(r, 0.0f, Vec3(1.0f), 0.5f)}) {
                const PlasticBsdf b(m);
                const glm::dvec3 sum = sampledCoatAlbedo(b, wo) + diffuseAlbedo(b, wo, m.baseColor);
                for (int c = 0; c < 3; ++c)
                    EXPECT_LE(sum[c], 1.0 + 1e-2) << "roughness " << r << " μ " << mu << " metallic " << m.metallic;
            }
        }
    }
}

TEST(PlasticBsdf, CoatAlbedoTableMatchesQuadratureOfTheCoatBrdf) {
    // The table integrates over visible normals; here the coat's BRDF (D, G2, exact Fresnel) is
    // integrated over directions: two routes to E(μ) that share only the formulas' parts.
    // The grid resolves lobes of α ≥ 0.09 (roughness ≥ 0.3; narrower ones need the sampler).
    for (float r : {0.3f, 0.6f, 1.0f}) {
        const PlasticBsdf b(plastic(r));
        for (float mu : {0.1f, 0.5f, 0.9f}) {
            const Vec3 wo = direction(mu, 0.0f);
            const double e = integrateHemisphere([&](Vec3 wi) { return b.coatEval(wo, wi) * wi.z; }, 1024, 1024).x;
            EXPECT_NEAR(coatAlbedo(r, mu), e, 3e-3 + 0.02 * e) << "roughness " << r << " μ " << mu;
        }
    }
    // Smooth: the exact Fresnel reflectance of index 1.5 (F0 = 0.04).
    EXPECT_NEAR(coatAlbedo(0.0f, 1.0f), 0.04f, 1e-6f);
    for (float mu : {0.05f, 0.4f, 0.9f}) EXPECT_EQ(coatAlbedo(0.0f, mu), fresnelDielectric(mu, 1.0f, 1.5f));
    // E_avg of a smooth coat: 2∫F μ dμ ≈ 0.0918 for n = 1.5 (the hemispherical reflectance).
    EXPECT_NEAR(coatAverageAlbedo(0.0f), 0.0918f, 1e-3f);
    // Masking loses energy: a rough coat reflects less than a smooth one at grazing angles.
    EXPECT_LT(coatAlbedo(1.0f, 0.1f), coatAlbedo(0.0f, 0.1f));
}

TEST(PlasticBsdf, BrdfIsReciprocal) {
    for (float r : {0.05f, 0.3f, 0.8f}) {
        const PlasticBsdf b(plastic(r, 0.4f, Vec3(0.7f, 0.2f, 0.1f)));
        for (uint64_t i = 0; i < 200; ++i) {
            const Vec3 wo = direction(0.02f + 0.98f * hashToUnit(hashKeys(7, i, 0)), 6.28f * hashToUnit(hashKeys(7, i, 1)));
            const Vec3 wi = direction(0.02f + 0.98f * hashToUnit(hashKeys(7, i, 2)), 6.28f * hashToUnit(hashKeys(7, i, 3)));
            const Vec3 a = b.coatEval(wo, wi) + b.diffuseEval(wo, wi, Vec3(0.5f));
            const Vec3 c = b.coatEval(wi, wo) + b.diffuseEval(wi, wo, Vec3(0.5f));
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[k], c[k], 1e-4f * std::max(1.0f, a[k])) << "pair " << i;
        }
    }
}

TEST(PlasticBsdf, SampledWeightIsBrdfOverPdf) {
    // f cos θi / pdf of each sampled coat direction equals the sample's weight: the sampler and the
    // BRDF the highlights evaluate are one lobe.
    const PlasticBsdf b(plastic(0.4f, 0.3f, Vec3(0.9f, 0.6f, 0.2f)));
    const Vec3 wo = direction(0.6f, 1.0f);
    int checked = 0;
    for (int i = 0; i < 400; ++i) {
        BsdfSample s;
        if (!b.sampleCoat(wo, Vec2(hashToUnit(hashKeys(9, i, 0)), hashToUnit(hashKeys(9, i, 1))), s)) continue;
        const Vec3 expect = b.coatEval(wo, s.wi) * (s.wi.z / s.pdf);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.weight[c], expect[c], 1e-3f * expect[c] + 1e-6f);
        ++checked;
    }
    EXPECT_GT(checked, 350);
}

TEST(PlasticBsdf, PhotonLobesKeepTheCoatAndBaseShares) {
    // Photons choose metal (m), coat ((1 − m)·s·E) or base (the rest); the coat lobe's weight over
    // its visible normals averages 1, so the expected reflected power is the coat's albedo.
    for (float r : {0.0f, 0.3f}) {
        const PlasticBsdf b(plastic(r, 0.25f, Vec3(0.5f)));
        const float mu = 0.45f;
        const Vec3 wo = direction(mu, 0.0f);
        double mean = 0.0;
        const int n = 128;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                BsdfSample s;
                if (b.sampleDielectricCoat(wo, Vec2((i + 0.5f) / n, (j + 0.5f) / n), s)) mean += s.weight.x;
            }
        EXPECT_NEAR(mean / (n * n), 1.0, 1e-2) << "roughness " << r;
        EXPECT_NEAR(b.coatChance(mu), 0.75f * coatAlbedo(r, mu), 1e-6f);
        EXPECT_NEAR(b.metalChance(), 0.25f, 1e-7f);
    }
}

TEST(PlasticBsdf, WithoutItsCoatThePlasticIsLambertian) {
    const PlasticBsdf b(plastic(0.3f, 0.0f, Vec3(0.6f), 0.0f));
    const Vec3 wo = direction(0.3f, 0.0f), wi = direction(0.8f, 2.0f);
    EXPECT_FLOAT_EQ(b.diffuseEval(wo, wi, Vec3(0.6f)).x, 0.6f / float(M_PI));
    EXPECT_EQ(b.coatEval(wo, wi), Vec3(0.0f));
    EXPECT_EQ(b.coatChance(0.5f), 0.0f);
}

}  // namespace
}  // namespace rtpm
