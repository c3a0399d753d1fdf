// Viewer server: wires the rooms of the viewer port together on its own io_context thread —
// the gate (admission until a connection is a viewer), the page (viewer_http), the viewers'
// WebSockets (viewer_connections) and the frames: output thread → tone map (frame_feed, only for
// display settings a viewer uses) → JPEG (viewer_frames, on the viewer thread) → each viewer that
// acknowledged its previous frame.
#include "server/viewer/viewer_server.h"

#include <asio.hpp>

#include <cstdio>
#include <stdexcept>
#include <thread>
#include <variant>

#include "server/viewer/frame_feed.h"
#include "server/viewer/viewer_connections.h"
#include "server/viewer/viewer_frames.h"
#include "server/viewer/viewer_gate.h"
#include "server/viewer/viewer_http.h"
#include "server/viewer/viewer_model.h"
#include "server/viewer/ws_endpoint.h"

namespace rtpm::server {

namespace {

using ConnId = WsEndpoint::ConnId;

/// `o` as the rooms read it: the origin list normalized (throws on a bad entry, before the port
/// is bound) and a log that writes to stderr if none was given.
ViewerOptions resolved(ViewerOptions o) {
    o.allowedOrigins = normalizedOrigins(o.allowedOrigins);
    if (!o.log)
        o.log = [](const std::string& line) {
            std::fprintf(stderr, "rtpm-server: %s\n", line.c_str());
        };
    return o;
}

}  // namespace

struct ViewerServer::Impl {
    const ViewerOptions opt;
    const CommandHandler onCommand;
    asio::io_context io;
    asio::executor_work_guard<asio::io_context::executor_type> guard{io.get_executor()};
    ViewerStats stats;
    std::unique_ptr<WsEndpoint> ws;  // bound in the constructor; the rooms below use it
    ViewerGate gate;
    ViewerFrames frames{opt.jpegQuality, opt.log, stats};
    ViewerConnections viewers;
    FrameFeed feed{opt.maxFps, stats, [this] { asio::post(io, [this] { encodePending(); }); }};
    asio::steady_timer stopTimer{io};
    std::thread thread;

    Impl(ViewerOptions o, CommandHandler handler)
        : opt(resolved(std::move(o))),
          onCommand(std::move(handler)),
          ws(bind()),
          gate(io, *ws, opt),
          viewers(*ws, frames) {
        thread = std::thread([this] {
            io.run();
            stats.threadEnded(threadCpuSeconds());
        });
    }

    std::unique_ptr<WsEndpoint> bind() {
        // Every handler runs on the viewer thread, which starts once every room is built.
        WsEndpoint::Handlers h;
        h.accept = [this](ConnId id, const WsEndpoint::Peer& peer) {
            return gate.accept(id, peer);
        };
        h.http = [this](ConnId id, const std::string& method, const std::string& path) {
            gate.progress(id);
            return serveWebAsset(method, path);
        };
        h.validate = [this](ConnId id, const std::string& path, const std::string& origin) {
            return gate.validate(id, path, origin);
        };
        h.open = [this](ConnId id) { viewers.open(id); };
        h.close = [this](ConnId id) { onGone(id); };
        h.message = [this](ConnId id, std::string&& payload, bool binary) {
            onMessage(id, payload, binary);
        };
        try {
            return std::make_unique<WsEndpoint>(io, opt.host, opt.port, kMaxViewerMessageBytes,
                                                1024, std::move(h));
        } catch (const std::runtime_error& e) {
            throw std::runtime_error(std::string("--http: ") + e.what());
        }
    }

    void onGone(ConnId id) {
        gate.gone(id);
        if (viewers.close(id)) refreshWanted();
    }

    void onMessage(ConnId id, const std::string& payload, bool binary) {
        Viewer* v = viewers.find(id);
        if (!v || gate.deciding(id)) return;  // deciding: its refusal is on the way
        if (binary) return viewers.sendText(id, replyErrorJson("controls are JSON text messages"));
        ViewerParse parsed = parseViewerCommand(payload);
        if (!parsed.ok())
            return viewers.sendText(id, replyErrorJson("control refused: " + parsed.error()));
        const ViewerCommand& cmd = parsed.command();
        if (auto* hello = std::get_if<ViewerHello>(&cmd)) {
            if (v->helloed) return viewers.sendText(id, replyErrorJson("hello sent twice"));
            return gate.hello(id, hello->token, [this, id](bool control) { welcome(id, control); });
        }
        if (!v->helloed)
            return viewers.sendText(id, replyErrorJson("say hello (with the token) first"));
        if (auto* d = std::get_if<ViewerDisplay>(&cmd)) {
            viewers.setDisplay(id, DisplayKey{d->layer, d->exposureStops});
            refreshWanted();
            viewers.sendFrame(id);
            encodePending();
            return;
        }
        if (auto* a = std::get_if<ViewerAck>(&cmd)) {
            if (!viewers.acknowledge(id, a->frame))
                return viewers.sendText(id,
                                        replyErrorJson("ack for frame " + std::to_string(a->frame) +
                                                       ", which was not the frame sent"));
            stats.shown(a->frame, ViewerStats::Clock::now());
            viewers.sendFrame(id);  // an encoded newer frame, or
            encodePending();        // the newest tone-mapped one, encoded now
            return;
        }
        if (!v->control)
            return viewers.sendText(
                id, replyErrorJson(
                        "this viewer is read-only: controls need the cluster or viewer token"));
        onCommand(cmd, v->control, [this, id](std::string json) {
            asio::post(io, [this, id, json = std::move(json)] {
                if (viewers.find(id)) viewers.sendText(id, json);
            });
        });
    }

    void welcome(ConnId id, bool control) {
        viewers.welcome(id, control);
        refreshWanted();
        viewers.sendFrame(id);
        encodePending();
    }

    /// Tells the output thread which display settings to tone-map frames for: those some viewer
    /// uses. Frames of settings nobody uses any more are dropped.
    void refreshWanted() {
        std::vector<DisplayKey> wanted = viewers.displays();
        frames.retain(wanted);
        feed.setWanted(std::move(wanted));
    }

    /// Encodes the tone-mapped frames some viewer is waiting for (acknowledged its last frame)
    /// and sends them; the others stay pending until a newer frame replaces them or their viewer
    /// acknowledges. So a frame is tone-mapped at most maxFps times a second while someone
    /// watches, and encoded only for a waiting viewer, once however many viewers share it.
    void encodePending() {
        const auto waiting = [this](const DisplayKey& key, uint64_t frame) {
            return viewers.waitingFor(key, frame);
        };
        if (frames.encode(feed, waiting)) viewers.sendFrames();
    }

    void stopOnThread() {
        if (gate.stopping()) return;
        gate.stop();
        ws->shutdown();
        gate.dropPending();
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

void ViewerServer::publishFrame(uint64_t frame, const FrameImage& image) {
    impl_->feed.publish(frame, image);
}

void ViewerServer::chargeCpu(double seconds) { impl_->stats.chargeStatus(seconds); }

void ViewerServer::publishStatus(std::string json) {
    asio::post(impl_->io, [this, json = std::move(json)]() mutable {
        impl_->viewers.publishStatus(std::move(json));
    });
}

void ViewerServer::publishScene(std::string json) {
    asio::post(impl_->io, [this, json = std::move(json)]() mutable {
        impl_->viewers.publishScene(std::move(json));
    });
}

void ViewerServer::publishEvent(std::string json) {
    asio::post(impl_->io, [this, json = std::move(json)] { impl_->viewers.broadcast(json, true); });
}

void ViewerServer::stop() {
    if (!impl_->thread.joinable()) return;
    asio::post(impl_->io, [this] { impl_->stopOnThread(); });
    impl_->thread.join();
}

ViewerReport ViewerServer::report() const { return impl_->stats.report(); }

}  // namespace rtpm::server
