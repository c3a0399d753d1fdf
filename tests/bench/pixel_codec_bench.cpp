// Pixel codec: encode/decode throughput and bytes per pixel on a caustic-like 640×480 buffer.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "proto/pixel_codec.h"
#include "tests/bench/bench_util.h"

namespace {

using rtpm::proto::PixelEncoding;
using rtpm::proto::PixelPair;

// A RING-like frame: smooth noisy direct light everywhere; caustic radiance only inside a
// cardioid-shaped band under the ring (about 6% of the pixels), zero elsewhere.
std::vector<PixelPair> ringFrame(int w, int h) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<PixelPair> px(static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            PixelPair& p = px[static_cast<size_t>(y) * w + x];
            const float d = 0.2f + 0.6f * static_cast<float>(y) / h + 0.05f * u(rng);
            p.direct[0] = d;
            p.direct[1] = 0.95f * d;
            p.direct[2] = 0.9f * d;
            const float dx = (x - 0.5f * w) / (0.25f * w), dy = (y - 0.65f * h) / (0.2f * h);
            const float r = std::sqrt(dx * dx + dy * dy), t = std::atan2(dy, dx);
            const float band = std::abs(r - 0.5f * (1.0f + std::cos(t)));
            const float c = band < 0.06f ? (1.5f - 20.0f * band) * (0.5f + u(rng)) : 0.0f;
            p.caustic[0] = c;
            p.caustic[1] = 0.9f * c;
            p.caustic[2] = 0.6f * c;
        }
    return px;
}

const std::vector<PixelPair>& frame() {
    static const std::vector<PixelPair> f = ringFrame(rtpm::bench::sized(640, 64), rtpm::bench::sized(480, 48));
    return f;
}

void report(benchmark::State& state, size_t encodedBytes) {
    const double n = static_cast<double>(frame().size());
    state.counters["B/px"] = static_cast<double>(encodedBytes) / n;
    // Throughput in MB of the 24 B/px float input handled per second.
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                            static_cast<int64_t>(frame().size() * sizeof(PixelPair)));
}

void BM_Encode(benchmark::State& state) {
    const auto enc = static_cast<PixelEncoding>(state.range(0));
    size_t bytes = 0;
    for (auto _ : state) {
        auto out = rtpm::proto::encodePixels(frame(), enc);
        bytes = out.bytes.size();
        benchmark::DoNotOptimize(out.bytes.data());
    }
    report(state, bytes);
}

void BM_Decode(benchmark::State& state) {
    const auto enc = static_cast<PixelEncoding>(state.range(0));
    auto encoded = rtpm::proto::encodePixels(frame(), enc);
    std::vector<PixelPair> out(frame().size());
    for (auto _ : state) {
        auto s = rtpm::proto::decodePixels(encoded.encoding, encoded.bytes, out);
        if (!s.ok()) state.SkipWithError(s.error().message.c_str());
        benchmark::DoNotOptimize(out.data());
    }
    report(state, encoded.bytes.size());
}

// Arg: 0 Float32, 1 Rgb8, 2 Rgb9e5, 3 Rgb9e5Zstd (PixelEncoding ids).
BENCHMARK(BM_Encode)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Apply(rtpm::bench::smokeOnce);
BENCHMARK(BM_Decode)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Apply(rtpm::bench::smokeOnce);

}  // namespace

int main(int argc, char** argv) { return rtpm::bench::runBenchmarks(argc, argv); }
