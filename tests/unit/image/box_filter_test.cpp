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

}  // namespace
}  // namespace rtpm
