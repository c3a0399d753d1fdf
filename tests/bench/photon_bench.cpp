// Photon shooting on the built-in scenes (paper Tables 2–4): throughput, phase split, caustic
// yield plain vs SPT, memory per photon — next to raw Embree throughput on photon-like rays.
//
// Run: photon_bench [--benchmark_filter=RING]. Rates are per wall second; the CPU column is the
// process's CPU time (all threads), so on a shared machine CPU/real shows how much CPU the run got.
// Benchmarks:
//  * Shoot/<scene>/<plain|spt>/db:<0|1>/threads:<1|all> — PhotonMaps::shootBatch of one set, P =
//    kBatchPaths paths per batch, accumulating as in the renderer (reset, untimed, at 1M photons).
//    Counters: paths/s and stored/s (photons inserted into the kd-tree) and rays/s over the whole
//    shootBatch; traceRays/s over tracing alone; sampling/rayCast/interaction = fractions of the
//    tracing time (paper Table 3, PhotonSetStats: phase fractions of 1-in-64 timed paths scaled
//    to the tracing wall time); insert = kd-tree insertion share of shootBatch; yield =
//    productive/traced paths over the run; rays/path.
//  * EmbreeEmission/<scene>/threads:<1|all> — raw rtcIntersect1 on kEmissionRays rays with
//    exactly the distribution and order of the photons' first segments: every emitter's share of
//    the budget (splitBudget), its Halton points through sampleEmission (area lights offset off
//    the surface as the tracer does), consecutive Halton indices in chunks of 256 per thread as in
//    tracePhotons. EmbreeWrapped/… casts the same rays through EmbreeScene::intersect (adds hit
//    post-processing: normals, uv, instance lookup). EmbreeRandom/… uses uniform origins in the
//    scene box with uniform directions (the eye-pass bench's incoherent set).
//  * Yield/<scene>/<plain|spt>/db:<0|1> — deterministic: kYieldBatches batches from a reset.
//    yield = productive paths / traced paths over all batches (SPT's first batch includes its
//    classification period), lastYield = the last batch alone (SPT's steady state); the SPT row
//    also reports vsPlain = its yield / the plain row's (paper Table 4); spt-nodilate is SPT with
//    sptDilate off (refine only boxes that were productive, no face neighbours).
//  * Split/<scene>/db:<0|1> — one thread, plain shooting, every path timed phase by phase through
//    tracePhotonPath(timed = true) instead of 1 in 64: a check of the sampled Table 3 split. The
//    cost of the clock reads inside each timed interval (measured here, ~1 read per interval) is
//    subtracted. rayCastPerRay = seconds per EmbreeScene::intersect inside photon tracing.
//  * Sample/<scene> — one thread, only the light sampling of a photon (its Halton steering numbers,
//    sampleEmission, the area-light origin offset) for the first-segment rays above: an untimed
//    cross-check of the sampling share (sampling share ≈ ns/sample × paths/s of one thread).
//  * Memory/<scene> — one set (SPT, diffuseBounces 1: the renderer's defaults) shoots batches of
//    kMemoryBatchPaths until it holds 1M photons (cap) or kMemorySeconds pass. bytes/photon =
//    KdTree::memoryBytes / photons (photon columns + nodes); peakMB = VmHWM after shooting with
//    the peak reset to the current RSS first (resetPeakRss), baseMB = VmRSS before shooting
//    (scene, BVH, earlier benchmarks' caches). Run each scene in its own process for a clean
//    baseline: --benchmark_filter='^Memory/RING/'.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "common/photon/photon_map.h"
#include "common/scene/scene_loader.h"
#include "tests/bench/bench_util.h"

namespace rtpm {
namespace {

// Under the smoke switch (bench_util.h): batches of 1 000 paths, 1 024 rays, a cap of 2 000 photons.
const uint32_t kBatchPaths = bench::sized(20000u, 1000u);  // PhotonSettings default P
const size_t kEmissionRays = bench::sized<size_t>(1u << 18, 1u << 10);
const uint32_t kYieldBatches = bench::sized(10u, 2u);
const uint32_t kMemoryBatchPaths = bench::sized(100000u, 1000u);
const uint64_t kMemoryCap = bench::sized<uint64_t>(1'000'000, 2000);
constexpr double kMemorySeconds = 40.0;

using Clock = std::chrono::steady_clock;

struct LoadedScene {
    Scene scene;
    std::unique_ptr<EmbreeScene> embree;
    std::vector<Ray> emission, random;
};

std::vector<Ray> emissionRays(const EmbreeScene& embree, size_t count) {
    const std::vector<Emitter> emitters = buildEmitters(embree);
    const std::vector<uint32_t> budget = splitBudget(emitters, static_cast<uint32_t>(count));
    std::vector<Ray> rays;
    rays.reserve(count);
    for (size_t l = 0; l < emitters.size(); ++l) {
        const Emitter& e = emitters[l];
        const Halton halton(PhotonSettings{}.seed, hashKeys(0, l, 0x42454e4348ull));
        const DimLayout dims = dimLayout(e.kind, 1);
        for (uint32_t i = 0; i < budget[l]; ++i) {
            const Vec2 uDir(halton.sample(dims.direction, i), halton.sample(dims.direction + 1, i));
            Vec2 uPoint(0.0f);
            if (dims.point >= 0) uPoint = Vec2(halton.sample(dims.point, i), halton.sample(dims.point + 1, i));
            const EmittedRay em = sampleEmission(e, embree, uDir, uPoint);
            Ray r;
            r.dir = em.dir;
            r.origin = e.kind == EmitterKind::Area ? embree.offsetOrigin(em.origin, em.normal, em.dir)
                                                   : em.origin;
            rays.push_back(r);
        }
    }
    return rays;
}

std::vector<Ray> randomRays(const EmbreeScene& embree, size_t count) {
    const Bounds b = embree.bounds();
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> uni(0.0f, 1.0f);
    std::normal_distribution<float> gauss;
    std::vector<Ray> rays;
    rays.reserve(count);
    for (size_t i = 0; i < count; ++i) {
        const Vec3 o = b.lo + Vec3(uni(rng), uni(rng), uni(rng)) * b.extent();
        Vec3 d(gauss(rng), gauss(rng), gauss(rng));
        d = glm::length(d) > 0.0f ? glm::normalize(d) : Vec3(0, 0, 1);
        rays.push_back(Ray{o, d});
    }
    return rays;
}

LoadedScene& loaded(const std::string& name) {
    static std::map<std::string, std::unique_ptr<LoadedScene>> cache;
    auto& slot = cache[name];
    if (!slot) {
        slot = std::make_unique<LoadedScene>();
        slot->scene = loadScene(name);
        slot->embree = std::make_unique<EmbreeScene>(slot->scene);
    }
    return *slot;
}

const std::vector<Ray>& raysOf(LoadedScene& s, bool emission) {
    std::vector<Ray>& rays = emission ? s.emission : s.random;
    if (rays.empty()) rays = emission ? emissionRays(*s.embree, kEmissionRays) : randomRays(*s.embree, kEmissionRays);
    return rays;
}

PhotonSettings shootSettings(bool selective, uint32_t diffuseBounces) {
    PhotonSettings ps;
    ps.photonsPerBatch = kBatchPaths;
    ps.selective = selective;
    ps.diffuseBounces = diffuseBounces;
    ps.capPhotons = kMemoryCap;
    return ps;
}

// Sums of PhotonSetStats differences across batches (the stats restart at a reset).
struct Totals {
    double paths = 0, productive = 0, stored = 0, rays = 0;
    double trace = 0, sampling = 0, rayCast = 0, interaction = 0, insert = 0;
    void addDelta(const PhotonSetStats& a, const PhotonSetStats& b) {
        paths += double(b.pathsTraced - a.pathsTraced);
        productive += double(b.productivePaths - a.productivePaths);
        stored += double(b.photonsStored - a.photonsStored);
        rays += double(b.raysCast - a.raysCast);
        trace += b.seconds.trace - a.seconds.trace;
        sampling += b.seconds.sampling - a.seconds.sampling;
        rayCast += b.seconds.rayCast - a.seconds.rayCast;
        interaction += b.seconds.interaction - a.seconds.interaction;
        insert += b.seconds.insert - a.seconds.insert;
    }
};

void shoot(benchmark::State& state, const std::string& name, bool selective, uint32_t db, int threads) {
    LoadedScene& s = loaded(name);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              size_t(bench::threadCount(threads)));
    PhotonMaps maps(shootSettings(selective, db), {0});
    Totals t;
    double shootSeconds = 0.0;
    for (auto _ : state) {
        const PhotonSetStats before = maps.stats(0);
        const Clock::time_point t0 = Clock::now();
        maps.shootBatch(*s.embree, 0);
        shootSeconds += std::chrono::duration<double>(Clock::now() - t0).count();
        t.addDelta(before, maps.stats(0));
        if (maps.capped(0)) {
            state.PauseTiming();
            maps.reset();
            state.ResumeTiming();
        }
    }
    using C = benchmark::Counter;
    state.counters["paths/s"] = C(t.paths, C::kIsRate);
    state.counters["stored/s"] = C(t.stored, C::kIsRate);
    state.counters["rays/s"] = C(t.rays, C::kIsRate);
    state.counters["traceRays/s"] = t.trace > 0 ? t.rays / t.trace : 0.0;
    state.counters["sampling"] = t.trace > 0 ? t.sampling / t.trace : 0.0;
    state.counters["rayCast"] = t.trace > 0 ? t.rayCast / t.trace : 0.0;
    state.counters["interaction"] = t.trace > 0 ? t.interaction / t.trace : 0.0;
    state.counters["insert"] = shootSeconds > 0 ? t.insert / shootSeconds : 0.0;
    state.counters["yield"] = t.paths > 0 ? t.productive / t.paths : 0.0;
    state.counters["rays/path"] = t.paths > 0 ? t.rays / t.paths : 0.0;
    state.counters["threads"] = bench::threadCount(threads);
}

enum class RayKind { Emission, Wrapped, Random };

void rawEmbree(benchmark::State& state, const std::string& name, RayKind kind, int threads) {
    LoadedScene& s = loaded(name);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              size_t(bench::threadCount(threads)));
    const std::vector<Ray>& rays = raysOf(s, kind != RayKind::Random);
    std::vector<unsigned> hitIds(rays.size());
    for (auto _ : state) {
        if (kind == RayKind::Wrapped) {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 256),
                              [&](const tbb::blocked_range<size_t>& r) {
                for (size_t i = r.begin(); i < r.end(); ++i) {
                    SurfaceHit hit;
                    hitIds[i] = s.embree->intersect(rays[i], hit) ? hit.triangle : ~0u;
                }
            });
        } else {
            bench::rawIntersect(s.embree->rtcScene(), rays, hitIds, false, 256);
        }
        benchmark::DoNotOptimize(hitIds.data());
    }
    size_t misses = 0;
    for (unsigned id : hitIds) misses += id == RTC_INVALID_GEOMETRY_ID;
    state.counters["rays/s"] = benchmark::Counter(double(state.iterations()) * double(rays.size()),
                                                  benchmark::Counter::kIsRate);
    state.counters["missed"] = double(misses) / double(rays.size());
    state.counters["threads"] = bench::threadCount(threads);
}

// Seconds per steady_clock::now(): the bias every timed interval carries. The minimum over short
// runs, so a preemption on the shared machine does not inflate it.
double clockReadSeconds() {
    constexpr int kReads = 5000;
    double best = 1.0;
    Clock::time_point x;
    for (int run = 0; run < 40; ++run) {
        const Clock::time_point a = Clock::now();
        for (int i = 0; i < kReads; ++i) x = Clock::now();
        benchmark::DoNotOptimize(x);
        best = std::min(best, std::chrono::duration<double>(Clock::now() - a).count() / kReads);
    }
    return best;
}

void splitRun(benchmark::State& state, const std::string& name, uint32_t db) {
    LoadedScene& s = loaded(name);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    const std::vector<Emitter> emitters = buildEmitters(*s.embree);
    const std::vector<uint32_t> budget = splitBudget(emitters, kBatchPaths);
    TraceSettings ts;
    ts.diffuseBounces = db;
    const double c = clockReadSeconds();
    double total = 0, sampling = 0, rayCast = 0, rays = 0, paths = 0;
    std::vector<TracedPhoton> out;
    uint64_t next = 0;
    for (auto _ : state) {
        for (size_t l = 0; l < emitters.size(); ++l) {
            const Halton halton(PhotonSettings{}.seed, hashKeys(0, l, 0x53504c4954ull));
            PhotonSource src;
            src.emitter = &emitters[l];
            src.halton = &halton;
            src.hashStream = l;
            src.powerPerPath = emitters[l].flux / float(budget[l]);
            src.dims = dimLayout(emitters[l].kind, db);
            for (uint32_t i = 0; i < budget[l]; ++i) {
                TraceStats st;
                out.clear();
                const Clock::time_point t0 = Clock::now();
                tracePhotonPath(*s.embree, src, ts, next + i, out, st, true);
                const double t = std::chrono::duration<double>(Clock::now() - t0).count();
                // Inside [t0, end]: tStart, tMark, two reads per ray, and one for the pair itself.
                total += t - c * double(3 + 2 * st.rays);
                sampling += st.samplingSeconds - c;
                rayCast += st.rayCastSeconds - c * double(st.rays);
                rays += double(st.rays);
                paths += 1;
            }
        }
        next += kBatchPaths;
    }
    state.counters["paths/s"] = benchmark::Counter(paths, benchmark::Counter::kIsRate);
    state.counters["sampling"] = sampling / total;
    state.counters["rayCast"] = rayCast / total;
    state.counters["interaction"] = (total - sampling - rayCast) / total;
    state.counters["rayCastPerRay"] = rays > 0 ? rayCast / rays : 0.0;
    state.counters["clockRead"] = c;
    state.counters["rays/path"] = paths > 0 ? rays / paths : 0.0;
}

void sampleRun(benchmark::State& state, const std::string& name) {
    LoadedScene& s = loaded(name);
    const std::vector<Emitter> emitters = buildEmitters(*s.embree);
    const std::vector<uint32_t> budget = splitBudget(emitters, kBatchPaths);
    double samples = 0;
    uint64_t next = 0;
    Vec3 sink(0.0f);
    for (auto _ : state) {
        for (size_t l = 0; l < emitters.size(); ++l) {
            const Emitter& e = emitters[l];
            const Halton halton(PhotonSettings{}.seed, hashKeys(0, l, 0x53414d50ull));
            const DimLayout dims = dimLayout(e.kind, 1);
            for (uint32_t i = 0; i < budget[l]; ++i) {
                const uint64_t index = next + i;
                const Vec2 uDir(halton.sample(dims.direction, index), halton.sample(dims.direction + 1, index));
                Vec2 uPoint(0.0f);
                if (dims.point >= 0)
                    uPoint = Vec2(halton.sample(dims.point, index), halton.sample(dims.point + 1, index));
                const EmittedRay em = sampleEmission(e, *s.embree, uDir, uPoint);
                sink += e.kind == EmitterKind::Area ? s.embree->offsetOrigin(em.origin, em.normal, em.dir)
                                                    : em.origin;
                sink += em.dir;
            }
            samples += double(budget[l]);
        }
        next += kBatchPaths;
    }
    benchmark::DoNotOptimize(sink);
    state.counters["samples/s"] = benchmark::Counter(samples, benchmark::Counter::kIsRate);
}

std::map<std::string, double>& plainYields() {
    static std::map<std::string, double> y;
    return y;
}

void yieldRun(benchmark::State& state, const std::string& name, bool selective, uint32_t db,
              bool dilate = true) {
    LoadedScene& s = loaded(name);
    PhotonSettings ps = shootSettings(selective, db);
    ps.capPhotons = 0;
    ps.sptDilate = dilate;
    double yield = 0.0, lastYield = 0.0, paths = 0.0;
    uint64_t stored = 0, refined = 0, cells = 0;
    for (auto _ : state) {
        PhotonMaps maps(ps, {0});
        PhotonSetStats before;
        for (uint32_t b = 0; b < kYieldBatches; ++b) {
            before = maps.stats(0);
            maps.shootBatch(*s.embree, 0);
        }
        const PhotonSetStats& st = maps.stats(0);
        yield = st.yield();
        const double lastPaths = double(st.pathsTraced - before.pathsTraced);
        lastYield = lastPaths > 0 ? double(st.productivePaths - before.productivePaths) / lastPaths : 0.0;
        paths = double(st.pathsTraced);
        stored = st.photonsStored;
        refined = st.spt.refinedCells;
        cells = st.spt.cells;
    }
    const std::string key = name + "/" + std::to_string(db);
    if (!selective) plainYields()[key] = yield;
    state.counters["yield"] = yield;
    state.counters["lastYield"] = lastYield;
    state.counters["paths"] = paths;
    state.counters["stored"] = double(stored);
    if (selective) {
        state.counters["cells"] = double(cells);
        state.counters["refined"] = double(refined);
        auto it = plainYields().find(key);
        if (it != plainYields().end() && it->second > 0) state.counters["vsPlain"] = yield / it->second;
    }
}

void memoryRun(benchmark::State& state, const std::string& name) {
    LoadedScene& s = loaded(name);
    PhotonSettings ps = shootSettings(true, 1);
    ps.photonsPerBatch = kMemoryBatchPaths;
    double bytesPerPhoton = 0, treeMB = 0, photons = 0, nodes = 0, baseMB = 0, peakMB = 0, secs = 0;
    bool resetOk = false;
    for (auto _ : state) {
        resetOk = bench::resetPeakRss();
        baseMB = double(bench::procStatusKb("VmRSS")) / 1024.0;
        PhotonMaps maps(ps, {0});
        const Clock::time_point t0 = Clock::now();
        while (!maps.capped(0) &&
               std::chrono::duration<double>(Clock::now() - t0).count() < kMemorySeconds)
            maps.shootBatch(*s.embree, 0);
        secs = std::chrono::duration<double>(Clock::now() - t0).count();
        peakMB = double(bench::procStatusKb("VmHWM")) / 1024.0;
        const KdTree* tree = maps.index<KdTree>(0);
        photons = tree ? double(tree->size()) : 0.0;
        nodes = tree ? double(tree->nodeCount()) : 0.0;
        treeMB = tree ? double(tree->memoryBytes()) / (1024.0 * 1024.0) : 0.0;
        bytesPerPhoton = photons > 0 ? double(tree->memoryBytes()) / photons : 0.0;
    }
    state.counters["photons"] = photons;
    state.counters["bytes/photon"] = bytesPerPhoton;
    state.counters["nodes/photon"] = photons > 0 ? nodes / photons : 0.0;
    state.counters["treeMB"] = treeMB;
    state.counters["baseMB"] = baseMB;
    state.counters["peakMB"] = peakMB;
    state.counters["peakResetOk"] = resetOk ? 1.0 : 0.0;
    state.counters["seconds"] = secs;
}

}  // namespace
}  // namespace rtpm

int main(int argc, char** argv) {
    using namespace rtpm;
    using benchmark::RegisterBenchmark;
    for (const std::string& name : builtinSceneNames()) {
        for (int threads : {1, 0}) {
            const std::string th = threads == 1 ? "/threads:1" : "/threads:all";
            for (bool selective : {false, true})
                for (uint32_t db : {0u, 1u}) {
                    const std::string id = "Shoot/" + name + (selective ? "/spt" : "/plain") +
                                           "/db:" + std::to_string(db) + th;
                    bench::minTime(RegisterBenchmark(id.c_str(), [=](benchmark::State& st) {
                        shoot(st, name, selective, db, threads);
                    })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime(), 1.0);
                }
            bench::minTime(RegisterBenchmark(("EmbreeEmission/" + name + th).c_str(), [=](benchmark::State& st) {
                rawEmbree(st, name, RayKind::Emission, threads);
            })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime(), 1.0);
            bench::minTime(RegisterBenchmark(("EmbreeWrapped/" + name + th).c_str(), [=](benchmark::State& st) {
                rawEmbree(st, name, RayKind::Wrapped, threads);
            })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime(), 1.0);
            bench::minTime(RegisterBenchmark(("EmbreeRandom/" + name + th).c_str(), [=](benchmark::State& st) {
                rawEmbree(st, name, RayKind::Random, threads);
            })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime(), 1.0);
        }
        for (uint32_t db : {0u, 1u})
            for (bool selective : {false, true}) {
                const std::string id = "Yield/" + name + (selective ? "/spt" : "/plain") +
                                       "/db:" + std::to_string(db);
                RegisterBenchmark(id.c_str(), [=](benchmark::State& st) {
                    yieldRun(st, name, selective, db);
                })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->Iterations(1);
            }
        for (uint32_t db : {0u, 1u}) {
            const std::string tail = name + "/db:" + std::to_string(db);
            RegisterBenchmark(("Yield/" + name + "/spt-nodilate/db:" + std::to_string(db)).c_str(),
                              [=](benchmark::State& st) { yieldRun(st, name, true, db, false); })
                ->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->Iterations(1);
            bench::minTime(RegisterBenchmark(("Split/" + tail).c_str(), [=](benchmark::State& st) {
                splitRun(st, name, db);
            })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime(), 1.0);
        }
        bench::minTime(RegisterBenchmark(("Sample/" + name).c_str(), [=](benchmark::State& st) {
            sampleRun(st, name);
        })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime(), 1.0);
        RegisterBenchmark(("Memory/" + name).c_str(), [=](benchmark::State& st) {
            memoryRun(st, name);
        })->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->Iterations(1);
    }
    return bench::runBenchmarks(argc, argv);
}
