// Eye-pass throughput at 640×480 on the built-in scenes, next to raw Embree rtcIntersect1
// throughput for coherent (camera-order primary) and incoherent (random) rays on the same scene,
// and the coherent rays in packets of 8 as the eye pass casts its primary rays (intersect8).
//
// Run: eye_pass_bench [--benchmark_filter=RING]   Counters: pixels/s, rays/s (every ray cast:
// primary + specular + shadow), shadow/s; raw benchmarks report rays/s. "threads:all" uses every
// hardware thread through TBB, "threads:1" limits TBB to one.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "common/trace/eye_pass.h"
#include "tests/bench/bench_util.h"
#include "common/scene/scene_loader.h"

namespace rtpm {
namespace {

const int kWidth = bench::sized(640, 64);
const int kHeight = bench::sized(480, 48);

struct LoadedScene {
    Scene scene;
    std::unique_ptr<EmbreeScene> embree;
    Camera camera;
    std::vector<Ray> coherent, incoherent;
};

LoadedScene& loaded(const std::string& name) {
    static std::map<std::string, std::unique_ptr<LoadedScene>> cache;
    auto& slot = cache[name];
    if (!slot) {
        slot = std::make_unique<LoadedScene>();
        slot->scene = loadScene(name);
        slot->embree = std::make_unique<EmbreeScene>(slot->scene);
        slot->camera = *slot->scene.camera;
        for (int y = 0; y < kHeight; ++y)
            for (int x = 0; x < kWidth; ++x)
                slot->coherent.push_back(Ray{slot->camera.position, slot->camera.rayDirection(x, y, kWidth, kHeight)});
        // Random origins in the scene box, uniformly distributed directions: no coherence at all.
        const Bounds b = slot->embree->bounds();
        std::mt19937 rng(12345);
        std::uniform_real_distribution<float> uni(0.0f, 1.0f);
        std::normal_distribution<float> gauss;
        for (int i = 0; i < kWidth * kHeight; ++i) {
            const Vec3 o = b.lo + Vec3(uni(rng), uni(rng), uni(rng)) * b.extent();
            Vec3 d(gauss(rng), gauss(rng), gauss(rng));
            d = glm::length(d) > 0.0f ? glm::normalize(d) : Vec3(0, 0, 1);
            slot->incoherent.push_back(Ray{o, d});
        }
    }
    return *slot;
}

using bench::threadCount;

/// `sampled`: the moving camera's eye pass (sampled dielectric splits, a new seed per iteration).
void eyePass(benchmark::State& state, const std::string& name, int threads, int width = kWidth,
             int height = kHeight, bool sampled = false) {
    LoadedScene& s = loaded(name);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threadCount(threads)));
    const Interleave pattern{width, height, 1};
    std::vector<PixelRadiance> out(size_t(pattern.pixelCount(0)));
    EyeStats stats;
    uint64_t seed = 0;
    for (auto _ : state) {
        renderSet(*s.embree, s.camera, EyeSettings{}, pattern, 0, nullptr, out, &stats, nullptr,
                  sampled ? ++seed : 0);
        benchmark::DoNotOptimize(out.data());
    }
    const double rays = double(stats.primaryRays + stats.secondaryRays + stats.shadowRays);
    const double pixels = double(width) * double(height);
    state.counters["pixels/s"] = benchmark::Counter(double(state.iterations()) * pixels,
                                                    benchmark::Counter::kIsRate);
    state.counters["rays/s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
    state.counters["shadow/s"] = benchmark::Counter(double(stats.shadowRays), benchmark::Counter::kIsRate);
    state.counters["rays/px"] = rays / (double(state.iterations()) * pixels);
    state.counters["threads"] = threadCount(threads);
}

void rawEmbree(benchmark::State& state, const std::string& name, bool coherent, int threads) {
    LoadedScene& s = loaded(name);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threadCount(threads)));
    const std::vector<Ray>& rays = coherent ? s.coherent : s.incoherent;
    RTCScene scene = s.embree->rtcScene();
    std::vector<unsigned> hitIds(rays.size());
    for (auto _ : state) {
        bench::rawIntersect(scene, rays, hitIds, coherent);  // camera order kept per chunk
        benchmark::DoNotOptimize(hitIds.data());
    }
    state.counters["rays/s"] = benchmark::Counter(double(state.iterations()) * double(rays.size()),
                                                  benchmark::Counter::kIsRate);
    state.counters["threads"] = threadCount(threads);
}

/// The incoherent rays as one stream per chunk of 1 024 (rtcIntersect1M): whether Embree gains
/// from streams of the secondary rays a sampled eye pass would gather, against rawEmbree's
/// rtcIntersect1 one by one.
void streamEmbree(benchmark::State& state, const std::string& name, int threads) {
    LoadedScene& s = loaded(name);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threadCount(threads)));
    const std::vector<Ray>& rays = s.incoherent;
    RTCScene scene = s.embree->rtcScene();
    std::vector<unsigned> hitIds(rays.size());
    for (auto _ : state) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
            std::vector<RTCRayHit> stream(r.size());
            for (size_t i = r.begin(); i < r.end(); ++i) stream[i - r.begin()] = bench::toRtcRayHit(rays[i]);
            RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
            rtcIntersect1M(scene, &ctx, stream.data(), unsigned(stream.size()), sizeof(RTCRayHit));
            for (size_t i = r.begin(); i < r.end(); ++i) hitIds[i] = stream[i - r.begin()].hit.primID;
        });
        benchmark::DoNotOptimize(hitIds.data());
    }
    state.counters["rays/s"] = benchmark::Counter(double(state.iterations()) * double(rays.size()),
                                                  benchmark::Counter::kIsRate);
    state.counters["threads"] = threadCount(threads);
}

/// The coherent (camera-order) rays as the eye pass traces its primary rays: packets of 8
/// neighbouring pixels through EmbreeScene::intersect8, hit records completed (normals, uv).
void packetEmbree(benchmark::State& state, const std::string& name, int threads) {
    LoadedScene& s = loaded(name);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threadCount(threads)));
    const std::vector<Ray>& rays = s.coherent;
    std::vector<uint32_t> masks(rays.size() / 8 + 1);
    for (auto _ : state) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, (rays.size() + 7) / 8, 128),
                          [&](const tbb::blocked_range<size_t>& r) {
            SurfaceHit hits[8];
            for (size_t p = r.begin(); p < r.end(); ++p) {
                const int count = int(std::min<size_t>(8, rays.size() - 8 * p));
                masks[p] = s.embree->intersect8(rays.data() + 8 * p, count, hits);
            }
        });
        benchmark::DoNotOptimize(masks.data());
    }
    state.counters["rays/s"] = benchmark::Counter(double(state.iterations()) * double(rays.size()),
                                                  benchmark::Counter::kIsRate);
    state.counters["threads"] = threadCount(threads);
}

}  // namespace
}  // namespace rtpm

int main(int argc, char** argv) {
    using namespace rtpm;
    for (const std::string& name : builtinSceneNames()) {
        for (int threads : {1, 0}) {
            const std::string suffix = name + (threads == 1 ? "/threads:1" : "/threads:all");
            bench::minTime(benchmark::RegisterBenchmark(("EyePass/" + suffix).c_str(),
                                         [=](benchmark::State& st) { eyePass(st, name, threads); })
                ->Unit(benchmark::kMillisecond)->UseRealTime(), 1.0);
            bench::minTime(benchmark::RegisterBenchmark(("EyePassSampled/" + suffix).c_str(),
                                         [=](benchmark::State& st) {
                                             eyePass(st, name, threads, kWidth, kHeight, true);
                                         })
                ->Unit(benchmark::kMillisecond)->UseRealTime(), 1.0);
            bench::minTime(benchmark::RegisterBenchmark(("EmbreeCoherent/" + suffix).c_str(),
                                         [=](benchmark::State& st) { rawEmbree(st, name, true, threads); })
                ->Unit(benchmark::kMillisecond)->UseRealTime(), 1.0);
            bench::minTime(benchmark::RegisterBenchmark(("EmbreeCoherentPacket8/" + suffix).c_str(),
                                         [=](benchmark::State& st) { packetEmbree(st, name, threads); })
                ->Unit(benchmark::kMillisecond)->UseRealTime(), 1.0);
            bench::minTime(benchmark::RegisterBenchmark(("EmbreeIncoherent/" + suffix).c_str(),
                                         [=](benchmark::State& st) { rawEmbree(st, name, false, threads); })
                ->Unit(benchmark::kMillisecond)->UseRealTime(), 1.0);
            bench::minTime(benchmark::RegisterBenchmark(("EmbreeIncoherentStream/" + suffix).c_str(),
                                         [=](benchmark::State& st) { streamEmbree(st, name, threads); })
                ->Unit(benchmark::kMillisecond)->UseRealTime(), 1.0);
        }
    }
    // A 160×120 image of the same view on one thread: small enough to profile under
    // valgrind --tool=callgrind (instruction counts are repeatable on a loaded machine).
    for (const std::string& name : builtinSceneNames())
        benchmark::RegisterBenchmark(("EyePassSmall/" + name).c_str(),
                                     [=](benchmark::State& st) {
                                         eyePass(st, name, 1, bench::sized(160, 32), bench::sized(120, 24));
                                     })
            ->Unit(benchmark::kMillisecond)->Iterations(1);
    return bench::runBenchmarks(argc, argv);
}
