// An EXR says what made it: the scene, resolution, settings, estimator, frames, photons and
// rtpm's version and commit travel in its header as string attributes and read back unchanged,
// through rtpm's reader and through OpenImageIO's oiiotool where it is installed (issue 24, item 6).
#include "common/render/image_metadata.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>
#include <sstream>

#include "common/core/version.h"
#include "common/image/frame_image.h"

namespace rtpm {
namespace {

std::string tempPath(const std::string& name) {
    return (std::filesystem::temp_directory_path() / ("rtpm_metadata_" + std::to_string(::getpid()) + "_" + name))
        .string();
}

ImageProvenance glassRun() {
    ImageProvenance p;
    p.program = "rtpm-render";
    p.scene = "scenes/glass \"v2\".glb";  // quotes and spaces survive
    p.settings.width = 8;
    p.settings.height = 6;
    p.settings.interleave = 2;
    p.settings.photons.photonsPerBatch = 1234;
    p.settings.photons.estimator = CausticEstimatorKind::Knn;
    p.frames = 17;
    p.photonsStored = 987654321012ull;
    return p;
}

TEST(ImageMetadata, NamesTheRunThatMadeTheImage) {
    const ExrAttributes a = imageMetadata(glassRun());
    EXPECT_EQ(a.at("rtpm:program"), "rtpm-render");
    EXPECT_EQ(a.at("rtpm:scene"), "scenes/glass \"v2\".glb");
    EXPECT_EQ(a.at("rtpm:resolution"), "8x6");
    EXPECT_EQ(a.at("rtpm:estimator"), "knn");
    EXPECT_EQ(a.at("rtpm:frames"), "17");
    EXPECT_EQ(a.at("rtpm:photons"), "987654321012");
    EXPECT_EQ(a.at("rtpm:version"), rtpmVersion());
    EXPECT_EQ(a.at("rtpm:commit"), rtpmCommit());
    EXPECT_NE(a.at("rtpm:settings").find("--width 8 --height 6 -M 2 -F 2 -P 1234 "), std::string::npos)
        << a.at("rtpm:settings");
    EXPECT_NE(a.at("rtpm:settings").find("--estimator knn"), std::string::npos) << a.at("rtpm:settings");
    EXPECT_FALSE(std::string(rtpmVersion()).empty());
    EXPECT_FALSE(std::string(rtpmCommit()).empty());
}

TEST(ImageMetadata, RoundTripsThroughTheExrHeader) {
    FrameImage frame(8, 6);
    frame.filterAndCompose(2);
    const ExrAttributes written = imageMetadata(glassRun());
    const std::string path = tempPath("frame.exr");
    writeExr(path, frame, false, written);
    const ExrImage img = readExr(path);
    for (const auto& [name, value] : written) {
        ASSERT_TRUE(img.attributes.count(name)) << name << " missing from the header";
        EXPECT_EQ(img.attributes.at(name), value) << name;
    }
    // What a user runs to read them (OpenImageIO's tool), where it is installed.
    if (std::system("command -v oiiotool > /dev/null 2>&1") == 0) {
        const std::string log = tempPath("oiiotool.txt");
        ASSERT_EQ(std::system(("oiiotool --info -v " + path + " > " + log + " 2>&1").c_str()), 0);
        std::stringstream ss;
        ss << std::ifstream(log).rdbuf();
        std::filesystem::remove(log);
        EXPECT_NE(ss.str().find("rtpm:frames: \"17\""), std::string::npos) << ss.str();
        EXPECT_NE(ss.str().find("rtpm:estimator: \"knn\""), std::string::npos) << ss.str();
        EXPECT_NE(ss.str().find("rtpm:version: \"" + std::string(rtpmVersion()) + "\""), std::string::npos)
            << ss.str();
    }
    std::filesystem::remove(path);
}

std::vector<uint8_t> fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Both programs write an image through writeImageFiles: the EXR with its header, and the PNG
// beside it tone-mapped by the settings' exposure knob (the same bytes writePng gives for it).
TEST(ImageMetadata, ImageFilesAreTheExrWithItsHeaderAndThePngAtTheSettingsExposure) {
    const Interleave pattern{8, 6, 1};
    std::vector<PixelRadiance> pixels(size_t(pattern.pixelCount(0)));
    for (size_t i = 0; i < pixels.size(); ++i) pixels[i].direct = Vec3(0.01f * float(i), 0.02f, 0.5f);
    FrameImage frame(8, 6);
    frame.scatter(pattern, 0, pixels);
    frame.filterAndCompose(1);
    ImageProvenance run = glassRun();
    run.settings.exposure = 1.5f;
    const std::string exr = tempPath("pair.exr");
    EXPECT_EQ(writeImageFiles(exr, frame, run), tempPath("pair.png"));
    EXPECT_EQ(readExr(exr).attributes.at("rtpm:frames"), "17");
    const std::string reference = tempPath("reference.png");
    writePng(reference, 8, 6, frame.final(), ToneMap{.stopsAboveAuto = 1.5f});
    EXPECT_EQ(fileBytes(tempPath("pair.png")), fileBytes(reference));
    writePng(reference, 8, 6, frame.final());
    EXPECT_NE(fileBytes(tempPath("pair.png")), fileBytes(reference)) << "the exposure knob changed nothing";
    for (const char* name : {"pair.exr", "pair.png", "reference.png"}) std::filesystem::remove(tempPath(name));
}

TEST(ImageMetadata, ANameOpenExrReservesIsRefused) {
    FrameImage frame(4, 4);
    frame.filterAndCompose(1);
    EXPECT_THROW(writeExr(tempPath("reserved.exr"), frame, false, {{"channels", "x"}}), std::invalid_argument);
    EXPECT_FALSE(std::filesystem::exists(tempPath("reserved.exr")));
}

}  // namespace
}  // namespace rtpm
