// Tests of the photon encodings: RGB9E5 power and octahedral direction round trips and edge cases.
#include "common/photon/photon.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace rtpm {
namespace {

constexpr float kMaxRgb9e5 = 2044.0f;          // 511/512 · 2^(31 - bias 20)
const float kSmallestStep = std::exp2(-29.0f);  // mantissa 1 at biased exponent 0

TEST(Rgb9e5, RoundTripErrorIsBelowHalfAStepOfTheSharedExponent) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> logScale(-32.0f, 10.9f);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int i = 0; i < 20000; ++i) {
        const float s = std::exp2(logScale(rng));
        const Vec3 rgb(unit(rng) * s, unit(rng) * s, unit(rng) * s);
        const Vec3 back = decodeRgb9e5(encodeRgb9e5(rgb));
        const float maxc = std::max({rgb.x, rgb.y, rgb.z});
        // The step of the shared exponent is at most 2^-8 · maxc (never below the smallest
        // step); rounding costs half of it.
        const float bound = std::max(maxc * std::exp2(-9.0f) * 1.0001f, 0.5f * kSmallestStep);
        for (int c = 0; c < 3; ++c) ASSERT_LE(std::abs(back[c] - rgb[c]), bound) << i;
        ASSERT_GE(back.x, 0.0f);
    }
}

TEST(Rgb9e5, LargestChannelHasRelativeErrorBelowTwoToMinusNineInTheNormalRange) {
    for (float v = std::exp2(-20.0f); v < kMaxRgb9e5; v *= 1.013f) {
        const float back = decodeRgb9e5(encodeRgb9e5(Vec3(v, 0.0f, v * 0.5f))).x;
        ASSERT_LE(std::abs(back - v), v * std::exp2(-9.0f) * 1.0001f) << v;
    }
}

TEST(Rgb9e5, ZeroEncodesToZero) {
    EXPECT_EQ(encodeRgb9e5(Vec3(0.0f)), 0u);
    EXPECT_EQ(decodeRgb9e5(0u), Vec3(0.0f));
}

TEST(Rgb9e5, NaNAndNegativeChannelsBecomeZeroAndOthersSurvive) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const Vec3 back = decodeRgb9e5(encodeRgb9e5(Vec3(nan, 0.75f, -3.0f)));
    EXPECT_EQ(back.x, 0.0f);
    EXPECT_EQ(back.y, 0.75f);
    EXPECT_EQ(back.z, 0.0f);
    EXPECT_EQ(decodeRgb9e5(encodeRgb9e5(Vec3(nan))), Vec3(0.0f));
    EXPECT_EQ(decodeRgb9e5(encodeRgb9e5(Vec3(-1.0f))), Vec3(0.0f));
}

TEST(Rgb9e5, HugeAndInfiniteClampToTheLargestValue) {
    const float inf = std::numeric_limits<float>::infinity();
    EXPECT_EQ(decodeRgb9e5(encodeRgb9e5(Vec3(inf, 1e30f, kMaxRgb9e5))), Vec3(kMaxRgb9e5));
    const Vec3 back = decodeRgb9e5(encodeRgb9e5(Vec3(2047.0f, 0.0f, 0.0f)));
    EXPECT_EQ(back.x, kMaxRgb9e5);
}

TEST(Rgb9e5, SmallestValuesRoundToZeroOrTheSmallestStep) {
    const float step = kSmallestStep;
    EXPECT_EQ(decodeRgb9e5(encodeRgb9e5(Vec3(step))), Vec3(step));
    EXPECT_EQ(decodeRgb9e5(encodeRgb9e5(Vec3(step * 0.4f))), Vec3(0.0f));
}

TEST(Rgb9e5, ExactlyRepresentableValuesRoundTripExactly) {
    for (const Vec3 v : {Vec3(1.0f, 0.5f, 0.25f), Vec3(511.0f, 1.0f, 0.0f), Vec3(std::exp2(-29.0f), 0.0f, 0.0f),
                         Vec3(std::exp2(-10.0f)), Vec3(3.0f, 2.0f, 1.0f)})
        EXPECT_EQ(decodeRgb9e5(encodeRgb9e5(v)), v);
}

float angleDegrees(Vec3 a, Vec3 b) {
    const double d = std::clamp(double(a.x) * b.x + double(a.y) * b.y + double(a.z) * b.z, -1.0, 1.0);
    // acos loses precision near 1: use the cross-product norm for small angles.
    const Vec3 c = glm::cross(a, b);
    return static_cast<float>(std::atan2(std::sqrt(double(glm::dot(c, c))), d) * 180.0 / M_PI);
}

TEST(Octahedral, RoundTripAngleErrorIsBelowOneHundredthOfADegree) {
    std::mt19937 rng(11);
    std::normal_distribution<float> g;
    float worst = 0.0f;
    for (int i = 0; i < 200000; ++i) {
        const Vec3 d = glm::normalize(Vec3(g(rng), g(rng), g(rng)));
        const Vec3 back = decodeOctahedral(encodeOctahedral(d));
        worst = std::max(worst, angleDegrees(d, back));
        ASSERT_NEAR(glm::length(back), 1.0f, 1e-6f);
    }
    EXPECT_LT(worst, 0.01f);
}

TEST(Octahedral, AxesAndHemisphereFoldRoundTrip) {
    for (const Vec3 d : {Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0),
                         Vec3(0, 0, 1), Vec3(0, 0, -1), glm::normalize(Vec3(1, 1, -1)),
                         glm::normalize(Vec3(-1, -1, -1)), glm::normalize(Vec3(1, -1, -1e-7f))})
        EXPECT_LT(angleDegrees(d, decodeOctahedral(encodeOctahedral(d))), 0.01f) << d.x << d.y << d.z;
}

TEST(Octahedral, ZeroAndNaNDirectionsDecodeToAUnitVector) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (const Vec3 d : {Vec3(0.0f), Vec3(nan, 0.0f, 1.0f), Vec3(std::numeric_limits<float>::infinity())}) {
        const Vec3 back = decodeOctahedral(encodeOctahedral(d));
        EXPECT_NEAR(glm::length(back), 1.0f, 1e-6f);
        EXPECT_EQ(back, Vec3(0.0f, 0.0f, 1.0f));
    }
}

TEST(Photon, MakeStoresPositionAndDecodesPowerAndDirection) {
    const Photon p = Photon::make(Vec3(1, 2, 3), Vec3(0.5f, 0.25f, 0.125f), Vec3(0, 0, -1));
    EXPECT_EQ(p.position, Vec3(1, 2, 3));
    EXPECT_EQ(p.powerRgb(), Vec3(0.5f, 0.25f, 0.125f));
    EXPECT_LT(angleDegrees(p.incomingDir(), Vec3(0, 0, -1)), 0.01f);
}

}  // namespace
}  // namespace rtpm
