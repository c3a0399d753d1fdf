// Viewer server: websocketpp endpoint on its own io_context thread; frames flow output thread →
// tone map (caller, only for display settings a waiting viewer uses) → JPEG (viewer thread, into
// a reused buffer) → each viewer that acknowledged its previous frame.
#include "server/viewer/viewer_server.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <deque>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "common/image/tone_map.h"
#include "server/viewer/jpeg_encoder.h"
#include "server/viewer/web_assets.h"
#include "server/viewer/ws_endpoint.h"

namespace rtpm::server {

double threadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

namespace {

using ConnId = WsEndpoint::ConnId;
using Clock = std::chrono::steady_clock;

/// Unsent bytes above which a viewer gets no more status text until it drains (frames are
/// flow-controlled by acknowledgements instead).
constexpr size_t kMaxBufferedBytes = 1u << 20;

/// Frames the frame-rate cap lets through at once (see publishFrame).
constexpr double kCapBurst = 2.0;

/// Frames between two estimates of the automatic exposure (~0.13 s at 30 fps).
constexpr uint64_t kExposureEvery = 4;

struct DisplayKey {
    ViewerLayer layer = ViewerLayer::Final;
    float exposure = 0.0f;
    bool operator<(const DisplayKey& o) const {
        return layer != o.layer ? layer < o.layer : exposure < o.exposure;
    }
    bool operator==(const DisplayKey&) const = default;
};

struct Viewer {
    bool helloed = false;
    bool control = false;
    DisplayKey key;
    bool awaitingAck = false;
    uint64_t lastSent = UINT64_MAX;
};

struct Encoded {
    uint64_t frame = UINT64_MAX;
    std::string message;  // 8-byte little-endian frame number + JPEG; the buffer is reused
};

struct Pending {
    uint64_t frame = 0;
    int width = 0, height = 0;
    std::vector<uint8_t> rgb;  // from and back to Impl::pool
};

bool sameToken(const std::string& a, const std::string& b) {
    // Constant time in the common length: no early exit on the first differing byte.
    unsigned diff = a.size() == b.size() ? 0u : 1u;
    for (size_t i = 0; i < a.size(); ++i) diff |= unsigned(uint8_t(a[i]) ^ uint8_t(i < b.size() ? b[i] : 0));
    return diff == 0;
}

std::string errorJson(const std::string& message) {
    return nlohmann::json{{"type", "error"}, {"message", message}}.dump();
}

}  // namespace

struct ViewerServer::Impl {
    ViewerOptions opt;
    CommandHandler onCommand;
    asio::io_context io;
    asio::executor_work_guard<asio::io_context::executor_type> guard{io.get_executor()};
    std::unique_ptr<WsEndpoint> ws;
    std::thread thread;

    // Viewer thread only.
    std::map<ConnId, Viewer> viewers;
    std::map<DisplayKey, Encoded> latest;
    std::vector<std::pair<DisplayKey, Pending>> work;  // being encoded (capacity reused)
    std::string status, scene;
    JpegEncoder jpeg;
    bool stopping = false;
    asio::steady_timer stopTimer{io};

    // Output thread only.
    std::vector<float> scaleScratch;  // displayScale's sample
    std::vector<DisplayKey> wantedCopy;
    struct Exposure {
        float scale = 1.0f;
        uint64_t frame = 0;
        bool valid = false;
    };
    std::map<DisplayKey, Exposure> exposures;  // last automatic exposure per display setting

    // Shared with the output thread.
    mutable std::mutex mu;
    std::vector<DisplayKey> wanted;  // display settings some viewer is waiting for a frame in
    std::map<DisplayKey, Pending> pending;  // tone-mapped, not yet encoded (latest wins)
    std::vector<std::vector<uint8_t>> pool;  // 8-bit frame buffers for reuse
    bool encodeQueued = false;
    double capTokens = kCapBurst;  // frame-rate cap
    Clock::time_point lastPublish{};
    std::deque<std::pair<uint64_t, Clock::time_point>> composedAt;  // last frames' composition times
    std::atomic<uint64_t> newestFrame{0};
    double toneMapCpu = 0.0, statusCpu = 0.0;
    double viewerThreadCpu = 0.0;
    ViewerReport stats;
    double lagSum = 0.0, latencySum = 0.0;

    Impl(ViewerOptions o, CommandHandler handler) : opt(std::move(o)), onCommand(std::move(handler)), jpeg(opt.jpegQuality) {
        WsEndpoint::Handlers h;
        h.http = [this](const std::string& method, const std::string& path) { return onHttp(method, path); };
        h.validate = [this](const std::string& path, const std::string& origin, const std::string& host) {
            return validate(path, origin, host);
        };
        h.open = [this](ConnId id) { viewers.emplace(id, Viewer{}); };
        h.close = [this](ConnId id) { onClose(id); };
        h.message = [this](ConnId id, std::string&& payload, bool binary) { onMessage(id, payload, binary); };
        try {
            ws = std::make_unique<WsEndpoint>(io, opt.host, opt.port, kMaxViewerMessageBytes, 1024, std::move(h));
        } catch (const std::runtime_error& e) {
            throw std::runtime_error(std::string("--http: ") + e.what());
        }
        thread = std::thread([this] {
            io.run();
            std::lock_guard lock(mu);
            viewerThreadCpu = threadCpuSeconds();
        });
    }

    // ---- HTTP ------------------------------------------------------------------------------

    WsEndpoint::HttpReply onHttp(const std::string& method, std::string path) {
        WsEndpoint::HttpReply r;
        r.headers = {{"Cache-Control", "no-store"}, {"X-Content-Type-Options", "nosniff"}};
        if (method != "GET" && method != "HEAD") {
            r.status = 405;
            r.headers.emplace_back("Allow", "GET, HEAD");
            return r;
        }
        if (path == "/") path = "/index.html";
        for (const WebAsset& a : webAssets())
            if (a.path == path) {
                r.status = 200;
                r.headers.emplace_back("Content-Type", std::string(a.contentType));
                r.headers.emplace_back("Content-Security-Policy",
                                       "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
                                       "style-src 'self'; script-src 'self'; frame-ancestors 'none'");
                if (method == "GET") r.body = std::string(a.body);
                return r;
            }
        r.status = 404;
        r.body = "not found\n";
        return r;
    }

    int validate(const std::string& path, const std::string& origin, const std::string& host) {
        if (stopping) return 503;
        if (path != "/ws") return 404;
        if (viewers.size() >= size_t(std::max(1, opt.maxViewers))) {
            std::fprintf(stderr, "rtpm-server: viewer refused: %zu viewers already connected\n", viewers.size());
            return 503;
        }
        // A page from another origin must not drive the master (cross-site WebSocket hijacking).
        if (!origin.empty() && origin != "http://" + host) {
            std::fprintf(stderr, "rtpm-server: viewer refused: origin %s is not http://%s\n", origin.c_str(), host.c_str());
            return 403;
        }
        return 0;
    }

    // ---- WebSocket ---------------------------------------------------------------------------

    void onClose(ConnId h) {
        auto it = viewers.find(h);
        if (it == viewers.end()) return;
        viewers.erase(it);
        refreshWanted();
    }

    /// Tells the output thread which display settings to tone-map frames for: those some viewer
    /// uses. Frames of settings nobody uses any more are dropped.
    void refreshWanted() {
        std::vector<DisplayKey> w;
        for (const auto& [h, v] : viewers)
            if (v.helloed && std::find(w.begin(), w.end(), v.key) == w.end()) w.push_back(v.key);
        for (auto it = latest.begin(); it != latest.end();) {
            bool used = false;
            for (const auto& [h, v] : viewers) used |= v.helloed && v.key == it->first;
            it = used ? std::next(it) : latest.erase(it);
        }
        std::lock_guard lock(mu);
        wanted = std::move(w);
        for (auto it = pending.begin(); it != pending.end();) {
            if (std::find(wanted.begin(), wanted.end(), it->first) != wanted.end()) {
                ++it;
                continue;
            }
            pool.push_back(std::move(it->second.rgb));
            it = pending.erase(it);
        }
    }

    void sendText(ConnId h, const std::string& text, bool droppable = false) {
        if (droppable && ws->buffered(h) > kMaxBufferedBytes) return;
        ws->send(h, text.data(), text.size(), false);
    }

    void trySendFrame(ConnId h, Viewer& v) {
        if (!v.helloed || v.awaitingAck) return;
        auto it = latest.find(v.key);
        if (it == latest.end() || it->second.frame == UINT64_MAX || it->second.frame == v.lastSent) return;
        if (!ws->send(h, it->second.message.data(), it->second.message.size(), true)) return;
        v.awaitingAck = true;
        v.lastSent = it->second.frame;
    }

    void onMessage(ConnId h, const std::string& payload, bool binary) {
        auto it = viewers.find(h);
        if (it == viewers.end()) return;
        Viewer& v = it->second;
        if (binary) {
            sendText(h, errorJson("controls are JSON text messages"));
            return;
        }
        ViewerParse parsed = parseViewerCommand(payload);
        if (!parsed.ok()) {
            sendText(h, errorJson("control refused: " + parsed.error()));
            return;
        }
        const ViewerCommand& cmd = parsed.command();
        if (auto* hello = std::get_if<ViewerHello>(&cmd)) {
            if (v.helloed) {
                sendText(h, errorJson("hello sent twice"));
                return;
            }
            const bool tokenOk = opt.token.empty() || sameToken(hello->token, opt.token);
            if (!tokenOk && !opt.publicView) {
                sendText(h, errorJson("wrong or missing token: start the page with the cluster or viewer token"));
                ws->close(h, 1008, "token");  // 1008: policy violation
                return;
            }
            v.helloed = true;
            v.control = tokenOk;
            sendText(h, nlohmann::json{{"type", "hello"}, {"control", v.control}}.dump());
            if (!scene.empty()) sendText(h, scene);
            if (!status.empty()) sendText(h, status);
            refreshWanted();
            trySendFrame(h, v);
            encodePending();
            return;
        }
        if (!v.helloed) {
            sendText(h, errorJson("say hello (with the token) first"));
            return;
        }
        if (auto* d = std::get_if<ViewerDisplay>(&cmd)) {
            DisplayKey k{d->layer, d->exposureStops};
            if (!(k == v.key)) {
                v.key = k;
                v.lastSent = UINT64_MAX;
            }
            refreshWanted();
            trySendFrame(h, v);
            encodePending();
            return;
        }
        if (auto* a = std::get_if<ViewerAck>(&cmd)) {
            if (!v.awaitingAck || a->frame != v.lastSent) {
                sendText(h, errorJson("ack for frame " + std::to_string(a->frame) + ", which was not the frame sent"));
                return;
            }
            v.awaitingAck = false;
            noteShown(a->frame);
            trySendFrame(h, v);  // an encoded newer frame, or
            encodePending();     // the newest tone-mapped one, encoded now
            return;
        }
        if (!v.control) {
            sendText(h, errorJson("this viewer is read-only: controls need the cluster or viewer token"));
            return;
        }
        onCommand(cmd, v.control, [this, h](std::string json) {
            asio::post(io, [this, h, json = std::move(json)] {
                if (viewers.count(h)) sendText(h, json);
            });
        });
    }

    void noteShown(uint64_t frame) {
        std::lock_guard lock(mu);
        const uint64_t newest = newestFrame.load();
        const uint64_t lag = newest > frame ? newest - frame : 0;
        ++stats.framesShown;
        lagSum += double(lag);
        stats.maxLagFrames = std::max(stats.maxLagFrames, lag);
        for (const auto& [f, t] : composedAt)
            if (f == frame) {
                const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t).count();
                latencySum += ms;
                stats.maxLatencyMs = std::max(stats.maxLatencyMs, ms);
            }
    }

    // ---- frames ------------------------------------------------------------------------------

    void publishFrame(uint64_t frame, const FrameImage& image) {
        const auto now = Clock::now();
        {
            std::lock_guard lock(mu);
            newestFrame = frame;
            composedAt.emplace_back(frame, now);
            if (composedAt.size() > 16) composedAt.pop_front();
            if (wanted.empty()) return;
            if (opt.maxFps > 0.0) {
                // Frame-rate cap: a token bucket filled at maxFps a second holding at most
                // kCapBurst frames. The master retires frames in bursts (pipelining: often two
                // at once), so a plain minimum interval would drop one of each pair of a master
                // running at the cap's rate; the bucket passes them and holds the average.
                const double dt = std::chrono::duration<double>(now - lastPublish).count();
                lastPublish = now;
                capTokens = std::min(kCapBurst, capTokens + dt * opt.maxFps);
                if (capTokens < 1.0) return;
                capTokens -= 1.0;
            }
            wantedCopy = wanted;
        }
        const double cpu0 = threadCpuSeconds();
        for (const DisplayKey& k : wantedCopy) {
            const std::vector<float>& buf = k.layer == ViewerLayer::Direct              ? image.direct()
                                            : k.layer == ViewerLayer::Caustic           ? image.causticFiltered()
                                            : k.layer == ViewerLayer::CausticUnfiltered ? image.caustic()
                                                                                        : image.final();
            Pending p;
            p.frame = frame;
            p.width = image.width();
            p.height = image.height();
            {
                std::lock_guard lock(mu);
                if (!pool.empty()) {
                    p.rgb = std::move(pool.back());
                    pool.pop_back();
                }
            }
            p.rgb.resize(buf.size());
            // Auto exposure from every 17th pixel (a stride prime to common widths: a lattice,
            // not a few columns), ~18 k samples at 640×480, renewed every kExposureEvery frames:
            // its strided reads cost half as much as the tone map itself.
            Exposure& e = exposures[k];
            if (!e.valid || frame < e.frame || frame - e.frame >= kExposureEvery) {
                e.scale = displayScale(buf, k.exposure, 17, scaleScratch);
                e.frame = frame;
                e.valid = true;
            }
            toneMapSrgb8(buf, e.scale, p.rgb);
            std::lock_guard lock(mu);
            auto [it, fresh] = pending.try_emplace(k);
            if (!fresh) pool.push_back(std::move(it->second.rgb));  // latest wins: the unencoded older frame is dropped
            it->second = std::move(p);
        }
        for (auto it = exposures.begin(); it != exposures.end();)  // bounded by the settings in use
            it = std::find(wantedCopy.begin(), wantedCopy.end(), it->first) == wantedCopy.end() ? exposures.erase(it) : std::next(it);
        std::lock_guard lock(mu);
        ++stats.framesPublished;
        toneMapCpu += threadCpuSeconds() - cpu0;
        if (!encodeQueued) {
            encodeQueued = true;
            asio::post(io, [this] { encodePending(); });
        }
    }

    /// Encodes the tone-mapped frames some viewer is waiting for (acknowledged its last frame)
    /// and sends them; the others stay pending until a newer frame replaces them or their viewer
    /// acknowledges. So a frame is tone-mapped at most maxFps times a second while someone
    /// watches, and encoded only for a waiting viewer, once however many viewers share it.
    void encodePending() {
        work.clear();
        {
            std::lock_guard lock(mu);
            encodeQueued = false;
            for (auto it = pending.begin(); it != pending.end();) {
                bool waiting = false;
                for (const auto& [h, v] : viewers)
                    waiting |= v.helloed && !v.awaitingAck && v.key == it->first && v.lastSent != it->second.frame;
                if (!waiting) {
                    ++it;
                    continue;
                }
                work.emplace_back(it->first, std::move(it->second));
                it = pending.erase(it);
            }
        }
        if (work.empty()) return;
        for (auto& [k, p] : work) {
            Encoded& e = latest[k];
            e.message.resize(8);
            for (int i = 0; i < 8; ++i) e.message[size_t(i)] = char((p.frame >> (8 * i)) & 0xff);
            try {
                jpeg.encodeInto(p.rgb, p.width, p.height, e.message, 8);
                e.frame = p.frame;
            } catch (const std::exception& ex) {
                std::fprintf(stderr, "rtpm-server: viewer: %s\n", ex.what());
                e.frame = UINT64_MAX;
            }
            std::lock_guard lock(mu);
            pool.push_back(std::move(p.rgb));
            ++stats.framesEncoded;
        }
        for (auto& [h, v] : viewers) trySendFrame(h, v);
    }

    void broadcast(const std::string& text, bool droppable) {
        for (auto& [h, v] : viewers)
            if (v.helloed) sendText(h, text, droppable);
    }

    void stopOnThread() {
        if (stopping) return;
        stopping = true;
        ws->shutdown();
        guard.reset();
        // A viewer that never answers the close handshake must not hold the process.
        stopTimer.expires_after(std::chrono::milliseconds(1500));
        stopTimer.async_wait([this](const asio::error_code& e) {
            if (!e) io.stop();
        });
    }
};

ViewerServer::ViewerServer(ViewerOptions options, CommandHandler onCommand)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(onCommand))) {}

ViewerServer::~ViewerServer() { stop(); }

uint16_t ViewerServer::port() const { return impl_->ws->port(); }

void ViewerServer::publishFrame(uint64_t frame, const FrameImage& image) { impl_->publishFrame(frame, image); }

void ViewerServer::chargeCpu(double seconds) {
    std::lock_guard lock(impl_->mu);
    impl_->statusCpu += seconds;
}

void ViewerServer::publishStatus(std::string json) {
    asio::post(impl_->io, [this, json = std::move(json)]() mutable {
        impl_->status = std::move(json);
        impl_->broadcast(impl_->status, true);
    });
}

void ViewerServer::publishScene(std::string json) {
    asio::post(impl_->io, [this, json = std::move(json)]() mutable {
        impl_->scene = std::move(json);
        impl_->broadcast(impl_->scene, false);
    });
}

void ViewerServer::publishEvent(std::string json) {
    asio::post(impl_->io, [this, json = std::move(json)] { impl_->broadcast(json, true); });
}

void ViewerServer::stop() {
    if (!impl_->thread.joinable()) return;
    asio::post(impl_->io, [this] { impl_->stopOnThread(); });
    impl_->thread.join();
}

ViewerReport ViewerServer::report() const {
    std::lock_guard lock(impl_->mu);
    ViewerReport r = impl_->stats;
    if (r.framesShown) {
        r.meanLagFrames = impl_->lagSum / double(r.framesShown);
        r.meanLatencyMs = impl_->latencySum / double(r.framesShown);
    }
    r.toneMapCpuSeconds = impl_->toneMapCpu;
    r.threadCpuSeconds = impl_->viewerThreadCpu;
    r.statusCpuSeconds = impl_->statusCpu;
    r.cpuSeconds = r.toneMapCpuSeconds + r.threadCpuSeconds + r.statusCpuSeconds;
    return r;
}

}  // namespace rtpm::server
