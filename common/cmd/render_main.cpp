// rtpm-render: the single-process renderer, the reference the cluster must equal.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <numeric>
#include <string>

#include "common/core/console.h"
#include "common/cmd/command_line.h"
#include "common/core/version.h"
#include "common/core/output_file.h"
#include "common/core/progress.h"
#include "common/core/strings.h"
#include "common/image/frame_image.h"
#include "common/scene/gltf_export.h"
#include "common/image/image_io.h"
#include "common/image/shown_change.h"
#include "common/render/image_metadata.h"
#include "common/render/render_flags.h"
#include "common/render/pass_budget.h"
#include "common/render/render_job.h"
#include "common/scene/scene_loader.h"
#include "common/trace/light_probe.h"

namespace {

using namespace rtpm;

// The first SIGINT/SIGTERM (0 = none): the frame loop stops after the frame in flight.
volatile std::sig_atomic_t gStopSignal = 0;

void onStopSignal(int sig) {
    gStopSignal = sig;
    std::signal(sig, SIG_DFL);  // a second signal ends the process at once
}

struct Options {
    std::string scene = "RING";
    std::string out;
    std::string exportGlb;
    std::string csv;
    int frames = 10;
    int saveEvery = 0;
    int threads = 0;
    bool noDefaultLight = false;
    std::vector<float> eye, target, lightPos;
    float yfov = 0.0f;
    float lightIntensity = 10.0f;
    SceneInputPolicy sceneInput;
    ConvergenceFlags convergence;
};

// rtpm-render's flags into `o`, `rs` and `overrides`: nullopt to go on, or the code main returns at
// once (--help, --version, a usage error). Throws UsageError for settings out of range.
std::optional<int> parseFlags(int argc, char** argv, Options& o, RenderSettings& rs,
                              SceneOverrides& overrides) {
    CLI::App app{"rtpm-render: single-process caustic renderer (photon maps per interleaving set, "
                 "image-space box filter). Writes a multi-layer EXR (R G B, direct.*, caustic.*, "
                 "caustic_filtered.*) and a tone-mapped PNG beside it.",
                 "rtpm-render"};
    addRenderFlags(app, rs, o.scene, o.noDefaultLight);
    addSceneInputFlags(app, o.sceneInput);
    addSceneChoiceFlags(app, overrides);
    addConvergenceFlags(app, o.convergence);
    app.add_option("--frames", o.frames,
                   "frames to render; every frame adds one photon batch per set until the cap "
                   "(accumulation), the last frame is written")
        ->capture_default_str()
        ->check(CLI::Range(1, std::numeric_limits<int>::max()))
        ->group("output");
    app.add_option("--out", o.out,
                   "output image NAME.exr or NAME.png: both NAME.exr (every layer, linear) and NAME.png "
                   "(tone-mapped) are written (default out/<scene>.exr)")
        ->group("output");
    app.add_option("--threads", o.threads, "worker threads (0 = all cores)")
        ->capture_default_str()
        ->check(CLI::Range(0, 4096));
    app.add_option("--camera-eye", o.eye, "camera position x y z (overrides the scene camera)")
        ->expected(3)
        ->group("scene");
    app.add_option("--camera-target", o.target, "camera target x y z")->expected(3)->group("scene");
    app.add_option("--camera-yfov", o.yfov, "vertical field of view in radians (with --camera-eye)")->group("scene");
    app.add_option("--light", o.lightPos, "add a point light at x y z (OBJ files carry no lights)")
        ->expected(3)
        ->group("scene");
    app.add_option("--light-intensity", o.lightIntensity, "intensity of --light in W/sr")
        ->capture_default_str()
        ->group("scene");
    app.add_option("--export-glb", o.exportGlb, "write the scene as a .glb file and exit")->group("output");
    app.add_option("--save-every", o.saveEvery,
                   "also write every n-th frame as <out>_<frame>.exr/.png, as rtpm-server does (0 = off)")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber)
        ->group("output");
    app.add_option("--csv", o.csv, "append one line of figures per frame to this CSV file")->group("output");
    addStandardFlags(app, kWireProtocolVersion,
                     {{0, "the image was written"},
                      {1, "the scene or an output cannot be used (refused before rendering), or writing failed"},
                      {130, "stopped by SIGINT (Ctrl-C): the frame in flight was finished and the image so far "
                            "written"},
                      {143, "stopped by SIGTERM, as for SIGINT"}},
                     {{"rtpm-render --scene RING --frames 16 --out out/ring.exr",
                       "16 frames of the built-in RING at 640x480: out/ring.exr (linear layers) and out/ring.png"},
                      {"rtpm-render --scene model.glb --width 1280 --height 720 --frames 1000 --target-error 0.02",
                       "a glTF file until the caustic's estimated error is 2 % (at most 1000 frames)"},
                      {"rtpm-render --scene GLASS --estimator knn --csv out/glass.csv",
                       "the paper's k-NN estimator, with one line of figures per frame in out/glass.csv"}});
    if (auto code = parseCommandLine(app, argc, argv)) return code;
    try {
        validateSettings(rs);
    } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
    }
    return std::nullopt;
}

// The scene --scene names, with the camera and light the flags give; its warnings and figures printed.
Scene loadFlaggedScene(const Options& o, SceneOverrides overrides) {
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

    using Clock = std::chrono::steady_clock;
    auto t0 = Clock::now();
    Scene scene = loadSceneToRender(o.scene, overrides, o.sceneInput);
    double loadSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    for (const std::string& w : scene.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    std::printf("scene %s: %zu triangles, %zu lights, %zu materials, loaded in %.1f ms\n", scene.name.c_str(),
                scene.triangleCount(), scene.lights.size(), scene.materials.size(), loadSeconds * 1e3);
    return scene;
}

// The --csv file, opened for appending, its header written when it is new.
FILE* openCsv(const std::string& path) {
    const bool fresh = !std::filesystem::exists(path);
    FILE* csv = std::fopen(path.c_str(), "a");
    if (!csv) throw OutputError("--csv " + path + ": cannot open: " + std::strerror(errno));
    if (fresh) std::fprintf(csv, "frame,mode,shoot_ms,eye_ms,filter_ms,total_ms,photons,paths\n");
    return csv;
}

// The settings line and the column heads of the per-frame lines.
void printRunHeader(const RenderSettings& rs) {
    std::printf("%dx%d, M=%d (%d sets), F=%d, P=%u paths/set/frame, k=%u, %s, diffuse bounces %u, %s estimator\n",
                rs.width, rs.height, rs.interleave, rs.interleave * rs.interleave, rs.filterSize(),
                rs.photons.photonsPerBatch, rs.photons.k, rs.photons.selective ? "SPT" : "plain shooting",
                rs.photons.diffuseBounces, causticEstimatorName(rs.photons.estimator));
    std::printf("%5s %-11s %9s %9s %9s %9s %11s %11s %7s %7s %9s\n", "frame", "mode", "shoot_ms", "eye_ms",
                "filter_ms", "total_ms", "photons", "paths", "yield", "batches", "est_error");
    std::fflush(stdout);
}

// What a frame's line shows besides its FrameStats.
struct FrameFigures {
    double filterMs, totalMs, yield, estimate;
};

// Frame `f`'s line under printRunHeader's heads, and its CSV line.
void printFrameLine(FILE* csv, int f, const FrameStats& st, const FrameFigures& fig, uint32_t passBatches,
                    uint32_t passPeriod) {
    const char* mode = st.converging         ? "converging"
                       : st.pathsThisFrame ? (f == 0 ? "interaction" : "accumulate")
                                           : "walkthrough";
    // Batches per set and pass, or "1/p" while the sets take turns shooting (pass_budget.h).
    char work[16];
    if (st.converging && passPeriod > 1) std::snprintf(work, sizeof work, "1/%u", passPeriod);
    else std::snprintf(work, sizeof work, "%u", st.converging ? passBatches : 1u);
    std::printf("%5d %-11s %9.1f %9.1f %9.2f %9.1f %11llu %11llu %6.1f%% %7s %9.4f\n", f, mode,
                st.shootSeconds * 1e3, st.eyeSeconds * 1e3, fig.filterMs, fig.totalMs,
                (unsigned long long)st.photonsStored, (unsigned long long)st.pathsTraced, fig.yield * 100.0, work,
                fig.estimate);
    std::fflush(stdout);
    if (csv)
        std::fprintf(csv, "%d,%s,%.3f,%.3f,%.3f,%.3f,%llu,%llu\n", f, mode, st.shootSeconds * 1e3,
                     st.eyeSeconds * 1e3, fig.filterMs, fig.totalMs, (unsigned long long)st.photonsStored,
                     (unsigned long long)st.pathsTraced);
}

int run(int argc, char** argv) {
    Options o;
    RenderSettings rs;
    SceneOverrides overrides;
    if (auto code = parseFlags(argc, argv, o, rs, overrides)) return *code;

    // Every output is checked (and its folder created) before any work: a render is never lost
    // to a path that cannot be written after its last frame.
    if (!o.exportGlb.empty()) prepareOutputFile("--export-glb", o.exportGlb);
    const std::string stem = toLower(std::filesystem::path(o.scene).stem().string());
    const ImageOutputPaths outPaths = imageOutputPaths(o.out.empty() ? "out/" + stem + ".exr" : o.out);
    if (o.exportGlb.empty()) {
        prepareOutputFile("--out", outPaths.exr);
        prepareOutputFile("--out", outPaths.png);
        if (!o.csv.empty()) prepareOutputFile("--csv", o.csv, OutputWrite::Append);
    }

    const auto threadLimit = o.threads > 0 ? std::make_unique<tbb::global_control>(
                                                 tbb::global_control::max_allowed_parallelism, size_t(o.threads))
                                           : nullptr;

    using Clock = std::chrono::steady_clock;
    Scene scene = loadFlaggedScene(o, overrides);
    if (!o.exportGlb.empty()) {
        exportGlb(scene, o.exportGlb);
        std::printf("wrote %s\n", o.exportGlb.c_str());
        return 0;
    }
    const Camera camera = *scene.camera;

    std::vector<uint32_t> sets(static_cast<size_t>(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    RenderJob job(std::move(scene), rs, sets);
    Interleave pattern{rs.width, rs.height, rs.interleave};
    FrameImage image(rs.width, rs.height);
    std::vector<SetPixels> pixels;

    FILE* csv = o.csv.empty() ? nullptr : openCsv(o.csv);
    printRunHeader(rs);
    PassBudget budget(o.convergence.frameBudgetMs * 1e-3);
    // The knn estimator's still frames (Accumulate) take turns over the same budget, one batch per
    // set at most, as the master's accumulation budget has them (server/convergence.h).
    const bool knn = rs.photons.estimator == CausticEstimatorKind::Knn;
    PassBudget accumulation(o.convergence.frameBudgetMs * 1e-3, /*growBatches=*/false);
    ShownChange shownChange;

    // SIGINT/SIGTERM: the frame in flight is finished and the image so far written; a second
    // signal ends the process at once (the handler restores the default action).
    std::signal(SIGINT, onStopSignal);
    std::signal(SIGTERM, onStopSignal);
    ProgressLine progress(stderr, isTerminal(stderr));
    const auto renderStart = Clock::now();
    int framesDone = 0;
    FrameStats last;
    auto provenance = [&] {
        return ImageProvenance{"rtpm-render", o.scene, rs, uint64_t(framesDone), last.photonsStored};
    };
    for (int f = 0; f < o.frames && gStopSignal == 0; ++f) {
        auto tf = Clock::now();
        const uint32_t passBatches = budget.batches();
        const uint32_t passPeriod = knn ? accumulation.period() : budget.period();
        FrameStats st = job.renderFrame(camera, pixels, passBatches, passPeriod);
        auto tfilter = Clock::now();
        for (const SetPixels& sp : pixels)
            scatterSet(image, pattern, sp);
        image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
        auto tend = Clock::now();
        framesDone = f + 1;
        last = st;
        double filterMs = std::chrono::duration<double, std::milli>(tend - tfilter).count();
        double totalMs = std::chrono::duration<double, std::milli>(tend - tf).count();
        // No first period predicted from the shooting (PassBudget::expectShooting, the master's,
        // for the viewer after motion): all sets pass first, as knn's frames (docs/ARCHITECTURE.md).
        budget.record(st.converging, totalMs * 1e-3);
        accumulation.record(knn && f > 0 && !st.walkthrough, totalMs * 1e-3);
        // The shown caustic's change since a sixth of the progression's photons (shown_change.h), where
        // the progressive estimator composed this frame; none before its first baseline.
        const double own = causticErrorEstimate(st.error);
        const double change = shownChange.add(st.converging, passPeriod, st.error.batches, image.causticFiltered(),
                                              image.width(), image.height());
        const double estimate = shownErrorFigure(own, change);
        uint64_t productive = 0;
        for (uint32_t s : sets) productive += job.photons().stats(s).productivePaths;
        double yield = st.pathsTraced ? double(productive) / double(st.pathsTraced) : 0.0;
        progress.clear();
        printFrameLine(csv, f, st, {filterMs, totalMs, yield, estimate}, passBatches, passPeriod);
        if (o.saveEvery > 0 && f > 0 && f % o.saveEvery == 0) {
            writeImageFiles(numberedPath(outPaths.exr, uint64_t(f), ".exr"), image, provenance());
        }
        if (st.eye.nonFinite) std::fprintf(stderr, "warning: %llu non-finite pixel values replaced by 0\n",
                                           (unsigned long long)st.eye.nonFinite);
        progress.update(uint64_t(framesDone), uint64_t(o.frames),
                        std::chrono::duration<double>(Clock::now() - renderStart).count());
        if (o.convergence.targetError > 0.0 && st.converging && estimate > 0.0 &&
            estimate <= o.convergence.targetError) {
            progress.clear();
            std::printf("target error reached at frame %d (estimated %.4f <= %g)\n", f, estimate,
                        o.convergence.targetError);
            break;
        }
    }
    progress.finish();
    if (csv) std::fclose(csv);
    const double wallSeconds = std::chrono::duration<double>(Clock::now() - renderStart).count();
    const int stopSignal = gStopSignal;
    if (stopSignal != 0)
        std::fprintf(stderr, "rtpm-render: %s after frame %d of %d: writing the image rendered so far\n",
                     stopSignal == SIGINT ? "SIGINT" : "SIGTERM", framesDone, o.frames);

    if (framesDone > 0) {
        writeImageFiles(outPaths.exr, image, provenance());
        std::printf("wrote %s and %s\n", outPaths.exr.c_str(), outPaths.png.c_str());
    }
    std::printf("summary: %d of %d frames in %s = %.2f fps, %llu photons stored, %llu photon paths traced%s\n",
                framesDone, o.frames, formatDuration(wallSeconds).c_str(),
                wallSeconds > 0 ? framesDone / wallSeconds : 0.0, (unsigned long long)last.photonsStored,
                (unsigned long long)last.pathsTraced, stopSignal ? " (stopped by a signal)" : "");
    return stopSignal ? 128 + stopSignal : 0;
}

}  // namespace

int main(int argc, char** argv) {
    rtpm::lineBufferConsole();
    try {
        return run(argc, argv);
    } catch (const rtpm::UsageError& e) {
        return rtpm::reportUsageError("rtpm-render", e);
    } catch (const rtpm::OutputError& e) {
        std::fprintf(stderr, "rtpm-render: output error: %s\n", e.what());
    } catch (const rtpm::SceneError& e) {
        std::fprintf(stderr, "rtpm-render: scene error: %s\n", e.what());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtpm-render: %s\n", e.what());
    }
    return 1;
}
