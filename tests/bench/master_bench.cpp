// Master capacity: frames/s the real rtpm-server master sustains receiving, decoding, assembling,
// filtering and composing 640×480 from synthetic clients that replay FrameData over loopback.
// The paper's master saturated at 22 fps (640×480, RGB8); the target here is ≥ 100 fps.
#include <benchmark/benchmark.h>

#include <asio.hpp>

#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include "common/core/interleave.h"
#include "common/scene/scene_loader.h"
#include "proto/auth.h"
#include "proto/messages.h"
#include "proto/pixel_codec.h"
#include "server/master.h"
#include "tests/bench/bench_util.h"

namespace {

using namespace rtpm;

const int kWidth = bench::sized(640, 64), kHeight = bench::sized(480, 48);
constexpr int kM = 4;

// Deterministic pixels shaped like a real frame: smooth direct light everywhere, caustics in
// about a fifth of the pixels (so the zstd plane is sparse, as in RING).
std::vector<proto::PixelPair> syntheticSet(const Interleave& pattern, int set) {
    std::vector<proto::PixelPair> px(static_cast<size_t>(pattern.pixelCount(set)));
    for (size_t n = 0; n < px.size(); ++n) {
        int x = pattern.pixelX(set, int(n)), y = pattern.pixelY(set, int(n));
        float d = 0.2f + 0.5f * float(x) / kWidth + 0.3f * float(y) / kHeight;
        px[n] = {{d, 0.9f * d, 0.8f * d}, {0, 0, 0}};
        float cx = float(x - kWidth / 2), cy = float(y - kHeight / 2);
        if (cx * cx + cy * cy < 120.0f * 120.0f) {
            float c = 2.0f + std::sin(float(x) * 0.05f) * std::cos(float(y) * 0.07f);
            px[n].caustic[0] = c;
            px[n].caustic[1] = 0.8f * c;
            px[n].caustic[2] = 0.5f * c;
        }
    }
    return px;
}

// One synthetic client: handshake, then answer every FrameBegin with its sets' FrameData
// (pre-encoded pixels, only the frame number changes) and a Stats, until Bye.
void syntheticClient(uint16_t port, const std::string& token, proto::PixelEncoding encoding,
                     std::atomic<bool>& failed) {
    try {
        asio::io_context io;
        asio::ip::tcp::socket sock(io);
        sock.connect({asio::ip::make_address("127.0.0.1"), port});
        sock.set_option(asio::ip::tcp::no_delay(true));
        const proto::Hello hello{proto::kProtocolVersion, 1, "synthetic"};
        asio::write(sock, asio::buffer(proto::encode(hello)));
        Interleave pattern{kWidth, kHeight, kM};
        std::vector<std::vector<uint8_t>> encoded(kM * kM);
        std::vector<proto::PixelEncoding> used(kM * kM);
        for (int s = 0; s < kM * kM; ++s) {
            auto e = proto::encodePixels(syntheticSet(pattern, s), encoding);
            encoded[size_t(s)] = std::move(e.bytes);
            used[size_t(s)] = e.encoding;
        }
        proto::FrameSplitter splitter;
        std::vector<uint8_t> buf(1 << 16);
        for (;;) {
            size_t n = sock.read_some(asio::buffer(buf));
            splitter.feed(std::span<const uint8_t>(buf.data(), n));
            for (;;) {
                auto r = splitter.next();
                if (!r.ok()) throw std::runtime_error(r.error().message);
                if (!r->has_value()) break;
                proto::Message& m = **r;
                if (std::holds_alternative<proto::Bye>(m) || std::holds_alternative<proto::Reject>(m)) return;
                if (auto* ch = std::get_if<proto::Challenge>(&m)) {
                    asio::write(sock, asio::buffer(proto::encode(proto::Auth{proto::authMac(token, ch->nonce, hello)})));
                    continue;
                }
                auto* fb = std::get_if<proto::FrameBegin>(&m);
                if (!fb) continue;
                for (uint32_t s : fb->sets) {
                    proto::FrameData fd{fb->frame, s, used[s], uint32_t(pattern.pixelCount(int(s))), encoded[s]};
                    asio::write(sock, asio::buffer(proto::encode(fd)));
                }
                proto::Stats st;
                st.frame = fb->frame;
                st.threads = 1;
                asio::write(sock, asio::buffer(proto::encode(st)));
            }
        }
    } catch (const std::exception&) {
        // EOF after the master's Bye is the normal end; anything before counts as a failure
        // only if the master did not finish (checked by the caller through its summary).
    }
    (void)failed;
}

// Arguments: clients, encoding id, frames.
void BM_MasterCapacity(benchmark::State& state) {
    const int clients = int(state.range(0));
    const auto encoding = static_cast<proto::PixelEncoding>(state.range(1));
    const int frames = bench::sized(int(state.range(2)), 3);
    Scene scene = loadScene("RING");
    for (auto _ : state) {
        server::MasterOptions o;
        o.port = 0;
        o.token = "5f2c8d0a9b7e4c1f3a6d8e2b0c9f7a14";  // any strong token
        o.sceneName = "RING";
        o.settings.width = kWidth;
        o.settings.height = kHeight;
        o.settings.interleave = kM;
        o.frames = frames;
        o.minClients = clients;
        o.encoding = encoding;
        o.deadline.fixed = std::chrono::milliseconds(5000);
        o.quiet = true;
        server::Master master(o, scene);
        std::atomic<bool> failed{false};
        std::vector<std::thread> threads;
        for (int c = 0; c < clients; ++c)
            threads.emplace_back(syntheticClient, master.port(), o.token, encoding, std::ref(failed));
        int rc = master.run();
        for (auto& t : threads) t.join();
        const server::MasterSummary& s = master.summary();
        if (rc != 0 || s.framesShown != uint64_t(frames) || s.framesIncomplete != 0) {
            state.SkipWithError("master did not show every frame complete");
            return;
        }
        state.SetIterationTime(s.seconds);
        state.counters["fps"] = double(s.framesShown) / s.seconds;
        state.counters["MB_per_frame"] = double(s.bytesReceived) / 1e6 / double(s.framesShown);
    }
}

// Encodings: 0 Float32 (exact), 1 Rgb8 (the paper's 6 B/px), 2 Rgb9e5, 3 Rgb9e5Zstd.
BENCHMARK(BM_MasterCapacity)
    ->ArgNames({"clients", "encoding", "frames"})
    ->Args({4, 0, 200})
    ->Args({4, 1, 200})
    ->Args({4, 2, 200})
    ->Args({4, 3, 200})
    ->Args({16, 3, 200})
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) { return rtpm::bench::runBenchmarks(argc, argv); }
