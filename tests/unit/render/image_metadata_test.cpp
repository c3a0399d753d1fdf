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

TEST(ImageMetadata, ANameOpenExrReservesIsRefused) {
    FrameImage frame(4, 4);
    frame.filterAndCompose(1);
    EXPECT_THROW(writeExr(tempPath("reserved.exr"), frame, false, {{"channels", "x"}}), std::invalid_argument);
    EXPECT_FALSE(std::filesystem::exists(tempPath("reserved.exr")));
}

}  // namespace
}  // namespace rtpm
