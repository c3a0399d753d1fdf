// Still frames of a scene through RenderJob + FrameImage, as rtpm-render shows them, each scored
// against an analytic caustic image: what the progressive-estimator accuracy tests measure.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <numbers>
#include <numeric>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "common/core/interleave.h"
#include "common/image/error_metrics.h"
#include "common/image/frame_image.h"
#include "common/image/image_io.h"
#include "common/image/shown_change.h"
#include "common/render/progressive.h"
#include "common/render/render_job.h"
#include "common/scene/scene.h"

namespace rtpm::testscenes {

/// An analytic caustic image: radiance per pixel (RGB, row-major, W/(m²·sr)) and the pixels
/// that may be compared (1: the reference holds there).
struct CausticReference {
    std::vector<float> rgb;
    std::vector<uint8_t> mask;
};

struct Convergence {
    std::vector<double> relMae;    ///< per frame: caustic-region rel. MAE of the shown caustic
    std::vector<double> energy;    ///< per frame: Σ shown caustic / Σ reference over the compared pixels
    std::vector<double> estimate;  ///< per frame: the error figure rtpm-render prints (0 = none)
    /// per frame: Σ shown caustic over the compared pixels the reference leaves dark / Σ
    /// reference: light spread beyond the caustic's edges
    std::vector<double> spill;
    std::vector<float> last;  ///< the last frame's shown caustic over the compared pixels (RGB)
};

/// Renders `frames` still frames of `scene` from its camera with every set of `rs`, composes
/// each as rtpm-render does (scatter, box filter) and scores the filtered caustic layer over the
/// reference's mask with compareRgb (the region from the reference itself). `passBatches`:
/// batches of every progressive pass. `moving`: the camera alternates between its view and a copy
/// one float step away (a walkthrough frame there first), so every frame is a moving one whose
/// map grows by a batch (the progressive estimator's caustics from irradiance points). Counts
/// non-finite output as a test failure.
inline Convergence renderConvergence(Scene scene, const RenderSettings& rs, const CausticReference& ref,
                                     int frames, uint32_t passBatches = 1, bool moving = false) {
    const Camera camera = *scene.camera;
    Camera nudged = camera;
    nudged.position.y = std::nextafter(nudged.position.y, 1e9f);
    std::vector<uint32_t> sets(size_t(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    FrameImage image(rs.width, rs.height);
    ShownChange change;
    std::vector<SetPixels> pixels;
    Convergence run;
    if (moving) job.renderFrame(nudged, FrameMode::Walkthrough, pixels);
    for (int f = 1; f <= frames; ++f) {
        const FrameStats st = job.renderFrame(moving && f % 2 == 0 ? nudged : camera, pixels, passBatches);
        if (rs.photons.estimator == CausticEstimatorKind::Progressive) {
            EXPECT_EQ(st.moving, moving) << "frame " << f;
        }
        for (const SetPixels& sp : pixels) scatterSet(image, pattern, sp);
        image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
        std::vector<float> shown = image.causticFiltered();
        // The error figure as rtpm-render prints it (render_main.cpp).
        const double own = causticErrorEstimate(st.error);
        const double changed = change.add(st.converging, 1, st.error.batches, shown, rs.width, rs.height);
        double total = 0.0, totalRef = 0.0, dark = 0.0;
        for (size_t p = 0; p < ref.mask.size(); ++p)
            for (int c = 0; c < 3; ++c) {
                if (!ref.mask[p]) shown[3 * p + c] = 0.0f;
                total += shown[3 * p + c];
                totalRef += ref.rgb[3 * p + c];
                if (ref.rgb[3 * p + c] == 0.0f) dark += shown[3 * p + c];
            }
        const ErrorMetrics em = compareRgb(shown, ref.rgb, ref.rgb, rs.width, rs.height);
        EXPECT_EQ(em.nonFiniteOutput, 0u);
        run.relMae.push_back(em.caustic.relMae);
        run.energy.push_back(total / totalRef);
        run.spill.push_back(dark / totalRef);
        run.estimate.push_back(shownErrorFigure(own, changed));
        if (f == frames) run.last = std::move(shown);
    }
    return run;
}

/// The error figure rtpm-render and the master print (the shown caustic's change since a sixth of
/// the progression's photons, scaled as Poisson noise changes and falling no faster than it:
/// common/image/shown_change.h) against the true rel. MAE: none before a baseline (an image from
/// the third frame on holding a third of the photons or less: frames 1–9 with one batch a pass),
/// one from frame 10 on, within the factor 1.5 either way.
/// Measured at the defaults with ellipses along fold lines (progressive.h kShapePhotons), frames
/// 10–24: curved mirror 1.01–1.15, flat mirror 1.15–1.47, glass slab 0.77–0.99, glass ball
/// 0.76–0.85. With frames 1 and 2 as baselines the mirrors read up to 1.6 and 1.5 × (scale 0.8)
/// from frame 3 on. Before the ellipses (f0cb59b, frames 3–24, scale 0.9): curved mirror
/// 0.97–1.47, flat mirror 0.78–1.03, glass slab 0.69–1.18, glass ball 0.79–1.01.
inline void expectErrorFigureTracks(const Convergence& run, const char* label) {
    constexpr size_t kFirstFigure = 10;
    for (size_t f = 0; f < std::min<size_t>(kFirstFigure - 1, run.estimate.size()); ++f)
        EXPECT_EQ(run.estimate[f], 0.0) << label << ", frame " << f + 1 << ": a figure before a baseline";
    double least = 1e300, most = 0.0;
    for (size_t f = kFirstFigure - 1; f < run.relMae.size(); ++f) {
        const double ratio = run.estimate[f] / run.relMae[f];
        least = std::min(least, ratio);
        most = std::max(most, ratio);
        EXPECT_GE(ratio, 1.0 / 1.5) << label << ", frame " << f + 1 << ": estimate " << run.estimate[f] << ", true "
                                    << run.relMae[f];
        EXPECT_LE(ratio, 1.5) << label << ", frame " << f + 1 << ": estimate " << run.estimate[f] << ", true "
                              << run.relMae[f];
    }
    std::printf("%s: error figure %.2f–%.2f × the true error over frames %zu–%zu\n", label, least, most, kFirstFigure,
                run.relMae.size());
}

/// Caustic reference of a floor (the plane y = 0, facing up, albedo `albedo`) seen by `camera`:
/// per pixel, `samples` × `samples` rays through a regular grid of points inside the pixel are
/// intersected with the floor and the pixel gets ρ/π times the mean of `irradiance(x, z)`
/// (W/m²) over their floor points, so a pixel on a caustic's edge gets its covered fraction.
/// `visible(origin, direction)` says whether a camera ray reaches the floor unobstructed; a
/// pixel is compared only if all of its rays do (and all go down).
template <class Irradiance, class Visible>
CausticReference floorReference(const Camera& camera, int width, int height, int samples, double albedo,
                                Irradiance irradiance, Visible visible) {
    CausticReference ref;
    ref.rgb.assign(size_t(width) * size_t(height) * 3, 0.0f);
    ref.mask.assign(size_t(width) * size_t(height), 0);
    const Camera::PixelRays rays = camera.pixelRays(width, height);
    const glm::dvec3 o(camera.position), forward(rays.forward), right(rays.right), up(rays.up);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) {
            double sum = 0.0;
            bool compared = true;
            for (int sj = 0; sj < samples && compared; ++sj)
                for (int si = 0; si < samples; ++si) {
                    // As Camera::PixelRays::direction, at (i + u, j + v) instead of the centre.
                    const double u = (double(si) + 0.5) / samples, v = (double(sj) + 0.5) / samples;
                    const double sx = (2.0 * (double(i) + u) / width - 1.0) * double(rays.halfW);
                    const double sy = (1.0 - 2.0 * (double(j) + v) / height) * double(rays.halfH);
                    const glm::dvec3 d = glm::normalize(forward + sx * right + sy * up);
                    if (!(d.y < 0.0) || !visible(o, d)) {
                        compared = false;
                        break;
                    }
                    const glm::dvec3 p = o + (-o.y / d.y) * d;
                    sum += irradiance(p.x, p.z);
                }
            if (!compared) continue;
            const size_t p = size_t(j) * size_t(width) + size_t(i);
            ref.mask[p] = 1;
            const float l = float(albedo / std::numbers::pi * sum / double(samples * samples));
            ref.rgb[3 * p] = ref.rgb[3 * p + 1] = ref.rgb[3 * p + 2] = l;
        }
    return ref;
}

/// The defaults' estimator against knn from the same photons: `frames` still (or `moving`)
/// frames of the scene `makeScene()` returns, rendered with `rs` and with `rs` but the knn
/// estimator; prints both per frame under `label`.
template <class MakeScene>
std::pair<Convergence, Convergence> againstKnn(MakeScene makeScene, RenderSettings rs, const CausticReference& ref,
                                               int frames, const char* label, bool moving = false) {
    const Convergence progressive = renderConvergence(makeScene(), rs, ref, frames, 1, moving);
    rs.photons.estimator = CausticEstimatorKind::Knn;
    const Convergence knn = renderConvergence(makeScene(), rs, ref, frames, 1, moving);
    for (size_t f = 0; f < progressive.relMae.size(); ++f)
        std::printf("%s, frame %2zu: rel. MAE %.4f (knn %.4f), energy %.4f (knn %.4f), estimate %.4f\n", label,
                    f + 1, progressive.relMae[f], knn.relMae[f], progressive.energy[f], knn.energy[f],
                    progressive.estimate[f]);
    // To look at: RTPM_TEST_IMAGES=DIR writes the reference and both last frames, one exposure.
    if (const char* dir = std::getenv("RTPM_TEST_IMAGES")) {
        const std::string base = std::string(dir) + "/" + label;
        ToneMap tm;
        tm.exposureStops = std::log2(autoExposureScale(ref.rgb));
        writePng(base + " reference.png", rs.width, rs.height, ref.rgb, tm);
        writePng(base + " progressive.png", rs.width, rs.height, progressive.last, tm);
        writePng(base + " knn.png", rs.width, rs.height, knn.last, tm);
    }
    return {progressive, knn};
}

/// A moving camera at `rs` (againstKnn's `moving`) against the knn gather from the same photons:
/// at frame f (from 1) the irradiance points' rel. MAE is at most `factor(f)` × knn's.
template <class MakeScene, class Factor>
void expectMovingBelowKnn(MakeScene makeScene, const RenderSettings& rs, const CausticReference& ref, int frames,
                          const char* label, Factor factor) {
    const auto [moving, knn] = againstKnn(makeScene, rs, ref, frames, label, true);
    for (size_t f = 0; f < moving.relMae.size(); ++f)
        EXPECT_LE(moving.relMae[f], factor(int(f) + 1) * knn.relMae[f]) << label << ", frame " << f + 1;
}

}  // namespace rtpm::testscenes
