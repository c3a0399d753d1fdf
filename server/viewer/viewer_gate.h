// The viewer port's admission: every TCP connection from accept until it is a viewer — budgets
// per address and in all, the deadline, the WebSocket's Origin, the token and the viewer count.
#pragma once

#include <asio.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "server/admission.h"
#include "server/viewer/viewer_options.h"
#include "server/viewer/ws_endpoint.h"

namespace rtpm::server {

/// The --viewer-origin list as the gate compares origins: lowered, without a trailing '/'.
/// Throws std::invalid_argument naming an entry that is not http(s)://HOST[:PORT].
std::vector<std::string> normalizedOrigins(const std::vector<std::string>& origins);

/// The HTTP port under the cluster port's rules (server/admission.h): every TCP connection holds
/// a pending slot from accept until its WebSocket said hello with the token, or it is gone; a
/// budget per address and in all, a deadline, failed tokens delayed and limited per address, at
/// most maxViewers viewers, one summary line per interval and totals at the end. Refusals are
/// sent to the peer and the connection closed here. Viewer thread only.
class ViewerGate {
public:
    using ConnId = WsEndpoint::ConnId;
    using Clock = std::chrono::steady_clock;
    /// Called when a connection becomes a viewer; `control`: it may send controls.
    using Admitted = std::function<void(bool control)>;

    /// `options` (allowedOrigins normalized, log set) must outlive the gate.
    ViewerGate(asio::io_context& io, WsEndpoint& ws, const ViewerOptions& options);

    /// A new TCP connection: false refuses it (capacity, rate limit, stopping).
    bool accept(ConnId id, const WsEndpoint::Peer& peer);
    /// `id` sent a whole HTTP request: its slot is not taken for an idle newcomer.
    void progress(ConnId id);
    /// A WebSocket upgrade of `id` to `path` from a page of `origin`: 0 accepts, else the status.
    int validate(ConnId id, const std::string& path, const std::string& origin);
    /// `id` said hello with `token`: `admitted` is called at once or after the failure delay, or
    /// the connection is refused. Ignored once `id` is no longer pending (its time is up).
    void hello(ConnId id, const std::string& token, Admitted admitted);
    /// True while a wrong token's answer is delayed: the connection's messages are ignored.
    bool deciding(ConnId id) const;
    /// `id` is gone (any kind of connection).
    void gone(ConnId id);

    /// Stops admitting and logs the last summary and the run's totals (idempotent).
    void stop();
    bool stopping() const { return stopping_; }
    /// Ends every connection that is not a viewer (after stop(): nothing to say goodbye to).
    void dropPending();

private:
    struct Conn {
        std::string source;  // Admission::sourceKey of the peer's address
        std::string origin;  // http://<the local address it reached>:<port>
        Clock::time_point deadline;
        bool pending = true;    // holds an admission slot
        bool viewer = false;    // admitted: counts against maxViewers
        bool deciding = false;  // sent a wrong token: answered after the failure delay
        std::shared_ptr<asio::steady_timer> delay;
    };
    /// Refusals at the WebSocket upgrade, counted for the summary line instead of a line each.
    struct UpgradeRefusals {
        uint64_t origin = 0;     // Origin not allowed
        uint64_t full = 0;       // maxViewers viewers already
        std::string lastOrigin;  // escaped and bounded (printableText): a peer's bytes
        bool any() const { return origin || full; }
        std::string text(int maxViewers) const;
    };

    void admit(ConnId id, bool control, const Admitted& admitted);
    void refuse(ConnId id, const std::string& message, Admission::End how, uint16_t code,
                const std::string& reason);
    void endPending(ConnId id, Admission::End how);
    bool full() const;
    bool originAllowed(const std::string& origin, const Conn& c) const;
    void refuseUpgrade(bool forOrigin, const std::string& origin);
    void armDeadline();
    void armLog();
    void logSummary(bool final = false);
    void logRunTotals();

    asio::io_context& io_;
    WsEndpoint& ws_;
    const ViewerOptions& opt_;
    Admission admission_;
    std::map<ConnId, Conn> conns_;
    asio::steady_timer deadlineTimer_, logTimer_;
    bool deadlineArmed_ = false, logArmed_ = false;
    UpgradeRefusals refusedInterval_, refusedTotal_;
    size_t viewers_ = 0;  // connections admitted as viewers and not gone
    bool stopping_ = false;
};

}  // namespace rtpm::server
