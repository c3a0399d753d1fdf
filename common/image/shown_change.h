// The still view's error figure from the shown caustic alone: how much it changed since the
// progression had half its frames.
//
// A progressive estimate's error falls as its photons grow; between the image at frame n and the
// one at frame n/2 the caustic changes by about its error at n: the noise of the frames in
// between (the noise at n/2 is √2 × that at n, the two share half their photons) and the blur the
// shrinking discs have shed (at r² ∝ 1/√N a doubling sheds 1 − 2^(−½) of it). Measured on the four
// analytic scenes at the defaults (tests/support/progressive_run.h), this change reads 0.56–1.76 ×
// the true caustic-region rel. MAE from frame 2 on, where the estimator's own
// figure (progressive.h causticErrorEstimate: Poisson noise and a blur step per pixel) read
// 0.43–3.3 ×: its Poisson noise over-counts QMC photons two to three times on smooth glass
// caustics, and it misses the box filter's blur on a mirror's fold lines.
//
// Frames are counted from the progression's first frame (1); the image is kept at frames b·2^k
// with b < 8 (1 … 8, 10, 12, 14, 16, 20, …: four per doubling), each until no later such frame
// needs it as its half (four or five images at once).
// At such a frame n ≥ 2 whose half n/2 is kept, and at least `period` frames after it (sets take
// turns, pass_budget.h: a set off its turn shows its last pixels, so fewer frames between would
// hide change), the figure is rel. MAE(image n, image n/2) over image n's caustic region
// (error_metrics.h); between such frames the last figure holds. rtpm-render and the master both
// feed it their composed image, so the same frames give the same figure in one process and in a
// cluster.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace rtpm {

class ShownChange {
public:
    /// One composed frame: `converging` false (or another image size) restarts the count (a
    /// progression's first frame),
    /// `period` is the frame's pass period (1 without turns). `caustic` is the shown caustic,
    /// width·height·3 floats. Returns the figure (0 while none is known yet).
    /// Cost: a copy of the image at the kept frames, one comparison at those frames.
    double add(bool converging, uint32_t period, std::span<const float> caustic, int width, int height);
    /// Frames of the current progression so far (the first is 1).
    uint64_t frame() const { return frame_; }
    /// The last figure (0 = none yet).
    double figure() const { return figure_; }

    /// Frames whose image is kept: b·2^k with b < 8.
    static bool kept(uint64_t n);

private:
    uint64_t frame_ = 0;
    int width_ = 0, height_ = 0;  ///< of the kept images
    double figure_ = 0.0;
    std::vector<std::pair<uint64_t, std::vector<float>>> images_;  ///< kept frames, oldest first
};

/// The error figure printed, shown and compared with --target-error: the change (ShownChange::add)
/// where the progressive estimator's own figure says it composed the frame (> 0) and a change is
/// known, that own figure otherwise (0 = none: knn, moving frames).
inline double shownErrorFigure(double estimatorFigure, double change) {
    return estimatorFigure > 0.0 && change > 0.0 ? change : estimatorFigure;
}

}  // namespace rtpm
