// The still view's error figure from the shown caustic alone: how much it changed since the
// progression had half its photons.
//
// A progressive estimate's error falls as its photons grow; between the image with N photons and
// the one with N/2 the caustic changes by about its error at N: the noise of the photons in
// between (the noise at N/2 is √2 × that at N, the two share half their photons) and the blur the
// shrinking discs have shed (at r² ∝ 1/√N a doubling sheds 1 − 2^(−½) of it). Measured on the four
// analytic scenes at the defaults (tests/support/progressive_run.h), this change reads 0.56–1.59 ×
// the true caustic-region rel. MAE from frame 2 on (320×240 with the 16.7 ms budget's turns:
// 0.95–1.16 from frame 8 on, ring_mirror_bench), where the estimator's own
// figure (progressive.h causticErrorEstimate: Poisson noise and a blur step per pixel) read
// 0.43–3.3 ×: its Poisson noise over-counts QMC photons two to three times on smooth glass
// caustics, and it misses the box filter's blur on a mirror's fold lines.
//
// "Half" is measured in photons, not frames: each frame says how far the progression went (`work`,
// the batches in the sets' estimates, CausticErrorSums::batches), and the image compared is the
// kept one with the most work at most half the frame's, provided it has at least
// kHalfTolerance × that half. Frames and photons grow alike with one batch per pass and no
// turns; where the sets take turns or the restart's map held many batches they do not, and the
// image of half the frames held far more than half the photons: at the 16.7 ms budget the curved
// mirror's figure read 0.024 at frame 16 where the true error was 0.051 (ring_mirror_bench), and
// --target-error 0.03 stopped a cluster at a true 0.051.
// Frames are counted from the progression's first frame (1); the image is kept at frames b·2^k
// with b < 8 (1 … 8, 10, 12, 14, 16, 20, …: four per doubling) while no later frame can need it.
// At such a frame n ≥ 2 whose half is kept and lies at least `period` frames back (sets take
// turns, pass_budget.h: a set off its turn shows its last pixels, so fewer frames between would
// hide change), the figure is rel. MAE(image n, half image) over image n's caustic region
// (error_metrics.h); between such frames the last figure holds. rtpm-render and the master both
// feed it their composed image and the sets' batches, so the same frames give the same figure in
// one process and in a cluster.
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
    /// `period` is the frame's pass period (1 without turns), `work` how far its estimate went
    /// (Σ over the sets of the batches in their estimates; 0 = unknown, the frame is counted but
    /// neither kept nor compared). `caustic` is the shown caustic, width·height·3 floats. Returns
    /// the figure (0 while none is known yet).
    /// Cost: a copy of the image at the kept frames, one comparison at those frames.
    double add(bool converging, uint32_t period, double work, std::span<const float> caustic, int width, int height);
    /// A half image has at least this share of half the frame's work (2^-1/4: the kept frames
    /// are four per doubling).
    static constexpr double kHalfTolerance = 0.8408964152537145;
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
    struct Kept {
        uint64_t frame = 0;
        double work = 0.0;
        std::vector<float> image;
    };
    std::vector<Kept> images_;  ///< kept frames, oldest first
};

/// The error figure printed, shown and compared with --target-error: the change (ShownChange::add)
/// where the progressive estimator's own figure says it composed the frame (> 0) and a change is
/// known, that own figure otherwise (0 = none: knn, moving frames).
inline double shownErrorFigure(double estimatorFigure, double change) {
    return estimatorFigure > 0.0 && change > 0.0 ? change : estimatorFigure;
}

}  // namespace rtpm
