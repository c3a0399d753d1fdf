// Helpers shared by the benchmarks: the smoke switch, thread limits, raw Embree ray batches,
// process memory figures.
#pragma once

#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/trace/embree_scene.h"

namespace rtpm::bench {

/// The smoke switch: RTPM_BENCH_SMOKE=1 in the environment (the ctest label bench-smoke) runs
/// every registered benchmark once, its set-up at the smallest size, to show that it still runs;
/// the figures of such a run mean nothing. Unset (or any other value), benchmarks run as written.
inline bool smoke() {
    static const bool on = [] {
        const char* v = std::getenv("RTPM_BENCH_SMOKE");
        return v != nullptr && std::string_view(v) == "1";
    }();
    return on;
}

/// `full`, or `small` under the smoke switch: a size a benchmark's set-up or loop uses.
template <class T>
T sized(T full, T small) {
    return smoke() ? small : full;
}

/// A benchmark's iteration policy when its code sets none: the library's (its default minimum
/// time, or --benchmark_min_time), one iteration under the smoke switch. For BENCHMARK(...)->Apply.
inline void smokeOnce(benchmark::internal::Benchmark* b) {
    if (smoke()) b->Iterations(1);
}

/// A benchmark timed for at least `seconds` (MinTime, which --benchmark_min_time does not
/// shorten), or one iteration under the smoke switch.
inline benchmark::internal::Benchmark* minTime(benchmark::internal::Benchmark* b, double seconds) {
    return smoke() ? b->Iterations(1) : b->MinTime(seconds);
}

/// BENCHMARK_MAIN's body. Under the smoke switch the exit status is 1 when no benchmark ran or one
/// reported an error (State::SkipWithError, which the library does not count as a failure), so a
/// broken benchmark fails its smoke test.
inline int runBenchmarks(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    if (!smoke()) {
        benchmark::RunSpecifiedBenchmarks();
        benchmark::Shutdown();
        return 0;
    }
    struct Checking : benchmark::ConsoleReporter {
        size_t runs = 0, errors = 0;
        void ReportRuns(const std::vector<Run>& reports) override {
            for (const Run& r : reports) {
                ++runs;
                if (r.error_occurred) {
                    ++errors;
                    std::fprintf(stderr, "benchmark %s failed: %s\n", r.benchmark_name().c_str(),
                                 r.error_message.c_str());
                }
            }
            ConsoleReporter::ReportRuns(reports);
        }
    } reporter;
    const size_t ran = benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();
    std::fprintf(stderr, "smoke: %zu benchmarks ran, %zu failed\n", ran, reporter.errors);
    return ran > 0 && reporter.errors == 0 ? 0 : 1;
}

/// Threads a benchmark runs with: `requested` > 0 as given, otherwise every hardware thread TBB
/// sees. Pass the result to tbb::global_control(max_allowed_parallelism, …).
inline int threadCount(int requested) {
    return requested > 0 ? requested : tbb::info::default_concurrency();
}

/// Closest-hit queries for every ray of `rays` through plain rtcIntersect1 (no hit
/// post-processing), parallel over chunks of `chunk` consecutive rays so a thread keeps the
/// order of its chunk (which is what makes camera-order rays coherent). `hitIds[i]` receives ray
/// i's primID (RTC_INVALID_GEOMETRY_ID on a miss) so the work cannot be optimised away.
/// Precondition: hitIds.size() == rays.size(). Thread-safe for concurrent calls on one scene.
/// `ray` as Embree's ray-hit record, with no hit yet.
inline RTCRayHit toRtcRayHit(const Ray& ray) {
    RTCRayHit rh{};
    rh.ray.org_x = ray.origin.x;
    rh.ray.org_y = ray.origin.y;
    rh.ray.org_z = ray.origin.z;
    rh.ray.dir_x = ray.dir.x;
    rh.ray.dir_y = ray.dir.y;
    rh.ray.dir_z = ray.dir.z;
    rh.ray.tnear = ray.tMin;
    rh.ray.tfar = ray.tMax;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

inline void rawIntersect(RTCScene scene, std::span<const Ray> rays, std::span<unsigned> hitIds,
                         bool coherent, size_t chunk = 1024) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), chunk),
                      [&](const tbb::blocked_range<size_t>& r) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        for (size_t i = r.begin(); i < r.end(); ++i) {
            RTCRayHit rh = toRtcRayHit(rays[i]);
            rtcIntersect1(scene, &ctx, &rh);
            hitIds[i] = rh.hit.primID;
        }
    });
}

/// A field of /proc/self/status in kB (e.g. "VmHWM", "VmRSS"), or -1 when it cannot be read
/// (not Linux, field absent). O(file size).
inline long procStatusKb(const std::string& field) {
    std::ifstream in("/proc/self/status");
    std::string line;
    const std::string key = field + ":";
    while (std::getline(in, line)) {
        if (line.compare(0, key.size(), key) != 0) continue;
        try {
            return std::stol(line.substr(key.size()));
        } catch (...) {
            return -1;
        }
    }
    return -1;
}

/// Resets the process's peak resident set (VmHWM) to the current RSS by writing "5" to
/// /proc/self/clear_refs (Linux ≥ 4.0), so a later VmHWM is the peak of what follows.
/// Returns false when the kernel or a sandbox refuses; VmHWM is then the process-lifetime peak.
inline bool resetPeakRss() {
    std::ofstream out("/proc/self/clear_refs");
    if (!out) return false;
    out << "5";
    out.flush();
    return static_cast<bool>(out);
}

}  // namespace rtpm::bench
