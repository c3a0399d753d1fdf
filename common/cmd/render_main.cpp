// rtpm-render: the single-process renderer, the reference the cluster must equal.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numeric>
#include <string>

#include "common/core/console.h"
#include "common/image/frame_image.h"
#include "common/core/strings.h"
#include "common/scene/gltf_export.h"
#include "common/image/image_io.h"
#include "common/render/render_flags.h"
#include "common/render/pass_budget.h"
#include "common/render/render_job.h"
#include "common/scene/scene_loader.h"

namespace {

using namespace rtpm;

struct Options {
    std::string scene = "RING";
    std::string out;
    std::string exportGlb;
    std::string csv;
    int frames = 10;
    int saveEvery = 0;
    int threads = 0;
    bool plain = false;
    bool noDefaultLight = false;
    std::vector<float> eye, target, lightPos;
    float yfov = 0.0f;
    float lightIntensity = 10.0f;
    float exposure = 0.0f;
    bool exposureSet = false;
    SceneInputPolicy sceneInput;
    ConvergenceFlags convergence;
};


int run(int argc, char** argv) {
    Options o;
    RenderSettings rs;
    CLI::App app{"rtpm-render: single-process caustic renderer (photon maps per interleaving set, "
                 "image-space box filter). Writes a multi-layer EXR (R G B, direct.*, caustic.*, "
                 "caustic_filtered.*) and a tone-mapped PNG beside it."};
    addRenderFlags(app, rs, o.scene, o.plain, o.noDefaultLight);
    addSceneInputFlags(app, o.sceneInput);
    addConvergenceFlags(app, o.convergence);
    app.add_option("--frames", o.frames,
                   "frames to render; every frame adds one photon batch per set until the cap "
                   "(accumulation), the last frame is written")
        ->capture_default_str();
    app.add_option("--out", o.out, "output EXR path (default out/<scene>.exr); the PNG goes beside it");
    app.add_option("--threads", o.threads, "worker threads (0 = all cores)")->capture_default_str();
    app.add_option("--camera-eye", o.eye, "camera position x y z (overrides the scene camera)")->expected(3);
    app.add_option("--camera-target", o.target, "camera target x y z")->expected(3);
    app.add_option("--camera-yfov", o.yfov, "vertical field of view in radians (with --camera-eye)");
    app.add_option("--light", o.lightPos, "add a point light at x y z (OBJ files carry no lights)")->expected(3);
    app.add_option("--light-intensity", o.lightIntensity, "intensity of --light in W/sr")->capture_default_str();
    auto* exp = app.add_option("--exposure", o.exposure, "PNG exposure in stops (default: automatic)");
    app.add_option("--export-glb", o.exportGlb, "write the scene as a .glb file and exit");
    app.add_option("--save-every", o.saveEvery,
                   "also write every n-th frame as <out>_<frame>.exr/.png, as rtpm-server does (0 = off)")
        ->capture_default_str();
    app.add_option("--csv", o.csv, "append one line of figures per frame to this CSV file");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    o.exposureSet = exp->count() > 0;
    rs.photons.selective = !o.plain;

    std::unique_ptr<tbb::global_control> threadLimit;
    if (o.threads > 0)
        threadLimit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                            size_t(o.threads));

    SceneOverrides overrides;
    overrides.defaultLight = !o.noDefaultLight;
    if (!o.eye.empty()) {
        CameraOverride c;
        c.eye = Vec3(o.eye[0], o.eye[1], o.eye[2]);
        if (!o.target.empty()) c.target = Vec3(o.target[0], o.target[1], o.target[2]);
        if (o.yfov > 0.0f) c.yfov = o.yfov;
        overrides.camera = c;
    }
    if (!o.lightPos.empty())
        overrides.light = PointLightOverride{Vec3(o.lightPos[0], o.lightPos[1], o.lightPos[2]), Vec3(o.lightIntensity)};

    auto t0 = std::chrono::steady_clock::now();
    Scene scene = loadScene(o.scene, overrides, o.sceneInput);
    double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (const std::string& w : scene.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    std::printf("scene %s: %zu triangles, %zu lights, %zu materials, loaded in %.1f ms\n", scene.name.c_str(),
                scene.triangleCount(), scene.lights.size(), scene.materials.size(), loadSeconds * 1e3);
    if (!o.exportGlb.empty()) {
        exportGlb(scene, o.exportGlb);
        std::printf("wrote %s\n", o.exportGlb.c_str());
        return 0;
    }
    if (o.frames < 1) throw std::invalid_argument("invalid setting: --frames must be >= 1");
    const Camera camera = *scene.camera;

    std::string stem = toLower(std::filesystem::path(o.scene).stem().string());
    std::string outPath = o.out.empty() ? "out/" + stem + ".exr" : o.out;
    const std::string pngPath = std::filesystem::path(outPath).replace_extension(".png").string();
    // Refuse now, not after the last frame: every frame rendered into an unwritable --out is lost.
    checkImageWritable(outPath);
    checkImageWritable(pngPath);

    const int setCount = rs.interleave * rs.interleave;
    std::vector<uint32_t> sets(static_cast<size_t>(setCount));
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    Interleave pattern{rs.width, rs.height, rs.interleave};
    FrameImage image(rs.width, rs.height);
    std::vector<SetPixels> pixels;

    FILE* csv = nullptr;
    if (!o.csv.empty()) {
        bool fresh = !std::filesystem::exists(o.csv);
        csv = std::fopen(o.csv.c_str(), "a");
        if (!csv) throw std::runtime_error("cannot open " + o.csv);
        if (fresh) std::fprintf(csv, "frame,mode,shoot_ms,eye_ms,filter_ms,total_ms,photons,paths\n");
    }
    std::printf("%dx%d, M=%d (%d sets), F=%d, P=%u paths/set/frame, k=%u, %s, diffuse bounces %u, %s estimator\n",
                rs.width, rs.height, rs.interleave, setCount, rs.filterSize(), rs.photons.photonsPerBatch,
                rs.photons.k, rs.photons.selective ? "SPT" : "plain shooting", rs.photons.diffuseBounces,
                causticEstimatorName(rs.photons.estimator));
    std::printf("%5s %-11s %9s %9s %9s %9s %11s %11s %7s %7s %9s\n", "frame", "mode", "shoot_ms", "eye_ms",
                "filter_ms", "total_ms", "photons", "paths", "yield", "batches", "est_error");
    PassBudget budget(o.convergence.frameBudgetMs * 1e-3);
    for (int f = 0; f < o.frames; ++f) {
        auto tf = std::chrono::steady_clock::now();
        const uint32_t passBatches = budget.batches();
        FrameStats st = job.renderFrame(camera, true, pixels, passBatches);
        auto tfilter = std::chrono::steady_clock::now();
        for (const SetPixels& sp : pixels)
            scatterSet(image, pattern, sp);
        image.filterAndCompose(rs.filterSize());
        auto tend = std::chrono::steady_clock::now();
        double filterMs = std::chrono::duration<double, std::milli>(tend - tfilter).count();
        double totalMs = std::chrono::duration<double, std::milli>(tend - tf).count();
        budget.record(st.converging, totalMs * 1e-3);
        const double estimate = causticErrorEstimate(st.error);
        uint64_t productive = 0;
        for (uint32_t s : sets) productive += job.photons().stats(s).productivePaths;
        double yield = st.pathsTraced ? double(productive) / double(st.pathsTraced) : 0.0;
        const char* mode = st.converging         ? "converging"
                           : st.pathsThisFrame ? (f == 0 ? "interaction" : "accumulate")
                                               : "walkthrough";
        std::printf("%5d %-11s %9.1f %9.1f %9.2f %9.1f %11llu %11llu %6.1f%% %7u %9.4f\n", f, mode,
                    st.shootSeconds * 1e3, st.eyeSeconds * 1e3, filterMs, totalMs,
                    (unsigned long long)st.photonsStored, (unsigned long long)st.pathsTraced, yield * 100.0,
                    st.converging ? passBatches : 1u, estimate);
        if (csv)
            std::fprintf(csv, "%d,%s,%.3f,%.3f,%.3f,%.3f,%llu,%llu\n", f, mode, st.shootSeconds * 1e3,
                         st.eyeSeconds * 1e3, filterMs, totalMs, (unsigned long long)st.photonsStored,
                         (unsigned long long)st.pathsTraced);
        if (o.saveEvery > 0 && f > 0 && f % o.saveEvery == 0) {
            writeExr(numberedPath(outPath, uint64_t(f), ".exr"), image);
            ToneMap frameTm;
            if (o.exposureSet) frameTm.exposureStops = o.exposure;
            writePng(numberedPath(outPath, uint64_t(f), ".png"), rs.width, rs.height, image.final(), frameTm);
        }
        if (st.eye.nonFinite) std::fprintf(stderr, "warning: %llu non-finite pixel values replaced by 0\n",
                                           (unsigned long long)st.eye.nonFinite);
        if (o.convergence.targetError > 0.0 && st.converging && estimate > 0.0 &&
            estimate <= o.convergence.targetError) {
            std::printf("target error reached at frame %d (estimated %.4f <= %g)\n", f, estimate,
                        o.convergence.targetError);
            break;
        }
    }
    if (csv) std::fclose(csv);

    writeExr(outPath, image);
    ToneMap tm;
    if (o.exposureSet) tm.exposureStops = o.exposure;
    writePng(pngPath, rs.width, rs.height, image.final(), tm);
    std::printf("wrote %s and %s\n", outPath.c_str(), pngPath.c_str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    rtpm::lineBufferConsole();
    try {
        return run(argc, argv);
    } catch (const rtpm::SceneError& e) {
        std::fprintf(stderr, "rtpm-render: scene error: %s\n", e.what());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtpm-render: %s\n", e.what());
    }
    return 1;
}
