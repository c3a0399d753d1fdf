// Tests of the error metrics (caustic region, relative RMSE, MAE, energy ratio) and of the
// rtpm-compare executable's output and exit codes on real EXR files.
#include "common/image/error_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <sys/wait.h>

#include "common/image/image_io.h"

namespace rtpm {
namespace {

constexpr int kW = 20, kH = 10;

std::vector<float> constant(float v) { return std::vector<float>(size_t(kW) * kH * 3, v); }

void setPixel(std::vector<float>& img, int x, int y, float v) {
    for (int c = 0; c < 3; ++c) img[(size_t(y) * kW + size_t(x)) * 3 + size_t(c)] = v;
}

TEST(ErrorMetrics, IdenticalImagesHaveZeroErrorAndUnitEnergy) {
    std::vector<float> ref = constant(0.0f);
    for (int x = 0; x < 5; ++x) setPixel(ref, x, 3, 2.0f + float(x));
    const ErrorMetrics m = compareRgb(ref, ref, ref, kW, kH);
    EXPECT_EQ(m.caustic.pixels, 5u);
    EXPECT_DOUBLE_EQ(m.caustic.relRmse, 0.0);
    EXPECT_DOUBLE_EQ(m.caustic.mae, 0.0);
    EXPECT_DOUBLE_EQ(m.image.relRmse, 0.0);
    EXPECT_DOUBLE_EQ(m.energyRatio, 1.0);
    EXPECT_EQ(m.nonFiniteOutput, 0u);
}

TEST(ErrorMetrics, UniformScaleGivesKnownErrors) {
    // Output = 1.1 × reference: every error is 10 % of the value, energy ratio 1.1.
    std::vector<float> ref = constant(0.0f), out = constant(0.0f);
    for (int x = 0; x < kW; ++x) {
        setPixel(ref, x, 2, 4.0f);
        setPixel(out, x, 2, 4.4f);
    }
    const ErrorMetrics m = compareRgb(out, ref, ref, kW, kH);
    EXPECT_EQ(m.caustic.pixels, size_t(kW));
    EXPECT_NEAR(m.caustic.relRmse, 0.1, 1e-6);
    EXPECT_NEAR(m.caustic.relMae, 0.1, 1e-6);
    EXPECT_NEAR(m.caustic.mae, 0.4, 1e-6);
    EXPECT_NEAR(m.energyRatio, 1.1, 1e-6);
    // Over the whole image the same absolute error is spread over 10× the pixels, and so is the
    // reference: the relative figures stay 0.1 for the MAE, the RMSE grows by sqrt(10).
    EXPECT_NEAR(m.image.relMae, 0.1, 1e-6);
    EXPECT_NEAR(m.image.relRmse, 0.1 * std::sqrt(10.0), 1e-5);
    EXPECT_NEAR(m.image.mae, 0.04, 1e-6);
}

TEST(ErrorMetrics, RegionIsFivePercentOfThe99thPercentileOfLitPixels) {
    // 100 lit pixels of luminance 1 … 100 on an otherwise black image: the 99th percentile of the
    // lit ones is 99 (nearest rank on 0…99), so the threshold is 4.95 and pixels ≥ 5 are inside.
    std::vector<float> ref(size_t(kW) * kH * 3, 0.0f);
    for (int i = 0; i < 100; ++i) setPixel(ref, i % kW, i / kW, float(i + 1));
    EXPECT_NEAR(regionThreshold(ref), 0.05 * 99.0, 1e-4);
    const ErrorMetrics m = compareRgb(ref, ref, ref, kW, kH);
    EXPECT_EQ(m.caustic.pixels, 96u);  // values 5 … 100
    RegionSettings wide;
    wide.regionFraction = 0.001;
    EXPECT_EQ(compareRgb(ref, ref, ref, kW, kH, wide).caustic.pixels, 100u);
}

TEST(ErrorMetrics, BlackReferenceGivesEmptyRegionAndUndefinedRatios) {
    const std::vector<float> ref = constant(0.0f);
    const std::vector<float> out = constant(1.0f);
    const ErrorMetrics m = compareRgb(out, ref, ref, kW, kH);
    EXPECT_EQ(m.caustic.pixels, 0u);
    EXPECT_TRUE(std::isnan(m.caustic.relRmse));
    EXPECT_TRUE(std::isnan(m.energyRatio));
    EXPECT_TRUE(std::isnan(m.image.relRmse));  // mean |r| = 0
    EXPECT_NEAR(m.image.mae, 1.0, 1e-9);
}

TEST(ErrorMetrics, NonFiniteOutputIsCountedAndExcluded) {
    std::vector<float> ref = constant(1.0f);
    std::vector<float> out = constant(1.0f);
    out[0] = std::numeric_limits<float>::quiet_NaN();
    out[5] = std::numeric_limits<float>::infinity();
    const ErrorMetrics m = compareRgb(out, ref, ref, kW, kH);
    EXPECT_EQ(m.nonFiniteOutput, 2u);
    EXPECT_DOUBLE_EQ(m.image.mae, 0.0);
}

TEST(ErrorMetrics, WrongBufferSizeIsRejected) {
    const std::vector<float> ref = constant(1.0f);
    const std::vector<float> small(10, 1.0f);
    EXPECT_THROW(compareRgb(small, ref, ref, kW, kH), std::invalid_argument);
}

TEST(ErrorMetrics, DefaultMaskIsTheCausticLayer) {
    EXPECT_EQ(defaultMaskLayer("caustic_filtered"), "caustic_filtered");
    EXPECT_EQ(defaultMaskLayer("caustic"), "caustic");
    EXPECT_EQ(defaultMaskLayer(""), "caustic");
    EXPECT_EQ(defaultMaskLayer("direct"), "caustic");
}

// ---- EXR files and rtpm-compare -----------------------------------------------------------

struct TempDir {
    std::filesystem::path path;
    TempDir() {
        path = std::filesystem::temp_directory_path() /
               ("rtpm_error_metrics_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        std::filesystem::create_directories(path);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path, ec);
    }
    std::string file(const std::string& name) const { return (path / name).string(); }
};

void writeCausticExr(const std::string& path, int w, int h, const std::vector<float>& caustic) {
    const ImageLayer layers[] = {{"caustic", caustic}, {"caustic_filtered", caustic}};
    writeExr(path, w, h, layers);
}

TEST(ErrorMetrics, CompareExrNamesTheMissingChannelAndTheSizeMismatch) {
    TempDir dir;
    std::vector<float> a = constant(1.0f);
    writeCausticExr(dir.file("a.exr"), kW, kH, a);
    const ImageLayer direct[] = {{"direct", a}};
    writeExr(dir.file("direct.exr"), kW, kH, direct);
    std::vector<float> b(size_t(kW) * 2 * kH * 3, 1.0f);
    writeCausticExr(dir.file("big.exr"), kW * 2, kH, b);

    const ExrImage ia = readExr(dir.file("a.exr"));
    const ExrImage id = readExr(dir.file("direct.exr"));
    const ExrImage ib = readExr(dir.file("big.exr"));
    EXPECT_NO_THROW(compareExr(ia, ia, "caustic_filtered", "caustic_filtered"));
    try {
        compareExr(id, ia, "caustic_filtered", "caustic_filtered", {}, "direct.exr", "a.exr");
        FAIL() << "missing channel accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("direct.exr: missing channel(s) caustic_filtered.R"), std::string::npos)
            << e.what();
    }
    try {
        compareExr(ib, ia, "caustic", "caustic", {}, "big.exr", "a.exr");
        FAIL() << "size mismatch accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("size mismatch"), std::string::npos) << e.what();
    }
}

#ifdef RTPM_BINARY_DIR
// Runs rtpm-compare and returns its exit status; stdout+stderr go to `log`.
int runCompare(const std::string& args, const std::string& log) {
    const std::string exe = std::string(RTPM_BINARY_DIR) + "/common/cmd/rtpm-compare";
    if (!std::filesystem::exists(exe)) return -1;
    const int status = std::system((exe + " " + args + " > " + log + " 2>&1").c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
}

std::string slurp(const std::string& path) {
    std::string s;
    if (FILE* f = std::fopen(path.c_str(), "rb")) {
        char buf[4096];
        size_t n;
        while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
        std::fclose(f);
    }
    return s;
}

TEST(RtpmCompare, ExitCodesAndCsvOutput) {
    const std::string exe = std::string(RTPM_BINARY_DIR) + "/common/cmd/rtpm-compare";
    if (!std::filesystem::exists(exe)) GTEST_SKIP() << "rtpm-compare not built in " << RTPM_BINARY_DIR;
    TempDir dir;
    std::vector<float> ref = constant(0.0f), out = constant(0.0f);
    for (int x = 0; x < kW; ++x) {
        setPixel(ref, x, 2, 4.0f);
        setPixel(out, x, 2, 4.4f);
    }
    writeCausticExr(dir.file("ref.exr"), kW, kH, ref);
    writeCausticExr(dir.file("out.exr"), kW, kH, out);
    const ImageLayer direct[] = {{"direct", ref}};
    writeExr(dir.file("direct.exr"), kW, kH, direct);
    writeCausticExr(dir.file("wide.exr"), kW + 1, kH, std::vector<float>(size_t(kW + 1) * kH * 3, 0.0f));
    const std::string log = dir.file("log.txt");

    EXPECT_EQ(runCompare(dir.file("out.exr") + " " + dir.file("ref.exr") + " --csv", log), 0) << slurp(log);
    const std::string csv = slurp(log);
    EXPECT_NE(csv.find("layer,width,height"), std::string::npos) << csv;
    EXPECT_NE(csv.find("caustic_filtered,20,10,"), std::string::npos) << csv;
    EXPECT_NE(csv.find(",1.1,"), std::string::npos) << csv;  // the energy ratio

    EXPECT_EQ(runCompare(dir.file("out.exr") + " " + dir.file("ref.exr") + " --max-rel-rmse 0.05", log), 3);
    EXPECT_EQ(runCompare(dir.file("out.exr") + " " + dir.file("ref.exr") + " --max-rel-rmse 0.2", log), 0);
    EXPECT_EQ(runCompare(dir.file("out.exr") + " " + dir.file("ref.exr") + " --energy-bounds 0.95 1.05", log), 3);

    // A command line that cannot be used: 2, the program's name and the flag it was meant to be.
    EXPECT_EQ(runCompare(dir.file("out.exr") + " " + dir.file("ref.exr") + " --max-rel-rsme 0.2", log), 2);
    EXPECT_NE(slurp(log).find("rtpm-compare: unknown flag --max-rel-rsme: did you mean --max-rel-rmse?"),
              std::string::npos)
        << slurp(log);
    EXPECT_EQ(runCompare("--version", log), 0);
    EXPECT_NE(slurp(log).find("rtpm-compare "), std::string::npos) << slurp(log);
    EXPECT_NE(slurp(log).find("protocol version "), std::string::npos) << slurp(log);

    EXPECT_EQ(runCompare(dir.file("missing.exr") + " " + dir.file("ref.exr"), log), 1);
    EXPECT_NE(slurp(log).find("missing.exr: no such file"), std::string::npos) << slurp(log);
    EXPECT_EQ(runCompare(dir.file("wide.exr") + " " + dir.file("ref.exr"), log), 1);
    EXPECT_NE(slurp(log).find("size mismatch"), std::string::npos) << slurp(log);
    EXPECT_EQ(runCompare(dir.file("direct.exr") + " " + dir.file("ref.exr"), log), 1);
    EXPECT_NE(slurp(log).find("missing channel(s) caustic_filtered.R"), std::string::npos) << slurp(log);
}
#endif

}  // namespace
}  // namespace rtpm
