// Tests of the caustic density estimate against analytic irradiance and its edge-case guards.
#include "common/photon/density.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "common/photon/median_kd_tree.h"
#include "common/photon/photon_grid.h"

namespace rtpm {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
const Vec3 kUp(0, 0, 1);
const Vec3 kDown(0, 0, -1);  // direction of travel of a photon landing on an up-facing floor
// Exactly representable in RGB9E5, so the stored flux is exact and only geometry is tested.
const Vec3 kPhotonPower = Vec3(1.0f, 0.5f, 0.25f) * std::exp2(-10.0f);

// N photons spread uniformly over a disc of radius R in the plane z = 0 by a sunflower
// (Vogel) pattern: deterministic, and the count inside any radius r around the centre is
// N r²/R² ± 1, so the kNN estimate has no sampling noise to speak of.
std::vector<Photon> sunflowerDisc(uint32_t n, float radius, Vec3 dir = kDown) {
    const float golden = kPi * (3.0f - std::sqrt(5.0f));
    std::vector<Photon> out;
    for (uint32_t i = 0; i < n; ++i) {
        const float r = radius * std::sqrt((static_cast<float>(i) + 0.5f) / static_cast<float>(n));
        const float phi = golden * static_cast<float>(i);
        out.push_back(Photon::make(Vec3(r * std::cos(phi), r * std::sin(phi), 0.0f), kPhotonPower, dir));
    }
    return out;
}

const Bounds kBox{Vec3(-2, -2, -1), Vec3(2, 2, 1)};

TEST(Density, UniformDiscGivesTheAnalyticRadiance) {
    const uint32_t n = 100000;
    const float radius = 1.0f;
    const auto photons = sunflowerDisc(n, radius);
    KdTree tree(kBox);
    tree.build(photons);
    const Vec3 albedo(0.8f, 0.6f, 0.4f);
    const float powerScale = 0.5f;
    // E = N Φ_p s / (π R²);  L = ρ/π · E.
    const Vec3 expected = albedo / kPi * (float(n) * kPhotonPower * powerScale / (kPi * radius * radius));
    KnnHeap heap;
    // Away from the rim the k-NN disc is filled uniformly: with k = 200 the count inside r_k is
    // k ± ~1-2 (lattice discrepancy), i.e. ~1 % error; allow 3 %.
    for (const Vec3 x : {Vec3(0.0f), Vec3(0.3f, 0.2f, 0.0f), Vec3(-0.5f, 0.4f, 0.0f), Vec3(0.0f, -0.7f, 0.0f)}) {
        const Vec3 l = causticRadiance(tree, x, kUp, albedo, 200, 0.3f, powerScale, heap);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(l[c], expected[c], 0.03f * expected[c]) << "x = " << x.x << ", " << x.y;
    }
}

TEST(Density, MedianTreeAndGridGiveTheSameEstimateAsTheKdTree) {
    const auto photons = sunflowerDisc(20000, 1.0f);
    KdTree tree(kBox);
    tree.build(photons);
    MedianKdTree median;
    median.build(photons);
    PhotonGrid grid(48);
    grid.build(photons);
    KnnHeap heap;
    for (const Vec3 x : {Vec3(0.0f), Vec3(0.6f, -0.1f, 0.0f), Vec3(0.99f, 0.0f, 0.0f)}) {
        const Vec3 a = causticRadiance(tree, x, kUp, Vec3(1.0f), 64, 0.2f, 1.0f, heap);
        const Vec3 b = causticRadiance(median, x, kUp, Vec3(1.0f), 64, 0.2f, 1.0f, heap);
        const Vec3 c = causticRadiance(grid, x, kUp, Vec3(1.0f), 64, 0.2f, 1.0f, heap);
        // Same k-th distance and the same flux (all photons carry equal power).
        EXPECT_FLOAT_EQ(a.x, b.x);
        EXPECT_FLOAT_EQ(a.x, c.x);
        EXPECT_GT(a.x, 0.0f);
    }
}

TEST(Density, PhotonsFromBehindAreIgnored) {
    const auto front = sunflowerDisc(5000, 1.0f);
    // Photons travelling upward (+z) hit the floor from below: they must not count, even when
    // they lie closer to x than any front photon.
    std::vector<Photon> mixed = front;
    for (const Photon& p : sunflowerDisc(5000, 0.3f, kUp)) mixed.push_back(p);
    KdTree frontOnly(kBox), both(kBox);
    frontOnly.build(front);
    both.build(mixed);
    KnnHeap heap;
    for (const Vec3 x : {Vec3(0.0f), Vec3(0.1f, 0.05f, 0.0f)}) {
        const Vec3 a = causticRadiance(frontOnly, x, kUp, Vec3(1.0f), 50, 0.5f, 1.0f, heap);
        const Vec3 b = causticRadiance(both, x, kUp, Vec3(1.0f), 50, 0.5f, 1.0f, heap);
        EXPECT_FLOAT_EQ(a.x, b.x);
        EXPECT_GT(a.x, 0.0f);
    }
    // Seen from below (normal -z) only the upward photons count.
    const Vec3 below = causticRadiance(both, Vec3(0.0f), kDown, Vec3(1.0f), 50, 0.5f, 1.0f, heap);
    EXPECT_GT(below.x, 0.0f);
    KdTree frontAlone(kBox);
    frontAlone.build(front);
    EXPECT_EQ(causticRadiance(frontAlone, Vec3(0.0f), kDown, Vec3(1.0f), 50, 0.5f, 1.0f, heap),
              Vec3(0.0f));
}

TEST(Density, EmptyMapAndDegenerateArgumentsGiveZero) {
    KdTree tree(kBox);
    KnnHeap heap;
    EXPECT_EQ(causticRadiance(tree, Vec3(0.0f), kUp, Vec3(1.0f), 50, 0.1f, 1.0f, heap), Vec3(0.0f));
    tree.build(sunflowerDisc(100, 1.0f));
    EXPECT_EQ(causticRadiance(tree, Vec3(0.0f), kUp, Vec3(1.0f), 0, 0.1f, 1.0f, heap), Vec3(0.0f));
    EXPECT_EQ(causticRadiance(tree, Vec3(0.0f), kUp, Vec3(1.0f), 5, 0.0f, 1.0f, heap), Vec3(0.0f));
    EXPECT_EQ(causticRadiance(tree, Vec3(0.0f), kUp, Vec3(1.0f), 5, std::nanf(""), 1.0f, heap),
              Vec3(0.0f));
    // Far from every photon: nothing within rMax.
    EXPECT_EQ(causticRadiance(tree, Vec3(1.9f, 1.9f, 0.0f), kUp, Vec3(1.0f), 5, 0.1f, 1.0f, heap),
              Vec3(0.0f));
}

TEST(Density, FewerThanKPhotonsUseTheMaximumRadius) {
    std::vector<Photon> photons = {Photon::make(Vec3(0.01f, 0, 0), kPhotonPower, kDown),
                                   Photon::make(Vec3(0, 0.02f, 0), kPhotonPower, kDown),
                                   Photon::make(Vec3(0.5f, 0, 0), kPhotonPower, kDown)};
    KdTree tree(kBox);
    tree.build(photons);
    KnnHeap heap;
    const float rMax = 0.1f;
    const Vec3 l = causticRadiance(tree, Vec3(0.0f), kUp, Vec3(1.0f), 10, rMax, 2.0f, heap);
    const Vec3 expected = 1.0f / kPi * 2.0f * kPhotonPower * 2.0f / (kPi * rMax * rMax);
    EXPECT_FLOAT_EQ(l.x, expected.x);
    EXPECT_FLOAT_EQ(l.z, expected.z);
}

TEST(Density, CoincidentPhotonsAtTheQueryPointGiveAFiniteValue) {
    std::vector<Photon> photons(64, Photon::make(Vec3(0.25f, 0.25f, 0.0f), kPhotonPower, kDown));
    KdTree tree(kBox);
    tree.build(photons);
    KnnHeap heap;
    const Vec3 l = causticRadiance(tree, Vec3(0.25f, 0.25f, 0.0f), kUp, Vec3(1.0f), 8, 0.1f, 1.0f, heap);
    const float rMin = kMinDensityRadiusRelative * tree.bounds().diagonal();
    const Vec3 expected = 1.0f / kPi * 8.0f * kPhotonPower / (kPi * rMin * rMin);
    for (int c = 0; c < 3; ++c) {
        EXPECT_TRUE(std::isfinite(l[c]));
        EXPECT_NEAR(l[c], expected[c], 1e-5f * expected[c]);
    }
}

TEST(Density, RadianceScalesLinearlyWithPowerScaleAndAlbedo) {
    KdTree tree(kBox);
    tree.build(sunflowerDisc(5000, 1.0f));
    KnnHeap heap;
    const Vec3 a = causticRadiance(tree, Vec3(0.1f), kUp, Vec3(0.5f), 40, 0.3f, 1.0f, heap);
    const Vec3 b = causticRadiance(tree, Vec3(0.1f), kUp, Vec3(1.0f), 40, 0.3f, 3.0f, heap);
    EXPECT_FLOAT_EQ(b.y, 6.0f * a.y);
}

}  // namespace
}  // namespace rtpm
