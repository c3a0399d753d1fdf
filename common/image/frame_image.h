// A full-resolution frame assembled from interleaving sets: direct, caustic, filtered and final.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/image/box_filter.h"
#include "common/core/pixel_radiance.h"
#include "common/core/interleave.h"

namespace rtpm {

/// The master's (and the single-process renderer's) image buffers, RGB float row-major.
/// final = direct + box-filtered caustic (paper §4.1). Not thread-safe.
class FrameImage {
public:
    FrameImage(int width, int height);

    /// Writes the pixels of `set` (row-major within the set, as renderSet produces them) into
    /// the direct and caustic buffers. Precondition (checked): pixels.size() == pixelCount(set).
    /// `ownWeight` in [0, 1] is the weight the set's own caustic values get against the
    /// box-filtered ones when composing (0: the paper's image).
    void scatter(const Interleave& pattern, int set, std::span<const PixelRadiance> pixels,
                 float ownWeight = 0.0f);
    /// The same with one own weight per pixel of the set, in 255ths (size pixels.size(); the
    /// progressive estimator's choice, progressive.h), and the relative noise of each caustic
    /// value in 64ths (ProgressiveSet::noise), which the filter's edge test allows for; empty,
    /// or the other overload: unknown, taken as infinite (no edge read at those pixels).
    void scatter(const Interleave& pattern, int set, std::span<const PixelRadiance> pixels,
                 std::span<const uint8_t> ownWeights, std::span<const uint8_t> noise = {});
    /// Box-filters the caustic buffer with an f × f window (docs/ARCHITECTURE.md §4) into filtered
    /// B, then composes, per pixel with its set's own weight w: shown = w·caustic + (1 − w)·B
    /// (exactly B where w = 0), causticFiltered = shown, final = direct + shown.
    /// With edgeRatio > 0 (and f > 1) B is the box that stops at the caustic's edges
    /// (edgeStoppingBox, box_filter.h; RenderSettings::filterEdgeRatio).
    /// Cost: O(W·H) independent of f; O(W·H·f²) with edgeRatio.
    void filterAndCompose(int f, float edgeRatio = 0.0f);

    int width() const { return width_; }
    int height() const { return height_; }
    const std::vector<float>& direct() const { return direct_; }
    const std::vector<float>& caustic() const { return caustic_; }
    const std::vector<float>& causticFiltered() const { return causticFiltered_; }
    const std::vector<float>& final() const { return final_; }

private:
    template <class Weight, class Noise>
    void scatterImpl(const Interleave& pattern, int set, std::span<const PixelRadiance> pixels,
                     Weight&& weight, Noise&& noise);

    int width_;
    int height_;
    std::vector<float> direct_, caustic_, causticFiltered_, final_;
    std::vector<float> ownWeight_;  ///< per pixel
    std::vector<float> noise_;      ///< per pixel: the caustic value's relative noise (scatter)
    BoxFilter filter_;
    std::vector<float> edgeScratch_;  ///< edgeStoppingBox's output, swapped in
};

}  // namespace rtpm
