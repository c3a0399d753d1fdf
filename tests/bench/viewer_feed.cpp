// A stand-in rtpm client for tests/bench/viewer_cost.sh: joins a real rtpm-server like
// rtpm-client, but answers every FrameBegin with the pixels of a frame rendered beforehand
// (an rtpm-render EXR's direct and unfiltered caustic layers, cut into the sets it owns and
// encoded once), paced to --fps frames a second. The master then does all of its real per-frame
// work (decode, scatter, box filter, compose, viewer) at a frame rate the render clients of this
// 2-core machine cannot reach at 640×480, so the viewer's share of the master's CPU can be
// measured at 30 fps and beyond.
//
//   viewer_feed --port-file F --exr ring640.exr [--fps 30] [--name feed-1]   (token: $RTPM_TOKEN)
#include <asio.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/core/interleave.h"
#include "common/image/image_io.h"
#include "proto/auth.h"
#include "proto/messages.h"
#include "proto/pixel_codec.h"

namespace {

using namespace rtpm;
using Clock = std::chrono::steady_clock;

struct Args {
    std::string portFile, exr, name = "feed";
    double fps = 30.0;
};

Args parse(int argc, char** argv) {
    Args a;
    for (int i = 1; i < argc; ++i) {
        const std::string k = argv[i];
        if (i + 1 >= argc) throw std::invalid_argument(k + " needs a value");
        const std::string v = argv[++i];
        if (k == "--port-file") a.portFile = v;
        else if (k == "--exr") a.exr = v;
        else if (k == "--name") a.name = v;
        else if (k == "--fps") a.fps = std::stod(v);
        else throw std::invalid_argument("unknown option " + k);
    }
    if (a.portFile.empty() || a.exr.empty()) throw std::invalid_argument("--port-file and --exr are required");
    if (!(a.fps >= 0.0)) throw std::invalid_argument("--fps must be >= 0 (0 = as fast as the master asks)");
    return a;
}

uint16_t readPort(const std::string& file) {
    for (int i = 0; i < 600; ++i) {  // bounded: 30 s
        std::ifstream f(file);
        unsigned p = 0;
        if (f >> p && p > 0 && p < 65536) return uint16_t(p);
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    throw std::runtime_error("no port in " + file + " after 30 s");
}

int run(const Args& a) {
    const ExrImage img = readExr(a.exr);
    const std::vector<float> direct = img.layerRgb("direct"), caustic = img.layerRgb("caustic");
    const char* tokenEnv = std::getenv("RTPM_TOKEN");
    asio::io_context io;
    asio::ip::tcp::socket sock(io);
    sock.connect({asio::ip::make_address("127.0.0.1"), readPort(a.portFile)});
    sock.set_option(asio::ip::tcp::no_delay(true));
    const std::string token = tokenEnv ? tokenEnv : "";
    const proto::Hello hello{proto::kProtocolVersion, 1, a.name};
    asio::write(sock, asio::buffer(proto::encode(hello)));  // the Challenge is answered below

    std::vector<std::vector<uint8_t>> encoded;  // per set, once Settings arrived
    std::vector<proto::PixelEncoding> used;
    std::vector<uint32_t> pixelCount;
    proto::FrameSplitter splitter;
    std::vector<uint8_t> buf(1 << 16);
    const auto start = Clock::now();
    uint64_t answered = 0;
    for (;;) {
        asio::error_code ec;
        const size_t n = sock.read_some(asio::buffer(buf), ec);
        if (ec) return answered > 0 ? 0 : 3;  // the master closed after its Bye
        splitter.feed(std::span<const uint8_t>(buf.data(), n));
        for (;;) {
            auto r = splitter.next();
            if (!r.ok()) throw std::runtime_error(r.error().message);
            if (!r->has_value()) break;
            proto::Message& m = **r;
            if (auto* rej = std::get_if<proto::Reject>(&m)) throw std::runtime_error("refused: " + rej->text);
            if (auto* ch = std::get_if<proto::Challenge>(&m)) {
                asio::write(sock, asio::buffer(proto::encode(proto::Auth{proto::authMac(token, ch->nonce, hello)})));
                continue;
            }
            if (std::holds_alternative<proto::Bye>(m)) return 0;
            if (auto* s = std::get_if<proto::Settings>(&m)) {
                if (s->render.width != img.width || s->render.height != img.height)
                    throw std::runtime_error("the master renders " + std::to_string(s->render.width) + "x" +
                                             std::to_string(s->render.height) + ", the EXR is " +
                                             std::to_string(img.width) + "x" + std::to_string(img.height));
                const Interleave pattern{img.width, img.height, s->render.interleave};
                const size_t sets = size_t(s->render.interleave) * size_t(s->render.interleave);
                encoded.assign(sets, {});
                used.assign(sets, s->encoding);
                pixelCount.assign(sets, 0);
                for (size_t set = 0; set < sets; ++set) {
                    std::vector<proto::PixelPair> px(size_t(pattern.pixelCount(int(set))));
                    for (size_t i = 0; i < px.size(); ++i) {
                        const size_t p = size_t(pattern.pixelY(int(set), int(i))) * size_t(img.width) +
                                         size_t(pattern.pixelX(int(set), int(i)));
                        for (int c = 0; c < 3; ++c) {
                            px[i].direct[c] = direct[3 * p + size_t(c)];
                            px[i].caustic[c] = caustic[3 * p + size_t(c)];
                        }
                    }
                    auto e = proto::encodePixels(px, s->encoding);
                    encoded[set] = std::move(e.bytes);
                    used[set] = e.encoding;
                    pixelCount[set] = uint32_t(px.size());
                }
                continue;
            }
            auto* fb = std::get_if<proto::FrameBegin>(&m);
            if (!fb) continue;
            if (encoded.empty()) throw std::runtime_error("FrameBegin before Settings");
            if (a.fps > 0.0)  // pace: answer the n-th frame no earlier than n / fps after the first
                std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                          std::chrono::duration<double>(double(answered) / a.fps)));
            for (uint32_t set : fb->sets) {
                if (set >= encoded.size()) throw std::runtime_error("FrameBegin names set " + std::to_string(set));
                proto::FrameData fd{fb->frame, set, used[set], pixelCount[set], encoded[set]};
                asio::write(sock, asio::buffer(proto::encode(fd)));
            }
            proto::Stats st;
            st.frame = fb->frame;
            st.threads = 1;
            asio::write(sock, asio::buffer(proto::encode(st)));
            ++answered;
        }
    }
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(parse(argc, argv));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "viewer_feed: %s\n", e.what());
        return 1;
    }
}
