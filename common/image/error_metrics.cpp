// Error metrics between rendered and reference layers: caustic region, whole image, energy ratio.
#include "common/image/error_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "common/image/image_io.h"

namespace rtpm {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double luminance(const float* rgb) {
    return 0.2126 * double(rgb[0]) + 0.7152 * double(rgb[1]) + 0.0722 * double(rgb[2]);
}

void checkSize(std::span<const float> buffer, size_t expected, const char* what) {
    if (buffer.size() != expected)
        throw std::invalid_argument(std::string(what) + " buffer holds " + std::to_string(buffer.size()) +
                                    " floats, expected width·height·3 = " + std::to_string(expected));
}

// Running sums of one region; doubles, since a 4k image's squared errors would drift in float.
struct Accumulator {
    size_t pixels = 0;
    size_t values = 0;
    double sumSq = 0.0, sumAbs = 0.0, sumRef = 0.0;
    void add(double o, double r) {
        const double d = o - r;
        sumSq += d * d;
        sumAbs += std::abs(d);
        sumRef += std::abs(r);
        ++values;
    }
    RegionError result() const {
        RegionError e;
        e.pixels = pixels;
        if (values == 0) {
            e.relRmse = e.mae = e.relMae = e.refMean = kNaN;
            return e;
        }
        const double n = double(values);
        e.refMean = sumRef / n;
        e.mae = sumAbs / n;
        const double rmse = std::sqrt(sumSq / n);
        e.relRmse = e.refMean > 0.0 ? rmse / e.refMean : kNaN;
        e.relMae = e.refMean > 0.0 ? e.mae / e.refMean : kNaN;
        return e;
    }
};

}  // namespace

double regionThreshold(std::span<const float> mask, const RegionSettings& region) {
    if (!(region.regionFraction > 0.0 && region.regionFraction <= 1.0) ||
        !(region.regionPercentile > 0.0 && region.regionPercentile <= 1.0))
        throw std::invalid_argument("region fraction and percentile must lie in (0, 1]");
    std::vector<double> lit;
    for (size_t i = 0; i + 2 < mask.size(); i += 3) {
        const double l = luminance(&mask[i]);
        if (l > 0.0 && std::isfinite(l)) lit.push_back(l);
    }
    if (lit.empty()) return 0.0;
    const size_t k = std::min(lit.size() - 1,
                              size_t(std::floor(region.regionPercentile * double(lit.size() - 1) + 0.5)));
    std::nth_element(lit.begin(), lit.begin() + std::ptrdiff_t(k), lit.end());
    return region.regionFraction * lit[k];
}

ErrorMetrics compareRgb(std::span<const float> output, std::span<const float> reference,
                        std::span<const float> mask, int width, int height, const RegionSettings& region) {
    if (width <= 0 || height <= 0) throw std::invalid_argument("image size must be positive");
    const size_t n = size_t(width) * size_t(height) * 3;
    checkSize(output, n, "output");
    checkSize(reference, n, "reference");
    checkSize(mask, n, "mask");

    ErrorMetrics m;
    m.width = width;
    m.height = height;
    m.threshold = regionThreshold(mask, region);
    const bool anyLit = m.threshold > 0.0;

    Accumulator inRegion, all;
    double sumOut = 0.0, sumRef = 0.0;
    for (size_t p = 0; p < n; p += 3) {
        const bool caustic = anyLit && luminance(&mask[p]) > m.threshold;
        if (caustic) ++inRegion.pixels;
        ++all.pixels;
        for (size_t c = 0; c < 3; ++c) {
            const float o = output[p + c];
            const float r = reference[p + c];
            const bool outOk = std::isfinite(o);
            const bool refOk = std::isfinite(r);
            if (!outOk) ++m.nonFiniteOutput;
            if (!refOk) ++m.nonFiniteReference;
            if (!outOk || !refOk) continue;
            all.add(o, r);
            if (caustic) inRegion.add(o, r);
            sumOut += o;
            sumRef += r;
        }
    }
    m.caustic = inRegion.result();
    m.image = all.result();
    m.energyRatio = sumRef != 0.0 ? sumOut / sumRef : kNaN;
    return m;
}

std::string defaultMaskLayer(const std::string& layer) {
    return layer.rfind("caustic", 0) == 0 ? layer : std::string("caustic");
}

namespace {

std::vector<float> layerOf(const ExrImage& img, const std::string& layer, const std::string& fileName) {
    const char* suffixes[3] = {"R", "G", "B"};
    std::vector<std::string> missing;
    for (const char* s : suffixes) {
        const std::string ch = layer.empty() ? std::string(s) : layer + "." + s;
        if (!img.channels.count(ch)) missing.push_back(ch);
    }
    if (!missing.empty()) {
        std::string list;
        for (const std::string& m : missing) list += (list.empty() ? "" : ", ") + m;
        std::string have;
        for (const std::string& c : img.channelNames) have += (have.empty() ? "" : " ") + c;
        throw std::invalid_argument(fileName + ": missing channel(s) " + list + " (the file has: " +
                                    (have.empty() ? std::string("none") : have) + ")");
    }
    return img.layerRgb(layer);
}

}  // namespace

ErrorMetrics compareExr(const ExrImage& output, const ExrImage& reference, const std::string& layer,
                        const std::string& maskLayer, const RegionSettings& region,
                        const std::string& outputName, const std::string& referenceName) {
    if (output.width != reference.width || output.height != reference.height)
        throw std::invalid_argument("size mismatch: " + outputName + " is " + std::to_string(output.width) +
                                    "x" + std::to_string(output.height) + ", " + referenceName + " is " +
                                    std::to_string(reference.width) + "x" + std::to_string(reference.height));
    const std::vector<float> out = layerOf(output, layer, outputName);
    const std::vector<float> ref = layerOf(reference, layer, referenceName);
    const std::vector<float> mask = maskLayer == layer ? ref : layerOf(reference, maskLayer, referenceName);
    return compareRgb(out, ref, mask, output.width, output.height, region);
}

}  // namespace rtpm
