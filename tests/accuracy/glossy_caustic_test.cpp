// A rough metal ring throws a blurred caustic that converges: RING with its ring at roughness
// 0.3, rendered with the defaults' estimator, against its own longer run, and against the smooth
// ring's caustic for its spread.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numeric>
#include <vector>

#include "common/core/interleave.h"
#include "common/image/error_metrics.h"
#include "common/image/frame_image.h"
#include "common/render/render_job.h"
#include "common/scene/builtin_scenes.h"

namespace rtpm {
namespace {

Scene ring(float roughness) {
    Scene s = buildRingScene();
    for (Material& m : s.materials)
        if (m.name == "ring metal") m.roughness = roughness;
    return s;
}

RenderSettings settings() {
    RenderSettings rs;
    rs.width = 128;
    rs.height = 96;
    rs.photons.photonsPerBatch = 10000;
    return rs;
}

/// The shown caustic (filtered layer) after each frame in `keep` (ascending), one batch per pass.
std::vector<std::vector<float>> caustics(Scene scene, const RenderSettings& rs, const std::vector<int>& keep) {
    const Camera camera = *scene.camera;
    std::vector<uint32_t> sets(size_t(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    FrameImage image(rs.width, rs.height);
    std::vector<SetPixels> pixels;
    std::vector<std::vector<float>> out;
    for (int f = 1; f <= keep.back(); ++f) {
        job.renderFrame(camera, pixels);
        if (std::find(keep.begin(), keep.end(), f) == keep.end()) continue;
        for (const SetPixels& sp : pixels) scatterSet(image, pattern, sp);
        image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
        out.push_back(image.causticFiltered());
    }
    return out;
}

std::vector<double> luminance(const std::vector<float>& rgb) {
    std::vector<double> l(rgb.size() / 3);
    for (size_t p = 0; p < l.size(); ++p)
        l[p] = 0.2126 * rgb[3 * p] + 0.7152 * rgb[3 * p + 1] + 0.0722 * rgb[3 * p + 2];
    return l;
}

/// Share of the caustic's energy in its brightest 1 % of pixels: how concentrated it is (the
/// smooth ring's fold lines and cusp hold much of it).
double topShare(const std::vector<float>& rgb) {
    std::vector<double> l = luminance(rgb);
    std::sort(l.begin(), l.end(), std::greater<>());
    const double total = std::accumulate(l.begin(), l.end(), 0.0);
    const size_t top = std::max<size_t>(1, l.size() / 100);
    return std::accumulate(l.begin(), l.begin() + std::ptrdiff_t(top), 0.0) / total;
}

TEST(GlossyCaustic, RoughRingThrowsAWiderCausticThatConverges) {
    const RenderSettings rs = settings();
    const std::vector<int> frames = {2, 8, 32, 128};
    const auto rough = caustics(ring(0.3f), rs, frames);
    const std::vector<float>& reference = rough.back();  // its own longer run
    std::vector<double> error;
    for (size_t i = 0; i + 1 < frames.size(); ++i) {
        const ErrorMetrics em = compareRgb(rough[i], reference, reference, rs.width, rs.height);
        EXPECT_EQ(em.nonFiniteOutput, 0u);
        error.push_back(em.caustic.relMae);
        std::printf("rough ring, frame %3d: caustic-region rel. MAE against frame %d: %.4f\n", frames[i],
                    frames.back(), em.caustic.relMae);
    }
    // The error falls as frames grow (noise and blur both go; 32 frames hold a quarter of the
    // reference's photons, so their error against it is partly its own).
    EXPECT_LT(error[1], 0.8 * error[0]);
    EXPECT_LT(error[2], 0.8 * error[1]);

    const auto smooth = caustics(ring(0.0f), rs, {frames.back()});
    const double shareRough = topShare(reference), shareSmooth = topShare(smooth.back());
    const auto lr = luminance(reference), ls = luminance(smooth.back());
    const double peakRough = *std::max_element(lr.begin(), lr.end());
    const double peakSmooth = *std::max_element(ls.begin(), ls.end());
    const double energy = std::accumulate(lr.begin(), lr.end(), 0.0) / std::accumulate(ls.begin(), ls.end(), 0.0);
    std::printf("brightest 1 %% of pixels hold %.3f of the caustic (smooth ring %.3f); peak %.3g (smooth %.3g); "
                "energy ratio %.3f\n", shareRough, shareSmooth, peakRough, peakSmooth, energy);
    EXPECT_LT(shareRough, 0.8 * shareSmooth);  // blurred: less of it in the brightest pixels
    EXPECT_LT(peakRough, 0.5 * peakSmooth);    // measured 0.2 at 128 frames
    // Energy: the ring's Schlick Fresnel (F0 = 0.93) and the single-scattering loss of GGX
    // against the smooth ring's constant reflectance; the same light, within 20 %.
    EXPECT_NEAR(energy, 1.0, 0.2);
}

}  // namespace
}  // namespace rtpm
