// The client's session with the master: one connection at a time, its handshake and message dispatch.
#pragma once

#include <asio.hpp>
#include <asio/ssl.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "client/render_thread.h"
#include "client/worker.h"
#include "proto/messages.h"
#include "proto/net/connection.h"

namespace rtpm::client {

/// What the session reports to the worker, on the io thread.
class SessionEvents {
public:
    virtual ~SessionEvents() = default;
    /// The handshake is done: render `welcome.sets` from the next FrameBegin on.
    virtual void onWelcome(const proto::Welcome& welcome) = 0;
    /// The master refused this client (the connection is still open: close it or wait).
    virtual void onReject(const proto::Reject& reject) = 0;
    /// Settings, Scene, Edit or FrameBegin after Welcome, for the render thread.
    virtual void onWork(RenderItem item) = 0;
    virtual void onBye(const proto::Bye& bye) = 0;
    /// The master broke the protocol (`why` names how); the session is still open.
    virtual void onProtocolError(const std::string& why) = 0;
    /// The connection is gone; `wasRunning` after a Welcome, `wasLeaving` after our Bye.
    virtual void onClosed(bool wasRunning, bool wasLeaving, const std::string& why) = 0;
    /// No byte from the master for the idle timeout (already printed); `text` is for the Bye.
    virtual void onSilent(const std::string& text) = 0;
};

/// Watches that bytes keep arriving on a connection: the master sends a Heartbeat every second.
/// Checks a few times per idle timeout; a tick that comes much later than asked means this
/// process was stopped (SIGSTOP, a suspended VM), and that gap is not the master's silence.
class IdleWatch {
public:
    IdleWatch(asio::io_context& io, double idleSeconds);
    /// Starts watching `conn` (which outlives the watch or is stop()ped first): calls
    /// `silent(seconds)` once, after no byte arrived for the idle timeout. No-op for timeout 0.
    void watch(const net::Connection& conn, std::function<void(double)> silent);
    void stop();

private:
    using Clock = std::chrono::steady_clock;
    void tick();

    asio::steady_timer timer_;
    const Clock::duration idle_;
    const Clock::duration tick_;
    const net::Connection* conn_ = nullptr;
    std::function<void(double)> silent_;
    uint64_t generation_ = 0;  ///< bumped by stop(): a tick already queued sees it changed
    uint64_t lastBytes_ = 0;
    Clock::time_point lastProgress_, lastTick_;
};

/// One connection to the master at a time (PROTOCOL.md's client side): sends Hello, answers the
/// Challenge with the token's MAC, waits for Welcome or Reject, then hands Settings, Scene, Edit
/// and FrameBegin to the worker in arrival order. A connection given up (for a rejoin, or
/// flushing our Bye) stays open until it is written, but nothing from it is reported except a
/// Leaving close. Not thread-safe (io thread).
class Session : public net::ConnectionHandler {
public:
    enum class State { Closed, AwaitWelcome, Running, Leaving };

    /// `cores` goes into Hello. Throws std::runtime_error if --tls-ca cannot be loaded.
    Session(asio::io_context& io, const WorkerOptions& options, uint32_t cores, SessionEvents& events);

    /// Starts the handshake on a connected socket; `address` names the master in log lines.
    void open(asio::ip::tcp::socket socket, std::string address);
    State state() const { return state_; }
    /// Waiting for Welcome or rendering.
    bool live() const { return state_ == State::AwaitWelcome || state_ == State::Running; }
    /// A Welcome arrived on the last connection opened (until the next open() or drop()).
    bool welcomed() const { return welcomed_; }
    const std::string& address() const { return address_; }

    /// Queues encoded bytes for the master (a rendered frame), while Running.
    void send(std::vector<uint8_t> bytes);
    /// Gives the connection up for a rejoin: says `bye` first (what is unsent is dropped), or
    /// closes at once; its end is not reported.
    void drop(std::optional<proto::Bye> bye);
    /// Says `bye` and closes once it is written (kByeGrace at most); onClosed(wasLeaving) follows.
    /// Returns false when there is no connection to say it on.
    bool leave(const proto::Bye& bye);
    /// Closes at once; not reported.
    void close();

    // net::ConnectionHandler: what the current connection delivers (others are ignored).
    void onMessage(net::Connection& c, proto::Message&& m, size_t) override;
    void onBadBytes(net::Connection& c, const proto::Error& e) override;
    void onClosed(net::Connection& c, const std::string& why) override;

private:
    void handshake(proto::Message& msg);
    void dispatch(proto::Message&& msg);
    /// Stops watching and forgets the connection (its handlers are ignored from now on).
    std::shared_ptr<net::Connection> release();

    const WorkerOptions& opt_;
    SessionEvents& events_;
    const uint32_t cores_;
    std::unique_ptr<asio::ssl::context> tls_;  ///< --tls
    std::shared_ptr<net::Connection> conn_;    ///< the current connection, once connected
    std::string address_;
    proto::Hello hello_;      ///< what this connection said (the Auth MAC covers it)
    bool challenged_ = false;  ///< the Challenge of this connection was answered
    bool welcomed_ = false;
    State state_ = State::Closed;
    IdleWatch idle_;
};

}  // namespace rtpm::client
