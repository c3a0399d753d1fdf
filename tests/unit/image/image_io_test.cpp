// Tests of image output: EXR layer round trip with the docs/ARCHITECTURE.md §9 channel names, PNG
// tone mapping.
#include "common/image/image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <vector>

#include "common/image/frame_image.h"

namespace rtpm {
namespace {

std::string tempPath(const std::string& name) {
    return (std::filesystem::temp_directory_path() /
            ("rtpm_image_io_" + std::to_string(::getpid()) + "_" + name)).string();
}

std::vector<float> ramp(int w, int h, float scale) {
    std::vector<float> v(size_t(w * h * 3));
    for (size_t i = 0; i < v.size(); ++i) v[i] = scale * float(i) + 0.125f;
    return v;
}

TEST(ImageIo, ExrRoundTripKeepsLayersAndChannelNames) {
    const int w = 7, h = 5;
    const auto a = ramp(w, h, 0.5f), b = ramp(w, h, -0.25f), c = ramp(w, h, 3.0f), d = ramp(w, h, 1e-3f);
    const ImageLayer layers[] = {{"", a}, {"direct", b}, {"caustic", c}, {"caustic_filtered", d}};
    const std::string path = tempPath("layers.exr");
    writeExr(path, w, h, layers);
    const ExrImage img = readExr(path);
    std::filesystem::remove(path);
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    const std::set<std::string> names(img.channelNames.begin(), img.channelNames.end());
    const std::set<std::string> expected{"R", "G", "B", "direct.R", "direct.G", "direct.B",
                                         "caustic.R", "caustic.G", "caustic.B",
                                         "caustic_filtered.R", "caustic_filtered.G", "caustic_filtered.B"};
    EXPECT_EQ(names, expected);
    EXPECT_EQ(img.channelNames.size(), 12u);
    EXPECT_EQ(img.layerRgb(""), a);  // float32: bit exact
    EXPECT_EQ(img.layerRgb("direct"), b);
    EXPECT_EQ(img.layerRgb("caustic"), c);
    EXPECT_EQ(img.layerRgb("caustic_filtered"), d);
    // Row-major from the top-left: pixel (x=2, y=1) red is element (1·w + 2)·3.
    EXPECT_EQ(img.channels.at("R")[size_t(1 * w + 2)], a[size_t((1 * w + 2) * 3)]);
}

TEST(ImageIo, HalfExrRoundTripWithinHalfPrecision) {
    const int w = 4, h = 3;
    const auto a = ramp(w, h, 0.37f);
    const ImageLayer layers[] = {{"", a}};
    const std::string path = tempPath("half.exr");
    writeExr(path, w, h, layers, /*half=*/true);
    const auto back = readExr(path).layerRgb("");
    std::filesystem::remove(path);
    ASSERT_EQ(back.size(), a.size());
    for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(back[i], a[i], std::abs(a[i]) * 1e-3f);
}

TEST(ImageIo, NonFiniteValuesAreWrittenAsZero) {
    std::vector<float> v = {1.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()};
    const ImageLayer layers[] = {{"", v}};
    const std::string path = tempPath("nan.exr");
    writeExr(path, 1, 1, layers);
    const auto back = readExr(path).layerRgb("");
    std::filesystem::remove(path);
    EXPECT_EQ(back, (std::vector<float>{1.0f, 0.0f, 0.0f}));
}

TEST(ImageIo, BadArgumentsAreReportedNotCrashed) {
    std::vector<float> v(5);
    const ImageLayer wrongSize[] = {{"", v}};
    EXPECT_THROW(writeExr(tempPath("bad.exr"), 1, 1, wrongSize), std::invalid_argument);
    std::vector<float> ok(3);
    const ImageLayer twice[] = {{"x", ok}, {"x", ok}};
    EXPECT_THROW(writeExr(tempPath("bad.exr"), 1, 1, twice), std::invalid_argument);
    const ImageLayer one[] = {{"", ok}};
    EXPECT_THROW(writeExr("/nonexistent-dir/x/y.exr", 1, 1, one), std::runtime_error);
    EXPECT_THROW(readExr("/nonexistent-dir/none.exr"), std::runtime_error);
    EXPECT_THROW(writePng(tempPath("bad.png"), 2, 2, ok), std::invalid_argument);
}

TEST(ImageIo, FrameImageWrittenWithDesignChannels) {
    const int w = 6, h = 4;
    FrameImage frame(w, h);
    Interleave pattern{w, h, 2};
    for (int set = 0; set < pattern.setCount(); ++set) {
        std::vector<PixelRadiance> px(size_t(pattern.pixelCount(set)));
        for (size_t n = 0; n < px.size(); ++n) {
            px[n].direct = Vec3(float(set), 1.0f, 2.0f);
            px[n].caustic = Vec3(0.5f);
        }
        frame.scatter(pattern, set, px);
    }
    frame.filterAndCompose(2);
    const std::string path = tempPath("frame.exr");
    writeExr(path, frame);
    const ExrImage img = readExr(path);
    std::filesystem::remove(path);
    EXPECT_EQ(img.layerRgb("direct"), frame.direct());
    EXPECT_EQ(img.layerRgb("caustic"), frame.caustic());
    EXPECT_EQ(img.layerRgb("caustic_filtered"), frame.causticFiltered());
    EXPECT_EQ(img.layerRgb(""), frame.final());
}

TEST(ImageIo, PngAppliesExposureClampAndSrgbCurve) {
    // Pixel values chosen at known points of the sRGB curve.
    const std::vector<float> rgb = {0.0f, 1.0f, 0.5f,  0.0031308f, 4.0f, 0.214041f,
                                    -1.0f, std::numeric_limits<float>::quiet_NaN(), 0.25f};
    const std::string path = tempPath("tone.png");
    ToneMap fixed;
    fixed.exposureStops = 0.0f;
    EXPECT_EQ(writePng(path, 3, 1, rgb, fixed), 1.0f);
    const auto back = readExr(path).layerRgb("");
    std::filesystem::remove(path);
    ASSERT_EQ(back.size(), rgb.size());
    const float expected[] = {0, 255, 188, 10, 255, 128, 0, 0, 137};
    for (size_t i = 0; i < rgb.size(); ++i) EXPECT_NEAR(back[i] * 255.0f, expected[i], 1.0f) << i;  // one 8-bit step
    // One stop up doubles the linear value before the curve: 0.25 → 0.5 → 188.
    fixed.exposureStops = 1.0f;
    EXPECT_EQ(writePng(path, 3, 1, rgb, fixed), 2.0f);
    EXPECT_NEAR(readExr(path).layerRgb("")[8] * 255.0f, 188.0f, 0.51f);
    std::filesystem::remove(path);
}

TEST(ImageIo, AutoExposureMapsThe99thPercentileToWhite) {
    // 1000 grey pixels of luminance 0.1 and 5 very hot ones: the hot ones must not set exposure.
    std::vector<float> rgb(1005 * 3, 0.1f);
    for (size_t i = 1000 * 3; i < rgb.size(); ++i) rgb[i] = 1e6f;
    EXPECT_NEAR(autoExposureScale(rgb), 10.0f, 1e-3f);
    EXPECT_EQ(autoExposureScale(std::vector<float>(30, 0.0f)), 1.0f);  // black image: unchanged
}

}  // namespace
}  // namespace rtpm
