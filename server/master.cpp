// The master: wires the acceptor, connections, client registry, frame-loop policy, frame
// assembler and image output stage together on one io_context (Asio's server-example shape).
#include "server/master.h"

#include "common/core/printable_text.h"

#include <asio.hpp>
#include <asio/ssl.hpp>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "common/core/interleave.h"
#include "common/scene/gltf_export.h"
#include "proto/bridge/bridge.h"
#include "proto/net/connection.h"
#include "proto/pixel_codec.h"
#include "server/client_registry.h"
#include "server/frame_assembler.h"
#include "common/image/image_io.h"
#include "server/frame_policy.h"
#include "server/handshake.h"
#include "proto/auth.h"
#include "server/image_output.h"
#include "server/viewer/viewer_server.h"

#include <nlohmann/json.hpp>

namespace rtpm::server {

namespace {

/// Frames in flight at once (and output jobs queued at once): the client renders frame f+1
/// while f travels and is assembled, so neither side idles (DESIGN §2.1 pipelining).
constexpr size_t kPipeline = 2;
/// Frames over which the per-frame fps figure is averaged.
constexpr size_t kFpsWindow = 8;
/// An authenticated peer's message must arrive at least this fast on average (after the read
/// timeout's allowance): a 24 MiB float32 frame may take ≈ 100 s, a trickle is still bounded.
constexpr uint64_t kMinReadBytesPerSecond = 256 * 1024;


std::pair<std::string, uint16_t> parseHostPort(const std::string& s) {
    const size_t colon = s.rfind(':');
    std::string host = colon == std::string::npos ? s : s.substr(0, colon);
    std::string port = colon == std::string::npos ? "0" : s.substr(colon + 1);
    if (host.empty()) host = "127.0.0.1";
    if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
        std::stoul(port) > 65535)
        throw std::invalid_argument("--http must be HOST:PORT (port 0-65535), got '" + s + "'");
    return {host, static_cast<uint16_t>(std::stoul(port))};
}

/// Converging frames reuse every pixel's record; the other modes trace every pixel again.
FrameCost frameCost(proto::FrameMode mode) {
    return mode == proto::FrameMode::Converging ? FrameCost::Converging : FrameCost::Retraced;
}

nlohmann::json vec(Vec3 v) { return nlohmann::json::array({v.x, v.y, v.z}); }

ImageOutputOptions outputOptions(const MasterOptions& o) {
    ImageOutputOptions io;
    io.width = o.settings.width;
    io.height = o.settings.height;
    io.interleave = o.settings.interleave;
    io.filter = o.settings.filterSize();
    io.out = o.out;
    io.csv = o.csv;
    io.quiet = o.quiet;
    return io;
}

}  // namespace

struct Master::Impl : net::ConnectionHandler {
    /// What the frame loop learns about a frame in flight, for its output line.
    struct FrameInfo {
        proto::FrameMode mode = proto::FrameMode::Accumulate;
        uint32_t epoch = 0;
        uint64_t bytes = 0;
        uint64_t photonsStored = 0;
        uint64_t setsReported = 0;  // sets of the clients whose Stats arrived
        float slowestMs = -1.0f;
        std::string slowest = "-";
        proto::Stats slowestStats;
        std::vector<ClientId> owners;  // who was asked for each set
        std::vector<proto::FrameData> data;
    };

    MasterOptions opt;
    Interleave pattern;
    uint32_t setCount;
    LiveScene live;
    std::vector<uint8_t> glb;  // file scenes: what clients load
    net::Connection::Buffer settingsMsg;

    asio::io_context io;
    asio::ip::tcp::acceptor acceptor{io};
    asio::steady_timer deadlineTimer{io};
    asio::steady_timer finishTimer{io};
    asio::steady_timer heartbeatTimer{io};
    asio::signal_set signals{io};

    std::set<std::shared_ptr<net::Connection>> connections;  // every peer, authenticated or not
    ClientRegistry registry;
    /// A connection in its handshake (server/admission.h holds its budgets).
    struct PendingPeer {
        uint64_t id = 0;
        std::string source;                 // Admission::sourceKey of its address
        std::optional<proto::Hello> hello;  // after step 1
        proto::Nonce nonce{};               // sent in the Challenge
        std::string name;                   // escaped, for logs
        bool failed = false;                // its answer is being delayed
        std::shared_ptr<asio::steady_timer> delay;
    };
    std::map<const net::Connection*, PendingPeer> pending;
    Admission admission{opt.admission};
    uint64_t nextPendingId = 1;
    asio::steady_timer admissionLogTimer{io};
    bool admissionLogArmed = false;
    std::unique_ptr<asio::ssl::context> tls;  // --tls-cert/--tls-key: every connection runs over TLS
    uint32_t clientPayloadCap = 0;            // largest message a client may announce (raiseClientPayloadCap)
    FramePolicy policy;
    FrameDeadline deadlines;
    std::chrono::milliseconds lastDeadline{0};  ///< of the newest frame begun (told to evicted clients)
    std::optional<proto::CameraState> previousCamera;  ///< of the last FrameBegin
    FrameAssembler assembler;
    std::map<uint64_t, FrameInfo> frameInfo;
    uint64_t nextFrame = 0;
    uint32_t sceneVersion = 1;
    size_t scriptPos = 0;
    size_t outputsQueued = 0;
    bool started = false;
    bool finishing = false;
    bool imageWriteFailed = false;  // an image could not be written: the run must not end with 0
    int exitCode = 0;
    TimePoint startTime{};
    std::deque<TimePoint> shownTimes;  // retirement times of the last kFpsWindow + 1 frames
    MasterSummary summary;

    // Live control (viewer and edit script share applyEdit).
    std::vector<proto::SceneEdit> pendingEdits;  // applied to `live`, sent with the next frame
    bool cameraMoved = false;                    // the next frame is a walkthrough frame
    bool settingsChanged = false;                // the next frame sends Settings and starts an epoch
    std::optional<RenderSettings> pendingResize;  // an M change, applied once no frame is in flight
    bool paused = false;
    bool stopRequested = false;                  // finish frames in flight, write, Bye
    std::vector<ScriptEdit> session;             // every edit applied, for "download script"
    std::map<ClientId, proto::Stats> lastStats;
    std::unique_ptr<ViewerServer> viewer;
    ImageOutput output;  // last member: its thread stops before the rest is destroyed

    Impl(MasterOptions o, Scene scene)
        : opt(std::move(o)),
          pattern{opt.settings.width, opt.settings.height, opt.settings.interleave},
          setCount(static_cast<uint32_t>(opt.settings.interleave * opt.settings.interleave)),
          live(std::move(scene)),
          policy(setCount, opt.walkthrough, kPipeline, static_cast<uint32_t>(std::max(1, opt.evictAfter)),
                 opt.settings.photons.estimator == CausticEstimatorKind::Progressive),
          deadlines(opt.deadline),
          assembler(setCount, deadlines.forFrame(true)),
          output(outputOptionsWithViewer()) {
        validateSettings(opt.settings);
        if (opt.frames < 0) throw std::invalid_argument("--frames must be >= 0 (0 = until stopped)");
        if (opt.minClients < 1) throw std::invalid_argument("--min-clients must be >= 1");
        if (opt.evictAfter < 1) throw std::invalid_argument("--evict-after must be >= 1");
        if (opt.token.empty() && !opt.insecureNoToken)
            throw std::invalid_argument("no token: pass --token or set RTPM_TOKEN (or --insecure-no-token)");
        if (!opt.insecureNoToken)
            if (auto weak = proto::tokenWeakness(opt.token)) throw std::invalid_argument("refusing the token: " + *weak);
        checkAnimation(opt.animation, live.scene());
        // Dry-run the script on a copy so a bad line fails at start, not at frame n.
        {
            LiveScene dry(live.loaded());
            RenderSettings drySettings = opt.settings;
            std::vector<proto::SceneEdit> sink;
            for (const ScriptEdit& e : opt.script) {
                if (e.kind == ScriptEdit::Kind::Settings) applySettingsEdit(e, opt.scriptFile, drySettings);
                else dry.apply(e, opt.scriptFile, sink);
            }
        }
        settingsMsg = std::make_shared<const std::vector<uint8_t>>(
            proto::encode(bridge::toWire(opt.settings, opt.encoding)));
        if (opt.tlsCert.empty() != opt.tlsKey.empty())
            throw std::invalid_argument("--tls-cert and --tls-key go together");
        if (!opt.tlsCert.empty()) {
            tls = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_server);
            tls->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                             asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                             asio::ssl::context::no_tlsv1_1);
            asio::error_code ec;
            tls->use_certificate_chain_file(opt.tlsCert, ec);
            if (ec) throw std::invalid_argument("--tls-cert " + opt.tlsCert + ": " + ec.message());
            tls->use_private_key_file(opt.tlsKey, asio::ssl::context::pem, ec);
            if (ec) throw std::invalid_argument("--tls-key " + opt.tlsKey + ": " + ec.message());
        }
        if (!opt.builtin) {
            glb = encodeGlb(live.loaded());
            auto probe = proto::tryEncode(sceneMessage());
            if (!probe.ok()) throw std::invalid_argument("scene too large to send: " + probe.error().message);
        }

        asio::ip::tcp::endpoint ep(asio::ip::make_address(opt.listen), opt.port);
        acceptor.open(ep.protocol());
        acceptor.set_option(asio::socket_base::reuse_address(true));
        acceptor.bind(ep);
        acceptor.listen();

        if (!opt.http.empty()) {
            auto [host, httpPort] = parseHostPort(opt.http);
            ViewerOptions vo;
            vo.host = host;
            vo.port = httpPort;
            vo.token = opt.viewerToken.empty() ? opt.token : opt.viewerToken;
            vo.publicView = opt.viewerPublic;
            vo.maxViewers = opt.maxViewers;
            vo.maxFps = opt.viewerFps;
            viewer = std::make_unique<ViewerServer>(vo, [this](const ViewerCommand& cmd, bool, ViewerServer::Reply reply) {
                asio::post(io, [this, cmd, reply = std::move(reply)] { onViewerCommand(cmd, reply); });
            });
        }
    }

    ImageOutputOptions outputOptionsWithViewer() {
        ImageOutputOptions io = outputOptions(opt);
        io.onComposed = [this](uint64_t frame, const FrameImage& image) {
            if (viewer) viewer->publishFrame(frame, image);
        };
        return io;
    }

    proto::Scene sceneMessage() const {
        proto::Scene m;
        m.sceneVersion = sceneVersion;
        if (opt.builtin) {
            m.source = proto::Scene::Source::Builtin;
            m.builtinName = opt.sceneName;
        } else {
            m.source = proto::Scene::Source::Gltf;
            m.gltf = glb;
        }
        m.edits = live.compactedEdits();
        return m;
    }

    uint16_t port() const { return acceptor.local_endpoint().port(); }

    // ---- startup -------------------------------------------------------------------------

    int run() {
        if (!opt.portFile.empty()) {
            std::string tmp = opt.portFile + ".tmp";
            FILE* f = std::fopen(tmp.c_str(), "w");
            if (!f) throw std::runtime_error("cannot write " + tmp);
            std::fprintf(f, "%u\n", static_cast<unsigned>(port()));
            std::fclose(f);
            std::filesystem::rename(tmp, opt.portFile);
        }
        std::printf("rtpm-server listening on %s:%u\n", opt.listen.c_str(), static_cast<unsigned>(port()));
        if (viewer) {
            auto [host, unused] = parseHostPort(opt.http);
            std::printf("viewer: http://%s:%u/\n", host.c_str(), static_cast<unsigned>(viewer->port()));
            publishScene();
        }
        std::printf("scene %s, %dx%d, M=%d (%u sets), F=%d, P=%u, k=%u, %s, %d frames (0 = until stopped), waiting for %d client(s)\n",
                    opt.sceneName.c_str(), opt.settings.width, opt.settings.height, opt.settings.interleave,
                    setCount, opt.settings.filterSize(), opt.settings.photons.photonsPerBatch,
                    opt.settings.photons.k, opt.settings.photons.selective ? "SPT" : "plain shooting", opt.frames,
                    opt.minClients);
        std::fflush(stdout);
        if (deadlines.adaptive())
            std::printf("frame deadline: adaptive, %.0f x the median frame time within [%lld, %lld] ms; a client "
                        "late or skipped %d frames in a row is evicted\n",
                        opt.deadline.multiple, (long long)opt.deadline.floor.count(),
                        (long long)opt.deadline.ceiling.count(), opt.evictAfter);
        else
            std::printf("frame deadline: %lld ms; a client late or skipped %d frames in a row is evicted\n",
                        (long long)opt.deadline.fixed->count(), opt.evictAfter);
        std::fflush(stdout);
        signals.add(SIGINT);
        signals.add(SIGTERM);
        waitForSignal();
        accept();
        heartbeat();
        io.run();
        output.drain();  // the frame in the output stage is written before run() returns
        if (viewer) {
            viewer->stop();
            const ViewerReport r = viewer->report();
            std::printf("viewer: %llu frames tone-mapped, %llu encoded, %llu drawn by pages; lag behind the newest "
                        "frame mean %.2f max %llu frames; composed-to-drawn latency mean %.1f max %.1f ms; viewer CPU "
                        "%.3f s (tone map %.3f, viewer thread %.3f, status %.3f)\n",
                        (unsigned long long)r.framesPublished, (unsigned long long)r.framesEncoded,
                        (unsigned long long)r.framesShown, r.meanLagFrames, (unsigned long long)r.maxLagFrames,
                        r.meanLatencyMs, r.maxLatencyMs, r.cpuSeconds, r.toneMapCpuSeconds, r.threadCpuSeconds,
                        r.statusCpuSeconds);
        }
        // Frames were shown but none complete: the image is not the scene's (issue 13: "4 frames
        // shown (4 incomplete)" used to exit 0). An unwritten image says more and keeps its code.
        if (exitCode != kExitImageNotWritten && summary.framesShown > 0 &&
            summary.framesIncomplete == summary.framesShown) {
            std::fprintf(stderr, "rtpm-server: no frame was complete (%llu shown, every one missing sets); "
                                 "exit code %d\n",
                         (unsigned long long)summary.framesShown, kExitNoCompleteFrame);
            exitCode = kExitNoCompleteFrame;
        }
        if (!opt.quiet || exitCode == 0) printSummary();
        return exitCode;
    }

    // Every second, a Heartbeat to each client with nothing queued: its idle timeout then tells a
    // frozen master from an idle one (paused, waiting for clients, a client without sets).
    void heartbeat() {
        heartbeatTimer.expires_after(proto::kHeartbeatInterval);
        heartbeatTimer.async_wait([this](const asio::error_code& ec) {
            if (ec || finishing) return;
            if (!heartbeatMsg) heartbeatMsg = std::make_shared<const std::vector<uint8_t>>(proto::encode(proto::Heartbeat{}));
            for (const auto& [id, c] : registry.clients())
                if (c.connection->queuedBytes() == 0) c.connection->send(heartbeatMsg);
            heartbeat();
        });
    }
    net::Connection::Buffer heartbeatMsg;

    // First signal: finish the frames in flight, write the last image, Bye. Second: stop now.
    void waitForSignal() {
        signals.async_wait([this](const asio::error_code& ec, int sig) {
            if (ec) return;
            if (stopRequested) {
                std::fprintf(stderr, "rtpm-server: signal %d again, stopping now\n", sig);
                shutdown(130, proto::ByeReason::Shutdown, "server interrupted");
                return;
            }
            std::fprintf(stderr, "rtpm-server: signal %d, finishing the frames in flight\n", sig);
            requestStop();
            waitForSignal();
        });
    }

    void requestStop() {
        if (stopRequested || finishing) return;
        stopRequested = true;
        pump();
    }

    void printSummary() {
        double fps = summary.seconds > 0 ? double(summary.framesShown) / summary.seconds : 0.0;
        std::printf("summary: %llu frames shown (%llu incomplete) in %.2f s = %.2f fps, %.1f MB received, "
                    "%llu clients joined, %llu evicted, %llu peers refused or dropped for protocol errors\n",
                    (unsigned long long)summary.framesShown, (unsigned long long)summary.framesIncomplete,
                    summary.seconds, fps, double(summary.bytesReceived) / 1e6,
                    (unsigned long long)summary.clientsJoined, (unsigned long long)summary.clientsEvicted,
                    (unsigned long long)summary.peersRejected);
        std::fflush(stdout);
    }

    // ---- acceptor ------------------------------------------------------------------------

    void accept() {
        acceptor.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket sock) {
            if (ec) {
                if (ec != asio::error::operation_aborted && !finishing) {
                    std::fprintf(stderr, "rtpm-server: accept failed: %s\n", ec.message().c_str());
                    accept();
                }
                return;
            }
            if (finishing) return;
            admit(std::move(sock));
            accept();
        });
    }

    // A new socket: budgets first (server/admission.h), then the handshake with only a Hello allowed.
    // Refusals and failures are counted into one summary line per interval, never one line each.
    void admit(asio::ip::tcp::socket sock) {
        asio::error_code ec;
        const auto ep = sock.remote_endpoint(ec);
        if (ec) return;  // already gone
        const std::string source = Admission::sourceKey(ep.address().to_string());
        const uint64_t id = nextPendingId++;
        const Admission::Verdict v = admission.onConnect(id, source, Clock::now());
        armAdmissionLog();
        if (v.decision != AdmissionDecision::Admit) {
            ++summary.peersRejected;
            if (tls) return;  // a plain Reject would be garbage to a TLS client; a TLS handshake per refusal is what a flood wants
            refuseNow(sock, v.decision == AdmissionDecision::RefuseCapacity ? proto::RejectReason::Capacity
                                                                            : proto::RejectReason::RateLimited,
                      v.text);
            return;
        }
        if (v.evict)
            for (auto& [conn, p] : pending)
                if (p.id == *v.evict) {
                    for (const auto& owned : connections)
                        if (owned.get() == conn) {
                            owned->send(proto::Reject{proto::RejectReason::Capacity,
                                                      "handshake slot given to another address; retry later"});
                            owned->closeAfterFlush(std::chrono::milliseconds(200));
                        }
                    break;
                }
        auto c = std::make_shared<net::Connection>(std::move(sock), *this, opt.maxQueuedBytes);
        if (tls) c->useTls(*tls, true);
        connections.insert(c);
        PendingPeer& p = pending[c.get()];
        p.id = id;
        p.source = source;
        c->expectOnly(proto::MessageType::Hello, proto::payloadLimit(proto::MessageType::Hello));
        c->start(opt.handshakeTimeout);
    }

    // Tells a peer it is refused without making a Connection of it (a flood costs one small write).
    static void refuseNow(asio::ip::tcp::socket& sock, proto::RejectReason reason, const std::string& text) {
        asio::error_code ec;
        sock.non_blocking(true, ec);
        const auto bytes = proto::encode(proto::Reject{reason, text.substr(0, proto::kMaxTextBytes)});
        sock.write_some(asio::buffer(bytes), ec);  // a fresh socket's send buffer takes it whole
        sock.shutdown(asio::ip::tcp::socket::shutdown_send, ec);
        // Read what the peer already sent (its Hello) so the close ends with FIN, not a reset that
        // could destroy the Reject before the peer reads it.
        uint8_t drain[4096];
        sock.read_some(asio::buffer(drain), ec);
        sock.close(ec);
    }

    void armAdmissionLog() {
        if (admissionLogArmed || finishing) return;
        const auto next = admission.nextSummary();
        if (!next) return;
        admissionLogArmed = true;
        admissionLogTimer.expires_at(*next);
        admissionLogTimer.async_wait([this](const asio::error_code& ec) {
            admissionLogArmed = false;
            if (ec) return;
            if (auto line = admission.summaryLine(Clock::now())) std::fprintf(stderr, "rtpm-server: %s\n", line->c_str());
            armAdmissionLog();
        });
    }

    // ---- connections ---------------------------------------------------------------------

    // Refuses a peer in its handshake. Not logged one by one (a flood would fill the disk): the
    // admission summary line counts it.
    void reject(net::Connection& c, proto::RejectReason reason, const std::string& text) {
        ++summary.peersRejected;
        c.send(proto::Reject{reason, text.substr(0, proto::kMaxTextBytes)});
        c.closeAfterFlush();
    }

    // A peer that broke the protocol after its handshake: log, Bye{ProtocolError}, drop.
    void protocolError(net::Connection& c, const std::string& why) {
        std::fprintf(stderr, "rtpm-server: closing %s: protocol error: %s\n", registry.describe(c).c_str(),
                     why.c_str());
        ++summary.peersRejected;
        c.send(proto::Bye{proto::ByeReason::ProtocolError, why.substr(0, proto::kMaxTextBytes)});
        c.closeAfterFlush();
        dropClientOf(c, "protocol error");
    }

    void dropClientOf(net::Connection& c, const std::string& why) {
        std::optional<ClientInfo> gone = registry.remove(c);
        if (!gone) return;
        assembler.dropClient(gone->id);
        policy.clientLeft(gone->id);
        std::fprintf(stderr, "rtpm-server: client %u (%s) left: %s\n", gone->id, gone->name.c_str(), why.c_str());
        lastStats.erase(gone->id);
        if (viewer)
            viewer->publishEvent(nlohmann::json{{"type", "event"}, {"what", "left"}, {"id", gone->id},
                                                {"name", gone->name}, {"why", why}}.dump());
        asio::post(io, [this] { pump(); });
    }

    void onBadBytes(net::Connection& c, const proto::Error& e) override {
        std::string why = std::string(proto::errorCodeName(e.code)) + ": " + e.message;
        if (!registry.find(c)) {
            endPending(c, Admission::End::ProtocolError);
            reject(c, e.code == proto::ErrorCode::BadVersion ? proto::RejectReason::VersionMismatch
                                                              : proto::RejectReason::ProtocolError,
                   why);
            return;
        }
        protocolError(c, why);
    }

    void endPending(const net::Connection& c, Admission::End how) {
        auto it = pending.find(&c);
        if (it == pending.end()) return;
        admission.onPendingEnded(it->second.id, how);
        if (it->second.delay) it->second.delay->cancel();
        pending.erase(it);
    }

    void onClosed(net::Connection& c, const std::string& why) override {
        endPending(c, c.handshakeTimedOut() ? Admission::End::TimedOut : Admission::End::Closed);
        dropClientOf(c, why);
        for (auto it = connections.begin(); it != connections.end(); ++it)
            if (it->get() == &c) {
                connections.erase(it);
                break;
            }
        if (finishing && connections.empty()) io.stop();
    }

    void onMessage(net::Connection& c, proto::Message&& m, size_t wireBytes) override {
        if (finishing) return;
        ClientInfo* client = registry.find(c);
        if (!client) {
            handshake(c, m);
            return;
        }
        if (auto* fd = std::get_if<proto::FrameData>(&m)) {
            onFrameData(c, *client, std::move(*fd), wireBytes);
        } else if (auto* st = std::get_if<proto::Stats>(&m)) {
            onStats(c, *client, *st);
        } else if (auto* bye = std::get_if<proto::Bye>(&m)) {
            std::string why = "said Bye (" + std::to_string(static_cast<int>(bye->reason)) + ") " + printableText(bye->text);
            c.closeAfterFlush();
            dropClientOf(c, why);
        } else {
            protocolError(c, std::string("unexpected ") + proto::messageTypeName(proto::typeOf(m)) + " from a client");
        }
    }

    // Hello → Challenge{nonce} → Auth{HMAC} → Welcome (PROTOCOL.md §7). The token never travels.
    void handshake(net::Connection& c, const proto::Message& m) {
        auto it = pending.find(&c);
        if (it == pending.end()) return;  // closing
        PendingPeer& p = it->second;
        if (p.failed) return;             // its refusal is on the way
        if (!p.hello) {
            HandshakeResult h = checkHello(m);
            if (!h.accepted) {
                endPending(c, Admission::End::ProtocolError);
                reject(c, h.reason, h.text);
                return;
            }
            p.hello = std::get<proto::Hello>(m);
            p.name = h.clientName;
            p.nonce = proto::makeNonce();
            c.expectOnly(proto::MessageType::Auth, proto::payloadLimit(proto::MessageType::Auth));
            c.send(proto::Challenge{p.nonce});
            return;
        }
        if (!opt.insecureNoToken)
            if (auto limited = admission.refuseAttempt(p.source, Clock::now())) {
                armAdmissionLog();
                endPending(c, Admission::End::Closed);
                reject(c, proto::RejectReason::RateLimited, *limited);
                return;
            }
        HandshakeResult h = checkAuth(m, *p.hello, p.nonce, opt.token, opt.insecureNoToken);
        if (!h.accepted && h.reason == proto::RejectReason::BadToken) {
            // The answer waits (the slot stays taken): guesses from one address are slowed and then
            // refused at connect (server/admission.h) instead of answered in a fraction of a millisecond.
            p.failed = true;
            p.delay = std::make_shared<asio::steady_timer>(io, admission.onAuthFailure(p.source, Clock::now()));
            armAdmissionLog();
            std::shared_ptr<net::Connection> owned = ownerOf(c);
            p.delay->async_wait([this, owned, text = h.text](const asio::error_code& ec) {
                if (ec || !owned) return;
                endPending(*owned, Admission::End::FailedAuth);
                reject(*owned, proto::RejectReason::BadToken, text);
            });
            return;
        }
        if (!h.accepted) {
            endPending(c, Admission::End::ProtocolError);
            reject(c, h.reason, h.text);
            return;
        }
        if (registry.size() >= static_cast<size_t>(opt.maxPeers)) {
            endPending(c, Admission::End::Closed);
            reject(c, proto::RejectReason::Capacity,
                   "the server has its maximum of " + std::to_string(opt.maxPeers) + " clients; retry later");
            return;
        }
        const std::string name = p.name;
        const unsigned cores = p.hello->cores;
        endPending(c, Admission::End::Authenticated);
        c.markAuthenticated();
        c.setReadDeadline(opt.readTimeout, kMinReadBytesPerSecond);
        raiseClientPayloadCap();
        c.capPayload(clientPayloadCap);
        HandshakeResult joined;
        joined.clientName = name;
        onAuthenticated(c, joined, cores);
    }

    // A client sends at most one FrameData of its largest set in float32 (24 B/px, the largest
    // encoding) plus a few fields; Stats and Bye are far smaller. So a header announcing more is
    // refused before its payload is buffered (before: 64 MiB per set were taken in). The bound only
    // grows during a run, so data of a frame rendered before a resize to fewer pixels still fits.
    void raiseClientPayloadCap() {
        const uint64_t m = uint64_t(opt.settings.interleave);
        const uint64_t setPixels = ((uint64_t(opt.settings.width) + m - 1) / m) * ((uint64_t(opt.settings.height) + m - 1) / m);
        const uint64_t cap = std::min<uint64_t>(std::max<uint64_t>(4096, 64 + 24 * setPixels),
                                                proto::payloadLimit(proto::MessageType::FrameData));
        if (cap <= clientPayloadCap) return;
        clientPayloadCap = uint32_t(cap);
        for (const auto& [id, info] : registry.clients()) info.connection->capPayload(clientPayloadCap);
    }

    std::shared_ptr<net::Connection> ownerOf(const net::Connection& c) const {
        for (const auto& p : connections)
            if (p.get() == &c) return p;
        return nullptr;
    }

    void onAuthenticated(net::Connection& c, const HandshakeResult& h, unsigned cores) {
        std::shared_ptr<net::Connection> owned = ownerOf(c);
        const ClientId id = registry.add(std::move(owned), h.clientName, cores);
        policy.clientsChanged();
        ++summary.clientsJoined;
        std::fprintf(stderr, "rtpm-server: client %u (%s, %s, %u cores) joined\n", id, h.clientName.c_str(),
                     c.peer().c_str(), cores);
        if (viewer)
            viewer->publishEvent(nlohmann::json{{"type", "event"}, {"what", "joined"}, {"id", id},
                                                {"name", h.clientName}, {"cores", cores}}.dump());
        // Tentative sets: what the client would hold if a frame began now. FrameBegin is binding.
        c.send(proto::Welcome{id, policy.tentativeSets(id, registry.joinOrder())});
        c.send(settingsMsg);
        c.send(sceneMessage());
        pump();
    }

    void onFrameData(net::Connection& c, ClientInfo& client, proto::FrameData&& fd, size_t wireBytes) {
        // The negotiated encoding (issue 13: the master asked for rgb9e5-zstd and took float32).
        if (!proto::encodingAnswers(opt.encoding, fd.encoding)) {
            protocolError(c, "frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) +
                                 ": pixel encoding " + std::to_string(static_cast<int>(fd.encoding)) +
                                 ", the master asked for " + std::to_string(static_cast<int>(opt.encoding)));
            return;
        }
        Verdict v = assembler.onFrameData(client.id, fd.frame, fd.set);
        if (isProtocolError(v)) {
            protocolError(c, "FrameData frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) +
                                 ": " + verdictName(v));
            return;
        }
        summary.bytesReceived += wireBytes;
        // Late data may belong to a frame rendered before a change of M: only data of a frame in
        // flight is checked against the current pattern.
        if (v == Verdict::Late) return;
        if (fd.pixelCount != static_cast<uint32_t>(pattern.pixelCount(static_cast<int>(fd.set)))) {
            protocolError(c, "frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) + ": " +
                                 std::to_string(fd.pixelCount) + " pixels, the set has " +
                                 std::to_string(pattern.pixelCount(static_cast<int>(fd.set))));
            return;
        }
        FrameInfo& info = frameInfo[fd.frame];
        info.bytes += wireBytes;
        info.data.push_back(std::move(fd));
    }

    void onStats(net::Connection& c, ClientInfo& client, const proto::Stats& st) {
        Verdict v = assembler.onStats(client.id, st.frame);
        if (isProtocolError(v)) {
            protocolError(c, "Stats frame " + std::to_string(st.frame) + ": " + verdictName(v));
            return;
        }
        if (v == Verdict::Accept) {
            FrameInfo& info = frameInfo[st.frame];
            info.photonsStored += st.photonsStored;
            info.setsReported += static_cast<uint64_t>(std::count(info.owners.begin(), info.owners.end(), client.id));
            lastStats[client.id] = st;
            if (st.frameMs > info.slowestMs) {
                info.slowestMs = st.frameMs;
                info.slowestStats = st;
                info.slowest = std::to_string(client.id) + ":" + client.name;
            }
            policy.stats(client.id, info.mode, st.photonsShot);
        }
        pump();
    }

    // ---- frame loop ----------------------------------------------------------------------

    void pump() {
        if (finishing) return;
        TimePoint now = Clock::now();
        for (RetiredFrame& r : assembler.takeReady(now)) retire(r, now);
        evictSlowClients();
        if (!started && registry.size() >= static_cast<size_t>(opt.minClients)) {
            started = true;
            startTime = now;
            std::fprintf(stderr, "rtpm-server: %zu client(s) connected, starting frames\n", registry.size());
        }
        const bool idle = assembler.inFlight() == 0 && outputsQueued == 0;
        if (pendingResize && idle) resize();
        raiseClientPayloadCap();  // before any FrameBegin under new settings
        const bool unlimited = opt.frames == 0;
        while (started && (unlimited || nextFrame < static_cast<uint64_t>(opt.frames)) && !paused && !stopRequested &&
               !pendingResize && assembler.inFlight() < kPipeline && outputsQueued < kPipeline && !registry.empty())
            beginFrame(now);
        armDeadline();
        if (assembler.inFlight() != 0 || outputsQueued != 0) return;
        if (!unlimited && nextFrame == static_cast<uint64_t>(opt.frames)) {
            shutdown(imageWriteFailed ? kExitImageNotWritten : 0, proto::ByeReason::Normal, "all frames rendered");
        } else if (stopRequested) {
            // The last image is written only if a frame was shown (otherwise there is none).
            finishing = true;
            if (opt.out.empty() || summary.framesShown == 0) {
                finishing = false;
                shutdown(unlimited ? 0 : 130, proto::ByeReason::Shutdown, "server stopped");
                return;
            }
            output.write(opt.out, [this, unlimited](std::string error) {
                const bool failed = !error.empty();
                if (failed) std::fprintf(stderr, "rtpm-server: cannot write %s: %s\n", opt.out.c_str(), error.c_str());
                asio::post(io, [this, unlimited, failed] {
                    finishing = false;
                    imageWriteFailed |= failed;
                    shutdown(imageWriteFailed ? kExitImageNotWritten : unlimited ? 0 : 130, proto::ByeReason::Shutdown,
                             "server stopped");
                });
            });
        }
    }

    // A change of M: every structure sized by M² is rebuilt while no frame is in flight; the
    // clients get the new Settings with the next frame, which starts an epoch.
    void resize() {
        opt.settings = *pendingResize;
        pendingResize.reset();
        pattern = Interleave{opt.settings.width, opt.settings.height, opt.settings.interleave};
        setCount = static_cast<uint32_t>(opt.settings.interleave * opt.settings.interleave);
        policy.resize(setCount);
        assembler.resize(setCount);
        output.reconfigure(opt.settings.interleave, opt.settings.filterSize());
        settingsMsg = std::make_shared<const std::vector<uint8_t>>(proto::encode(bridge::toWire(opt.settings, opt.encoding)));
        settingsChanged = true;
        std::fprintf(stderr, "rtpm-server: M is now %d (%u sets)\n", opt.settings.interleave, setCount);
    }

    // ---- live edits (edit script and viewer) ---------------------------------------------------

    /// The one edit path: a script line or a viewer control. Throws SceneError (nothing changes)
    /// when the edit does not fit the scene or the settings. Takes effect with the next frame.
    void applyEdit(const ScriptEdit& e, const std::string& source) {
        if (e.kind == ScriptEdit::Kind::Settings) {
            RenderSettings s = pendingResize ? *pendingResize : opt.settings;
            applySettingsEdit(e, source, s);
            if (s.interleave != opt.settings.interleave || pendingResize) {
                pendingResize = s;
            } else {
                const bool photonsChange = s.photons.k != opt.settings.photons.k ||
                                           s.photons.photonsPerBatch != opt.settings.photons.photonsPerBatch ||
                                           s.photons.tree != opt.settings.photons.tree ||
                                           s.photons.estimator != opt.settings.photons.estimator;
                if (s.filterSize() != opt.settings.filterSize())
                    output.reconfigure(s.interleave, s.filterSize());
                opt.settings = s;
                settingsMsg = std::make_shared<const std::vector<uint8_t>>(
                    proto::encode(bridge::toWire(opt.settings, opt.encoding)));
                for (const auto& [id, c] : registry.clients()) c.connection->send(settingsMsg);
                settingsChanged = settingsChanged || photonsChange;
            }
        } else {
            live.apply(e, source, pendingEdits);
            if (e.kind == ScriptEdit::Kind::Camera) cameraMoved = true;
        }
        ScriptEdit recorded = e;
        recorded.frame = nextFrame;
        session.push_back(recorded);
    }

    void onViewerCommand(const ViewerCommand& cmd, const ViewerServer::Reply& reply) {
        auto ok = [&](const std::string& what) { reply(nlohmann::json{{"type", "ok"}, {"what", what}}.dump()); };
        auto error = [&](const std::string& what) {
            reply(nlohmann::json{{"type", "error"}, {"message", what}}.dump());
        };
        if (finishing || stopRequested) return error("the server is stopping");
        if (auto* e = std::get_if<ViewerEdit>(&cmd)) {
            try {
                applyEdit(e->edit, "viewer");
            } catch (const SceneError& ex) {
                return error(std::string("edit refused: ") + ex.what());
            }
            if (e->edit.kind != ScriptEdit::Kind::Camera) publishScene();
            ok(formatScriptEdit(session.back()));
            pump();
        } else if (auto* p = std::get_if<ViewerPause>(&cmd)) {
            paused = p->paused;
            if (lastStatus) publishStatus(lastStatus->first, lastStatus->second);
            std::fprintf(stderr, "rtpm-server: %s by a viewer\n", paused ? "paused" : "resumed");
            ok(paused ? "paused" : "resumed");
            pump();
        } else if (std::get_if<ViewerSnapshot>(&cmd)) {
            if (opt.out.empty() || summary.framesShown == 0) return error("no image to save yet (or no --out)");
            const std::string path = numberedPath(opt.out, summary.framesShown, "_snapshot.exr");
            output.write(path, [reply, path](std::string err) {
                reply(err.empty() ? nlohmann::json{{"type", "ok"}, {"what", "saved " + path}}.dump()
                                  : nlohmann::json{{"type", "error"}, {"message", "snapshot failed: " + err}}.dump());
            });
        } else if (std::get_if<ViewerScriptRequest>(&cmd)) {
            std::string text = "# rtpm edit script recorded by the viewer: replay with\n# rtpm-server --scene " +
                               opt.sceneName + " --edit-script FILE";
            if (opt.animation != Animation::None) text += "  (this session also ran an --animate preset)";
            text += "\n";
            for (const ScriptEdit& e : session) text += formatScriptEdit(e) + "\n";
            reply(nlohmann::json{{"type", "script"}, {"text", text}}.dump());
        }
    }

    void publishScene() {
        if (!viewer) return;
        const Scene& s = live.scene();
        nlohmann::json lights = nlohmann::json::array(), materials = nlohmann::json::array();
        for (size_t i = 0; i < s.lights.size() && i < 64; ++i)
            lights.push_back({{"index", i}, {"position", vec(s.lights[i].position)}, {"intensity", vec(s.lights[i].intensity)}});
        for (size_t i = 0; i < s.materials.size() && i < 64; ++i) {
            const Material& m = s.materials[i];
            materials.push_back({{"index", i},
                                 {"type", m.type == MaterialType::Mirror ? "mirror" : m.type == MaterialType::Dielectric ? "dielectric" : "diffuse"},
                                 {"color", vec(m.baseColor)}, {"ior", m.ior}, {"absorption", vec(m.absorption)}});
        }
        // Emissive instances are the lights of scenes without punctual ones (RING): the viewer moves
        // them with transform edits (translation from the loaded pose) and sets their emission.
        nlohmann::json emitters = nlohmann::json::array();
        for (size_t i = 0; i < s.instances.size() && emitters.size() < 64; ++i) {
            const uint32_t mat = s.meshes[s.instances[i].mesh].material;
            if (!s.materials[mat].isEmissive()) continue;
            auto centreOf = [&](const Scene& sc) {
                Bounds ib;
                const Instance& in = sc.instances[i];
                for (const Vec3& p : sc.meshes[in.mesh].positions) ib.extend(Vec3(in.transform * glm::vec4(p, 1.0f)));
                return ib.centre();
            };
            emitters.push_back({{"index", i}, {"name", s.instances[i].name}, {"material", mat},
                                {"loadedCentre", vec(centreOf(live.loaded()))}, {"centre", vec(centreOf(s))},
                                {"emission", vec(s.materials[mat].emission)}});
        }
        const Bounds b = s.bounds();
        const RenderSettings& rs = pendingResize ? *pendingResize : opt.settings;
        viewer->publishScene(nlohmann::json{
            {"type", "scene"}, {"name", opt.sceneName}, {"width", rs.width}, {"height", rs.height},
            {"centre", vec(b.centre())}, {"diagonal", b.diagonal()}, {"lights", lights}, {"emitters", emitters}, {"materials", materials},
            {"settings", {{"M", rs.interleave}, {"F", rs.filter}, {"k", rs.photons.k}, {"P", rs.photons.photonsPerBatch},
                          {"tree", photonTreeName(rs.photons.tree)},
                          {"estimator", causticEstimatorName(rs.photons.estimator)}}}}.dump());
    }

    struct FrameStatus {
        uint64_t frame = 0;
        uint32_t epoch = 0;
        proto::FrameMode mode{};
        double fps = 0, photonsPerSet = 0;
        proto::Stats slowest;
        std::string slowestName;
        size_t arrived = 0;
        std::vector<ClientId> owners;
        uint32_t passes = 0;  ///< progressive estimator: fewest passes of a set that arrived (0 = knn or a restart)
    };

    std::optional<std::pair<FrameStatus, double>> lastStatus;  // re-sent when pausing

    void publishStatus(const FrameStatus& f, double masterMs) {
        if (!viewer) return;
        const double cpu0 = threadCpuSeconds();
        lastStatus.emplace(f, masterMs);
        nlohmann::json clients = nlohmann::json::array();
        for (ClientId id : registry.joinOrder()) {
            const ClientInfo* c = registry.find(id);
            auto st = lastStats.find(id);
            clients.push_back({{"id", id}, {"name", c->name}, {"cores", c->cores},
                               {"sets", policy.assignment().owner.size() == setCount ? policy.assignment().setsOf(id)
                                                                                     : std::vector<uint32_t>{}},
                               {"lastMs", st == lastStats.end() ? 0.0f : st->second.frameMs},
                               {"photons", st == lastStats.end() ? 0 : st->second.photonsStored}});
        }
        const Camera& cam = live.camera();
        viewer->publishStatus(nlohmann::json{
            {"type", "status"}, {"frame", f.frame}, {"epoch", f.epoch}, {"mode", proto::frameModeName(f.mode)},
            {"fps", f.fps}, {"photonsPerSet", f.photonsPerSet}, {"cap", opt.settings.photons.capPhotons},
            {"M", opt.settings.interleave}, {"setsArrived", f.arrived}, {"paused", paused},
            {"estimator", causticEstimatorName(opt.settings.photons.estimator)}, {"passes", f.passes},
            {"split", {{"photonMs", f.slowest.photonMs}, {"renderMs", f.slowest.renderMs},
                       {"encodeMs", f.slowest.encodeMs}, {"clientMs", f.slowest.frameMs}, {"masterMs", masterMs}}},
            {"slowest", f.slowestName}, {"owners", f.owners}, {"clients", clients},
            {"camera", {{"eye", vec(cam.position)}, {"forward", vec(cam.forward)}, {"up", vec(cam.up)}, {"yfov", cam.yfov}}}}
            .dump());        viewer->chargeCpu(threadCpuSeconds() - cpu0);  // the status is the viewer's cost
    }

    void armDeadline() {
        auto d = assembler.nextDeadline();
        if (!d) {
            deadlineTimer.cancel();
            return;
        }
        deadlineTimer.expires_at(*d);
        deadlineTimer.async_wait([this](const asio::error_code& ec) {
            if (!ec) pump();
        });
    }

    void evictSlowClients() {
        const auto evict = policy.evictions(registry.joinOrder(),
                                            [this](ClientId id) { return assembler.consecutiveMisses(id); });
        for (ClientId id : evict) {
            ClientInfo* c = registry.find(id);
            auto connection = c->connection;
            const std::string why = "evicted: late or skipped " + std::to_string(opt.evictAfter) +
                                    " frames in a row (frame deadline " +
                                    std::to_string(lastDeadline.count()) +
                                    " ms); its sets go to others, it may rejoin";
            std::fprintf(stderr, "rtpm-server: client %u (%s) %s (before frame %llu)\n", id, c->name.c_str(),
                         why.c_str(), (unsigned long long)nextFrame);
            ++summary.clientsEvicted;
            connection->send(proto::Bye{proto::ByeReason::Timeout, why});
            connection->closeAfterFlush();
            dropClientOf(*connection, "evicted (late or frozen)");
        }
    }

    void beginFrame(TimePoint now) {
        const uint64_t f = nextFrame;
        std::vector<proto::SceneEdit> edits;
        animate(opt.animation, f, live, edits);
        while (scriptPos < opt.script.size() && opt.script[scriptPos].frame <= f) {
            try {
                applyEdit(opt.script[scriptPos++], opt.scriptFile);  // validated by the dry run
            } catch (const SceneError& e) {
                std::fprintf(stderr, "rtpm-server: edit script: %s\n", e.what());
            }
        }
        if (pendingResize) return;  // an M change waits for the frames in flight (pump resumes)
        ++nextFrame;
        edits.insert(edits.end(), pendingEdits.begin(), pendingEdits.end());
        pendingEdits.clear();
        if (settingsChanged)
            for (const auto& [id, c] : registry.clients()) c.connection->send(settingsMsg);
        // Every client gets the edits before the FrameBegin of the new epoch (flow §6).
        for (const proto::SceneEdit& e : edits) {
            ++sceneVersion;
            live.record(e);
            auto bytes = std::make_shared<const std::vector<uint8_t>>(proto::encode(proto::Edit{sceneVersion, e}));
            for (const auto& [id, c] : registry.clients()) c.connection->send(bytes);
        }
        const proto::CameraState cam = bridge::toWire(live.camera());
        const bool still = previousCamera && *previousCamera == cam;
        previousCamera = cam;
        policy.setProgressive(opt.settings.photons.estimator == CausticEstimatorKind::Progressive);  // may be edited
        FramePlan plan = policy.plan(f, !edits.empty() || settingsChanged, registry.joinOrder(),
                                     [this](ClientId id) { return assembler.outstanding(id); }, cameraMoved,
                                     still && !cameraMoved);
        settingsChanged = false;
        cameraMoved = false;
        for (auto& [id, sets] : plan.sets)
            registry.find(id)->connection->send(
                proto::FrameBegin{f, plan.epoch, sceneVersion, cam, plan.mode, std::move(sets)});
        frameInfo[f].mode = plan.mode;
        frameInfo[f].epoch = plan.epoch;
        frameInfo[f].owners = plan.owners;
        // A frame whose cost the last ones do not predict waits the ceiling, and so does the last
        // frame of a finite run (it is the image written: nothing rendered may be cut short).
        const bool last = opt.frames > 0 && f + 1 == static_cast<uint64_t>(opt.frames);
        lastDeadline = deadlines.forFrame(plan.mode == proto::FrameMode::Interaction || plan.reassigned || last,
                                          frameCost(plan.mode));
        assembler.beginFrame(f, plan.owners, now, lastDeadline);
    }

    void retire(RetiredFrame& r, TimePoint now) {
        FrameInfo info = std::move(frameInfo[r.frame]);
        frameInfo.erase(r.frame);
        OutputJob job;
        job.frame = r.frame;
        job.mode = info.mode;
        // Frames often retire in pairs (pipelining): a rate over the last few frames says more
        // than the gap to the previous one.
        shownTimes.push_back(now);
        if (shownTimes.size() > kFpsWindow + 1) shownTimes.pop_front();
        double span = std::chrono::duration<double>(now - (shownTimes.size() > 1 ? shownTimes.front() : startTime)).count();
        double frames = shownTimes.size() > 1 ? double(shownTimes.size() - 1) : 1.0;
        job.fps = span > 0 ? frames / span : 0.0;
        job.bytes = info.bytes;
        job.photonsPerSet = info.setsReported ? double(info.photonsStored) / double(info.setsReported) : 0.0;
        job.slowest = info.slowest;
        job.slowestMs = std::max(0.0f, info.slowestMs);
        job.slowestPhotonMs = info.slowestStats.photonMs;
        job.slowestEyeMs = info.slowestStats.renderMs;
        job.slowestEncodeMs = info.slowestStats.encodeMs;
        job.arrived = r.arrived.size();
        job.setCount = setCount;
        job.deadlineHit = r.deadlineHit;
        job.owners = std::move(info.owners);
        uint32_t passes = UINT32_MAX;
        for (const proto::FrameData& d : info.data) passes = std::min(passes, d.passes);
        job.data = std::move(info.data);
        job.last = r.frame + 1 == static_cast<uint64_t>(opt.frames);
        FrameStatus status{r.frame, info.epoch, info.mode, job.fps, job.photonsPerSet, info.slowestStats,
                           info.slowest, job.arrived, job.owners, passes == UINT32_MAX ? 0u : passes};
        if (!opt.out.empty() && opt.saveEvery > 0 && r.frame > 0 && r.frame % uint64_t(opt.saveEvery) == 0)
            job.saveAs = numberedPath(opt.out, r.frame, ".exr");
        ++summary.framesShown;
        if (!r.missing.empty()) ++summary.framesIncomplete;
        if (!r.deadlineHit && !r.arrived.empty()) deadlines.completed(r.waited, frameCost(info.mode));
        summary.seconds = std::chrono::duration<double>(now - startTime).count();
        if (r.deadlineHit) {
            std::string late;
            for (ClientId c : r.late) late += " " + std::to_string(c);
            std::fprintf(stderr, "rtpm-server: frame %llu shown at its deadline (%lld ms) with %zu/%u sets (late:%s)\n",
                         (unsigned long long)r.frame,
                         (long long)std::chrono::duration_cast<std::chrono::milliseconds>(r.waited).count(),
                         r.arrived.size(), setCount, late.c_str());
        }
        ++outputsQueued;
        output.post(std::move(job), [this, status = std::move(status)](OutputResult result) {
            asio::post(io, [this, status, result = std::move(result)] {
                --outputsQueued;
                imageWriteFailed |= result.writeFailed;
                publishStatus(status, result.masterMs);
                for (const auto& [id, why] : result.badPayloads)
                    if (ClientInfo* c = registry.find(id)) protocolError(*c->connection, why);
                pump();
            });
        });
    }

    // ---- end -----------------------------------------------------------------------------

    void shutdown(int code, proto::ByeReason reason, const std::string& text) {
        if (finishing) return;
        finishing = true;
        exitCode = code;
        asio::error_code ec;
        acceptor.close(ec);
        deadlineTimer.cancel();
        heartbeatTimer.cancel();
        admissionLogTimer.cancel();
        for (auto& [conn, p] : pending)
            if (p.delay) p.delay->cancel();
        if (admission.totals().any()) {
            const AdmissionCounts& t = admission.totals();
            std::fprintf(stderr, "rtpm-server: admission over the run: %llu connections, %llu authenticated, %llu refused "
                         "(capacity), %llu refused (rate limit), %llu evicted, %llu timed out, %llu protocol errors, "
                         "%llu failed authentications\n",
                         (unsigned long long)t.connections, (unsigned long long)t.admitted,
                         (unsigned long long)t.refusedCapacity, (unsigned long long)t.refusedRateLimited,
                         (unsigned long long)t.evicted, (unsigned long long)t.timedOut,
                         (unsigned long long)t.protocolErrors, (unsigned long long)t.failedAuth);
        }
        signals.cancel();
        for (const auto& c : connections) {
            if (registry.find(*c)) c->send(proto::Bye{reason, text});
            c->closeAfterFlush();
        }
        if (connections.empty()) {
            io.stop();
            return;
        }
        finishTimer.expires_after(std::chrono::seconds(3));
        finishTimer.async_wait([this](const asio::error_code& e) {
            if (!e) io.stop();
        });
    }
};

Master::Master(MasterOptions options, Scene scene) : impl_(std::make_unique<Impl>(std::move(options), std::move(scene))) {}
Master::~Master() = default;
uint16_t Master::port() const { return impl_->port(); }
uint16_t Master::viewerPort() const { return impl_->viewer ? impl_->viewer->port() : 0; }
int Master::run() { return impl_->run(); }
void Master::stop() {
    asio::post(impl_->io, [this] { impl_->requestStop(); });
}
const MasterSummary& Master::summary() const { return impl_->summary; }

}  // namespace rtpm::server
