// rtpm-compare: error metrics of a rendered EXR against a reference EXR, as a table or CSV.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "common/cmd/command_line.h"
#include "common/core/version.h"
#include "common/core/console.h"
#include "common/image/error_metrics.h"
#include "common/image/image_io.h"

namespace {

using namespace rtpm;

// Exit codes: scripts tell a failed comparison from a comparison that could not be made, and
// both from a command line that cannot be used (kExitUsage, 2, as every program).
constexpr int kExitError = 1;      // missing file, size mismatch, missing channel
constexpr int kExitOverBound = 3;  // --max-rel-rmse, --energy-bounds or --identical not met

std::string fmt(double v, const char* spec = "%.4g") {
    if (std::isnan(v)) return "n/a";
    char buf[64];
    std::snprintf(buf, sizeof buf, spec, v);
    return buf;
}

ExrImage load(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw std::runtime_error(path + ": no such file");
    if (std::filesystem::is_directory(path, ec)) throw std::runtime_error(path + ": is a directory");
    return readExr(path);
}

// Whether `output` holds the channels of `reference` with bit-identical values (NaN payloads and
// the sign of zero included); on a difference, says on stderr where the first one lies. The
// header's attributes (which program wrote the file, …) are not compared.
bool identicalPixels(const ExrImage& output, const ExrImage& reference) {
    if (output.width != reference.width || output.height != reference.height) {
        std::fprintf(stderr, "rtpm-compare: not identical: %dx%d against %dx%d pixels\n", output.width,
                     output.height, reference.width, reference.height);
        return false;
    }
    if (output.channelNames != reference.channelNames) {
        std::fprintf(stderr, "rtpm-compare: not identical: the files hold different channels\n");
        return false;
    }
    bool same = true;
    for (const std::string& name : reference.channelNames) {
        const std::vector<float>& o = output.channels.at(name);
        const std::vector<float>& r = reference.channels.at(name);
        size_t differing = 0, first = 0;
        for (size_t i = 0; i < r.size(); ++i) {
            if (std::memcmp(&o[i], &r[i], sizeof(float)) == 0) continue;
            if (differing++ == 0) first = i;
        }
        if (differing == 0) continue;
        const int width = std::max(reference.width, 1);
        std::fprintf(stderr,
                     "rtpm-compare: not identical: channel %s differs at %zu pixels, the first at (%d, %d): "
                     "%.9g against %.9g\n",
                     name.c_str(), differing, int(first % width), int(first / width), o[first], r[first]);
        same = false;
    }
    return same;
}

int run(int argc, char** argv) {
    std::string outputPath, referencePath, maskLayer;
    std::vector<std::string> layers;
    RegionSettings region;
    bool csv = false;
    bool identical = false;
    double maxRelRmse = 0.0;
    std::vector<double> energyBounds;
    CLI::App app{
        "rtpm-compare: errors of OUTPUT.exr against REFERENCE.exr, per layer.\n"
        "Caustic region: pixels whose reference mask-layer luminance exceeds FRACTION x the\n"
        "PERCENTILE quantile of its positive values (default 5% of the 99th percentile).\n"
        "rel_rmse = sqrt(mean((o-r)^2)) / mean(|r|); mae = mean(|o-r|); rel_mae = mae / mean(|r|)\n"
        "over all channels of the region's pixels; energy = sum(o) / sum(r) over the whole image.",
        "rtpm-compare"};
    app.add_option("output", outputPath, "rendered EXR (the image judged)")->required();
    app.add_option("reference", referencePath, "reference EXR (converged or analytic)")->required();
    app.add_option("--layer", layers,
                   "layer(s) to compare: caustic_filtered, caustic, direct, or \"\" / final for R G B "
                   "(repeatable; default caustic_filtered)");
    app.add_option("--mask-layer", maskLayer,
                   "reference layer that defines the caustic region (default: the compared layer if it "
                   "is a caustic layer, else caustic)");
    app.add_option("--fraction", region.regionFraction, "region threshold relative to the quantile")
        ->capture_default_str()
        ->check(CLI::Range(1e-9, 1.0));
    app.add_option("--percentile", region.regionPercentile, "quantile of positive mask luminance, (0, 1]")
        ->capture_default_str()
        ->check(CLI::Range(1e-9, 1.0));
    app.add_flag("--csv", csv, "print CSV (header + one row per layer) instead of a table");
    app.add_option("--max-rel-rmse", maxRelRmse, "fail (exit 3) when the caustic-region rel_rmse exceeds this");
    app.add_option("--energy-bounds", energyBounds, "fail (exit 3) when the energy ratio is outside [LO, HI]")
        ->expected(2);
    app.add_flag("--identical", identical,
                 "fail (exit 3) unless both files hold the same channels with bit-identical values (the "
                 "header's attributes, such as the program that wrote it, are not compared)");
    addStandardFlags(app, kWireProtocolVersion,
                     {{0, "compared, within the bounds given"},
                      {kExitError, "cannot compare: missing file or channel, size mismatch"},
                      {kExitOverBound, "a bound given by --max-rel-rmse or --energy-bounds is not met, the pixels "
                                       "differ under --identical, or OUTPUT holds NaN/Inf values"}},
                     {{"rtpm-compare out/ring.exr reference.exr",
                       "the filtered caustic's errors against a reference, and the energy ratio"},
                      {"rtpm-compare --identical out/cluster.exr out/single.exr",
                       "exit 0 only if both images hold bit-identical pixels"}});
    if (auto code = parseCommandLine(app, argc, argv)) return *code;
    if (layers.empty()) layers.push_back("caustic_filtered");
    for (std::string& l : layers)
        if (l == "final") l.clear();

    const ExrImage output = load(outputPath);
    const ExrImage reference = load(referencePath);

    bool overBound = identical && !identicalPixels(output, reference);
    if (csv) {
        std::printf("layer,width,height,threshold,caustic_pixels,caustic_rel_rmse,caustic_mae,caustic_rel_mae,"
                    "image_rel_rmse,image_mae,image_rel_mae,energy_ratio,nonfinite_output,nonfinite_reference\n");
    } else {
        std::printf("output    %s\nreference %s\n", outputPath.c_str(), referencePath.c_str());
        std::printf("%-18s %8s %10s %10s %10s | %10s %10s %10s | %8s\n", "layer", "region_px", "rel_rmse", "mae",
                    "rel_mae", "img_rmse", "img_mae", "img_rmae", "energy");
    }
    for (const std::string& layer : layers) {
        const std::string mask = maskLayer.empty() ? defaultMaskLayer(layer) : maskLayer;
        const ErrorMetrics m = compareExr(output, reference, layer, mask, region, outputPath, referencePath);
        const std::string name = layer.empty() ? "final" : layer;
        if (csv) {
            std::printf("%s,%d,%d,%.6g,%zu,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%zu,%zu\n", name.c_str(), m.width,
                        m.height, m.threshold, m.caustic.pixels, m.caustic.relRmse, m.caustic.mae,
                        m.caustic.relMae, m.image.relRmse, m.image.mae, m.image.relMae, m.energyRatio,
                        m.nonFiniteOutput, m.nonFiniteReference);
        } else {
            std::printf("%-18s %8zu %10s %10s %10s | %10s %10s %10s | %8s\n", name.c_str(), m.caustic.pixels,
                        fmt(m.caustic.relRmse).c_str(), fmt(m.caustic.mae).c_str(), fmt(m.caustic.relMae).c_str(),
                        fmt(m.image.relRmse).c_str(), fmt(m.image.mae).c_str(), fmt(m.image.relMae).c_str(),
                        fmt(m.energyRatio, "%.4f").c_str());
        }
        if (m.nonFiniteOutput || m.nonFiniteReference) {
            std::fprintf(stderr, "rtpm-compare: %s: %zu non-finite values in %s, %zu in %s (excluded)\n",
                         name.c_str(), m.nonFiniteOutput, outputPath.c_str(), m.nonFiniteReference,
                         referencePath.c_str());
            overBound = overBound || m.nonFiniteOutput > 0;
        }
        if (maxRelRmse > 0.0 && !(m.caustic.relRmse <= maxRelRmse)) {
            std::fprintf(stderr, "rtpm-compare: %s: caustic rel_rmse %s exceeds %g\n", name.c_str(),
                         fmt(m.caustic.relRmse).c_str(), maxRelRmse);
            overBound = true;
        }
        if (energyBounds.size() == 2 && !(m.energyRatio >= energyBounds[0] && m.energyRatio <= energyBounds[1])) {
            std::fprintf(stderr, "rtpm-compare: %s: energy ratio %s outside [%g, %g]\n", name.c_str(),
                         fmt(m.energyRatio).c_str(), energyBounds[0], energyBounds[1]);
            overBound = true;
        }
    }
    return overBound ? kExitOverBound : 0;
}

}  // namespace

int main(int argc, char** argv) {
    rtpm::lineBufferConsole();
    try {
        return run(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtpm-compare: %s\n", e.what());
    }
    return kExitError;
}
