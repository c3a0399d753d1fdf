// renderSet's sampled dielectric splits (a moving camera's eye paths): unbiased against the
// deterministic splitting, cheaper on nested glass, and independent of the thread count.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <vector>

#include "common/trace/eye_pass.h"
#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

using namespace testscenes;

// Nested dielectrics: a tinted liquid block (η 1.33, absorbing) inside a glass box (η 1.5) on a
// diffuse floor, lit by a point light and a key light, seen from above at an angle.
Scene nestedGlass() {
    Scene s;
    const uint32_t floor = addMaterial(s, MaterialType::Diffuse, Vec3(0.7f, 0.6f, 0.5f));
    addMesh(s, quad(Vec3(0.0f), Vec3(2, 0, 0), Vec3(0, 0, -2), floor));
    const uint32_t glass = addMaterial(s, MaterialType::Dielectric, Vec3(1.0f), 1.5f);
    addMesh(s, box(Vec3(-0.4f, 0.0f, -0.4f), Vec3(0.4f, 0.8f, 0.4f), glass));
    const uint32_t liquid = addMaterial(s, MaterialType::Dielectric, Vec3(1.0f), 1.33f);
    s.materials[liquid].absorption = Vec3(0.2f, 0.8f, 1.6f);
    addMesh(s, box(Vec3(-0.3f, 0.1f, -0.3f), Vec3(0.3f, 0.6f, 0.3f), liquid));
    addPointLight(s, Vec3(0.8f, 2.0f, 0.6f), Vec3(6.0f));
    addPointLight(s, Vec3(-1.5f, 1.0f, 1.5f), Vec3(2.0f, 2.0f, 3.0f));
    s.camera = Camera::lookAt(Vec3(0.9f, 1.6f, 1.8f), Vec3(0.0f, 0.35f, 0.0f), Vec3(0, 1, 0), 0.7f);
    s.validate("nested glass");
    return s;
}

constexpr int kW = 48, kH = 36;

std::vector<PixelRadiance> render(const EmbreeScene& es, uint64_t seed, EyeStats* stats = nullptr) {
    const Interleave pattern{kW, kH, 1};
    std::vector<PixelRadiance> out(size_t(pattern.pixelCount(0)));
    renderSet(es, *es.scene().camera, EyeSettings{}, pattern, 0, nullptr, out, stats, nullptr, seed);
    return out;
}

// Over 400 seeds each pixel's mean is the deterministic image within 4.5 standard errors (the
// per-pixel sample deviation / √400; 4.5 σ keeps the family-wise false-alarm rate below 1e-2
// over 1 728 pixels and three channels by a Šidák bound), and the image's sum within 0.5 %.
TEST(SampledSplits, MeanOverSeedsIsTheDeterministicImage) {
    const Scene scene = nestedGlass();
    const EmbreeScene es(scene);
    EyeStats detStats;
    const std::vector<PixelRadiance> det = render(es, 0, &detStats);
    EXPECT_EQ(detStats.sampledSplits, 0u);
    constexpr int kSeeds = 400;
    std::vector<glm::dvec3> sum(det.size(), glm::dvec3(0.0)), sum2(det.size(), glm::dvec3(0.0));
    EyeStats sampledStats;
    for (int s = 1; s <= kSeeds; ++s) {
        const std::vector<PixelRadiance> img = render(es, uint64_t(s) * 0x9E3779B97F4A7C15ull, &sampledStats);
        for (size_t p = 0; p < img.size(); ++p) {
            const glm::dvec3 v(img[p].direct);
            sum[p] += v;
            sum2[p] += v * v;
        }
    }
    EXPECT_GT(sampledStats.sampledSplits, 0u);
    // Fewer secondary rays per frame than the deterministic tree.
    EXPECT_LT(double(sampledStats.secondaryRays) / kSeeds, 0.8 * double(detStats.secondaryRays));
    double total = 0.0, totalDet = 0.0;
    int sampledPixels = 0;
    for (size_t p = 0; p < det.size(); ++p) {
        const glm::dvec3 mean = sum[p] / double(kSeeds);
        const glm::dvec3 var = glm::max(sum2[p] / double(kSeeds) - mean * mean, glm::dvec3(0.0));
        for (int c = 0; c < 3; ++c) {
            const double se = std::sqrt(var[c] / (kSeeds - 1));
            EXPECT_NEAR(mean[c], double(det[p].direct[c]), 4.5 * se + 1e-6 * std::abs(double(det[p].direct[c])))
                << "pixel " << p << " channel " << c;
            total += mean[c];
            totalDet += double(det[p].direct[c]);
        }
        sampledPixels += var.x > 0.0 ? 1 : 0;
    }
    EXPECT_GT(sampledPixels, 50);
    EXPECT_NEAR(total / totalDet, 1.0, 0.005);
}

// The seed alone decides the numbers: one thread or many give the same bits.
TEST(SampledSplits, ImageDoesNotDependOnTheThreadCount) {
    const Scene scene = nestedGlass();
    const EmbreeScene es(scene);
    const std::vector<PixelRadiance> many = render(es, 12345);
    std::vector<PixelRadiance> one;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        one = render(es, 12345);
    }
    ASSERT_EQ(one.size(), many.size());
    for (size_t p = 0; p < one.size(); ++p)
        for (int c = 0; c < 3; ++c) EXPECT_EQ(one[p].direct[c], many[p].direct[c]) << "pixel " << p;
}

}  // namespace
}  // namespace rtpm
