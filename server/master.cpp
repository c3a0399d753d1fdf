// The master: wires its rooms together on one io_context, in the shape of Asio's server
// examples — the peers (acceptor, admission, a handshake session per connection, the client
// registry), the frame loop (policy, deadline, assembler), the live control (the one edit path),
// the image output stage and the viewer (its outbound model in server/viewer/viewer_model.h).
#include "server/master.h"

#include <asio.hpp>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <utility>

#include "common/image/image_io.h"
#include "proto/auth.h"
#include "proto/net/listen_address.h"
#include "server/frame_loop.h"
#include "server/image_output.h"
#include "server/live_control.h"
#include "server/peers.h"
#include "server/viewer/viewer_model.h"
#include "server/viewer/viewer_server.h"

namespace rtpm::server {

namespace {

/// The options with every check that needs no scene and no socket done (process start: throws).
MasterOptions validated(MasterOptions o) {
    validateSettings(o.settings);
    if (o.frames < 0) throw std::invalid_argument("--frames must be >= 0 (0 = until stopped)");
    if (o.minClients < 1) throw std::invalid_argument("--min-clients must be >= 1");
    if (o.evictAfter < 1) throw std::invalid_argument("--evict-after must be >= 1");
    if (o.token.empty() && !o.insecureNoToken)
        throw std::invalid_argument("no token: pass --token or set RTPM_TOKEN (or --insecure-no-token)");
    if (!o.insecureNoToken)
        if (auto weak = proto::tokenWeakness(o.token)) throw std::invalid_argument("refusing the token: " + *weak);
    if (!o.http.empty() && o.viewerToken.empty() && o.token.empty())
        throw std::invalid_argument(
            "--http with --insecure-no-token needs --viewer-token: without one anyone who reaches the HTTP port "
            "could drive the master (generate one with `openssl rand -hex 16`)");
    if (!o.viewerToken.empty())
        if (auto weak = proto::tokenWeakness(o.viewerToken))
            throw std::invalid_argument("refusing --viewer-token: " + *weak);
    return o;
}

}  // namespace

struct Master::Impl final : PeerEvents, FrameLoopListener {
    MasterOptions opt;
    asio::io_context io;
    asio::signal_set signals{io};
    asio::steady_timer finishTimer{io};
    LiveControl control;
    Peers peers;
    FrameLoop loop;
    std::unique_ptr<ViewerServer> viewer;
    std::optional<std::pair<ViewerFrame, double>> lastShown;  // its status is re-sent when pausing
    MasterSummary summary;
    int exitCode = 0;
    ImageOutput output;  // last member: its thread stops before the rest is destroyed

    Impl(MasterOptions o, Scene scene)
        : opt(validated(std::move(o))),
          control(opt, std::move(scene), peers, output),
          peers(io, opt, *this),
          loop(io, opt, peers, control, output, *this),
          output(outputOptions()) {
        peers.raisePayloadCap(opt.settings);
        if (!opt.http.empty()) startViewer();
    }

    ImageOutputOptions outputOptions() {
        ImageOutputOptions o;
        o.width = opt.settings.width;
        o.height = opt.settings.height;
        o.interleave = opt.settings.interleave;
        o.filter = opt.settings.filterSize();
        o.out = opt.out;
        o.csv = opt.csv;
        o.quiet = opt.quiet;
        o.sceneName = opt.sceneName;
        o.totalFrames = opt.frames > 0 ? uint64_t(opt.frames) : 0;
        o.onComposed = [this](uint64_t frame, const FrameImage& image) {
            if (viewer) viewer->publishFrame(frame, image);
        };
        return o;
    }

    void startViewer() {
        auto [host, httpPort] = net::parseListenAddress("--http", opt.http);
        ViewerOptions vo;
        vo.host = host;
        vo.port = httpPort;
        vo.token = opt.viewerToken.empty() ? opt.token : opt.viewerToken;
        vo.publicView = opt.viewerPublic;
        vo.maxViewers = opt.maxViewers;
        vo.maxFps = opt.viewerFps;
        vo.allowedOrigins = opt.viewerOrigins;
        viewer = std::make_unique<ViewerServer>(vo, [this](const ViewerCommand& cmd, bool, ViewerServer::Reply reply) {
            asio::post(io, [this, cmd, reply = std::move(reply)] { onViewerCommand(cmd, reply); });
        });
    }

    // ---- start and end ---------------------------------------------------------------------

    int run() {
        writePortFile();
        printStart();
        signals.add(SIGINT);
        signals.add(SIGTERM);
        waitForSignal();
        peers.start();
        io.run();
        output.drain();  // the frame in the output stage is written before run() returns
        if (viewer) {
            viewer->stop();
            printViewerReport(viewer->report());
        }
        fillSummary();
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

    void writePortFile() {
        if (opt.portFile.empty()) return;
        std::string tmp = opt.portFile + ".tmp";
        FILE* f = std::fopen(tmp.c_str(), "w");
        if (!f) throw std::runtime_error("cannot write " + tmp);
        std::fprintf(f, "%u\n", static_cast<unsigned>(peers.port()));
        std::fclose(f);
        std::filesystem::rename(tmp, opt.portFile);
    }

    void printStart() {
        std::printf("rtpm-server listening on %s:%u\n", opt.listen.c_str(), static_cast<unsigned>(peers.port()));
        if (viewer) {
            auto [host, unused] = net::parseListenAddress("--http", opt.http);
            std::printf("viewer: http://%s:%u/\n", host.c_str(), static_cast<unsigned>(viewer->port()));
            publishScene();
        }
        const RenderSettings& s = opt.settings;
        std::printf("scene %s, %dx%d, M=%d (%d sets), F=%d, P=%u, k=%u, %s, %d frames (0 = until stopped), waiting for %d client(s)\n",
                    opt.sceneName.c_str(), s.width, s.height, s.interleave, s.interleave * s.interleave, s.filterSize(),
                    s.photons.photonsPerBatch, s.photons.k, s.photons.selective ? "SPT" : "plain shooting", opt.frames,
                    opt.minClients);
        std::fflush(stdout);
        if (loop.deadlineAdaptive())
            std::printf("frame deadline: adaptive, %.0f x the median frame time within [%lld, %lld] ms; a client "
                        "late or skipped %d frames in a row is evicted\n",
                        opt.deadline.multiple, (long long)opt.deadline.floor.count(),
                        (long long)opt.deadline.ceiling.count(), opt.evictAfter);
        else
            std::printf("frame deadline: %lld ms; a client late or skipped %d frames in a row is evicted\n",
                        (long long)opt.deadline.fixed->count(), opt.evictAfter);
        std::fflush(stdout);
    }

    static void printViewerReport(const ViewerReport& r) {
        std::printf("viewer: %llu frames tone-mapped, %llu encoded, %llu drawn by pages; lag behind the newest "
                    "frame mean %.2f max %llu frames; composed-to-drawn latency mean %.1f max %.1f ms; viewer CPU "
                    "%.3f s (tone map %.3f, viewer thread %.3f, status %.3f)\n",
                    (unsigned long long)r.framesPublished, (unsigned long long)r.framesEncoded,
                    (unsigned long long)r.framesShown, r.meanLagFrames, (unsigned long long)r.maxLagFrames,
                    r.meanLatencyMs, r.maxLatencyMs, r.cpuSeconds, r.toneMapCpuSeconds, r.threadCpuSeconds,
                    r.statusCpuSeconds);
    }

    void fillSummary() {
        const FrameCounts& f = loop.counts();
        summary.framesShown = f.framesShown;
        summary.framesIncomplete = f.framesIncomplete;
        summary.seconds = f.seconds;
        summary.bytesReceived = f.bytesReceived;
        summary.clientsEvicted = f.clientsEvicted;
        summary.clientsJoined = peers.counts().joined;
        summary.peersRefused = peers.counts().refused;
        summary.failedAuth = peers.counts().failedAuth;
        summary.protocolErrors = peers.counts().protocolErrors;
    }

    void printSummary() {
        double fps = summary.seconds > 0 ? double(summary.framesShown) / summary.seconds : 0.0;
        std::printf("summary: %llu frames shown (%llu incomplete) in %.2f s = %.2f fps, %.1f MB received, "
                    "%llu clients joined, %llu evicted, %llu peers refused (capacity, rate limit, version), "
                    "%llu failed authentications, %llu protocol errors\n",
                    (unsigned long long)summary.framesShown, (unsigned long long)summary.framesIncomplete,
                    summary.seconds, fps, double(summary.bytesReceived) / 1e6,
                    (unsigned long long)summary.clientsJoined, (unsigned long long)summary.clientsEvicted,
                    (unsigned long long)summary.peersRefused, (unsigned long long)summary.failedAuth,
                    (unsigned long long)summary.protocolErrors);
        std::fflush(stdout);
    }

    // First signal: finish the frames in flight, write the last image, Bye. Second: stop now.
    void waitForSignal() {
        signals.async_wait([this](const asio::error_code& ec, int sig) {
            if (ec) return;
            if (!loop.running()) {
                std::fprintf(stderr, "rtpm-server: signal %d again, stopping now\n", sig);
                loop.abort();
                return;
            }
            std::fprintf(stderr, "rtpm-server: signal %d, finishing the frames in flight\n", sig);
            loop.requestStop();
            waitForSignal();
        });
    }

    void ending() override { peers.quiesce(); }

    void finished(int code, proto::ByeReason reason, const std::string& text) override {
        exitCode = code;
        signals.cancel();
        if (!peers.closeAll(reason, text)) {
            io.stop();
            return;
        }
        finishTimer.expires_after(std::chrono::seconds(3));
        finishTimer.async_wait([this](const asio::error_code& e) {
            if (!e) io.stop();
        });
    }

    void allClosed() override { io.stop(); }

    // ---- peers -----------------------------------------------------------------------------

    void clientJoined(ClientInfo& c) override {
        if (viewer) viewer->publishEvent(clientEventJson({true, c.id, c.name, c.cores, {}}));
        // Tentative sets: what the client would hold if a frame began now. FrameBegin is binding.
        c.connection->send(proto::Welcome{c.id, loop.clientJoined(c.id)});
        c.connection->send(control.settingsMessage());
        c.connection->send(control.sceneMessage());
        loop.pump();
    }

    void clientLeft(const ClientInfo& c, const std::string& why) override {
        loop.clientLeft(c.id);
        if (viewer) viewer->publishEvent(clientEventJson({false, c.id, c.name, 0, why}));
        asio::post(io, [this] { loop.pump(); });
    }

    void clientMessage(ClientInfo& c, proto::Message&& m, size_t wireBytes) override {
        loop.onMessage(c, std::move(m), wireBytes);
    }

    // ---- viewer ----------------------------------------------------------------------------

    void frameShown(const ViewerFrame& frame, double masterMs) override { publishStatus(frame, masterMs); }

    void publishStatus(const ViewerFrame& frame, double masterMs) {
        if (!viewer) return;
        const double cpu0 = threadCpuSeconds();
        lastShown.emplace(frame, masterMs);
        viewer->publishStatus(statusJson(loop.status(frame, masterMs)));
        viewer->chargeCpu(threadCpuSeconds() - cpu0);  // the status is the viewer's cost
    }

    void publishScene() {
        if (!viewer) return;
        const LiveScene& live = control.live();
        viewer->publishScene(sceneJson(opt.sceneName, live.loaded(), live.scene(), control.settingsShown()));
    }

    void onViewerCommand(const ViewerCommand& cmd, const ViewerServer::Reply& reply) {
        if (!loop.running()) return reply(replyErrorJson("the server is stopping"));
        if (auto* e = std::get_if<ViewerEdit>(&cmd)) {
            try {
                control.apply(e->edit, "viewer", loop.nextFrame());
            } catch (const SceneError& ex) {
                return reply(replyErrorJson(std::string("edit refused: ") + ex.what()));
            }
            if (e->edit.kind != ScriptEdit::Kind::Camera) publishScene();
            reply(replyOkJson(control.lastEditLine()));
            loop.pump();
        } else if (auto* p = std::get_if<ViewerPause>(&cmd)) {
            control.setPaused(p->paused);
            if (lastShown) publishStatus(lastShown->first, lastShown->second);
            std::fprintf(stderr, "rtpm-server: %s by a viewer\n", p->paused ? "paused" : "resumed");
            reply(replyOkJson(p->paused ? "paused" : "resumed"));
            loop.pump();
        } else if (std::get_if<ViewerSnapshot>(&cmd)) {
            const uint64_t shown = loop.counts().framesShown;
            if (opt.out.empty() || shown == 0) return reply(replyErrorJson("no image to save yet (or no --out)"));
            const std::string path = numberedPath(opt.out, shown, "_snapshot.exr");
            output.write(path, [reply, path](std::string err) {
                reply(err.empty() ? replyOkJson("saved " + path) : replyErrorJson("snapshot failed: " + err));
            });
        } else if (std::get_if<ViewerScriptRequest>(&cmd)) {
            reply(replyScriptJson(control.sessionScript()));
        }
    }
};

Master::Master(MasterOptions options, Scene scene) : impl_(std::make_unique<Impl>(std::move(options), std::move(scene))) {}
Master::~Master() = default;
uint16_t Master::port() const { return impl_->peers.port(); }
uint16_t Master::viewerPort() const { return impl_->viewer ? impl_->viewer->port() : 0; }
int Master::run() { return impl_->run(); }
void Master::stop() {
    asio::post(impl_->io, [this] { impl_->loop.requestStop(); });
}
const MasterSummary& Master::summary() const {
    impl_->fillSummary();
    return impl_->summary;
}

}  // namespace rtpm::server
