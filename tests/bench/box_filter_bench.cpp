// Box filter speed at 640×480, F = 3…8: running sums vs the naive O(F²) filter vs OpenImageIO.
#include <benchmark/benchmark.h>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <random>
#include <vector>

#include "common/image/box_filter.h"
#include "tests/bench/bench_util.h"

namespace {

const int kWidth = rtpm::bench::sized(640, 64);
const int kHeight = rtpm::bench::sized(480, 48);

std::vector<float> causticImage() {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> img(static_cast<size_t>(kWidth) * kHeight * 3);
    for (float& v : img) v = u(rng) < 0.1f ? 5.0f * u(rng) : 0.0f;
    return img;
}

void setFps(benchmark::State& state) {
    state.counters["fps"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["Mpx/s"] = benchmark::Counter(
        static_cast<double>(state.iterations()) * kWidth * kHeight / 1e6, benchmark::Counter::kIsRate);
}

void BM_BoxFilterRunningSums(benchmark::State& state) {
    const int f = static_cast<int>(state.range(0));
    auto img = causticImage();
    std::vector<float> out(img.size());
    rtpm::BoxFilter filter;
    for (auto _ : state) {
        filter.apply(img, kWidth, kHeight, f, out);
        benchmark::DoNotOptimize(out.data());
    }
    setFps(state);
}

void BM_BoxFilterNaive(benchmark::State& state) {
    const int f = static_cast<int>(state.range(0));
    auto img = causticImage();
    std::vector<float> out(img.size());
    for (auto _ : state) {
        rtpm::boxFilterNaive(img, kWidth, kHeight, f, out);
        benchmark::DoNotOptimize(out.data());
    }
    setFps(state);
}

// OpenImageIO's general convolution with a normalised F×F box kernel on one thread. Its borders
// treat missing pixels as black (no renormalisation), so it does slightly less work than ours.
void BM_BoxFilterOiioConvolve(benchmark::State& state) {
    const int f = static_cast<int>(state.range(0));
    auto img = causticImage();
    OIIO::ImageSpec spec(kWidth, kHeight, 3, OIIO::TypeDesc::FLOAT);
    OIIO::ImageBuf src(spec, img.data());
    OIIO::ImageBuf kernel = OIIO::ImageBufAlgo::make_kernel("box", static_cast<float>(f),
                                                            static_cast<float>(f));
    OIIO::ImageBuf dst(spec);
    for (auto _ : state) {
        bool ok = OIIO::ImageBufAlgo::convolve(dst, src, kernel, true, OIIO::ROI(), 1);
        if (!ok) state.SkipWithError("OIIO convolve failed");
        benchmark::DoNotOptimize(dst.localpixels());
    }
    setFps(state);
}

BENCHMARK(BM_BoxFilterRunningSums)->DenseRange(3, 8)->Unit(benchmark::kMillisecond)->Apply(rtpm::bench::smokeOnce);
BENCHMARK(BM_BoxFilterNaive)->DenseRange(3, 8)->Unit(benchmark::kMillisecond)->Apply(rtpm::bench::smokeOnce);
BENCHMARK(BM_BoxFilterOiioConvolve)->DenseRange(3, 8)->Unit(benchmark::kMillisecond)->Apply(rtpm::bench::smokeOnce);

}  // namespace

int main(int argc, char** argv) { return rtpm::bench::runBenchmarks(argc, argv); }
