// Which library should encode the viewer's live frames? Tone mapping plus TurboJPEG, libwebp and
// libpng on a real rendered frame (RTPM_VIEWER_BENCH_EXR, e.g. RING 640×480 from rtpm-render):
// time per frame and bytes per frame (the viewer's CPU and bandwidth at 30 fps).
//
//   build/common/cmd/rtpm-render --scene RING --frames 4 --out /tmp/ring640.exr
//   RTPM_VIEWER_BENCH_EXR=/tmp/ring640.exr build/tests/bench/viewer_encode_bench
#include <benchmark/benchmark.h>

#include <png.h>
#include <webp/encode.h>

#include <cmath>
#include <cstdio>
#include <span>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include "common/image/image_io.h"
#include "common/image/tone_map.h"
#include "server/viewer/jpeg_encoder.h"
#include "tests/bench/bench_util.h"

namespace {

struct Frame {
    int width = 0, height = 0;
    std::vector<float> linear;
    std::vector<uint8_t> srgb;
};

const Frame& frame() {
    static const Frame f = [] {
        const char* path = std::getenv("RTPM_VIEWER_BENCH_EXR");
        if (!path) throw std::runtime_error("set RTPM_VIEWER_BENCH_EXR to a rendered EXR (see the file comment)");
        rtpm::ExrImage img = rtpm::readExr(path);
        Frame out;
        out.width = img.width;
        out.height = img.height;
        out.linear = img.layerRgb("");
        out.srgb.resize(out.linear.size());
        rtpm::toneMapSrgb8(out.linear, rtpm::displayScale(out.linear, 0.0f), out.srgb);
        return out;
    }();
    return f;
}

void BM_ToneMap(benchmark::State& state) {
    const Frame& f = frame();
    std::vector<uint8_t> out(f.linear.size());
    for (auto _ : state) {
        rtpm::toneMapSrgb8(f.linear, rtpm::displayScale(f.linear, 0.0f), out);
        benchmark::DoNotOptimize(out.data());
    }
}

// The previous display tone map (three nested square roots per channel, SIMD), for comparison
// with the table in toneMapSrgb8 on the same machine at the same moment.
__attribute__((target_clones("avx2", "default")))
void toneMapSqrtFit(std::span<const float> rgb, float scale, std::span<uint8_t> out) {
    const float* in = rgb.data();
    uint8_t* o = out.data();
    for (size_t i = 0; i < rgb.size(); ++i) {
        float x = in[i] * scale;
        x = x > 0.0f ? x : 0.0f;
        x = x < 1.0f ? x : 1.0f;
        const float s1 = std::sqrt(x), s2 = std::sqrt(s1), s3 = std::sqrt(s2);
        const float curve = 0.585122381f * s1 + 0.783140355f * s2 - 0.368262736f * s3;
        float v = x <= 0.0031308f ? 12.92f * x : curve;
        v = v < 1.0f ? v : 1.0f;
        o[i] = uint8_t(int(255.0f * v + 0.5f));
    }
}

void BM_ToneMapSqrtFit(benchmark::State& state) {
    const Frame& f = frame();
    std::vector<uint8_t> out(f.linear.size());
    const float scale = rtpm::displayScale(f.linear, 0.0f);
    for (auto _ : state) {
        toneMapSqrtFit(f.linear, scale, out);
        benchmark::DoNotOptimize(out.data());
    }
}

void BM_DisplayScale(benchmark::State& state) {
    const Frame& f = frame();
    for (auto _ : state) benchmark::DoNotOptimize(rtpm::displayScale(f.linear, 0.0f));
}

void BM_TurboJpeg(benchmark::State& state) {
    const Frame& f = frame();
    rtpm::server::JpegEncoder enc(int(state.range(0)));
    size_t bytes = 0;
    for (auto _ : state) bytes = enc.encode(f.srgb, f.width, f.height).size();
    state.counters["bytes"] = double(bytes);
}

void BM_WebP(benchmark::State& state) {
    const Frame& f = frame();
    WebPConfig config;
    WebPConfigInit(&config);
    config.quality = float(state.range(0));
    config.method = 0;  // fastest
    size_t bytes = 0;
    for (auto _ : state) {
        WebPPicture pic;
        WebPPictureInit(&pic);
        pic.width = f.width;
        pic.height = f.height;
        WebPMemoryWriter writer;
        WebPMemoryWriterInit(&writer);
        pic.writer = WebPMemoryWrite;
        pic.custom_ptr = &writer;
        WebPPictureImportRGB(&pic, f.srgb.data(), f.width * 3);
        if (!WebPEncode(&config, &pic)) state.SkipWithError("WebPEncode failed");
        bytes = writer.size;
        WebPPictureFree(&pic);
        WebPMemoryWriterClear(&writer);
    }
    state.counters["bytes"] = double(bytes);
}

void BM_Png(benchmark::State& state) {
    const Frame& f = frame();
    size_t bytes = 0;
    std::vector<uint8_t> buf;
    for (auto _ : state) {
        png_image img{};
        img.version = PNG_IMAGE_VERSION;
        img.width = png_uint_32(f.width);
        img.height = png_uint_32(f.height);
        img.format = PNG_FORMAT_RGB;
        png_alloc_size_t size = 0;
        png_image_write_to_memory(&img, nullptr, &size, 0, f.srgb.data(), 0, nullptr);
        buf.resize(size);
        if (!png_image_write_to_memory(&img, buf.data(), &size, 0, f.srgb.data(), 0, nullptr))
            state.SkipWithError(img.message);
        bytes = size;
    }
    state.counters["bytes"] = double(bytes);
}

using rtpm::bench::smokeOnce;
BENCHMARK(BM_ToneMap)->Unit(benchmark::kMillisecond)->Apply(smokeOnce);
BENCHMARK(BM_ToneMapSqrtFit)->Unit(benchmark::kMillisecond)->Apply(smokeOnce);
BENCHMARK(BM_DisplayScale)->Unit(benchmark::kMillisecond)->Apply(smokeOnce);
BENCHMARK(BM_TurboJpeg)->Arg(85)->Arg(75)->Unit(benchmark::kMillisecond)->Apply(smokeOnce);
BENCHMARK(BM_WebP)->Arg(75)->Unit(benchmark::kMillisecond)->Apply(smokeOnce);
BENCHMARK(BM_Png)->Unit(benchmark::kMillisecond)->Apply(smokeOnce);

}  // namespace

int main(int argc, char** argv) { return rtpm::bench::runBenchmarks(argc, argv); }
