// Error metrics between a rendered layer and a reference layer (docs/ARCHITECTURE.md §12: every
// speed figure stands next to a measured error).
#pragma once

#include <cstddef>
#include <span>
#include <string>

namespace rtpm {

struct ExrImage;

/// How the caustic region is chosen.
///
/// The region is the set of pixels whose reference *mask layer* luminance (Rec. 709 weights of
/// linear RGB) exceeds `regionFraction` × the `regionPercentile` quantile of that luminance over
/// the pixels where it is positive. Taking the quantile over the lit pixels only (not over the
/// whole image) keeps the threshold meaningful when the caustic covers less than 1 % of the
/// image, where the plain 99th percentile of all pixels would be zero; the 99th percentile rather
/// than the maximum keeps a handful of hot pixels from raising the threshold. With the defaults
/// (5 % of the 99th percentile) the region is "where the caustic is clearly visible": its faint
/// tails, where a relative error means little, are left to the whole-image figures.
struct RegionSettings {
    double regionFraction = 0.05;     ///< threshold relative to the quantile, in (0, 1]
    double regionPercentile = 0.99;   ///< quantile of positive mask luminance, in (0, 1]
};

/// Errors of one region (all channels of every pixel in it).
///  * relRmse = sqrt(mean((o − r)²)) / mean(|r|): the RMSE in units of the reference's mean
///    value there (a coefficient of variation of the error; 0.1 reads "10 % of the typical value").
///  * mae = mean(|o − r|) in the layer's units (W/(m²·sr) for radiance layers);
///    relMae = mae / mean(|r|).
/// All three are NaN when the region is empty; relRmse and relMae are NaN when mean(|r|) is 0.
struct RegionError {
    size_t pixels = 0;  ///< pixels in the region
    double relRmse = 0.0;
    double mae = 0.0;
    double relMae = 0.0;
    double refMean = 0.0;  ///< mean(|r|) over the region's channels
};

/// Metrics of one output layer against its reference layer.
struct ErrorMetrics {
    int width = 0;
    int height = 0;
    double threshold = 0.0;  ///< mask luminance above which a pixel is in the caustic region
    RegionError caustic;     ///< pixels of the caustic region
    RegionError image;       ///< every pixel
    /// Σ output / Σ reference over every channel of every pixel (the caustic energy ratio when
    /// the layers are caustic layers); NaN when the reference sums to 0.
    double energyRatio = 0.0;
    /// Output values that were NaN/Inf (counted per channel). They are excluded from every sum
    /// above; any non-zero count is itself a failure of the renderer.
    size_t nonFiniteOutput = 0;
    size_t nonFiniteReference = 0;  ///< same for the reference
};

/// Compares interleaved RGB buffers `output` and `reference` (width·height·3 floats each, row-
/// major), the region chosen from `mask` (width·height·3, usually the reference caustic layer).
/// Throws std::invalid_argument if a size is not width·height·3. Pure; cost O(W·H) plus one
/// nth_element for the quantile.
ErrorMetrics compareRgb(std::span<const float> output, std::span<const float> reference,
                        std::span<const float> mask, int width, int height,
                        const RegionSettings& region = {});

/// The luminance threshold compareRgb uses for `mask` (see RegionSettings). 0 when no pixel of
/// the mask is positive (the region is then empty).
double regionThreshold(std::span<const float> mask, const RegionSettings& region = {});

/// The mask layer compareExr uses by default for comparing `layer`: the layer itself when its
/// name starts with "caustic", otherwise "caustic" (the region is where the caustic is, even when
/// the final or direct image is compared).
std::string defaultMaskLayer(const std::string& layer);

/// Compares layer `layer` ("" = R G B, otherwise layer.R/.G/.B) of two decoded images; the region
/// comes from layer `maskLayer` of the reference. Throws std::invalid_argument with a message
/// naming what is wrong when the sizes differ or a channel is missing (which file, which channel).
ErrorMetrics compareExr(const ExrImage& output, const ExrImage& reference, const std::string& layer,
                        const std::string& maskLayer, const RegionSettings& region = {},
                        const std::string& outputName = "output",
                        const std::string& referenceName = "reference");

}  // namespace rtpm
