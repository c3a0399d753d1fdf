// The still view's error figure from the shown caustic alone: how much it changed since the
// progression had a sixth of its photons, scaled as the change of a photon estimate's noise.
//
// A progressive estimate's error falls as its photons grow. For N photons of which the image
// with M < N holds M (the passes add photons, the earlier ones stay), Poisson noise of variance
// v at N gives the two images a difference of variance v · (N/M − 1): the change divided by
// √(N/M − 1) is the noise at N. Blur, the other part of the error, sheds only a share of itself
// between M and N (at r² ∝ 1/√N, 1 − (M/N)^½), so the change under-counts it, the less the
// longer the baseline; QMC noise (smooth glass caustics) changes more than Poisson's between
// two images, and the longer baseline over-counts it less than the change since half did.
// Measured on the four analytic scenes at the defaults (tests/support/progressive_run.h, 160×120,
// frames 4–64), the figure reads 0.61–1.35 × the true caustic-region rel. MAE with the baseline
// at a sixth of the photons; with the baseline at half (the figure until 2026-11-27) the change
// read 0.58–1.67 × (the glass slab's QMC noise 1.09–1.67 ×, the flat mirror's blur 0.58 ×), at a
// quarter 0.62–1.42 ×, at an eighth 0.59–1.31 ×. The estimator's own figure (progressive.h
// causticErrorEstimate: Poisson noise and a blur step per pixel) read 0.43–3.3 ×.
//
// Photons, not frames: each frame says how far the progression went (`work`, the batches in the
// sets' estimates, CausticErrorSums::batches). Frames and photons grow alike with one batch per
// pass and no turns; where the sets take turns or the restart's map held many batches they do not
// (at the 16.7 ms budget the curved mirror's image at half the frames held far more than half the
// photons, and a figure of frames read half the true error).
// Frames are counted from the progression's first frame (1); the image is kept at frames b·2^k
// with b < 8 (1 … 8, 10, 12, 14, 16, 20, …: four per doubling) while it may still be a baseline,
// and of those holding less than half the last frame's work only the ones with b ∈ {1, 3} (two
// per doubling), so about nine images are held. At such a frame n ≥ 2 the baseline is
// the kept image with the least work of those with at least kBaselineTolerance / kBaselineRatio
// and at most a third of frame n's work that lie at least `period` frames back (sets take turns,
// pass_budget.h: a set off its turn shows its last pixels, so fewer frames between would hide
// change); the figure is rel. MAE(image n, baseline) over image n's caustic region
// (error_metrics.h) divided by √(work / baseline work − 1), but no less than the last such figure
// × √(its work / work): the figure falls no faster than photon noise does (the change since a
// baseline misses the error both images share, and its dip read the glass slab's error at 0.61 ×
// over frames 5–7, 0.69 × with the floor; both parts of the error fall as N^-½ in the end: noise,
// and blur at r² ∝ 1/√N). Between such frames the last figure holds. Only images from frame
// kFirstBaseline on may be baselines. Before the first baseline there is no figure (0): with one
// batch a pass frames 1–9 (frame 1 as frame 2's baseline, half its work, read the curved mirror's
// error at 0.64 ×, and the estimator's own figure, which stood in until 2026-11-28, 0.43–3.2 × at
// frame 1).
// rtpm-render and the master both feed it their composed image and the sets' batches, so the
// same frames give the same figure in one process and in a cluster.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace rtpm {

/// The first frame of a progression whose image may be a baseline: the first two hold only each
/// set's own photons (the other sets' shots are shared two frames late, set_photons.h
/// kSharedPhotonLag), and the change since one of them read the curved mirror's error at up to
/// 1.6 × (the flat mirror's 1.5 ×) once the discs became ellipses along the fold lines
/// (progressive.h kShapePhotons): the error then falls much faster than photon noise over the
/// first frames. With one batch a pass the first figure comes at frame 10.
inline constexpr uint64_t kFirstBaseline = 3;

class ShownChange {
public:
    /// `firstBaseline`: the first frame of a progression whose image may be a baseline
    /// (kFirstBaseline; 1 lets every kept frame be one).
    explicit ShownChange(uint64_t firstBaseline = kFirstBaseline) : firstBaseline_(firstBaseline) {}
    /// One composed frame: `converging` false (or another image size) restarts the count (a
    /// progression's first frame),
    /// `period` is the frame's pass period (1 without turns), `work` how far its estimate went
    /// (Σ over the sets of the batches in their estimates; 0 = unknown, the frame is counted but
    /// neither kept nor compared). `caustic` is the shown caustic, width·height·3 floats. Returns
    /// the figure (0 while none is known yet).
    /// Cost: a copy of the image at the kept frames, one comparison at those frames.
    double add(bool converging, uint32_t period, double work, std::span<const float> caustic, int width, int height);
    /// The baseline holds about 1/kBaselineRatio of the frame's work: at least
    /// kBaselineTolerance / kBaselineRatio (2^-1/4: images are kept four per doubling) and at
    /// most 1/kBaselineMost. A baseline of half (frame 1 for frame 2) read the curved mirror's
    /// error at 0.64 ×: a doubling sheds too little of the blur to show it.
    static constexpr double kBaselineRatio = 6.0;
    static constexpr double kBaselineMost = 3.0;
    static constexpr double kBaselineTolerance = 0.8408964152537145;
    /// The first frame of a progression whose image may be a baseline: the first two hold only
    /// each set's own photons (the other sets' shots are shared two frames late, set_photons.h
    /// kSharedPhotonLag), and the change since one of them read the curved mirror's error at
    /// 1.8–2.5 × once its discs became ellipses along the fold lines (progressive.h
    /// kShapePhotons): its error then falls much faster than photon noise over the first frames.

    /// Frames of the current progression so far (the first is 1).
    uint64_t frame() const { return frame_; }
    /// The last figure (0 = none yet).
    double figure() const { return figure_; }
    /// Images held (the bound on the memory the figure takes: width·height·12 bytes each).
    size_t keptImages() const { return images_.size(); }

    /// Frames whose image is kept: b·2^k with b < 8.
    static bool kept(uint64_t n);
    /// Kept frames whose image stays while it holds less than half the last frame's work: b·2^k
    /// with b ∈ {1, 3}.
    static bool keptLong(uint64_t n);

private:
    uint64_t firstBaseline_;
    uint64_t frame_ = 0;
    int width_ = 0, height_ = 0;  ///< of the kept images
    double figure_ = 0.0;
    double figureWork_ = 0.0;  ///< the work of the frame that set figure_
    struct Kept {
        uint64_t frame = 0;
        double work = 0.0;
        std::vector<float> image;
    };
    std::vector<Kept> images_;  ///< kept frames, oldest first
};

/// The share of the change (ShownChange::add) the error figure reads. Since pixels whose disc
/// the rule narrowed show their own estimates up to 1.5 × the filter's half-window
/// (progressive.h kOwnFull, kOwnNone) the change alone read the four analytic scenes at
/// 0.80–1.54 × their true error (tests/support/progressive_run.h, frames 3–24: curved mirror
/// 1.03–1.54, glass ball 0.80–0.98, glass slab 0.81–1.07, flat mirror 0.82–1.01): their QMC noise
/// and the pixels' own-or-filtered choice change more between two images than nested Poisson
/// noise does. 0.9 put that range within the factor 1.5 either way (0.72–1.39); the baseline's
/// length did not narrow it (at a quarter and at a tenth of the photons the curved mirror still
/// read up to 1.74 and 1.64 × with every pixel's own estimate up to 2 × the half-window). Later
/// it under-reads: 0.64 × on the glass slab at frames 59–64, 0.62 × on the glass ball from frame
/// 40, 0.29 × on the curved mirror's variant after 30 s, whose fold lines' blur no longer changes.
/// Since the discs became ellipses along fold lines (progressive.h kShapePhotons) the mirrors'
/// error falls faster than noise; with baselines from frame kFirstBaseline on the change read
/// 1.14–1.29 × (curved mirror), 1.29–1.65 (flat mirror), 0.86–1.11 (glass slab), 0.86–0.96 (glass
/// ball) over frames 10–24, and 0.8 puts that within the factor 1.5 (0.76–1.47); by frame 64 the
/// glass slab and ball read 0.57 and 0.55 ×. The variant
/// still reads 0.45–0.57 × over its first 4 s at the 16.7 ms budget, 0.26 × by 30 s.
inline constexpr double kShownChangeScale = 0.8;
/// The error figure printed, shown and compared with --target-error: kShownChangeScale × the
/// change (ShownChange::add) where the progressive estimator's own figure says it composed the
/// frame (> 0), else 0 = none
/// (knn, moving frames, and a progression's frames before its first baseline: the first two
/// with one batch a pass). The estimator's own figure (progressive.h causticErrorEstimate) stood
/// in before a baseline until 2026-11-28: it read 0.43–3.2 × the true error at the first frame of
/// the analytic scenes, a figure no one should stop a render on.
inline double shownErrorFigure(double estimatorFigure, double change) {
    return estimatorFigure > 0.0 ? kShownChangeScale * change : 0.0;
}

}  // namespace rtpm
