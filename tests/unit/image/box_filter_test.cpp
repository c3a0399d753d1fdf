// Box filter: the constant-time filter matches the O(F²) reference, borders, degenerate sizes, NaN.
#include "common/image/box_filter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace rtpm {
namespace {

std::vector<float> randomImage(int w, int h, uint32_t seed) {
    std::mt19937 rng(seed);
    // Radiance-like values over four decades, like a caustic buffer.
    std::uniform_real_distribution<float> exponent(-2.0f, 2.0f);
    std::vector<float> img(static_cast<size_t>(w) * h * 3);
    for (float& v : img) v = std::pow(10.0f, exponent(rng));
    return img;
}

void expectNear(const std::vector<float>& a, const std::vector<float>& b, double relTol) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
        const double scale = std::max(std::abs(static_cast<double>(b[i])), 1e-30);
        ASSERT_LE(std::abs(static_cast<double>(a[i]) - b[i]) / scale, relTol) << "at float " << i;
    }
}

TEST(BoxFilter, MatchesNaiveForEveryWidthOneToEightOnOddAndEvenSizes) {
    BoxFilter filter;  // reused across sizes: scratch reuse must not leak state
    const int sizes[][2] = {{1, 1}, {1, 7}, {7, 1}, {2, 3}, {5, 4}, {17, 13}, {32, 9}, {64, 70},
                            {37, 130}};
    uint32_t seed = 1;
    for (auto [w, h] : sizes) {
        for (int f = 1; f <= 8; ++f) {
            auto img = randomImage(w, h, seed++);
            std::vector<float> fast(img.size()), naive(img.size());
            filter.apply(img, w, h, f, fast);
            boxFilterNaive(img, w, h, f, naive);
            SCOPED_TRACE(testing::Message() << w << "x" << h << " F=" << f);
            expectNear(fast, naive, 1e-5);
        }
    }
}

TEST(BoxFilter, WidthOneIsIdentity) {
    auto img = randomImage(13, 11, 7);
    std::vector<float> out(img.size());
    boxFilter(img, 13, 11, 1, out);
    EXPECT_EQ(out, img);
}

TEST(BoxFilter, WindowLargerThanImageAveragesWholeImage) {
    const int w = 5, h = 3;
    auto img = randomImage(w, h, 3);
    double mean[3] = {0, 0, 0};
    for (size_t i = 0; i < img.size(); ++i) mean[i % 3] += img[i];
    std::vector<float> out(img.size());
    boxFilter(img, w, h, 64, out);  // every window, whatever its anchor, covers the image
    for (size_t i = 0; i < out.size(); ++i)
        EXPECT_NEAR(out[i], mean[i % 3] / (w * h), 1e-5 * mean[i % 3] / (w * h));
}

TEST(BoxFilter, ConstantImageStaysConstantIncludingBorders) {
    const int w = 23, h = 17;
    std::vector<float> img(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < img.size(); ++i) img[i] = i % 3 == 0 ? 0.25f : (i % 3 == 1 ? 3.0f : 1e-3f);
    for (int f = 1; f <= 8; ++f) {
        std::vector<float> out(img.size());
        boxFilter(img, w, h, f, out);
        for (size_t i = 0; i < out.size(); ++i) ASSERT_FLOAT_EQ(out[i], img[i]) << "F=" << f;
    }
}

TEST(BoxFilter, EvenWidthAnchorPutsTheExtraPixelRightAndBelow) {
    // A single bright pixel at (2, 2) of a 6×6 image, F = 2: window of (x, y) is
    // [x, x+1] × [y, y+1], so exactly pixels (1..2, 1..2) see it, each with weight 1/4.
    const int w = 6, h = 6;
    std::vector<float> img(w * h * 3, 0.0f);
    img[(2 * w + 2) * 3] = 4.0f;
    std::vector<float> out(img.size());
    boxFilter(img, w, h, 2, out);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool sees = (x == 1 || x == 2) && (y == 1 || y == 2);
            EXPECT_FLOAT_EQ(out[(y * w + x) * 3], sees ? 1.0f : 0.0f) << x << "," << y;
        }
    EXPECT_EQ(BoxWindow(4).r0, 1);
    EXPECT_EQ(BoxWindow(4).r1, 2);
    EXPECT_EQ(BoxWindow(5).r0, 2);
    EXPECT_EQ(BoxWindow(5).r1, 2);
}

TEST(BoxFilter, BordersDivideByTheNumberOfPixelsThatExist) {
    // Corner (0, 0) with F = 3 averages the 2×2 pixels that exist, not 9 with zeros.
    const int w = 4, h = 4;
    std::vector<float> img(w * h * 3, 0.0f);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 2; ++x) img[(y * w + x) * 3 + 1] = 2.0f;
    std::vector<float> out(img.size());
    boxFilter(img, w, h, 3, out);
    EXPECT_FLOAT_EQ(out[1], 2.0f);
    EXPECT_EQ(BoxWindow(3).validCount(0, 4), 2);
    EXPECT_EQ(BoxWindow(3).validCount(1, 4), 3);
    EXPECT_EQ(BoxWindow(8).validCount(0, 1), 1);
}

TEST(BoxFilter, NonFiniteInputsCountAsZeroAndDoNotSpread) {
    const int w = 9, h = 8;
    std::vector<float> img(w * h * 3, 1.0f);
    img[(3 * w + 4) * 3 + 0] = std::numeric_limits<float>::quiet_NaN();
    img[(3 * w + 4) * 3 + 1] = std::numeric_limits<float>::infinity();
    img[(6 * w + 1) * 3 + 2] = -std::numeric_limits<float>::infinity();
    for (int f = 1; f <= 8; ++f) {
        std::vector<float> fast(img.size()), naive(img.size());
        boxFilter(img, w, h, f, fast);
        boxFilterNaive(img, w, h, f, naive);
        for (size_t i = 0; i < fast.size(); ++i) {
            ASSERT_TRUE(std::isfinite(fast[i])) << "F=" << f << " at " << i;
            ASSERT_NEAR(fast[i], naive[i], 1e-6) << "F=" << f << " at " << i;
        }
    }
    // F = 3: the NaN pixel's neighbour averages 8 ones and one zero.
    std::vector<float> out(img.size());
    boxFilter(img, w, h, 3, out);
    EXPECT_FLOAT_EQ(out[(3 * w + 5) * 3], 8.0f / 9.0f);
}

TEST(BoxFilter, TallImagesStayExactAcrossPeriodicResums) {
    // More rows than BoxFilter::kResumRows with a very bright row: rounding residue of the
    // subtraction must not survive into the dark rows far below it.
    const int w = 8, h = 3 * BoxFilter::kResumRows + 5;
    auto img = randomImage(w, h, 99);
    for (int x = 0; x < w * 3; ++x) img[10 * w * 3 + x] = 1e7f;
    for (int f : {3, 4, 8}) {
        std::vector<float> fast(img.size()), naive(img.size());
        boxFilter(img, w, h, f, fast);
        boxFilterNaive(img, w, h, f, naive);
        expectNear(fast, naive, 1e-5);
    }
}

// The edge-stopping box (edgeStoppingBox) over the plain box's output, as FrameImage runs it.
std::vector<float> edgeStopped(const std::vector<float>& in, int w, int h, int f, float ratio,
                               const std::vector<float>& noise = {}) {
    std::vector<float> box(in.size()), out(in.size());
    boxFilter(in, w, h, f, box);
    edgeStoppingBox(in, box, noise, w, h, f, ratio, out);
    return out;
}

TEST(EdgeStoppingBox, KeepsAStepSharpWhereTheBoxBlursIt) {
    const int w = 12, h = 6;
    std::vector<float> img(size_t(w * h * 3));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) img[size_t((y * w + x) * 3 + c)] = x < w / 2 ? 1.0f : 10.0f;
    const std::vector<float> out = edgeStopped(img, w, h, 3, 2.0f);
    std::vector<float> box(img.size());
    boxFilter(img, w, h, 3, box);
    EXPECT_EQ(out, img);  // each side averages itself only
    EXPECT_GT(box[size_t((w / 2 - 1) * 3)], 3.0f) << "the box blurs the step (the test's premise)";
}

TEST(EdgeStoppingBox, EqualsTheBoxWhereDifferencesAreWithinTheFloor) {
    const int w = 17, h = 9;
    std::mt19937 rng(7);
    // Grey values within 4 % of each other: below the floor (kEdgeFloor of the window's mean).
    std::uniform_real_distribution<float> within(1.0f, 1.04f);
    std::vector<float> img(size_t(w * h * 3));
    for (size_t p = 0; p < size_t(w * h); ++p) img[3 * p] = img[3 * p + 1] = img[3 * p + 2] = within(rng);
    std::vector<float> box(img.size());
    boxFilterNaive(img, w, h, 3, box);
    expectNear(edgeStopped(img, w, h, 3, 2.5f), box, 1e-6);
}

TEST(EdgeStoppingBox, UnknownNoiseIsInfiniteAndGivesTheBox) {
    const int w = 13, h = 7;
    const std::vector<float> img = randomImage(w, h, 5);  // four decades: edges everywhere
    std::vector<float> box(img.size());
    boxFilterNaive(img, w, h, 3, box);
    const std::vector<float> unknown(size_t(w * h), std::numeric_limits<float>::infinity());
    expectNear(edgeStopped(img, w, h, 3, 2.0f, unknown), box, 1e-6);
}

TEST(EdgeStoppingBox, DifferencesWithinTheNoiseAreAveragedAsTheBoxDoes) {
    // A flat caustic of 1 seen through ±30 % noise, each value saying its relative noise is 0.3:
    // no difference there exceeds 2 × the pair's noise enough to read as an edge, so the window
    // is the box's; told nothing of the noise, the same values read as edges and keep their grain.
    const int w = 15, h = 9;
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> grain(0.7f, 1.3f);
    std::vector<float> img(size_t(w * h * 3));
    for (size_t p = 0; p < size_t(w * h); ++p) {
        const float v = grain(rng);
        for (int c = 0; c < 3; ++c) img[p * 3 + size_t(c)] = v;
    }
    std::vector<float> box(img.size());
    boxFilterNaive(img, w, h, 3, box);
    expectNear(edgeStopped(img, w, h, 3, 2.0f, std::vector<float>(size_t(w * h), 0.3f)), box, 1e-6);
    const std::vector<float> blind = edgeStopped(img, w, h, 3, 2.0f);
    double apart = 0.0;
    for (size_t i = 0; i < img.size(); ++i) apart = std::max(apart, std::abs(double(blind[i]) - box[i]) / box[i]);
    EXPECT_GT(apart, 0.02) << "without the noise the grain is not averaged away (the test's premise)";
}

TEST(EdgeStoppingBox, RatioZeroIsThePlainBoxBitForBit) {
    const int w = 13, h = 7;
    const std::vector<float> img = randomImage(w, h, 3);
    std::vector<float> box(img.size());
    boxFilter(img, w, h, 3, box);
    EXPECT_EQ(edgeStopped(img, w, h, 3, 0.0f), box);
}

TEST(EdgeStoppingBox, ANeighbourNearTheRatioMovesThePixelLittle) {
    // Continuity: the weights fade, so a value that crosses the ratio by a hair (2e-3) moves the
    // results by a few hairs, not by a step.
    const int w = 3, h = 1;
    std::vector<float> a = {1, 1, 1, 1.999f, 1.999f, 1.999f, 1, 1, 1};
    std::vector<float> b = a;
    for (int c = 0; c < 3; ++c) b[size_t(3 + c)] = 2.001f;
    const std::vector<float> oa = edgeStopped(a, w, h, 3, 2.0f), ob = edgeStopped(b, w, h, 3, 2.0f);
    EXPECT_NEAR(oa[0], ob[0], 5e-3f);
    EXPECT_NEAR(oa[3], ob[3], 5e-3f);
}

TEST(EdgeStoppingBox, NonFiniteInputsCountAsZeroAndTheOutputStaysFinite) {
    const int w = 5, h = 5;
    std::vector<float> img(size_t(w * h * 3), 1.0f);
    img[size_t((2 * w + 2) * 3)] = std::numeric_limits<float>::quiet_NaN();
    img[size_t((1 * w + 1) * 3 + 1)] = std::numeric_limits<float>::infinity();
    for (float v : edgeStopped(img, w, h, 3, 2.0f)) EXPECT_TRUE(std::isfinite(v));
}

}  // namespace
}  // namespace rtpm
