// Convergence of the caustic on the curved-mirror scene against its analytic reference: error,
// energy and time per frame for rtpm, and the same error for an outside render (POV-Ray).
//
//   ring_mirror_bench [--estimator progressive|knn|moving] [--photons P] [--frames N] [--width W]
//                     [--height H] [-M m] [-F f] [--confidence g] [--no-spt] [--csv FILE]
//       renders N frames of the still view (tests/support/ring_mirror.h, L S D paths only; moving:
//       the frames of a camera that moves every frame, by one float step to and fro; with
//       --seconds S, stops after the frame that reaches S s of wall time) and prints after
//       frames 1, 2, 4, 8, 16, 32, 48, … and the last: elapsed wall and CPU seconds of the process since
//       the scene was ready (less the time spent scoring reported frames), the caustic-region rel. MAE of the shown caustic (filtered and
//       faded as rtpm-render shows it) and the caustic energy over the compared pixels relative
//       to the reference.
//   ring_mirror_bench --compare FILE.exr [--layer NAME] [--minus DIRECT.exr] [--out DIFF.exr]
//                     [--error-map MAP.png]
//       the same error and energy for the R G B layer of an image (or layer NAME, e.g.
//       caustic_filtered of an rtpm-render / rtpm-server EXR; at the image's own resolution),
//       minus another one (POV-Ray's render without photons, so that only the caustic is
//       compared; tests/bench/pov_compare.py). --error-map: also prints the share of the absolute
//       error (luminance, caustic region) that the worst 1 … 50 % of its pixels carry, and writes
//       the signed error as a PNG: red where the image is brighter than the reference, blue
//       where darker, at the reference's exposure + 2 stops.
//   ring_mirror_bench --write-scene FILE.glb
//       writes the scene as binary glTF (radial normals, light and camera included), so that
//       rtpm-render and the cluster render it: `--scene FILE.glb --photon-depth 2
//       --diffuse-bounces 0` (tests/bench/cluster_bench.sh, scene MIRROR).
//   ring_mirror_bench --reference FILE.exr      writes the analytic reference (R G B).
//   ring_mirror_bench --static-frame 10000 --static-frame 1000000 [--photons P] [--frames N]
//       still-frame time of one set with its map filled to each size (staticFrame below).
//   Every mode: [--light X,Y,Z] [--ring-height H] place the point light (default 0.55,0.9,0) and
//       set the mirror's height (default 0.35 m), for a variant of the scene (light inside the
//       ring, within 0.95 of its radius, above the floor); the same values for writing the scene
//       and for scoring a render of it.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/core/interleave.h"
#include "common/image/error_metrics.h"
#include "common/image/frame_image.h"
#include "common/image/image_io.h"
#include "common/image/shown_change.h"
#include "common/render/pass_budget.h"
#include "common/render/render_job.h"
#include "common/scene/gltf_export.h"
#include "tests/support/ring_mirror.h"

namespace {

using namespace rtpm;

double cpuSeconds() {
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    return double(ru.ru_utime.tv_sec) + double(ru.ru_stime.tv_sec) +
           1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

struct Options {
    std::string estimator = "progressive";
    uint32_t photons = 100000;
    int frames = 16;
    int width = 320, height = 240, m = 3, f = 0;
    float gamma = 1.5f;
    double seconds = 0.0;  ///< --seconds: stop after the frame that reaches this wall time
    double mask = 0.97;
    uint32_t k = 64;
    bool selective = true;  ///< --no-spt: plain shooting
    double budgetMs = 0.0;  ///< --frame-budget-ms: still passes grow to this frame time (0: one batch)
    std::string csv, compare, reference, out, minus, layer, writeScene, errorMap;
    std::vector<uint64_t> staticStored;  ///< --static-frame, repeatable
    Vec3 light{testscenes::RingMirror{}.light};       ///< --light
    double ringHeight = testscenes::RingMirror{}.height;  ///< --ring-height
};

/// The scene with this run's variant (--light, --ring-height) and compared region (--mask).
testscenes::RingMirror ringMirror(const Options& o) {
    testscenes::RingMirror rm;
    rm.light = o.light;
    rm.height = o.ringHeight;
    rm.maskFraction = o.mask;
    return rm;
}

struct Score {
    double relMae = 0.0, energy = 0.0;
};

// Caustic-region rel. MAE (error_metrics.h's region: 5 % of the 99th percentile of the
// reference) and Σ output / Σ reference over the pixels the reference covers.
Score score(std::span<const float> rgb, const std::vector<float>& ref, const std::vector<uint8_t>& mask,
            int w, int h) {
    std::vector<float> masked(rgb.begin(), rgb.end());
    double so = 0.0, sr = 0.0;
    for (size_t p = 0; p < mask.size(); ++p)
        for (int c = 0; c < 3; ++c) {
            if (!mask[p]) {
                masked[3 * p + c] = 0.0f;
                continue;
            }
            so += masked[3 * p + c];
            sr += ref[3 * p + c];
        }
    const ErrorMetrics em = compareRgb(masked, ref, ref, w, h);
    return Score{em.caustic.relMae, sr > 0.0 ? so / sr : 0.0};
}

RenderSettings settingsFor(const Options& o) {
    RenderSettings rs;
    rs.width = o.width;
    rs.height = o.height;
    rs.interleave = o.m;
    rs.filter = o.f;
    rs.photons.photonsPerBatch = o.photons;
    rs.photons.maxDepth = 2;  // L S D only: the reference's light transport
    rs.photons.diffuseBounces = 0;
    rs.photons.progressiveGamma = o.gamma;
    rs.photons.k = o.k;
    rs.photons.selective = o.selective;
    // "moving": the progressive estimator's moving-camera frames (irradiance points): the camera
    // alternates between the view and a copy nudged by one float step, so every frame moves.
    const auto kind = parseCausticEstimator(o.estimator == "moving" ? "progressive" : o.estimator);
    if (!kind)
        throw std::invalid_argument("--estimator must be progressive, knn or moving, not " + o.estimator);
    rs.photons.estimator = *kind;
    return rs;
}

int converge(const Options& o) {
    const testscenes::RingMirror rm = ringMirror(o);
    std::vector<float> ref;
    std::vector<uint8_t> mask;
    rm.referenceImage(o.width, o.height, ref, mask);
    const RenderSettings rs = settingsFor(o);
    Scene scene = rm.scene();
    const Camera camera = *scene.camera;
    std::vector<uint32_t> sets(size_t(rs.interleave * rs.interleave));
    std::iota(sets.begin(), sets.end(), 0u);
    const double cpu0 = cpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    RenderJob job(std::move(scene), rs, sets);
    const Interleave pattern{rs.width, rs.height, rs.interleave};
    FrameImage image(rs.width, rs.height);
    std::vector<SetPixels> pixels;
    FILE* csv = o.csv.empty() ? nullptr : std::fopen(o.csv.c_str(), "w");
    if (!o.csv.empty() && !csv) throw std::runtime_error("cannot open " + o.csv);
    if (csv) std::fprintf(csv, "estimator,photons,frame,wall_s,cpu_s,rel_mae,energy,estimate\n");
    std::printf("%s, P = %u, %dx%d, M = %d, F = %d\n", o.estimator.c_str(), o.photons, rs.width,
                rs.height, rs.interleave, rs.filterSize());
    std::printf("%6s %9s %9s %9s %8s %10s %9s %7s\n", "frame", "wall_s", "cpu_s", "rel_mae", "energy", "stored",
                "estimate", "batches");
    PassBudget budget(o.budgetMs * 1e-3);
    ShownChange change;
    double batchesShot = 0.0;  ///< per set: a pass taking turns shoots 1 / period of a batch on average
    double scoreWall = 0.0, scoreCpu = 0.0;  ///< seconds spent scoring reported frames
    const bool moving = o.estimator == "moving";
    Camera nudged = camera;
    nudged.position.y = std::nextafter(nudged.position.y, 1e9f);
    if (moving) job.renderFrame(nudged, FrameMode::Walkthrough, pixels);  // no photons yet: the next frame moves
    for (int f = 1; f <= o.frames; ++f) {
        const auto tf = std::chrono::steady_clock::now();
        const uint32_t passBatches = budget.batches(), passPeriod = budget.period();
        const FrameStats st = job.renderFrame(moving && f % 2 == 0 ? nudged : camera, pixels, passBatches,
                                              passPeriod);
        budget.record(st.converging, std::chrono::duration<double>(std::chrono::steady_clock::now() - tf).count());
        batchesShot += st.converging ? double(passBatches) / double(passPeriod) : 1.0;
        const bool last = f == o.frames ||
                          (o.seconds > 0.0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >= o.seconds);
        for (const SetPixels& sp : pixels)
            scatterSet(image, pattern, sp);
        image.filterAndCompose(rs.filterSize(), rs.filterEdgeRatio());
        // The error figure rtpm-render prints (render_main.cpp, common/image/shown_change.h).
        const double own = causticErrorEstimate(st.error);
        const double changed = change.add(st.converging, passPeriod, st.error.batches, image.causticFiltered(), rs.width,
                                          rs.height);
        const double estimate = shownErrorFigure(own, changed);
        const bool report = (f & (f - 1)) == 0 || f % 16 == 0 || last;
        if (!report) continue;
        // Scoring against the reference is the benchmark's, not the renderer's: its time is left
        // out of the later frames' figures (POV-Ray's times have none either).
        const auto ts = std::chrono::steady_clock::now();
        const double cpuScore = cpuSeconds();
        const double wall = std::chrono::duration<double>(ts - t0).count() - scoreWall;
        const double cpu = cpuScore - cpu0 - scoreCpu;
        const Score s = score(image.causticFiltered(), ref, mask, rs.width, rs.height);
        scoreWall += std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count();
        scoreCpu += cpuSeconds() - cpuScore;
        std::printf("%6d %9.2f %9.2f %9.4f %8.4f %10llu %9.4f %7.1f\n", f, wall, cpu, s.relMae, s.energy,
                    (unsigned long long)st.photonsStored, estimate, batchesShot);
        std::fflush(stdout);
        if (csv)
            std::fprintf(csv, "%s,%u,%d,%.3f,%.3f,%.5f,%.5f,%.5f\n", o.estimator.c_str(), o.photons, f, wall,
                         cpu, s.relMae, s.energy, estimate);
        if (last) break;
    }
    if (csv) std::fclose(csv);
    if (!o.out.empty()) {
        const ImageLayer layers[2] = {{"", image.causticFiltered()}, {"reference", ref}};
        writeExr(o.out, rs.width, rs.height, layers);
        // Side by side at one exposure: shown caustic | reference.
        std::vector<float> both(size_t(rs.width) * 2 * size_t(rs.height) * 3);
        for (int y = 0; y < rs.height; ++y)
            for (int x = 0; x < rs.width; ++x)
                for (int c = 0; c < 3; ++c) {
                    const size_t src = (size_t(y) * size_t(rs.width) + size_t(x)) * 3 + size_t(c);
                    const size_t dst = (size_t(y) * size_t(rs.width) * 2 + size_t(x)) * 3 + size_t(c);
                    both[dst] = image.causticFiltered()[src];
                    both[dst + size_t(rs.width) * 3] = ref[src];
                }
        ToneMap tm;
        tm.exposureStops = std::log2(autoExposureScale(ref));
        writePng(std::filesystem::path(o.out).replace_extension(".png").string(), rs.width * 2, rs.height,
                 both, tm);
        std::printf("wrote %s\n", o.out.c_str());
    }
    return 0;
}

// Still-frame cost against the map's size: one interleaving set (a client owning set 0),
// default settings but L S D photons; the map is first filled to `stored` photons by frames whose
// camera alternates between two positions (each a restart that shoots and inserts a batch), then
// `frames` still frames (progressive passes) are timed. Prints the median and mean still-frame
// wall time and the process CPU time over them.
void staticFrame(const Options& o, uint64_t stored) {
    const testscenes::RingMirror rm = ringMirror(o);
    RenderSettings rs = settingsFor(o);
    Scene scene = rm.scene();
    const Camera still = *scene.camera;
    Camera moved = still;
    moved.position.x += 1e-3f;
    RenderJob job(std::move(scene), rs, {0u});
    std::vector<SetPixels> pixels;
    int fill = 0;  // ends on `moved`, so the first timed frame restarts the still view
    while (fill % 2 == 0 || (job.photons().stats(0).photonsStored < stored && !job.photons().capped(0))) {
        job.renderFrame(fill % 2 ? moved : still, pixels);
        ++fill;
    }
    std::vector<double> ms;
    double shoot = 0.0, eye = 0.0;
    const double cpu0 = cpuSeconds();
    for (int f = 0; f <= o.frames; ++f) {
        const auto t0 = std::chrono::steady_clock::now();
        const FrameStats st = job.renderFrame(still, pixels);
        const double t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        if (f == 0) continue;  // the restart
        if (!st.converging) throw std::runtime_error("a still frame did not converge");
        ms.push_back(t);
        shoot += st.shootSeconds * 1e3;
        eye += st.eyeSeconds * 1e3;
    }
    const double cpu = (cpuSeconds() - cpu0) * 1e3 / double(o.frames);
    std::vector<double> sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    const double mean = std::accumulate(ms.begin(), ms.end(), 0.0) / double(ms.size());
    std::printf("stored %9llu (fill frames %4d, P = %u): still frame median %7.2f ms, mean %7.2f ms "
                "(shoot %6.2f, gather+compose %6.2f), CPU %7.2f ms/frame\n",
                (unsigned long long)job.photons().stats(0).photonsStored, fill, rs.photons.photonsPerBatch,
                sorted[sorted.size() / 2], mean, shoot / double(o.frames), eye / double(o.frames), cpu);
    std::fflush(stdout);
}

// --error-map: where the error sits. The caustic region as the error metrics define it (reference
// luminance above 5 % of its 99th percentile, within the mask).
void writeErrorMap(const std::string& path, std::span<const float> rgb, const std::vector<float>& ref,
                   const std::vector<uint8_t>& mask, int w, int h) {
    auto lum = [](std::span<const float> v, size_t p) {
        return 0.2126 * double(v[3 * p]) + 0.7152 * double(v[3 * p + 1]) + 0.0722 * double(v[3 * p + 2]);
    };
    std::vector<double> refLum(mask.size());
    for (size_t p = 0; p < mask.size(); ++p) refLum[p] = lum(ref, p);
    std::vector<double> sorted = refLum;
    const size_t k99 = std::min(sorted.size() - 1, size_t(0.99 * double(sorted.size())));
    std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(k99), sorted.end());
    const double threshold = 0.05 * sorted[k99];
    std::vector<double> errors;
    std::vector<float> map(ref.size(), 0.0f);
    double total = 0.0;
    for (size_t p = 0; p < mask.size(); ++p) {
        if (!mask[p] || !(refLum[p] > threshold)) continue;
        const double e = lum(rgb, p) - refLum[p];
        errors.push_back(std::abs(e));
        total += std::abs(e);
        map[3 * p + (e > 0.0 ? 0 : 2)] = float(std::abs(e));
    }
    std::sort(errors.rbegin(), errors.rend());
    double worst = 0.0;
    size_t k = 0;
    for (double share : {0.01, 0.02, 0.05, 0.1, 0.2, 0.5}) {
        for (; k < size_t(share * double(errors.size())); ++k) worst += errors[k];
        std::printf("the worst %2.0f %% of %zu pixels: %.3f of the absolute error\n", share * 100.0, errors.size(),
                    total > 0.0 ? worst / total : 0.0);
    }
    ToneMap tm;
    tm.exposureStops = std::log2(autoExposureScale(ref)) + 2.0;
    writePng(path, w, h, map, tm);
    std::printf("wrote %s\n", path.c_str());
}

int compareFile(const Options& o) {
    const testscenes::RingMirror rm = ringMirror(o);
    const ExrImage img = readExr(o.compare);
    std::vector<float> ref;
    std::vector<uint8_t> mask;
    rm.referenceImage(img.width, img.height, ref, mask);
    for (const char* c : {"R", "G", "B"})
        if (!img.channels.count(o.layer.empty() ? std::string(c) : o.layer + "." + c))
            throw std::invalid_argument(o.compare + " has no layer '" + o.layer + "' (channel " +
                                        (o.layer.empty() ? std::string(c) : o.layer + "." + c) + ")");
    std::vector<float> rgb = img.layerRgb(o.layer);
    if (!o.minus.empty()) {  // e.g. the same render without photons: its direct light
        const ExrImage direct = readExr(o.minus);
        if (direct.width != img.width || direct.height != img.height)
            throw std::invalid_argument(o.minus + " is not the size of " + o.compare);
        const std::vector<float> d = direct.layerRgb("");
        for (size_t i = 0; i < rgb.size(); ++i) rgb[i] -= d[i];
    }
    if (!o.out.empty()) {
        const ImageLayer layers[2] = {{"", rgb}, {"reference", ref}};
        writeExr(o.out, img.width, img.height, layers);
    }
    const Score s = score(rgb, ref, mask, img.width, img.height);
    std::printf("rel_mae %.5f energy %.5f\n", s.relMae, s.energy);
    if (!o.errorMap.empty()) writeErrorMap(o.errorMap, rgb, ref, mask, img.width, img.height);
    return 0;
}

int writeScene(const Options& o) {
    const testscenes::RingMirror rm = ringMirror(o);
    exportGlb(rm.scene(), o.writeScene);
    std::printf("wrote %s\n", o.writeScene.c_str());
    return 0;
}

int writeReference(const Options& o) {
    const testscenes::RingMirror rm = ringMirror(o);
    std::vector<float> ref;
    std::vector<uint8_t> mask;
    rm.referenceImage(o.width, o.height, ref, mask);
    const ImageLayer layer{"", ref};
    writeExr(o.reference, o.width, o.height, std::span<const ImageLayer>(&layer, 1));
    std::printf("wrote %s\n", o.reference.c_str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    try {
        for (int i = 1; i < argc; ++i) {
            const std::string a = argv[i];
            auto next = [&]() -> std::string {
                if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
                return argv[++i];
            };
            if (a == "--estimator") o.estimator = next();
            else if (a == "--photons") o.photons = uint32_t(std::stoul(next()));
            else if (a == "--frames") o.frames = std::stoi(next());
            else if (a == "--width") o.width = std::stoi(next());
            else if (a == "--height") o.height = std::stoi(next());
            else if (a == "-M") o.m = std::stoi(next());
            else if (a == "-F") o.f = std::stoi(next());
            else if (a == "--confidence") o.gamma = std::stof(next());
            else if (a == "--no-spt") o.selective = false;
            else if (a == "--frame-budget-ms") o.budgetMs = std::stod(next());
            else if (a == "--csv") o.csv = next();
            else if (a == "--compare") o.compare = next();
            else if (a == "--reference") o.reference = next();
            else if (a == "--out") o.out = next();
            else if (a == "--minus") o.minus = next();
            else if (a == "--error-map") o.errorMap = next();
            else if (a == "--layer") o.layer = next();
            else if (a == "--write-scene") o.writeScene = next();
            else if (a == "--seconds") o.seconds = std::stod(next());
            else if (a == "--mask") o.mask = std::stod(next());
            else if (a == "--static-frame") o.staticStored.push_back(std::stoull(next()));
            else if (a == "--k") o.k = uint32_t(std::stoul(next()));
            else if (a == "--light") {
                const std::string v = next();
                float x = 0.0f, y = 0.0f, z = 0.0f;
                char end = 0;
                if (std::sscanf(v.c_str(), "%f,%f,%f%c", &x, &y, &z, &end) != 3)
                    throw std::invalid_argument("--light takes X,Y,Z (e.g. 0.55,0.9,0), not " + v);
                o.light = Vec3(x, y, z);
            } else if (a == "--ring-height") o.ringHeight = std::stod(next());
            else throw std::invalid_argument("unknown argument " + a);
        }
        if (o.frames < 1 || o.width < 1 || o.height < 1) throw std::invalid_argument("sizes must be >= 1");
        const testscenes::RingMirror defaults;
        if (!(std::hypot(double(o.light.x), double(o.light.z)) <= 0.95 * defaults.radius) || !(o.light.y > 0.0f) ||
            !std::isfinite(o.light.y))
            throw std::invalid_argument("--light must lie inside the ring (within 0.95 of its radius from its "
                                        "axis) and above the floor");
        if (!(o.ringHeight > 0.0 && o.ringHeight <= 10.0))
            throw std::invalid_argument("--ring-height must be in (0, 10] m");
        if (!o.writeScene.empty()) return writeScene(o);
        if (!o.compare.empty()) return compareFile(o);
        if (!o.reference.empty()) return writeReference(o);
        if (!o.staticStored.empty()) {
            for (uint64_t n : o.staticStored) staticFrame(o, n);
            return 0;
        }
        return converge(o);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "ring_mirror_bench: %s\n", e.what());
        return 1;
    }
}
