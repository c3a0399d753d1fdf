// Display tone mapping: the table matches writePng's exact operator within a quarter step.
#include "common/image/tone_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/image/image_io.h"

namespace rtpm {
namespace {

TEST(ToneMap, TableMatchesTheExactSrgbCurveWithinOneStep) {
    std::vector<float> rgb;
    for (int i = 0; i <= 3000; ++i) rgb.push_back(std::pow(float(i) / 3000.0f, 3.0f) * 1.2f);
    std::vector<uint8_t> out(rgb.size());
    toneMapSrgb8(rgb, 1.0f, out);
    for (size_t i = 0; i < rgb.size(); ++i) {
        const long exact = std::lround(255.0f * linearToSrgb(rgb[i]));
        EXPECT_LE(std::abs(long(out[i]) - exact), 1) << rgb[i];
    }
}

TEST(ToneMap, EveryValueOfADenseSweepIsWithinOneStepAtEveryAlignment) {
    // 2^20 values evenly over [0, 1.05] at scale 1, plus a scaled run: exercises the SIMD body
    // (32 at a time) and the scalar tail (the sizes are not multiples of 32).
    for (const float scale : {1.0f, 3.7f}) {
        std::vector<float> rgb((1u << 20) + 13);
        for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = 1.05f * float(i) / float(rgb.size()) / scale;
        std::vector<uint8_t> out(rgb.size());
        toneMapSrgb8(rgb, scale, out);
        long worst = 0;
        for (size_t i = 0; i < rgb.size(); ++i) {
            const long exact = std::lround(255.0f * linearToSrgb(std::min(1.0f, rgb[i] * scale)));
            worst = std::max(worst, std::abs(long(out[i]) - exact));
        }
        EXPECT_LE(worst, 1) << "scale " << scale;
    }
}

TEST(ToneMap, NonFiniteAndNegativeBecomeBlackAndOverflowClips) {
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> rgb{std::nanf(""), -1.0f, inf, 1e30f, 0.0f, 1.0f, -inf};
    std::vector<uint8_t> out(rgb.size());
    toneMapSrgb8(rgb, 1.0f, out);
    EXPECT_EQ(out, (std::vector<uint8_t>{0, 0, 255, 255, 0, 255, 0}));
    // The same values in the 32-wide SIMD body, at every position of a block.
    for (size_t at = 0; at < 32; ++at) {
        std::vector<float> block(64, 0.5f);
        for (size_t j = 0; j < rgb.size(); ++j) block[(at + j) % 64] = rgb[j];
        std::vector<uint8_t> o(block.size());
        toneMapSrgb8(block, 1.0f, o);
        for (size_t j = 0; j < rgb.size(); ++j) EXPECT_EQ(o[(at + j) % 64], out[j]) << "position " << (at + j) % 64;
    }
}

TEST(ToneMap, DisplayScaleFollowsThe99thPercentileAndExposure) {
    // 1000 pixels of luminance 0.5 → p99 = 0.5 → scale 2; +1 EV doubles it.
    std::vector<float> rgb(3000, 0.5f);
    EXPECT_NEAR(displayScale(rgb, 0.0f, 1), 2.0f, 1e-5f);
    EXPECT_NEAR(displayScale(rgb, 1.0f, 8), 4.0f, 1e-5f);
    std::vector<float> black(3000, 0.0f);
    EXPECT_EQ(displayScale(black, 0.0f), 1.0f);
}

}  // namespace
}  // namespace rtpm
