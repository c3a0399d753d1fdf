// Frame assembly: scatter interleaved sets, box-filter the caustic buffer, compose the final image.
#include "common/image/frame_image.h"

#include <algorithm>
#include <limits>

#include "common/core/check.h"

namespace rtpm {

namespace {
// A pixel's noise when its set sent none: infinite, every difference there is noise.
constexpr float kUnknownNoise = std::numeric_limits<float>::infinity();
}  // namespace

FrameImage::FrameImage(int width, int height) : width_(width), height_(height) {
    RTPM_CHECK(width > 0 && height > 0);
    const size_t n = size_t(width) * size_t(height) * 3;
    direct_.assign(n, 0.0f);
    caustic_.assign(n, 0.0f);
    causticFiltered_.assign(n, 0.0f);
    final_.assign(n, 0.0f);
    ownWeight_.assign(size_t(width) * size_t(height), 0.0f);
    noise_.assign(size_t(width) * size_t(height), kUnknownNoise);
}

void FrameImage::scatter(const Interleave& pattern, int set, std::span<const PixelRadiance> pixels,
                         float ownWeight) {
    RTPM_CHECK(ownWeight >= 0.0f && ownWeight <= 1.0f);
    // No noise known (knn, a moving view's frames): infinite, so the filter reads no edge there.
    scatterImpl(pattern, set, pixels, [&](size_t) { return ownWeight; },
                [](size_t) { return kUnknownNoise; });
}

void FrameImage::scatter(const Interleave& pattern, int set, std::span<const PixelRadiance> pixels,
                         std::span<const uint8_t> ownWeights, std::span<const uint8_t> noise) {
    RTPM_CHECK(ownWeights.size() == pixels.size());
    RTPM_CHECK(noise.empty() || noise.size() == pixels.size());
    scatterImpl(
        pattern, set, pixels, [&](size_t i) { return float(ownWeights[i]) * (1.0f / 255.0f); },
        [&](size_t i) { return noise.empty() ? kUnknownNoise : float(noise[i]) * (1.0f / 64.0f); });
}

template <class Weight, class Noise>
void FrameImage::scatterImpl(const Interleave& pattern, int set, std::span<const PixelRadiance> pixels,
                             Weight&& weight, Noise&& noise) {
    RTPM_CHECK(pattern.width == width_ && pattern.height == height_);
    RTPM_CHECK(pixels.size() == size_t(pattern.pixelCount(set)));
    const int cols = pattern.setColumns(set);
    const int rows = pattern.setRows(set);
    const int x0 = set % pattern.m;
    const int y0 = set / pattern.m;
    for (int r = 0; r < rows; ++r) {
        const size_t rowBase = size_t(y0 + r * pattern.m) * size_t(width_);
        for (int c = 0; c < cols; ++c) {
            const PixelRadiance& p = pixels[size_t(r) * size_t(cols) + size_t(c)];
            const size_t o = (rowBase + size_t(x0 + c * pattern.m)) * 3;
            ownWeight_[o / 3] = weight(size_t(r) * size_t(cols) + size_t(c));
            noise_[o / 3] = noise(size_t(r) * size_t(cols) + size_t(c));
            for (int k = 0; k < 3; ++k) {
                direct_[o + k] = p.direct[k];
                caustic_[o + k] = p.caustic[k];
            }
        }
    }
}

void FrameImage::filterAndCompose(int f, float edgeRatio) {
    filter_.apply(caustic_, width_, height_, f, causticFiltered_);
    // Where no set sent its noise (a moving view's frames) every weight is 1: the box as it is.
    const bool anyNoise = std::any_of(noise_.begin(), noise_.end(), [](float n) { return n < kUnknownNoise; });
    if (edgeRatio > 0.0f && f > 1 && anyNoise) {
        edgeScratch_.resize(causticFiltered_.size());
        edgeStoppingBox(caustic_, causticFiltered_, noise_, width_, height_, f, edgeRatio, edgeScratch_);
        causticFiltered_.swap(edgeScratch_);
    }
    for (size_t i = 0; i < final_.size(); ++i) {
        const float w = ownWeight_[i / 3];
        if (w > 0.0f) causticFiltered_[i] = w * caustic_[i] + (1.0f - w) * causticFiltered_[i];
        final_[i] = direct_[i] + causticFiltered_[i];
    }
}

}  // namespace rtpm
