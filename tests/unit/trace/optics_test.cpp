// Tests of the smooth-surface optics against closed-form Fresnel and Snell values.
#include "common/trace/optics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rtpm {
namespace {

TEST(Optics, FresnelNormalIncidenceMatchesClosedForm) {
    for (float n2 : {1.33f, 1.5f, 2.42f}) {
        const float expected = ((1.0f - n2) / (1.0f + n2)) * ((1.0f - n2) / (1.0f + n2));
        EXPECT_NEAR(fresnelDielectric(1.0f, 1.0f, n2), expected, 1e-6f);
        EXPECT_NEAR(fresnelDielectric(1.0f, n2, 1.0f), expected, 1e-6f);  // same from inside
    }
    EXPECT_NEAR(fresnelDielectric(1.0f, 1.0f, 1.5f), 0.04f, 1e-6f);
    EXPECT_NEAR(fresnelDielectric(0.7f, 1.5f, 1.5f), 0.0f, 1e-7f);  // index-matched: invisible
}

TEST(Optics, FresnelAtBrewsterAngleHasNoPPolarisedPart) {
    // At Brewster's angle Rp = 0 and θi + θt = 90°, so Rs = −sin(θi − θt) and R = Rs²/2.
    const float n = 1.5f;
    const double thetaB = std::atan(double(n));
    const double thetaT = M_PI / 2 - thetaB;
    const double expected = 0.5 * std::pow(std::sin(thetaB - thetaT), 2.0);
    EXPECT_NEAR(fresnelDielectric(float(std::cos(thetaB)), 1.0f, n), expected, 1e-6);
}

TEST(Optics, FresnelGrazingIncidenceReflectsEverything) {
    EXPECT_NEAR(fresnelDielectric(0.0f, 1.0f, 1.5f), 1.0f, 1e-6f);
    EXPECT_GT(fresnelDielectric(0.01f, 1.0f, 1.5f), 0.9f);
    // Unpolarized external reflectance grows monotonically from normal to grazing incidence.
    float previous = 0.0f;
    for (int k = 100; k >= 0; --k) {
        const float r = fresnelDielectric(float(k) / 100.0f, 1.0f, 1.5f);
        EXPECT_GE(r, previous - 1e-6f);
        previous = r;
    }
}

TEST(Optics, FresnelTotalInternalReflectionBeyondCriticalAngle) {
    const float n = 1.5f;
    const float thetaC = std::asin(1.0f / n);
    EXPECT_EQ(fresnelDielectric(std::cos(thetaC + 0.01f), n, 1.0f), 1.0f);
    EXPECT_EQ(fresnelDielectric(std::cos(1.2f), n, 1.0f), 1.0f);
    EXPECT_LT(fresnelDielectric(std::cos(thetaC - 0.01f), n, 1.0f), 1.0f);
    Vec3 t;
    const Vec3 nrm(0, 0, 1);
    const Vec3 beyond(std::sin(thetaC + 0.01f), 0.0f, -std::cos(thetaC + 0.01f));
    EXPECT_FALSE(refract(beyond, nrm, n, t));
    const Vec3 within(std::sin(thetaC - 0.01f), 0.0f, -std::cos(thetaC - 0.01f));
    EXPECT_TRUE(refract(within, nrm, n, t));
}

TEST(Optics, FresnelIsReciprocal) {
    // R(θi; n1 → n2) = R(θt; n2 → n1): the same interface seen from both sides.
    for (float thetaI = 0.0f; thetaI < 1.5f; thetaI += 0.1f) {
        const float n1 = 1.0f, n2 = 1.5f;
        const float thetaT = std::asin(n1 / n2 * std::sin(thetaI));
        EXPECT_NEAR(fresnelDielectric(std::cos(thetaI), n1, n2),
                    fresnelDielectric(std::cos(thetaT), n2, n1), 2e-6f);
        // A negative cosine means the other side: the indices are swapped.
        EXPECT_NEAR(fresnelDielectric(-std::cos(thetaT), n1, n2),
                    fresnelDielectric(std::cos(thetaT), n2, n1), 1e-7f);
    }
}

TEST(Optics, RefractObeysSnellAndCrossesTheSurface) {
    const Vec3 n(0, 1, 0);
    for (float thetaI = 0.0f; thetaI < 1.5f; thetaI += 0.15f) {
        const Vec3 d(std::sin(thetaI), -std::cos(thetaI), 0.0f);
        Vec3 t;
        ASSERT_TRUE(refract(d, n, 1.0f / 1.5f, t));
        EXPECT_NEAR(glm::length(t), 1.0f, 1e-6f);
        EXPECT_LT(glm::dot(t, n), 0.0f);
        EXPECT_NEAR(1.0f * std::sin(thetaI), 1.5f * t.x, 1e-6f);  // Snell, tangential component
        EXPECT_NEAR(t.z, 0.0f, 1e-7f);                         // stays in the plane of incidence
    }
}

TEST(Optics, ReflectMirrorsAboutNormal) {
    const Vec3 d = glm::normalize(Vec3(1.0f, -2.0f, 0.5f));
    const Vec3 r = reflect(d, Vec3(0, 1, 0));
    EXPECT_NEAR(r.x, d.x, 1e-7f);
    EXPECT_NEAR(r.y, -d.y, 1e-7f);
    EXPECT_NEAR(r.z, d.z, 1e-7f);
    const Vec3 r2 = reflect(d, Vec3(0, -1, 0));  // the normal's side does not matter
    EXPECT_NEAR(glm::length(r - r2), 0.0f, 1e-7f);
}

TEST(Optics, BeerLambertIsExponentialInDistance) {
    const Vec3 sigma(0.0f, 1.0f, 10.0f);
    const Vec3 t = beerLambert(sigma, 0.3f);
    EXPECT_EQ(t.x, 1.0f);
    EXPECT_NEAR(t.y, std::exp(-0.3f), 1e-7f);
    EXPECT_NEAR(t.z, std::exp(-3.0f), 1e-7f);
    // Two halves compose to the whole.
    const Vec3 h = beerLambert(sigma, 0.15f);
    EXPECT_NEAR(h.z * h.z, t.z, 1e-7f);
    EXPECT_EQ(beerLambert(sigma, 0.0f), Vec3(1.0f));
}

TEST(Optics, DielectricInterfaceClassifiesSides) {
    const Vec3 n(0, 0, 1);
    const auto in = dielectricInterface(glm::normalize(Vec3(0.3f, 0, -1)), n, 1.5f);
    EXPECT_TRUE(in.entering);
    EXPECT_EQ(in.etaI, 1.0f);
    EXPECT_EQ(in.etaT, 1.5f);
    EXPECT_EQ(in.normal, n);
    const auto out = dielectricInterface(glm::normalize(Vec3(0.3f, 0, 1)), n, 1.5f);
    EXPECT_FALSE(out.entering);
    EXPECT_EQ(out.etaI, 1.5f);
    EXPECT_EQ(out.normal, -n);
    EXPECT_NEAR(out.cosI, 1.0f / std::sqrt(1.09f), 1e-6f);
}

}  // namespace
}  // namespace rtpm
