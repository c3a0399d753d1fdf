// One TCP connection speaking the rtpm protocol: framed reads through proto::FrameSplitter, queued writes.
#pragma once

#include <asio.hpp>
#include <asio/ssl.hpp>

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "proto/messages.h"
#include "proto/net/read_deadline.h"
#include "proto/net/write_queue.h"

namespace rtpm::net {

class Connection;

/// What a Connection reports to its owner. Called on the I/O thread only.
class ConnectionHandler {
public:
    virtual ~ConnectionHandler() = default;
    /// A whole, validated message. `wireBytes` = header + payload.
    virtual void onMessage(Connection& c, proto::Message&& m, size_t wireBytes) = 0;
    /// The peer's bytes cannot be decoded (bad magic, version, size, field…); the session stops
    /// reading. The handler decides what to send before closing.
    virtual void onBadBytes(Connection& c, const proto::Error& e) = 0;
    /// The connection is gone (peer closed, I/O error, close() completed). Called exactly once,
    /// after which the handler must drop its reference.
    virtual void onClosed(Connection& c, const std::string& why) = 0;
};

/// A connection (the master's to each peer, the client's to the master): reads as fast as the peer sends, splitting the stream into messages; writes
/// queued buffers one at a time (one write in flight, Asio's rule), sharing encoded buffers
/// between sessions. Lives on one io_context thread; not thread-safe. Owned by a shared_ptr so
/// pending handlers keep it alive.
class Connection : public std::enable_shared_from_this<Connection> {
public:
    using Buffer = WriteQueue::Buffer;

    /// `maxQueuedBytes`: a peer that lets more than this pile up unread is closed (it is not
    /// reading; memory must not grow without bound).
    Connection(asio::ip::tcp::socket socket, ConnectionHandler& handler, size_t maxQueuedBytes);

    /// Runs the connection over TLS with `context` (which outlives the connection): the TLS
    /// handshake runs first, within start()'s handshake timeout; sends queue until it is done.
    /// Call before start(). `server`: this side accepts; otherwise `verifyHost` is the name (or
    /// address) the peer's certificate must carry, also sent as SNI.
    void useTls(asio::ssl::context& context, bool server, const std::string& verifyHost = "");

    /// Starts reading. `handshakeTimeout`: the connection is closed unless markAuthenticated()
    /// is called within it (zero: no timeout). Until then reads go through a small buffer.
    void start(std::chrono::milliseconds handshakeTimeout);
    /// The handshake is over: cancels its timeout, lifts expectOnly(), reads in large chunks.
    void markAuthenticated();
    /// Until markAuthenticated(): the next messages must be of `type` with at most
    /// `maxPayloadBytes`; a header announcing anything else is a decode error (onBadBytes)
    /// before any of its payload is buffered. Call from onMessage to change what comes next.
    void expectOnly(proto::MessageType type, uint32_t maxPayloadBytes) { splitter_.allowOnly(type, maxPayloadBytes); }
    /// After markAuthenticated(): no message of more than `maxPayloadBytes` (a bound derived
    /// from what the peer is asked to send) is buffered; a header announcing more is a decode
    /// error (onBadBytes) from its 16 bytes alone.
    void capPayload(uint32_t maxPayloadBytes) { splitter_.capPayload(maxPayloadBytes); }
    /// A message that has begun to arrive must keep arriving: the connection is closed when no
    /// byte of it comes for `stall`, or when it is not complete within `stall` plus its size at
    /// `minBytesPerSecond` (so neither a silent nor a trickling peer holds a half message, and
    /// its buffer, forever). Zero: no read deadline (the default). Idle time between messages
    /// is not limited here.
    void setReadDeadline(std::chrono::milliseconds stall, uint64_t minBytesPerSecond);

    /// Queues bytes (a whole encoded message) for sending.
    void send(Buffer bytes);
    void send(const proto::Message& m) { send(std::make_shared<const std::vector<uint8_t>>(proto::encode(m))); }

    /// Drops every queued buffer except the one being written (a message is never cut).
    void dropUnsent();
    /// Stops reading, sends what is queued, then closes (or closes after `grace` regardless).
    void closeAfterFlush(std::chrono::milliseconds grace = std::chrono::milliseconds(2000));
    /// Closes now; queued bytes are dropped.
    void close(const std::string& why);

    /// "address:port" of the peer (fixed at construction, valid after the socket closes).
    const std::string& peer() const { return peer_; }
    bool closing() const { return closing_; }
    /// The handshake timeout closed it (start()'s timeout passed before markAuthenticated()).
    bool handshakeTimedOut() const { return handshakeTimedOut_; }
    size_t queuedBytes() const { return writes_.bytes(); }
    uint64_t bytesReceived() const { return bytesReceived_; }
    /// The peer has sent at least one byte: read already, or waiting in the socket unread.
    bool peerSentBytes();

private:
    void readMore();
    void writeNext();
    void finish(const std::string& why);
    void updateReadDeadline();
    void startReading();
    asio::ip::tcp::socket& lowest() { return tls_ ? tls_->next_layer() : socket_; }
    /// Calls f with the stream that carries the protocol (the TLS stream or the plain socket).
    template <class F>
    void withStream(F&& f) {
        if (tls_) f(*tls_);
        else f(socket_);
    }

    asio::ip::tcp::socket socket_;
    std::unique_ptr<asio::ssl::stream<asio::ip::tcp::socket>> tls_;  // owns the socket when set
    bool tlsServer_ = true;
    ConnectionHandler& handler_;
    asio::steady_timer timer_;   // the handshake timeout, then closeAfterFlush's grace
    ReadDeadline readDeadline_;  // of a partial message
    std::string peer_;
    proto::FrameSplitter splitter_;
    std::vector<uint8_t> readBuf_;
    WriteQueue writes_;
    uint64_t bytesReceived_ = 0;
    bool closing_ = false;   // no more messages are delivered
    bool finished_ = false;  // onClosed delivered
    bool authenticated_ = false;
    bool handshakeTimedOut_ = false;
};

}  // namespace rtpm::net
