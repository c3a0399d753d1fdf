// The cost of a moving camera's frames over a growing or a prefilled photon map: a built-in scene
// orbited as the server's `--animate orbit` does (3° per frame about the scene's centre), every
// set rendered in this process (rtpm-render's share), one line per frame: the process CPU
// milliseconds of shooting the frame's batches and of the rest of the frame (irradiance points,
// eye pass or progressive restart), the eye phase's wall time, the photons stored, the work of
// the irradiance points and the eye pass's secondary rays.
//
//   motion_bench [--scene RING] [--frames 20] [--prefill PATHS] [--estimator knn|progressive]
//                [--threads N] [--still | --nudge] [--out FILE.exr]
//
// --prefill shoots that many paths per set before the first timed frame (frame 0 of the orbit,
// uncapped), so a map of a given size can be timed; --still keeps the camera fixed; --nudge moves
// it every frame by one float step to and fro (moving frames of the scene's own view, comparable
// with a still render: rtpm-compare). --out writes the last frame as rtpm-render does.
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <numeric>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "common/image/frame_image.h"
#include "common/image/image_io.h"
#include "common/render/render_job.h"
#include "common/scene/scene_loader.h"

namespace {

double cpuSeconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
    using namespace rtpm;
    std::string sceneName = "RING";
    int frames = 20;
    uint64_t prefill = 0;
    int threads = 0;
    bool still = false, nudge = false;
    std::string outPath;
    RenderSettings rs;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "motion_bench: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--scene") sceneName = next();
        else if (a == "--frames") frames = std::stoi(next());
        else if (a == "--prefill") prefill = std::stoull(next());
        else if (a == "--threads") threads = std::stoi(next());
        else if (a == "--still") still = true;
        else if (a == "--nudge") nudge = true;
        else if (a == "--out") outPath = next();
        else if (a == "--estimator") {
            const std::string e = next();
            if (e == "knn") rs.photons.estimator = CausticEstimatorKind::Knn;
            else if (e == "progressive") rs.photons.estimator = CausticEstimatorKind::Progressive;
            else {
                std::fprintf(stderr, "motion_bench: --estimator knn|progressive\n");
                return 2;
            }
        } else {
            std::fprintf(stderr, "motion_bench: unknown option '%s'\n", a.c_str());
            return 2;
        }
    }
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0)
        limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, size_t(threads));
    Scene scene = loadScene(sceneName);
    const Camera start = *scene.camera;
    const Vec3 pivot = scene.bounds().centre();
    rs.photons.capPhotons = std::max<uint64_t>(rs.photons.capPhotons, 100'000'000);
    std::vector<uint32_t> sets(size_t(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    std::vector<SetPixels> out;
    // The job's maps are its own non-const member: shooting through them is what renderFrame does.
    PhotonMaps& prefillMaps = const_cast<PhotonMaps&>(job.photons());
    prefillMaps.prepare(job.embree());
    for (uint64_t b = 0; b < (prefill + rs.photons.photonsPerBatch - 1) / rs.photons.photonsPerBatch; ++b)
        for (uint32_t s : sets) prefillMaps.shootBatch(job.embree(), s);
    std::printf("frame,shoot_cpu_ms,frame_cpu_ms,frame_ms,photons_stored,moving,point_gathers,lookups,"
                "candidates_per_lookup,secondary_rays\n");
    PhotonMaps& maps = const_cast<PhotonMaps&>(job.photons());
    for (int f = 0; f < frames; ++f) {
        Camera c = start;
        if (nudge) {
            if (f % 2 == 1) c.position.y = std::nextafter(c.position.y, 1e9f);
        } else if (!still) {
            Mat4 r = glm::translate(Mat4(1.0f), pivot);
            r = glm::rotate(r, glm::radians(3.0f * float(f)), Vec3(0, 1, 0));
            r = glm::translate(r, -pivot);
            c.position = Vec3(r * glm::vec4(c.position, 1.0f));
            c.forward = glm::normalize(Vec3(r * glm::vec4(c.forward, 0.0f)));
            c.up = glm::normalize(Vec3(r * glm::vec4(c.up, 0.0f)));
        }
        // The frame's batch is shot here (what renderFrame shoots on a frame that is not a
        // progressive pass), so that its CPU time is apart from the rest of the frame's.
        const double cpu0 = cpuSeconds();
        maps.prepare(job.embree());
        for (uint32_t s : sets) maps.shootBatch(job.embree(), s);
        const double cpu1 = cpuSeconds();
        const IrradiancePointCounts before = job.irradiance().counts();
        const FrameStats st = job.renderFrame(c, FrameMode::Walkthrough, out);
        const double cpu2 = cpuSeconds();
        const IrradiancePointCounts after = job.irradiance().counts();
        const uint64_t lookups = after.lookups - before.lookups;
        std::printf("%d,%.1f,%.1f,%.1f,%llu,%d,%llu,%llu,%.2f,%llu\n", f, 1e3 * (cpu1 - cpu0), 1e3 * (cpu2 - cpu1),
                    1e3 * st.eyeSeconds, (unsigned long long)st.photonsStored, int(st.moving),
                    (unsigned long long)(after.gathers - before.gathers), (unsigned long long)lookups,
                    lookups ? double(after.candidates - before.candidates) / double(lookups) : 0.0,
                    (unsigned long long)st.eye.secondaryRays);
        std::fflush(stdout);
    }
    if (!outPath.empty()) {
        const Interleave pattern{rs.width, rs.height, rs.interleave};
        FrameImage image(rs.width, rs.height);
        for (const SetPixels& sp : out) scatterSet(image, pattern, sp);
        image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
        writeExr(outPath, image);
    }
    return 0;
}
