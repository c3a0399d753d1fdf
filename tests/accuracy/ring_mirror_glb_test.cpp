// The curved-mirror scene survives the glTF export the cluster benchmark loads it from
// (ring_mirror_bench --write-scene; tests/bench/cluster_bench.sh, scene MIRROR): the radial
// normals, the light and the camera come back, and the loaded scene renders the same caustic as
// the in-memory one, so the analytic reference scores the cluster's image as it scores
// ring_mirror_bench's.
#include <cmath>
#include <cstdio>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "common/core/interleave.h"
#include "common/image/frame_image.h"
#include "common/render/render_job.h"
#include "common/scene/gltf_export.h"
#include "common/scene/gltf_loader.h"
#include "tests/support/ring_mirror.h"

namespace rtpm {
namespace {

using testscenes::RingMirror;

const Mesh* meshNamed(const Scene& s, const std::string& name) {
    for (const Mesh& m : s.meshes)
        if (m.name == name) return &m;
    return nullptr;
}

// The shown caustic (filtered, faded as rtpm-render shows it) after `frames` still frames with
// L S D photon paths, the settings the benchmark gives the cluster.
std::vector<float> shownCaustic(Scene scene, int frames) {
    RenderSettings rs;
    rs.width = 80;
    rs.height = 60;
    rs.photons.photonsPerBatch = 20000;
    rs.photons.maxDepth = 2;
    rs.photons.diffuseBounces = 0;
    const Camera camera = *scene.camera;
    std::vector<uint32_t> sets(size_t(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    FrameImage image(rs.width, rs.height);
    std::vector<SetPixels> pixels;
    for (int f = 0; f < frames; ++f) {
        job.renderFrame(camera, pixels);
        for (const SetPixels& sp : pixels)
            scatterSet(image, pattern, sp);
        image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
    }
    return image.causticFiltered();
}

TEST(RingMirrorGlb, NormalsLightAndCameraSurviveTheExport) {
    const Scene original = RingMirror{}.scene();
    const Scene loaded = loadGltfFromMemory(encodeGlb(original), "ring_mirror.glb", "");
    const Mesh* a = meshNamed(original, "ring");
    const Mesh* b = meshNamed(loaded, "ring");
    ASSERT_NE(a, nullptr);
    ASSERT_NE(b, nullptr) << "the exported scene lost the mirror mesh";
    ASSERT_EQ(a->normals.size(), a->positions.size());
    ASSERT_EQ(b->normals.size(), a->normals.size()) << "radial normals did not survive the export";
    for (size_t i = 0; i < a->normals.size(); ++i) {
        ASSERT_EQ(b->normals[i], a->normals[i]) << "normal " << i;
        ASSERT_EQ(b->positions[i], a->positions[i]) << "position " << i;
    }
    ASSERT_EQ(loaded.lights.size(), 1u);
    EXPECT_EQ(loaded.lights[0].type, LightType::Point);
    EXPECT_EQ(loaded.lights[0].position, original.lights[0].position);
    EXPECT_EQ(loaded.lights[0].intensity, original.lights[0].intensity);
    ASSERT_TRUE(loaded.camera.has_value());
    EXPECT_EQ(loaded.camera->position, original.camera->position);
    EXPECT_NEAR(glm::length(loaded.camera->forward - original.camera->forward), 0.0f, 1e-6f);
    EXPECT_NEAR(glm::length(loaded.camera->up - original.camera->up), 0.0f, 1e-6f);
    EXPECT_FLOAT_EQ(loaded.camera->yfov, original.camera->yfov);
}

// Three frames at 80 × 60 (≈ 1 s of CPU): the loaded scene's caustic equals the original's to
// float rounding of the camera basis (measured: identical). The same mirror without its radial
// normals (flat facets) differs by 3.9e-3 of the caustic's L1 norm at this size (measured), far
// above the tolerance: the check can tell lost normals.
TEST(RingMirrorGlb, LoadedSceneRendersTheSameCaustic) {
    const Scene original = RingMirror{}.scene();
    const std::vector<float> a = shownCaustic(original, 3);
    const std::vector<float> b = shownCaustic(loadGltfFromMemory(encodeGlb(original), "ring_mirror.glb", ""), 3);
    ASSERT_EQ(a.size(), b.size());
    double sum = 0.0, diff = 0.0;
    for (size_t i = 0; i < a.size(); ++i) {
        ASSERT_TRUE(std::isfinite(b[i]));
        sum += std::abs(a[i]);
        diff += std::abs(a[i] - b[i]);
    }
    ASSERT_GT(sum, 0.0) << "no caustic rendered";
    constexpr double kTolerance = 1e-5;
    std::printf("exported vs original: %.3g of the caustic's L1 norm\n", diff / sum);
    EXPECT_LE(diff / sum, kTolerance) << "the exported scene renders a different caustic";

    RingMirror flat;
    flat.smooth = false;
    const std::vector<float> c = shownCaustic(flat.scene(), 3);
    double flatDiff = 0.0;
    for (size_t i = 0; i < a.size(); ++i) flatDiff += std::abs(a[i] - c[i]);
    std::printf("flat facets vs smooth: %.3g of the caustic's L1 norm\n", flatDiff / sum);
    EXPECT_GT(flatDiff / sum, 100 * kTolerance) << "the check cannot tell smooth from flat normals";
}

}  // namespace
}  // namespace rtpm
