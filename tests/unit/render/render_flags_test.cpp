// The rendering flags read from the settings tables: values, switches, range errors, --exposure's effect.
#include "common/render/render_flags.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "common/image/image_io.h"

namespace rtpm {
namespace {

// Parses `args` with rtpm-render's rendering flags; the settings they give, or the parser's error.
struct Parsed {
    RenderSettings settings;
    std::string error;  ///< empty: parsed
};

Parsed parse(std::vector<std::string> args) {
    Parsed p;
    std::string scene;
    bool noDefaultLight = false;
    CLI::App app{"test", "rtpm-render"};
    addRenderFlags(app, p.settings, scene, noDefaultLight);
    args.insert(args.begin(), "rtpm-render");
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    try {
        app.parse(int(argv.size()), argv.data());
    } catch (const CLI::ParseError& e) {
        p.error = e.what();
    }
    return p;
}

TEST(RenderFlags, ExposureFlagParsesAndRefusesOutOfRange) {
    EXPECT_EQ(parse({}).settings.exposure, 0.0f);  // automatic exposure by default
    const Parsed up = parse({"--exposure", "1.5"});
    EXPECT_EQ(up.error, "");
    EXPECT_EQ(up.settings.exposure, 1.5f);
    EXPECT_EQ(parse({"--exposure", "-20"}).settings.exposure, -20.0f);
    const Parsed high = parse({"--exposure", "20.5"});
    EXPECT_NE(high.error.find("--exposure"), std::string::npos) << high.error;
    EXPECT_NE(high.error.find("not in range -20 to 20"), std::string::npos) << high.error;
    EXPECT_NE(parse({"--exposure", "bright"}).error.find("is not a number in [-20, 20]"), std::string::npos);
}

TEST(RenderFlags, FixedSettingsComeFromTheirRows) {
    const Parsed p = parse({"--width", "320", "--depth", "8", "--seed", "7", "--no-spt", "--gather-visibility",
                            "--cap", "0", "-M", "4"});
    ASSERT_EQ(p.error, "");
    EXPECT_EQ(p.settings.width, 320);
    EXPECT_EQ(p.settings.eye.maxDepth, 8);
    EXPECT_EQ(p.settings.photons.seed, 7u);
    EXPECT_FALSE(p.settings.photons.selective);
    EXPECT_TRUE(p.settings.photons.gatherVisibility);
    EXPECT_EQ(p.settings.photons.capPhotons, 0u);
    EXPECT_EQ(p.settings.interleave, 4);
    EXPECT_TRUE(parse({}).settings.photons.selective);
    EXPECT_NE(parse({"--width", "0"}).error.find("--width: Value 0 not in range 1 to 16384"), std::string::npos);
    EXPECT_NE(parse({"--diffuse-bounces", "2.5"}).error.find("not a whole number"), std::string::npos);
    EXPECT_NE(parse({"--no-spt", "1"}).error, "");  // a switch takes no value
    // The image metadata names every row: the switches only when given.
    const std::string d = describeSettings(p.settings);
    EXPECT_NE(d.find("--width 320 --height 480 -M 4 -F 4 "), std::string::npos) << d;
    EXPECT_NE(d.find(" --exposure 0 "), std::string::npos) << d;
    EXPECT_NE(d.find(" --seed 7 --no-spt --gather-visibility"), std::string::npos) << d;
    EXPECT_EQ(describeSettings(RenderSettings{}).find("--no-spt"), std::string::npos);
}

TEST(RenderFlags, ExposureScalesTheToneMappedImageNotTheRadiance) {
    // 100 pixels of luminance 0.1: the automatic exposure maps 0.1 to white (scale 10); one stop
    // above doubles that scale, two stops below quarter it. The radiance passed in is untouched.
    const std::vector<float> rgb(100 * 3, 0.1f);
    const std::vector<float> before = rgb;
    const std::string path = (std::filesystem::temp_directory_path() / "rtpm_exposure_flag_test.png").string();
    const float automatic = writePng(path, 10, 10, rgb, ToneMap{.stopsAboveAuto = parse({}).settings.exposure});
    EXPECT_EQ(automatic, autoExposureScale(rgb));  // exposure 0 is the automatic scale, bit for bit
    const float up = writePng(path, 10, 10, rgb, ToneMap{.stopsAboveAuto = parse({"--exposure", "1"}).settings.exposure});
    EXPECT_FLOAT_EQ(up, 2.0f * automatic);
    const float down = writePng(path, 10, 10, rgb, ToneMap{.stopsAboveAuto = parse({"--exposure", "-2"}).settings.exposure});
    EXPECT_FLOAT_EQ(down, 0.25f * automatic);
    // 0.1 · 10 / 4 = 0.25 linear → sRGB 137 of 255.
    EXPECT_NEAR(readExr(path).layerRgb("")[0] * 255.0f, 137.0f, 1.0f);
    std::filesystem::remove(path);
    EXPECT_EQ(rgb, before);
}

}  // namespace
}  // namespace rtpm
