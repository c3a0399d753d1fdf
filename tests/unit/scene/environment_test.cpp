// The world light: equirectangular mapping, the importance sampling's density against its
// histogram, and every way a map file or flag is refused.
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "common/core/halton.h"
#include "common/render/render_flags.h"
#include "common/scene/environment.h"
#include "common/scene/environment_loader.h"
#include "common/scene/scene.h"
#include "common/scene/scene_loader.h"

namespace rtpm {
namespace {

namespace fs = std::filesystem;

// A map whose texels vary over three orders of magnitude, with a bright 2 × 2 "sun" and a black band.
Texture testMap(int height) {
    Texture t;
    t.width = 2 * height;
    t.height = height;
    t.rgb.resize(size_t(t.width) * size_t(height) * 3);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < t.width; ++i) {
            float v = 0.05f + 0.5f * float((i * 7 + j * 3) % 11) / 11.0f;
            if (j == height - 3) v = 0.0f;  // black band: never drawn
            if (j >= 3 && j < 5 && i >= 10 && i < 12) v = 200.0f;
            float* px = &t.rgb[(size_t(j) * size_t(t.width) + size_t(i)) * 3];
            px[0] = v;
            px[1] = 0.5f * v;
            px[2] = v > 0.0f ? 0.25f * v + 0.01f : 0.0f;
        }
    return t;
}

double texelSolidAngle(int j, int width, int height) {
    const double pi = std::numbers::pi;
    return 2.0 * pi / width * (std::cos(pi * j / height) - std::cos(pi * (j + 1) / height));
}

TEST(Environment, MappingIsBlendersEquirectangularWithYUp) {
    // The image centre looks along +X, row 0 is the zenith, u grows toward +Z.
    EXPECT_NEAR(glm::length(Environment::directionOf(Vec2(0.5f, 0.5f)) - Vec3(1, 0, 0)), 0.0f, 1e-6f);
    EXPECT_NEAR(Environment::directionOf(Vec2(0.3f, 0.0f)).y, 1.0f, 1e-6f);
    EXPECT_NEAR(glm::length(Environment::directionOf(Vec2(0.75f, 0.5f)) - Vec3(0, 0, 1)), 0.0f, 1e-6f);
    for (float u : {0.1f, 0.37f, 0.5f, 0.9f})
        for (float v : {0.05f, 0.5f, 0.8f}) {
            const Vec2 back = Environment::uvOf(Environment::directionOf(Vec2(u, v)));
            EXPECT_NEAR(back.x, u, 1e-5f);
            EXPECT_NEAR(back.y, v, 1e-5f);
        }
    // radiance() reads the texel the direction falls in.
    const Texture map = testMap(8);
    const Environment env = Environment::fromMap(map);
    const Vec3 d = Environment::directionOf(Vec2((10.5f) / 16.0f, 3.5f / 8.0f));
    EXPECT_EQ(env.radiance(d), Vec3(200.0f, 100.0f, 50.01f));
}

TEST(Environment, UniformSkyIsSampledUniformlyWithItsExactIntegral) {
    const Environment env = Environment::uniform(Vec3(0.5f, 1.0f, 2.0f));
    EXPECT_FALSE(env.empty());
    EXPECT_FALSE(env.hasMap());
    EXPECT_NEAR(env.integral().y, 4.0 * std::numbers::pi, 1e-5);
    EXPECT_FLOAT_EQ(env.pdf(Vec3(0, 1, 0)), float(1.0 / (4.0 * std::numbers::pi)));
    EXPECT_TRUE(Environment{}.empty());
    EXPECT_TRUE(Environment::uniform(Vec3(0.0f)).empty());
}

// The importance sampling (file comment of environment.h): pdf() agrees with what sample()
// returns, the density integrates to 1 over the sphere, L/pdf has the same Σ_rgb for every
// sample, and a histogram of 2^20 independent samples (hashed, seed fixed) per texel matches
// P_texel = pdf·Ω: each texel's count within 5 standard deviations of its binomial expectation
// (512 texels: a false failure has probability < 3e-4).
TEST(Environment, MapSamplingDensityMatchesItsHistogram) {
    const int h = 16, w = 32;
    const Texture map = testMap(h);
    const Environment env = Environment::fromMap(map);
    ASSERT_TRUE(env.hasMap());
    double total = 0.0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const Vec3 d = Environment::directionOf(Vec2((i + 0.5f) / w, (j + 0.5f) / h));
            total += double(env.pdf(d)) * texelSolidAngle(j, w, h);
        }
    EXPECT_NEAR(total, 1.0, 1e-5);

    const int side = 1024;
    std::vector<uint32_t> counts(size_t(w * h), 0);
    double ratioSum = -1.0;
    for (int a = 0; a < side; ++a)
        for (int b = 0; b < side; ++b) {
            const uint64_t key = splitMix64(uint64_t(a) * side + uint64_t(b) + 12345);
            const EnvironmentSample s = env.sample(Vec2(hashToUnit(key), hashToUnit(splitMix64(key))));
            ASSERT_GT(s.pdf, 0.0f);
            ASSERT_NEAR(glm::length(s.direction), 1.0f, 1e-5f);
            ASSERT_GT(s.radiance.x + s.radiance.y + s.radiance.z, 0.0f) << "a black texel was drawn";
            const Vec2 uv = Environment::uvOf(s.direction);
            const int i = std::clamp(int(uv.x * w), 0, w - 1), j = std::clamp(int(uv.y * h), 0, h - 1);
            ++counts[size_t(j * w + i)];
            // pdf() finds the texel from the direction again: off a texel's border it must agree.
            const float fx = uv.x * w - float(i), fy = uv.y * h - float(j);
            if (fx > 1e-3f && fx < 1.0f - 1e-3f && fy > 1e-3f && fy < 1.0f - 1e-3f)
                ASSERT_NEAR(env.pdf(s.direction), s.pdf, 1e-3f * s.pdf) << a << ", " << b;
            const double ratio = double(s.radiance.x + s.radiance.y + s.radiance.z) / s.pdf;
            if (ratioSum < 0.0) ratioSum = ratio;
            EXPECT_NEAR(ratio, ratioSum, 1e-3 * ratioSum);
        }
    const double n = double(side) * side;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const Vec3 d = Environment::directionOf(Vec2((i + 0.5f) / w, (j + 0.5f) / h));
            const double p = double(env.pdf(d)) * texelSolidAngle(j, w, h);
            const double expected = n * p, sigma = std::sqrt(n * p * (1.0 - p));
            EXPECT_LE(std::abs(double(counts[size_t(j * w + i)]) - expected), 5.0 * sigma + 1.0)
                << "texel " << i << ", " << j;
            // A black texel is never drawn (checked per sample above); only a direction on its border
            // can round into it.
            if (j == h - 3) EXPECT_LE(counts[size_t(j * w + i)], 8u);
        }
    // The sun (4 of 512 texels) holds most of the power and draws most of the samples.
    uint32_t sun = 0;
    for (int j = 3; j < 5; ++j)
        for (int i = 10; i < 12; ++i) sun += counts[size_t(j * w + i)];
    EXPECT_GT(double(sun) / n, 0.5);
    // ∫ L dω: Σ L·Ω over texels.
    double integral = 0.0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) integral += map.rgb[(size_t(j * w + i)) * 3] * texelSolidAngle(j, w, h);
    EXPECT_NEAR(env.integral().x, integral, 1e-4 * integral);
}

// ---- files and flags ------------------------------------------------------------------------

class EnvFiles : public ::testing::Test {
protected:
    EnvFiles() {
        dir_ = fs::temp_directory_path() / ("rtpm_env_" + std::to_string(::getpid()));
        fs::create_directories(dir_);
    }
    ~EnvFiles() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    // An RGB float EXR written with OpenEXR itself (NaN and Inf kept as they are).
    std::string exr(const std::string& name, int w, int h, const std::vector<float>& rgb) const {
        const std::string path = (dir_ / name).string();
        Imf::Header header(w, h);
        for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
        Imf::OutputFile file(path.c_str(), header);
        Imf::FrameBuffer fb;
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c)
            fb.insert(names[c], Imf::Slice(Imf::FLOAT, (char*)(rgb.data() + c), 3 * sizeof(float),
                                           3 * sizeof(float) * size_t(w)));
        file.setFrameBuffer(fb);
        file.writePixels(h);
        return path;
    }
    std::string text(const std::string& name, const std::string& bytes) const {
        const std::string path = (dir_ / name).string();
        std::ofstream(path, std::ios::binary) << bytes;
        return path;
    }
    static std::string errorOf(const EnvironmentOverride& request, uint64_t budget = uint64_t(1) << 30) {
        try {
            loadEnvironment(request, budget);
        } catch (const SceneError& e) {
            return e.what();
        }
        return "";
    }
    fs::path dir_;
};

TEST_F(EnvFiles, AGoodMapLoadsWithItsStrengthApplied) {
    std::vector<float> rgb(8 * 4 * 3, 0.25f);
    EnvironmentOverride request;
    request.file = exr("sky.exr", 8, 4, rgb);
    request.strength = 4.0f;
    const Environment env = loadEnvironment(request, uint64_t(1) << 20);
    ASSERT_TRUE(env.hasMap());
    EXPECT_EQ(env.width(), 8);
    EXPECT_EQ(env.radiance(Vec3(0, 1, 0)), Vec3(1.0f));
    EXPECT_NEAR(env.integral().x, 4.0 * std::numbers::pi, 1e-4);
}

TEST_F(EnvFiles, BadFilesAreRefusedNamingTheFileAndTheFault) {
    auto expectError = [&](const std::string& file, const std::string& words, uint64_t budget = uint64_t(1) << 30) {
        EnvironmentOverride request;
        request.file = file;
        const std::string e = errorOf(request, budget);
        EXPECT_NE(e.find(file), std::string::npos) << e;
        EXPECT_NE(e.find(words), std::string::npos) << "expected '" << words << "' in: " << e;
    };
    expectError((dir_ / "missing.exr").string(), "environment");
    expectError(exr("square.exr", 8, 8, std::vector<float>(8 * 8 * 3, 1.0f)), "twice as wide as high");
    std::vector<float> rgb(8 * 4 * 3, 1.0f);
    rgb[(2 * 8 + 5) * 3 + 1] = std::numeric_limits<float>::quiet_NaN();
    expectError(exr("nan.exr", 8, 4, rgb), "column 5, row 2 is NaN");
    rgb[(2 * 8 + 5) * 3 + 1] = std::numeric_limits<float>::infinity();
    expectError(exr("inf.exr", 8, 4, rgb), "is infinite");
    rgb[(2 * 8 + 5) * 3 + 1] = -1.0f;
    expectError(exr("negative.exr", 8, 4, rgb), "is negative");
    expectError(text("sky.png", "\x89PNG\r\n\x1a\n not really"), "neither an OpenEXR nor a Radiance HDR");
    expectError(text("cut.exr", std::string("\x76\x2f\x31\x01", 4) + "garbage"), "cannot decode the OpenEXR");
    expectError(exr("big.exr", 64, 32, std::vector<float>(64 * 32 * 3, 1.0f)), "--max-scene-bytes", 4096);
}

TEST_F(EnvFiles, ARadianceHdrFileLoads) {
    // Radiance RGBE, flat: 4 × 2 texels of value 1 (mantissa 128, exponent 129).
    std::string hdr = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n";
    for (int i = 0; i < 8; ++i) hdr += std::string("\x80\x80\x80\x81", 4);
    EnvironmentOverride request;
    request.file = text("sky.hdr", hdr);
    const Environment env = loadEnvironment(request, uint64_t(1) << 20);
    EXPECT_EQ(env.width(), 4);
    EXPECT_NEAR(env.radiance(Vec3(0, 1, 0)).x, 1.0f, 1e-6f);
}

TEST(EnvFlags, ColourStrengthAndTheirConflictsAreParsed) {
    auto parse = [](std::vector<std::string> args, SceneOverrides& o) -> std::string {
        CLI::App app;
        addSceneChoiceFlags(app, o);
        std::vector<std::string> argv = {"prog"};
        argv.insert(argv.end(), args.begin(), args.end());
        std::vector<const char*> c;
        for (const auto& a : argv) c.push_back(a.c_str());
        try {
            app.parse(int(c.size()), c.data());
        } catch (const CLI::ParseError& e) {
            return e.what();
        }
        return "";
    };
    SceneOverrides o;
    EXPECT_EQ(parse({"--env-color", "0.1,0.2,0.3", "--env-strength", "2"}, o), "");
    ASSERT_TRUE(o.environment);
    EXPECT_EQ(o.environment->colour, Vec3(0.1f, 0.2f, 0.3f));
    EXPECT_EQ(o.environment->strength, 2.0f);
    SceneOverrides grey;
    EXPECT_EQ(parse({"--env-color", "0.5"}, grey), "");
    EXPECT_EQ(grey.environment->colour, Vec3(0.5f));
    SceneOverrides a, b, c, d;
    EXPECT_NE(parse({"--env-color", "1,2"}, a).find("R,G,B"), std::string::npos);
    EXPECT_NE(parse({"--env-color", "1,-2,3"}, b).find("R,G,B"), std::string::npos);
    EXPECT_NE(parse({"--env", "x.exr", "--env-color", "1"}, c), "");
    EXPECT_NE(parse({"--env-strength", "2"}, d).find("--env-strength"), std::string::npos);
}

TEST(EnvScene, AWorldLightReplacesTheDefaultLightsAndABuiltinKeepsItsOwn) {
    SceneOverrides o;
    o.environment.emplace();
    o.environment->colour = Vec3(0.5f);
    const Scene ring = loadScene("RING", o);
    EXPECT_EQ(ring.environment.uniformRadiance(), Vec3(0.5f));
    EXPECT_EQ(loadScene("RING").lights.size(), ring.lights.size());
    EXPECT_TRUE(loadScene("RING").environment.empty());
}

}  // namespace
}  // namespace rtpm
