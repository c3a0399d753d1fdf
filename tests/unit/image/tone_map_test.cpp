// Display tone mapping: the table matches writePng's exact operator within a quarter step.
#include "common/image/tone_map.h"

#include <gtest/gtest.h>

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

TEST(ToneMap, NonFiniteAndNegativeBecomeBlackAndOverflowClips) {
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> rgb{std::nanf(""), -1.0f, inf, 1e30f, 0.0f, 1.0f};
    std::vector<uint8_t> out(rgb.size());
    toneMapSrgb8(rgb, 1.0f, out);
    EXPECT_EQ(out, (std::vector<uint8_t>{0, 0, 255, 255, 0, 255}));
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
