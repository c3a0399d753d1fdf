// What the browser viewer's port is told at start: address, token, limits, frame rate, origins.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "server/admission.h"

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
    std::string token;  ///< controls need it (the viewer or the cluster token); "" = none needed
    bool publicView = false;  ///< viewers without the token may watch (no controls)
    int maxViewers = 8;       ///< viewers that said hello, at once; more are refused
    int jpegQuality = 85;
    double maxFps = 30.0;  ///< frames sent to viewers per second at most (0 = every frame)
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
    /// Where log lines go ("" prefix-free text, one line each); default: stderr as "rtpm-server:
    /// …".
    std::function<void(const std::string&)> log;
};

}  // namespace rtpm::server
