// The progressive estimator against the curved mirror's analytic caustic (tests/support/
// ring_mirror.h): a still view's growing passes must give what the same photons give in small
// ones, the caustic energy must stay on the receiver at every frame, the estimate must be no
// worse than knn's at any frame, and the estimator's own error estimate must track the true
// error.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "common/render/render_job.h"
#include "tests/support/progressive_run.h"
#include "tests/support/ring_mirror.h"

namespace rtpm {
namespace {

using testscenes::CausticReference;
using testscenes::Convergence;
using testscenes::RingMirror;

// Renders `frames` still frames of the curved mirror (L S D photons, as the reference) and
// scores each one as rtpm-render shows it. `passBatches`: batches of every progressive pass.
Convergence render(RenderSettings rs, int frames, uint32_t passBatches = 1, const RingMirror& rm = RingMirror{}) {
    rs.photons.maxDepth = 2;
    rs.photons.diffuseBounces = 0;
    CausticReference ref;
    rm.referenceImage(rs.width, rs.height, ref.rgb, ref.mask);
    return renderConvergence(rm.scene(), rs, ref, frames, passBatches);
}

RenderSettings small() {
    RenderSettings rs;
    rs.width = 160;
    rs.height = 120;
    return rs;
}

// The same photons (plain QMC shooting: batches are consecutive pieces of one Halton sequence)
// after a first frame of one batch, then 31 passes of one batch or one pass of 31 batches: the
// rings hold the same photons, so the image must be the same up to float summation order (a
// still view's growing passes change nothing but the speed). Shrinking-radius SPPM shrank its
// radius per pass, so the split changed the result (0.176 against 0.045 rel. MAE).
TEST(ProgressiveEstimator, GrowingPassesGiveWhatTheSamePhotonsGiveInSmallPasses) {
    RenderSettings rs = small();
    rs.interleave = 1;
    rs.photons.selective = false;
    rs.photons.photonsPerBatch = 20000;
    const Convergence single = render(rs, 32);
    const Convergence grown = render(rs, 2, 31);
    std::printf("32 passes of one batch: rel. MAE %.4f; one batch, then a pass of 31: %.4f\n",
                single.relMae.back(), grown.relMae.back());
    EXPECT_NEAR(grown.relMae.back(), single.relMae.back(), 0.02 * single.relMae.back());
}

// The same number of paths split into passes of very different sizes (plain shooting, M = 1,
// 3.2 M paths per set): 160 passes of 20 000, 8 of 400 000, 2 of 1.6 M. The error must not care
// (within 15 % of the best): 0.040, 0.041, 0.039. Before the ladder's outer disc was widened
// (kOuterArea) and the shown disc capped by its photon count (maxDiscPhotons), the first batch's
// k-NN radius bounded the large passes' discs and nothing bounded the small ones': 0.060, 0.039,
// 0.040.
TEST(ProgressiveEstimator, ErrorDoesNotDependOnHowPhotonsAreSplitIntoPasses) {
    RenderSettings rs = small();
    rs.interleave = 1;
    rs.photons.selective = false;
    const std::pair<uint32_t, int> splits[] = {{20000, 160}, {400000, 8}, {1600000, 2}};
    std::vector<double> errors;
    for (const auto& [paths, passes] : splits) {
        rs.photons.photonsPerBatch = paths;
        errors.push_back(render(rs, passes).relMae.back());
        std::printf("%d passes of %u paths: rel. MAE %.4f\n", passes, paths, errors.back());
    }
    const double best = *std::min_element(errors.begin(), errors.end());
    for (size_t i = 0; i < errors.size(); ++i)
        EXPECT_LE(errors[i], 1.15 * best) << splits[i].second << " passes of " << splits[i].first << " paths";
}

// Defaults (M = 3, the box filter and own weights, SPT): the caustic's total over the receiver
// (the pixels the reference covers) against the analytic total. A gather estimator does not keep
// the photons' total over a fold caustic: a pixel beside the fold line counts the fold's photons
// that the pixels on it count too. Both estimators show more than arrives; the default must be no
// farther from the analytic total than knn from the same photons, at every frame, and come within
// 3 % of it by frame 24. (The
// walk used to start at the first whole ring holding kMinPhotons: 1.074 / 1.088 / 1.056 at frames
// 1 / 4 / 24 against knn's 1.080 / 1.080 / 1.054, and the earlier form of this test, within 2 %
// of knn's, passed on that shared excess; then 1.055 / 1.057 / 1.019. Over the whole image, where
// knn's wide discs draw halos around every bright edge, the default shows 1-3 % less than knn.)
// The ellipses decided from the restart's photons (progressive.h kShapePhotons) show 1.082 at
// frame 1 against knn's 1.080 (rel. MAE 0.0793; 0.0986 and 1.048 with shapes decided from the
// passes' photons only), then 1.068 / 1.040 / 1.008 at frames 2 / 3 / 24: frame 1 may lie 0.005
// farther than knn's.
// The error is no worse than knn's and falls meanwhile.
TEST(ProgressiveEstimator, EnergyStaysOnTheReceiverAtEveryFrame) {
    const Convergence run = render(small(), 24);
    RenderSettings knn = small();
    knn.photons.estimator = CausticEstimatorKind::Knn;
    const Convergence reference = render(knn, 24);
    for (size_t f = 0; f < run.energy.size(); ++f) {
        std::printf("frame %2zu: rel. MAE %.4f (knn %.4f), energy %.4f (knn %.4f), estimate %.4f\n", f + 1,
                    run.relMae[f], reference.relMae[f], run.energy[f], reference.energy[f], run.estimate[f]);
        EXPECT_LE(std::abs(run.energy[f] - 1.0), std::abs(reference.energy[f] - 1.0) + (f == 0 ? 0.005 : 0.0))
            << "frame " << f + 1;
        EXPECT_LE(run.relMae[f], reference.relMae[f]) << "frame " << f + 1 << ": worse than knn";
    }
    EXPECT_NEAR(run.energy.back(), 1.0, 0.03);
    EXPECT_LT(run.relMae.back(), 0.75 * run.relMae.front());
}

// A variant of the curved mirror the estimator's constants were not chosen on (the mirror 0.5 m
// high, the light at (−0.3, 0.7, 0.35): three cusps joined by fold lines over a broad glow), at
// the defaults and 320×240: most of its error sits at the fold lines, where the box filter's
// window averaged both sides while the pixels showed their own estimates only up to half the
// window (progressive.h kOwnFull, kOwnNone). Measured at frames 4 / 8: 0.0794 / 0.0639 with own
// estimates from 0.5 to 1 × the half-window, 0.0736 / 0.0546 from 0.75 to 1.5 × where the rule
// narrowed the disc (0.0732 / 0.0537 with every pixel from 0.75 to 1.5 ×). (At 160×120 a
// pixel's footprint is twice as wide and the two differ only early: 0.0653 / 0.0427 / 0.0336
// against 0.0573 / 0.0423 / 0.0353 at frames 4 / 8 / 16 with 1 to 1.5 ×.) Discs that become
// ellipses along the fold lines (progressive.h kShapePhotons) read 0.0643 / 0.0458.
TEST(ProgressiveEstimator, AVariantsFoldLinesStaySharpAtTheDefaults) {
    RingMirror rm;
    rm.light = Vec3(-0.3f, 0.7f, 0.35f);
    rm.height = 0.5;
    RenderSettings rs;
    rs.width = 320;
    rs.height = 240;
    const Convergence run = render(rs, 8, 1, rm);
    std::printf("curved mirror variant, 320x240, frames 4 / 8: rel. MAE %.4f / %.4f\n", run.relMae[3], run.relMae[7]);
    EXPECT_LT(run.relMae[3], 0.068);
    EXPECT_LT(run.relMae[7], 0.050);
}

// The error figure rtpm-render and the master print against the analytic error, defaults: none
// at frames 1–9, within 1.5 × either way from the 10th frame on (tests/support/progressive_run.h
// expectErrorFigureTracks). It used to be the estimator's own figure (causticErrorEstimate:
// Poisson noise and a blur step per pixel): 0.60 at frame 2 to 1.52 at frame 24 here, and 2–3 ×
// on the glass caustics, whose QMC photons are less noisy than Poisson's count says.
TEST(ProgressiveEstimator, ItsErrorEstimateTracksTheTrueError) {
    const Convergence run = render(small(), 24);
    for (size_t f = 0; f < run.relMae.size(); ++f)
        std::printf("frame %2zu: estimate %.4f, true %.4f, ratio %.2f\n", f + 1, run.estimate[f], run.relMae[f],
                    run.estimate[f] / run.relMae[f]);
    testscenes::expectErrorFigureTracks(run, "curved mirror");
}

}  // namespace
}  // namespace rtpm
