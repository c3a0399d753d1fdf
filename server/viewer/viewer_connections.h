// The viewers: each open WebSocket's state (hello, controls, display setting, the frame in
// flight) and what is sent to it — text within a buffer limit, frames one at a time.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "server/viewer/frame_feed.h"
#include "server/viewer/viewer_frames.h"
#include "server/viewer/ws_endpoint.h"

namespace rtpm::server {

/// One open WebSocket.
struct Viewer {
    bool helloed = false;  ///< said hello and was admitted (ViewerGate)
    bool control = false;  ///< may send controls (had the token)
    DisplayKey key;
    bool awaitingAck = false;        ///< a frame was sent and not yet acknowledged
    uint64_t lastSent = UINT64_MAX;  ///< the frame sent last (UINT64_MAX: none at this setting)
};

/// The open WebSockets and the texts every newcomer gets (scene, latest status). A viewer has at
/// most one frame in flight: it gets the next, the newest of its display setting, once it has
/// acknowledged the last. Viewer thread only.
class ViewerConnections {
public:
    using ConnId = WsEndpoint::ConnId;

    ViewerConnections(WsEndpoint& ws, const ViewerFrames& frames);

    /// The WebSocket handshake of `id` completed.
    void open(ConnId id);
    /// `id` is gone; true if it was an open WebSocket.
    bool close(ConnId id);
    /// The viewer `id`, or null.
    Viewer* find(ConnId id);
    /// `id` said hello and was admitted: told so (with `control`), then sent the scene and status.
    void welcome(ConnId id, bool control);
    /// `id` shows `key` from now on (a new setting: its next frame is sent whatever its number).
    void setDisplay(ConnId id, const DisplayKey& key);
    /// `id` drew `frame`: false if that is not the frame in flight.
    bool acknowledge(ConnId id, uint64_t frame);

    /// The display settings of the viewers that said hello, each once.
    std::vector<DisplayKey> displays() const;
    /// Whether a viewer at `key` waits for a frame and has not been sent `frame`.
    bool waitingFor(const DisplayKey& key, uint64_t frame) const;
    /// Sends `id` the newest encoded frame of its setting, if it waits and has not had it.
    void sendFrame(ConnId id);
    /// sendFrame to every viewer.
    void sendFrames();

    /// Sends `text`; a `droppable` text is skipped while the viewer has over 1 MiB unsent.
    void sendText(ConnId id, const std::string& text, bool droppable = false);
    /// sendText to every viewer that said hello.
    void broadcast(const std::string& text, bool droppable);
    /// The latest status (kept for newcomers) and the scene, to every viewer.
    void publishStatus(std::string json);
    void publishScene(std::string json);

private:
    WsEndpoint& ws_;
    const ViewerFrames& frames_;
    std::map<ConnId, Viewer> viewers_;
    std::string status_, scene_;
};

}  // namespace rtpm::server
