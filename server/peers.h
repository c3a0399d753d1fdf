// The peers: every connection from accept to close — admission budgets, one handshake session per
// connection, the registry of authenticated clients, heartbeats, protocol errors and eviction.
#pragma once

#include <asio.hpp>

#include <map>
#include <memory>
#include <set>
#include <string>

#include "proto/net/connection.h"
#include "server/acceptor.h"
#include "server/admission.h"
#include "server/client_registry.h"
#include "server/handshake.h"
#include "server/peer_connections.h"
#include "server/master.h"

namespace rtpm::server {

/// What the peers tell the rest of the master. Called on the I/O thread.
class PeerEvents {
public:
    virtual ~PeerEvents() = default;
    /// `client` finished its handshake and is registered (it has been sent nothing yet).
    virtual void clientJoined(ClientInfo& client) = 0;
    /// `client` is no longer registered (Bye, closed, protocol error, evicted).
    virtual void clientLeft(const ClientInfo& client, const std::string& why) = 0;
    /// A FrameData or Stats of a registered client.
    virtual void clientMessage(ClientInfo& client, proto::Message&& m, size_t wireBytes) = 0;
    /// The last connection closed while the peers were quiesced.
    virtual void allClosed() = 0;
};

/// Peer totals of a run.
struct PeerCounts {
    uint64_t joined = 0;
    uint64_t refused = 0;         ///< refused at connect or in the handshake: capacity, rate limit, version
    uint64_t failedAuth = 0;      ///< refused for a wrong token (or none where one is needed)
    uint64_t protocolErrors = 0;  ///< closed for bytes that break the protocol, in or after the handshake
};

/// Owns every connection (authenticated or not). Peers that send bad bytes are closed with a log
/// line naming them (PROTOCOL.md §7 for the handshake). Lives on the I/O thread; not thread-safe.
class Peers final : public net::ConnectionHandler {
public:
    /// Binds (see Acceptor). `options` outlives the peers.
    Peers(asio::io_context& io, const MasterOptions& options, PeerEvents& events);

    uint16_t port() const { return acceptor_.port(); }
    /// Starts accepting and the heartbeat.
    void start();

    ClientRegistry& registry() { return registry_; }
    const PeerCounts& counts() const { return counts_; }

    /// Sends `bytes` to every registered client.
    void sendToAll(const net::Connection::Buffer& bytes);
    /// A client that broke the protocol: log, Bye{ProtocolError}, drop.
    void protocolError(net::Connection& c, const std::string& why);
    /// A client that fell behind: log, Bye{Timeout, why}, drop.
    void evict(ClientId id, const std::string& why);
    /// A client sends at most one FrameData of its largest set in float32 (24 B/px, the largest
    /// encoding) plus a few fields; Stats and Bye are far smaller. So a header announcing more is
    /// refused before its payload is buffered. The bound only grows during a run, so data of a
    /// frame rendered before a resize to fewer pixels still fits.
    void raisePayloadCap(const RenderSettings& settings);
    /// A client whose message stops arriving holds the frames waiting for it, so its stall is
    /// bounded by the frame deadline the frames measure now (`frameDeadline`, the adaptive one
    /// even for a frame given the ceiling), never by more than --read-timeout-ms nor less than
    /// kMinReadStall. Applies to every client from its next byte on.
    void boundReadStall(std::chrono::milliseconds frameDeadline);
    /// Below this a healthy peer's TCP retransmissions (200 ms at the least, doubling) could
    /// look like a stall.
    static constexpr std::chrono::milliseconds kMinReadStall{1000};

    /// The run is ending: no more accepts, heartbeats or messages handled.
    void quiesce();
    /// Closes the port, logs the admission totals, says Bye{reason, text} to every client and
    /// closes every connection after its queue drains (PeerEvents::allClosed follows). Returns
    /// false when none was open.
    bool closeAll(proto::ByeReason reason, const std::string& text);

    void onMessage(net::Connection& c, proto::Message&& m, size_t wireBytes) override;
    void onBadBytes(net::Connection& c, const proto::Error& e) override;
    void onClosed(net::Connection& c, const std::string& why) override;

private:
    void admit(asio::ip::tcp::socket sock);
    void handshake(net::Connection& c, PeerConnections::Pending& p, const proto::Message& m);
    void join(net::Connection& c, const HandshakeSession& session);
    void reject(net::Connection& c, proto::RejectReason reason, const std::string& text);
    void endPending(const net::Connection& c, Admission::End how);
    void dropClientOf(net::Connection& c, const std::string& why);
    void armAdmissionLog();
    void heartbeat();

    asio::io_context& io_;
    const MasterOptions& opt_;
    PeerEvents& events_;
    Acceptor acceptor_;
    PeerConnections connections_;  // every peer, authenticated or not, with its handshake
    ClientRegistry registry_;
    Admission admission_;
    asio::steady_timer admissionLogTimer_;
    asio::steady_timer heartbeatTimer_;
    uint32_t clientPayloadCap_ = 0;  // largest message a client may announce (raisePayloadCap)
    std::chrono::milliseconds readStall_;  // a client's mid-message stall bound (boundReadStall)
    bool admissionLogArmed_ = false;
    bool closing_ = false;
    PeerCounts counts_;
};

}  // namespace rtpm::server
