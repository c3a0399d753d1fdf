// A full-resolution frame assembled from interleaving sets: direct, caustic, filtered and final.
#pragma once

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
    void scatter(const Interleave& pattern, int set, std::span<const PixelRadiance> pixels);
    /// Box-filters the caustic buffer with an f × f window (DESIGN §4) and composes final.
    /// Cost: O(W·H) independent of f.
    void filterAndCompose(int f);

    int width() const { return width_; }
    int height() const { return height_; }
    const std::vector<float>& direct() const { return direct_; }
    const std::vector<float>& caustic() const { return caustic_; }
    const std::vector<float>& causticFiltered() const { return causticFiltered_; }
    const std::vector<float>& final() const { return final_; }

private:
    int width_;
    int height_;
    std::vector<float> direct_, caustic_, causticFiltered_, final_;
    BoxFilter filter_;
};

}  // namespace rtpm
