// The flat mirror's analytic caustic (tests/support/flat_mirror.h), a sharp-edged trapezoid
// that punishes blur: its reference image checked against the mirror's flux in closed form, the
// photons' flux against the same, and the progressive estimator's error against how the same
// photons are split into passes.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "common/photon/photon_map.h"
#include "common/render/render_job.h"
#include "common/trace/embree_scene.h"
#include "tests/support/flat_mirror.h"
#include "tests/support/progressive_run.h"

namespace rtpm {
namespace {

using testscenes::CausticReference;
using testscenes::Convergence;
using testscenes::FlatMirror;

constexpr int kWidth = 160, kHeight = 120;

// The reference image, turned back into flux: the camera looks straight down, so every pixel
// covers the same floor rectangle, and Σ_pixels E · area must be the flux the mirror reflects,
// R · I · Ω with Ω the rectangle's solid angle in closed form (the lit trapezoid lies inside the
// view and away from the pixels that see the mirror). Measured: 0.361188 W against 0.361228 W
// (ratio 0.99989; the 8 × 8 samples of the edges' pixels). A wrong edge (the mirror's image
// from L instead of L'), a missing cosine or a point-sampled edge (±1/2 pixel per edge) is off
// by ≥ 1 %.
TEST(FlatMirrorReference, ImageHoldsTheMirrorsFlux) {
    const FlatMirror fm;
    const CausticReference ref = fm.reference(kWidth, kHeight);
    const Camera cam = *fm.scene().camera;
    const Camera::PixelRays rays = cam.pixelRays(kWidth, kHeight);
    const double h = cam.position.y;
    const double area = (2.0 * rays.halfW * h / kWidth) * (2.0 * rays.halfH * h / kHeight);
    double flux = 0.0;
    size_t hidden = 0, lit = 0;
    for (size_t p = 0; p < ref.mask.size(); ++p) {
        flux += double(ref.rgb[3 * p]) * std::numbers::pi / fm.floorAlbedo * area;
        hidden += !ref.mask[p];
        lit += ref.rgb[3 * p] > 0.0f;
    }
    const double expected = fm.reflectance * fm.intensity * fm.solidAngle();
    std::printf("flat mirror reference, %dx%d, 8x8 samples: flux %.6f W, R*I*Omega %.6f W (ratio %.6f), "
                "%zu lit pixels, %zu see the mirror\n",
                kWidth, kHeight, flux, expected, flux / expected, lit, hidden);
    EXPECT_NEAR(flux / expected, 1.0, 1e-3);
    EXPECT_GT(hidden, 0u);  // the mask is exercised: the camera sees the mirror's face
    // Far from every edge (the trapezoid's centre line), a pixel is E at its centre up to the
    // variation of E across it.
    for (const double x : {0.3, 0.45}) {
        const double e = fm.irradiance(x, 0.0);
        ASSERT_GT(e, 0.0);
        EXPECT_NEAR(fm.irradiance(x + 0.01, 0.01) / e, 1.0, 0.02);
    }
    EXPECT_EQ(fm.irradiance(0.1, 0.0), 0.0);   // in front of the trapezoid's near edge
    EXPECT_EQ(fm.irradiance(0.7, 0.0), 0.0);   // beyond its far edge
    EXPECT_EQ(fm.irradiance(0.4, 0.7), 0.0);   // beside it
}

// The photons themselves carry the mirror's flux: Σ stored power per batch (plain shooting,
// L S D, 4 × 100 000 paths) against R · I · Ω. Measured ratio 1.0012 (the Halton directions'
// integration error). So what an image shows beyond it is the estimator's.
TEST(FlatMirrorReference, PhotonsCarryTheMirrorsFlux) {
    const FlatMirror fm;
    const Scene scene = fm.scene();
    EmbreeScene es(scene);
    PhotonSettings ps;
    ps.photonsPerBatch = 100000;
    ps.selective = false;
    ps.maxDepth = 2;
    ps.diffuseBounces = 0;
    PhotonMaps maps(ps, {0});
    for (int b = 0; b < 4; ++b) maps.shootBatch(es, 0);
    const double flux = maps.storedPowerPerBatch(0).x;
    const double expected = fm.reflectance * fm.intensity * fm.solidAngle();
    std::printf("flat mirror photons: %.6f W per batch, R*I*Omega %.6f W (ratio %.5f)\n", flux, expected,
                flux / expected);
    EXPECT_NEAR(flux / expected, 1.0, 0.01);
}

// The defaults at this file's size, with the flat mirror's own photon paths.
RenderSettings sceneSettings() {
    RenderSettings rs;
    rs.width = kWidth;
    rs.height = kHeight;
    rs.photons.maxDepth = 2;
    rs.photons.diffuseBounces = 0;
    return rs;
}

// The progressive estimator as the curved mirror's test runs it (progressive_estimator_test.cpp):
// M = 1, plain shooting, L S D photons, 3.2 M paths as 160 passes of 20 000, 8 of 400 000 and
// 2 of 1.6 M, shown as rtpm-render shows them.
//  (a) The error does not care how the photons were split: within 15 % of the best. Measured
//      0.0588, 0.0611, 0.0581 (kOuterArea 8; 0.0588, 0.0601, 0.0574 with 4). (At 1.6 M paths, 80 / 4 / 1 passes, it does not hold: 0.0774,
//      0.0793, 0.0670, the third a restart alone.) Before the ladder's outer disc was widened
//      (kOuterArea) and the shown disc capped (maxDiscPhotons): 0.0699, 0.0577, 0.0461, which
//      fails; its large passes were sharper than today's (0.0461 against 0.0574).
//  (c) The error falls with photons: at 3.2 M paths below 0.7 × its value at 400 000 (the
//      20 000-path run's 20th frame): measured 0.0588 against 0.1223.
// Not checked, measured: the caustic's total over the receiver is 3-5 % above the reference's
// at every frame (3.2 M paths: 1.033, 1.032, 1.035; knn 1.066), although the photons carry the
// exact flux (PhotonsCarryTheMirrorsFlux). The excess is light shown beyond the sharp edges:
// pixels the reference leaves dark hold 8.2 % of the reference's total while the lit ones keep
// 95.0 % of theirs. A pixel just outside an edge has no photon in its small discs and takes the
// first disc with kMinPhotons, reaching into the caustic, while one just inside keeps a small
// disc: choosing the disc per pixel spreads light outward without taking as much from inside.
TEST(FlatMirrorProgressive, ErrorDoesNotDependOnHowPhotonsAreSplitIntoPasses) {
    const FlatMirror fm;
    const CausticReference ref = fm.reference(kWidth, kHeight);
    RenderSettings rs = sceneSettings();
    rs.interleave = 1;
    rs.photons.selective = false;
    const std::pair<uint32_t, int> splits[] = {{20000, 160}, {400000, 8}, {1600000, 2}};
    std::vector<double> errors;
    for (const auto& [paths, passes] : splits) {
        rs.photons.photonsPerBatch = paths;
        const Convergence run = renderConvergence(fm.scene(), rs, ref, passes);
        errors.push_back(run.relMae.back());
        std::printf("flat mirror, %d passes of %u paths: rel. MAE %.4f, energy over the receiver %.4f "
                    "(beyond the edges %.4f)\n",
                    passes, paths, errors.back(), run.energy.back(), run.spill.back());
        if (paths == 20000) {
            std::printf("flat mirror, 400 000 paths: rel. MAE %.4f; 3.2 M: %.4f\n", run.relMae[19],
                        run.relMae.back());
            EXPECT_LT(run.relMae.back(), 0.7 * run.relMae[19]);
        }
    }
    const double best = *std::min_element(errors.begin(), errors.end());
    for (size_t i = 0; i < errors.size(); ++i)
        EXPECT_LE(errors[i], 1.15 * best) << splits[i].second << " passes of " << splits[i].first << " paths";
}

// At the defaults (M = 3, SPT, the box filter and own weights; the scene's own L S D paths) the
// progressive estimate is no worse than knn's from the same photons at any of 24 frames.
TEST(FlatMirrorProgressive, AtTheDefaultsNoWorseThanKnnAtAnyFrame) {
    const FlatMirror fm;
    const CausticReference ref = fm.reference(kWidth, kHeight);
    RenderSettings rs = sceneSettings();
    const auto [progressive, knn] = againstKnn([&] { return fm.scene(); }, rs, ref, 24, "flat mirror, defaults");
    for (size_t f = 0; f < progressive.relMae.size(); ++f)
        EXPECT_LE(progressive.relMae[f], knn.relMae[f]) << "frame " << f + 1;
    // Ellipses along the rims (progressive.h kShapePhotons): 0.0107 at frame 24, 0.0250 with
    // circles only.
    EXPECT_LT(progressive.relMae.back(), 0.016);
    testscenes::expectErrorFigureTracks(progressive, "flat mirror");
}

// The filter window that stops at the caustic's edges (box_filter.h edgeStoppingBox, the default
// --filter-edges 2) against the paper's plain box on the same photons: the flat mirror's caustic
// is a lit quadrilateral whose sharp rims the box smears over a pixel either side where the
// filter shows a pixel. Since pixels whose disc the rule narrowed (at the rims) show their own
// estimates up to 0.75–1.5 × the window's half-width (progressive.h kOwnFull, kOwnNone; until
// 2026-11-28 0.5–1 ×) the filter shows far fewer pixels there, so the two differ less: 0.0320
// against 0.0333 at frame 16, 0.0250 against 0.0257 at frame 24 (then 0.0260 against 0.0292), the
// same to 4 digits up to frame 6. The test that ignored the noise read 0.0238 at frame 24 then,
// and drew the interleaving grid on RING's floor. Since the discs at the rims became ellipses
// along them (progressive.h kShapePhotons) hardly a pixel there is filtered and the two are
// level: 0.0403 / 0.0142 / 0.0107 against 0.0403 / 0.0140 / 0.0105 at frames 4 / 16 / 24, at most
// 1.9 % apart (frames 15–24): the filter that stops at edges must not cost more than 2.5 % at any
// frame.
TEST(FlatMirrorProgressive, TheFilterThatStopsAtEdgesKeepsTheRimsSharp) {
    const FlatMirror fm;
    const CausticReference ref = fm.reference(kWidth, kHeight);
    RenderSettings rs = sceneSettings();
    const Convergence edges = renderConvergence(fm.scene(), rs, ref, 24);
    rs.filterEdges = 0.0f;
    const Convergence box = renderConvergence(fm.scene(), rs, ref, 24);
    for (size_t f = 0; f < edges.relMae.size(); ++f) {
        std::printf("flat mirror, frame %2zu: rel. MAE %.4f with the edges kept, %.4f with the plain box\n", f + 1,
                    edges.relMae[f], box.relMae[f]);
        EXPECT_LE(edges.relMae[f], 1.025 * box.relMae[f]) << "frame " << f + 1;
    }
}

// A moving camera (every frame one float step to and fro, the map growing by a batch a frame) at
// the defaults: the irradiance points (common/photon/irradiance_points.h) against the knn gather
// per pixel from the same photons, at most 0.92 × its error at every frame. This mirror's caustic
// is a lit quadrilateral with sharp rims, where the points take their inner discs. Measured
// 0.854 / 0.866 / 0.899 / 0.890 × knn at frames 1–4, 0.897 / 0.805 at 8 / 24; with the whole k-NN
// disc at every point (until 2026-11-28) 1.049 / 1.032 / 1.010 / 0.993 and 0.979 / 0.857.
// Frames 1–24 on this scene were among those the sharpness thresholds were chosen on.
TEST(MovingCameraOnFlatMirror, IrradiancePointsBeatKnn) {
    const FlatMirror fm;
    const CausticReference ref = fm.reference(kWidth, kHeight);
    testscenes::expectMovingBelowKnn([&] { return fm.scene(); }, sceneSettings(), ref, 24, "flat mirror, moving",
                                     [](int) { return 0.92; });
}

}  // namespace
}  // namespace rtpm
