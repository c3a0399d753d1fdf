// No scene renders black without flags: every built-in scene and every glTF file of
// tests/data/gltf/corpus (shaped like Blender's exports, most of them without light or camera)
// rendered as rtpm-render does at 160 × 120, one frame, and its PNG's mean value (auto exposure,
// sRGB, as writePng maps it) must reach 0.02. Without the default sky the metal sphere was a
// mirror of a black world (mean 0). (tests/data/gltf/handmade.gltf is the loader's fixture: its
// camera faces empty space on purpose, and it has lights, so it stays black.) Costs about 10 s of
// CPU, most of it HEADLIGHT's.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <numeric>
#include <string>
#include <vector>

#include "common/image/frame_image.h"
#include "common/image/image_io.h"
#include "common/render/render_job.h"
#include "common/scene/scene_loader.h"
#include "tests/support/scratch_dir.h"

namespace rtpm {
namespace {

namespace fs = std::filesystem;

// Mean of the 8-bit PNG's values / 255 for `nameOrPath` at the defaults, 160 × 120, one frame.
double meanToneMapped(const std::string& nameOrPath) {
    Scene scene = loadScene(nameOrPath);
    RenderSettings rs;
    rs.width = 160;
    rs.height = 120;
    std::vector<uint32_t> sets(size_t(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    const Camera camera = *scene.camera;
    RenderJob job(std::move(scene), rs, sets);
    std::vector<SetPixels> pixels;
    job.renderFrame(camera, pixels);
    FrameImage image(rs.width, rs.height);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    for (const SetPixels& sp : pixels) scatterSet(image, pattern, sp);
    image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
    const std::vector<float>& rgb = image.final();
    const float scale = autoExposureScale(rgb);
    double sum = 0.0;
    for (float v : rgb) sum += std::round(255.0f * linearToSrgb(std::isfinite(v) ? v * scale : 0.0f)) / 255.0;
    return sum / double(rgb.size());
}

std::vector<std::string> scenesToCheck() {
    std::vector<std::string> all = builtinSceneNames();
    std::vector<std::string> files;
    for (const auto& entry : fs::directory_iterator(RTPM_TEST_DATA_DIR "/gltf/corpus"))
        if (entry.path().extension() == ".gltf" || entry.path().extension() == ".glb")
            files.push_back(entry.path().string());
    std::sort(files.begin(), files.end());
    all.insert(all.end(), files.begin(), files.end());
    return all;
}

TEST(DefaultLighting, NoBuiltinOrTestGltfSceneRendersBlack) {
    const std::vector<std::string> scenes = scenesToCheck();
    ASSERT_GE(scenes.size(), 5u + 6u) << "the built-in scenes and the glTF corpus";
    for (const std::string& s : scenes) {
        const double mean = meanToneMapped(s);
        EXPECT_GE(mean, 0.02) << s << " renders black or nearly at the defaults";
        std::printf("%-60s mean tone-mapped %.3f\n", fs::path(s).filename().c_str(), mean);
    }
}

// What a scene without any light gets: the two spot lights and the dim sky, named in the warning.
TEST(DefaultLighting, LightlessFileGetsTheSpotLightsAndTheDefaultSky) {
    const Scene s = loadScene(RTPM_TEST_DATA_DIR "/gltf/corpus/metal_sphere.gltf");
    EXPECT_EQ(s.lights.size(), 2u);
    ASSERT_TRUE(s.environment.hasMap());
    EXPECT_NEAR(s.environment.radiance(Vec3(0, 1, 0)).x, 0.12f, 0.003f);
    EXPECT_NEAR(s.environment.radiance(Vec3(0, -1, 0)).x, 0.03f, 0.003f);
    std::string warnings;
    for (const std::string& w : s.warnings) warnings += w;
    EXPECT_NE(warnings.find("sky"), std::string::npos) << warnings;
    // A scene with lights keeps its own lighting: no sky.
    EXPECT_TRUE(loadScene(RTPM_TEST_DATA_DIR "/gltf/handmade.gltf").environment.empty());
}

// An empty file (Blender's export with nothing selected: one node, no mesh) renders its world, as
// Blender does, with a warning saying there is nothing else: not an error.
TEST(DefaultLighting, AnEmptyFileShowsTheWorldAndSaysSo) {
    testsupport::ScratchDir dir;
    const std::string path = dir.write("empty.gltf", R"({"asset":{"version":"2.0"},"scene":0,
"scenes":[{"name":"Scene","nodes":[0]},{"name":"Empty Scene"}],"nodes":[{"name":"Empty"}]})");
    const Scene s = loadScene(path);
    EXPECT_EQ(s.triangleCount(), 0u);
    EXPECT_TRUE(s.environment.hasMap()) << "the default sky";
    std::string warnings;
    for (const std::string& w : s.warnings) warnings += w + "\n";
    EXPECT_NE(warnings.find("no triangles"), std::string::npos) << warnings;
    EXPECT_GE(meanToneMapped(path), 0.02) << "the sky shows";
}

}  // namespace
}  // namespace rtpm
