// The browser viewer's HTTP and WebSocket server (websocketpp on standalone Asio), on its own
// thread.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "common/image/frame_image.h"
#include "server/viewer/viewer_command.h"
#include "server/viewer/viewer_options.h"
#include "server/viewer/viewer_stats.h"

namespace rtpm::server {

/// Serves server/web/ (embedded at build time) and one WebSocket per viewer. The page says hello
/// with a token; it then receives JSON text (status, scene, clients, errors) and binary JPEG
/// frames, and sends controls (viewer_command.h). A viewer gets a new frame only after it
/// acknowledged the previous one, and then the newest: a slow viewer drops frames for itself
/// only, and holds at most one frame. While someone watches, composed frames are tone-mapped at
/// most maxFps times a second (latest wins), and encoded only when a viewer is waiting for one
/// (has acknowledged its last), once per display setting however many viewers share it: a
/// viewer's acknowledgement is answered at once with the newest frame. publishFrame() is two
/// short mutexes and no work when nobody watches.
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
