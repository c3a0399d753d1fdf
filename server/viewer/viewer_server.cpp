// Viewer server: websocketpp endpoint on its own io_context thread; frames flow output thread →
// tone map (caller, only for display settings a waiting viewer uses) → JPEG (viewer thread, into
// a reused buffer) → each viewer that acknowledged its previous frame.
#include "server/viewer/viewer_server.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <deque>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "common/core/printable_text.h"
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
    bool failing = false;  // sent a wrong token: answered after the failure delay, ignored meanwhile
    std::shared_ptr<asio::steady_timer> delay;
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

std::string lowered(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

/// Refusals at the WebSocket upgrade, counted for the summary line instead of a line each.
struct UpgradeRefusals {
    uint64_t origin = 0;     // Origin not allowed
    uint64_t full = 0;       // maxViewers viewers already
    std::string lastOrigin;  // escaped and bounded (printableText): a peer's bytes
    bool any() const { return origin || full; }
    std::string text(int maxViewers) const {
        std::string t;
        if (origin)
            t += std::to_string(origin) + " WebSocket upgrades refused for their Origin (last \"" + lastOrigin +
                 "\"; allow one with --viewer-origin)";
        if (full)
            t += std::string(t.empty() ? "" : ", ") + std::to_string(full) + " viewers refused: " +
                 std::to_string(maxViewers) + " (--max-viewers) already watching";
        return t;
    }
};

}  // namespace

struct ViewerServer::Impl {
    ViewerOptions opt;
    CommandHandler onCommand;
    asio::io_context io;
    asio::executor_work_guard<asio::io_context::executor_type> guard{io.get_executor()};
    std::unique_ptr<WsEndpoint> ws;
    std::thread thread;
    std::function<void(const std::string&)> log;

    // Viewer thread only: the HTTP port's admission, under the cluster port's rules
    // (server/admission.h): every TCP connection holds a pending slot from accept until its
    // WebSocket said hello with the token, or it is gone; a budget per address and in all, a
    // deadline, failed tokens delayed and limited per address, one summary line per interval.
    struct Conn {
        std::string source;  // Admission::sourceKey of the peer's address
        std::string origin;  // http://<the local address it reached>:<port>
        Clock::time_point deadline;
        bool pending = true;  // holds an admission slot
    };
    std::map<ConnId, Conn> conns;
    Admission admission{opt.admission};
    asio::steady_timer deadlineTimer{io}, logTimer{io};
    bool deadlineArmed = false, logArmed = false;
    UpgradeRefusals refusedInterval, refusedTotal;
    size_t viewersHelloed = 0;
    std::vector<std::string> allowedOrigins;  // lowered, without a trailing '/'

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
        log = opt.log ? opt.log : [](const std::string& line) { std::fprintf(stderr, "rtpm-server: %s\n", line.c_str()); };
        for (std::string origin : opt.allowedOrigins) {
            origin = lowered(origin);
            while (!origin.empty() && origin.back() == '/') origin.pop_back();
            if (origin.rfind("http://", 0) != 0 && origin.rfind("https://", 0) != 0)
                throw std::invalid_argument("--viewer-origin must be http://HOST[:PORT] or https://HOST[:PORT], got '" +
                                            printableText(origin) + "'");
            allowedOrigins.push_back(origin);
        }
        WsEndpoint::Handlers h;
        h.accept = [this](ConnId id, const WsEndpoint::Peer& peer) { return onAccept(id, peer); };
        h.http = [this](ConnId id, const std::string& method, const std::string& path) {
            admission.onProgress(id);  // a whole request: its slot is not taken for an idle newcomer
            return onHttp(method, path);
        };
        h.validate = [this](ConnId id, const std::string& path, const std::string& origin) {
            return validate(id, path, origin);
        };
        h.open = [this](ConnId id) { viewers.emplace(id, Viewer{}); };
        h.close = [this](ConnId id) { onGone(id); };
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

    // ---- admission ---------------------------------------------------------------------------

    bool onAccept(ConnId id, const WsEndpoint::Peer& peer) {
        if (stopping) return false;
        const auto now = Clock::now();
        const std::string source = Admission::sourceKey(peer.remote);
        const Admission::Verdict v = admission.onConnect(id, source, now);
        armLog();
        if (v.decision != AdmissionDecision::Admit) return false;
        if (v.evict) {
            // Admission ended its slot already; the socket goes now.
            if (auto e = conns.find(*v.evict); e != conns.end()) e->second.pending = false;
            ws->drop(*v.evict);
        }
        Conn c;
        c.source = source;
        const bool v6 = peer.local.find(':') != std::string::npos;
        c.origin = "http://" + (v6 ? "[" + peer.local + "]" : peer.local) + ":" + std::to_string(ws->port());
        c.deadline = now + opt.handshakeTimeout;
        conns[id] = std::move(c);
        armDeadline();
        return true;
    }

    void endPending(ConnId id, Admission::End how) {
        auto it = conns.find(id);
        if (it == conns.end() || !it->second.pending) return;
        it->second.pending = false;
        admission.onPendingEnded(id, how);
    }

    void onGone(ConnId id) {
        endPending(id, Admission::End::Closed);
        conns.erase(id);
        onClose(id);
    }

    /// Every 100 ms while a connection is pending: reaps finished HTTP requests (websocketpp ends
    /// those silently) and drops connections past their deadline.
    void armDeadline() {
        if (deadlineArmed || stopping) return;
        deadlineArmed = true;
        deadlineTimer.expires_after(std::chrono::milliseconds(100));
        deadlineTimer.async_wait([this](const asio::error_code& e) {
            deadlineArmed = false;
            if (e || stopping) return;
            ws->sweep();
            const auto now = Clock::now();
            bool any = false;
            for (auto& [id, c] : conns) {
                if (!c.pending) continue;
                if (now < c.deadline) {
                    any = true;
                    continue;
                }
                c.pending = false;
                admission.onPendingEnded(id, Admission::End::TimedOut);
                ws->drop(id);
            }
            armLog();
            if (any) armDeadline();
        });
    }

    void armLog() {
        if (logArmed || stopping) return;
        const auto next = admission.nextSummary();
        if (!next) return;
        logArmed = true;
        logTimer.expires_at(*next);
        logTimer.async_wait([this](const asio::error_code& e) {
            logArmed = false;
            if (e) return;
            logSummary();
            armLog();
        });
    }

    // One line per interval at most, whatever a flood does (peer bytes escaped and bounded).
    void logSummary(bool final = false) {
        const auto line = admission.summaryLine(Clock::now(), final);
        const std::string refusals = refusedInterval.text(opt.maxViewers);
        refusedInterval = UpgradeRefusals{};
        if (line) log("viewer port: " + *line + (refusals.empty() ? "" : "; " + refusals));
        else if (!refusals.empty()) log("viewer port: " + refusals);
    }

    void logRunTotals() {
        const AdmissionCounts& t = admission.totals();
        if (!t.any() && !refusedTotal.any()) return;
        std::string line = "viewer port over the run: " + std::to_string(t.connections) + " connections, " +
                           std::to_string(t.admitted) + " viewers, " + std::to_string(t.refusedCapacity) +
                           " refused (capacity), " + std::to_string(t.refusedRateLimited) + " refused (rate limit), " +
                           std::to_string(t.evicted) + " evicted for a newcomer, " + std::to_string(t.timedOut) +
                           " timed out, " + std::to_string(t.failedAuth) + " failed tokens";
        if (refusedTotal.any()) line += "; " + refusedTotal.text(opt.maxViewers);
        log(line);
    }

    bool originAllowed(const std::string& origin, const Conn& c) const {
        const std::string o = lowered(origin);
        if (o == c.origin) return true;
        const bool loopback = c.origin.rfind("http://127.", 0) == 0 || c.origin.rfind("http://[::1]:", 0) == 0;
        if (loopback && o == "http://localhost:" + std::to_string(ws->port())) return true;
        return std::find(allowedOrigins.begin(), allowedOrigins.end(), o) != allowedOrigins.end();
    }

    void refuseUpgrade(bool forOrigin, const std::string& origin) {
        for (UpgradeRefusals* r : {&refusedInterval, &refusedTotal}) {
            if (forOrigin) {
                ++r->origin;
                r->lastOrigin = printableText(origin);
            } else {
                ++r->full;
            }
        }
        armLog();
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

    int validate(ConnId id, const std::string& path, const std::string& origin) {
        if (stopping) return 503;
        if (path != "/ws") return 404;
        auto c = conns.find(id);
        if (c == conns.end() || !c->second.pending) return 503;  // its time is up
        // Only viewers that said hello count: sockets that never do time out instead.
        if (viewersHelloed >= size_t(std::max(1, opt.maxViewers))) {
            refuseUpgrade(false, origin);
            return 503;
        }
        // A page from another origin must not drive the master (cross-site WebSocket hijacking,
        // DNS rebinding: such a page chooses the Host header, so only the address the connection
        // reached and the --viewer-origin list are trusted). Non-browser clients send no Origin.
        if (!origin.empty() && !originAllowed(origin, c->second)) {
            refuseUpgrade(true, origin);
            return 403;
        }
        return 0;  // no progress yet: a WebSocket that never says hello stays evictable

    }

    // ---- WebSocket ---------------------------------------------------------------------------

    void onClose(ConnId h) {
        auto it = viewers.find(h);
        if (it == viewers.end()) return;
        if (it->second.helloed) --viewersHelloed;
        if (it->second.delay) it->second.delay->cancel();
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
        if (v.failing) return;  // its refusal is on the way
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
            onHello(h, v, hello->token);
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

    // The token is checked as the cluster port checks its MAC: a source out of allowance is
    // refused unevaluated, a wrong token is answered after the failure delay (holding the slot)
    // and counted against the source. A missing token with publicView is a watcher, not a guess.
    void onHello(ConnId h, Viewer& v, const std::string& token) {
        auto c = conns.find(h);
        if (c == conns.end() || !c->second.pending) return;  // its time is up
        if (opt.token.empty()) return admitViewer(h, v, true);
        if (token.empty() && opt.publicView) return admitViewer(h, v, false);
        const auto now = Clock::now();
        if (auto limited = admission.refuseAttempt(c->second.source, now)) {
            armLog();
            sendText(h, errorJson(*limited));
            endPending(h, Admission::End::Closed);
            ws->close(h, 1008, "rate limited");  // 1008: policy violation
            return;
        }
        if (sameToken(token, opt.token)) return admitViewer(h, v, true);
        v.failing = true;
        v.delay = std::make_shared<asio::steady_timer>(io, admission.onAuthFailure(c->second.source, now));
        armLog();
        v.delay->async_wait([this, h](const asio::error_code& e) {
            auto it = viewers.find(h);
            if (e || it == viewers.end()) return;
            it->second.failing = false;
            if (opt.publicView) return admitViewer(h, it->second, false);
            sendText(h, errorJson("wrong or missing token: start the page with the cluster or viewer token"));
            endPending(h, Admission::End::FailedAuth);
            ws->close(h, 1008, "token");
        });
    }

    void admitViewer(ConnId h, Viewer& v, bool control) {
        if (viewersHelloed >= size_t(std::max(1, opt.maxViewers))) {
            refuseUpgrade(false, "");
            sendText(h, errorJson("the viewer has its maximum of " + std::to_string(opt.maxViewers) +
                                  " viewers (--max-viewers); retry later"));
            endPending(h, Admission::End::Closed);
            ws->close(h, 1013, "full");  // 1013: try again later
            return;
        }
        endPending(h, Admission::End::Authenticated);
        ++viewersHelloed;
        v.helloed = true;
        v.control = control;
        sendText(h, nlohmann::json{{"type", "hello"}, {"control", v.control}}.dump());
        if (!scene.empty()) sendText(h, scene);
        if (!status.empty()) sendText(h, status);
        refreshWanted();
        trySendFrame(h, v);
        encodePending();
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
                log(std::string("viewer: ") + ex.what());
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
        deadlineTimer.cancel();
        logTimer.cancel();
        logSummary(true);
        logRunTotals();
        ws->shutdown();
        for (const auto& [id, c] : conns)  // not viewers: nothing to say goodbye to
            if (c.pending) ws->drop(id);
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
