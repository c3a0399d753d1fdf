// The browser viewer's HTTP and WebSocket server (websocketpp on standalone Asio), on its own thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/image/frame_image.h"
#include "server/admission.h"
#include "server/viewer/viewer_command.h"

namespace rtpm::server {

/// Limits of the HTTP port before a connection is a viewer (see ViewerServer): every TCP
/// connection, page requests included, holds a pending slot until its WebSocket presented the
/// token. A page load is four short requests and a WebSocket, and a browser opens up to six
/// connections to a host at once (more with several tabs): 16 an address, as on the cluster
/// port, and 64 in all keep the port under ~70 descriptors with --max-viewers 8.
inline AdmissionLimits defaultViewerAdmission() {
    AdmissionLimits a;
    a.maxPending = 64;
    a.maxPendingPerSource = 16;
    return a;
}

struct ViewerOptions {
    std::string host = "127.0.0.1";  ///< address the HTTP port binds to
    uint16_t port = 0;               ///< 0 = any free port
    std::string token;               ///< controls need it (the viewer or the cluster token); "" = none needed
    bool publicView = false;         ///< viewers without the token may watch (no controls)
    int maxViewers = 8;              ///< viewers that said hello, at once; more are refused
    int jpegQuality = 85;
    double maxFps = 30.0;            ///< frames sent to viewers per second at most (0 = every frame)
    /// Budgets of connections that are not (yet) viewers, failed-token allowance, log interval.
    AdmissionLimits admission = defaultViewerAdmission();
    /// A connection must be a viewer (WebSocket open and hello with the token answered) within
    /// this, or be done: an idle socket, a slow request or a WebSocket that never says hello is
    /// closed then.
    std::chrono::milliseconds handshakeTimeout{5000};
    /// Origins (scheme://host[:port], as browsers send them) whose pages may open the WebSocket,
    /// besides http://<the address the connection reached>:<port> (and http://localhost:<port>
    /// on loopback). The Host header is never trusted: a rebinding page controls it.
    std::vector<std::string> allowedOrigins;
    /// Where log lines go ("" prefix-free text, one line each); default: stderr as "rtpm-server: …".
    std::function<void(const std::string&)> log;
};

/// Lag and cost figures, for the summary line and tests.
struct ViewerReport {
    uint64_t framesPublished = 0;  ///< frames tone-mapped for at least one viewer
    uint64_t framesEncoded = 0;    ///< JPEGs made (one per frame and display setting)
    uint64_t framesShown = 0;      ///< acknowledged by a page (drawn)
    double meanLagFrames = 0.0;    ///< newest composed frame − drawn frame, when the page drew it
    uint64_t maxLagFrames = 0;
    double meanLatencyMs = 0.0;    ///< composed → drawn (acknowledged)
    double maxLatencyMs = 0.0;
    double cpuSeconds = 0.0;       ///< all of the below
    double toneMapCpuSeconds = 0.0;  ///< tone mapping (and auto exposure) on the output thread
    double threadCpuSeconds = 0.0;   ///< the viewer thread: JPEG, WebSocket and HTTP I/O, controls
    double statusCpuSeconds = 0.0;   ///< building the status JSON on the frame loop (chargeCpu)
};

/// CPU seconds the calling thread has used (CLOCK_THREAD_CPUTIME_ID).
double threadCpuSeconds();

/// Serves server/web/ (embedded at build time) and one WebSocket per viewer. The page says hello
/// with a token; it then receives JSON text (status, scene, clients, errors) and binary JPEG
/// frames, and sends controls (viewer_command.h). A viewer gets a new frame only after it
/// acknowledged the previous one, and then the newest: a slow viewer drops frames for itself
/// only, and holds at most one frame. While someone watches, composed frames are tone-mapped at
/// most maxFps times a second (latest wins), and encoded only when a viewer is waiting for one
/// (has acknowledged its last), once per display setting however many viewers share it: a
/// viewer's acknowledgement is answered at once with the newest frame. publishFrame() is one
/// mutex and no work when nobody watches.
/// Controls are validated on the viewer thread; edits, pause, snapshot and script requests go
/// to `onCommand` (called on the viewer thread; `reply` may be called from any thread, once).
class ViewerServer {
public:
    using Reply = std::function<void(std::string json)>;
    using CommandHandler = std::function<void(const ViewerCommand&, bool control, Reply reply)>;

    /// Binds and starts the thread. Throws std::runtime_error if it cannot listen.
    ViewerServer(ViewerOptions options, CommandHandler onCommand);
    ~ViewerServer();  ///< closes every viewer and joins the thread
    ViewerServer(const ViewerServer&) = delete;
    ViewerServer& operator=(const ViewerServer&) = delete;

    uint16_t port() const;
    /// Output thread: frame `frame` was composed into `image`. Tone-maps it (on the caller's
    /// thread) for every display setting a viewer uses and hands it over for encoding.
    void publishFrame(uint64_t frame, const FrameImage& image);
    /// Any thread: count `seconds` of that thread's CPU as the viewer's (e.g. building status).
    void chargeCpu(double seconds);
    /// Any thread: the frame's figures and the clients (JSON object text), to every viewer.
    void publishStatus(std::string json);
    /// Any thread: the scene's editable state (JSON object text), kept for viewers joining later.
    void publishScene(std::string json);
    /// Any thread: a one-off event (client joined or left…), to every viewer.
    void publishEvent(std::string json);
    /// Closes every viewer and stops accepting (idempotent); the thread ends.
    void stop();
    ViewerReport report() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rtpm::server
