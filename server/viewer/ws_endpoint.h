// The viewer's HTTP/WebSocket transport: websocketpp 0.8 behind a small interface of std types.
// websocketpp 0.8's headers do not compile as C++20 (template-ids on constructors), so they are
// included by ws_endpoint.cpp alone, built as C++17; this header is valid C++17 and C++20.
#pragma once

#include <asio.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace rtpm::server {

/// HTTP requests and WebSocket connections on one io_context (the caller's; every handler runs
/// on the thread that runs it). Every accepted TCP connection gets an id, never reused, that
/// names it from `accept` to `close` (plain HTTP requests included).
class WsEndpoint {
public:
    using ConnId = uint64_t;
    struct HttpReply {
        int status = 404;
        std::vector<std::pair<std::string, std::string>> headers;
        std::string body;
    };
    /// Addresses of an accepted connection (Asio's to_string() forms; empty if already gone).
    struct Peer {
        std::string remote;  ///< the peer's IP address
        std::string local;   ///< the local IP address the peer connected to
    };
    struct Handlers {
        /// A new TCP connection, before any of its bytes are read: true keeps it, false closes it
        /// at once (answered with a bare 503 if the socket takes it without blocking).
        std::function<bool(ConnId, const Peer&)> accept;
        /// A plain HTTP request (method, path without the query), read whole.
        std::function<HttpReply(ConnId, const std::string& method, const std::string& path)> http;
        /// A WebSocket upgrade: 0 accepts, else the HTTP status to refuse with.
        std::function<int(ConnId, const std::string& path, const std::string& origin)> validate;
        /// open: the WebSocket handshake completed. close: the connection is gone (any kind;
        /// called once for every accepted id, at the latest by the next sweep()).
        std::function<void(ConnId)> open, close;
        std::function<void(ConnId, std::string&& payload, bool binary)> message;
    };

    /// Binds host:port (port 0 = any). Throws std::runtime_error naming what failed.
    WsEndpoint(asio::io_context& io, const std::string& host, uint16_t port, size_t maxMessageBytes,
               size_t maxBodyBytes, Handlers handlers);
    ~WsEndpoint();
    WsEndpoint(const WsEndpoint&) = delete;
    WsEndpoint& operator=(const WsEndpoint&) = delete;

    uint16_t port() const;
    /// Queues a message; false when the connection is gone or not open.
    bool send(ConnId id, const char* data, size_t size, bool binary);
    /// Bytes queued and not yet written to the socket (0 when gone).
    size_t buffered(ConnId id) const;
    /// Starts the WebSocket close handshake (an open WebSocket only).
    void close(ConnId id, uint16_t code, const std::string& reason);
    /// Ends any connection at once, whatever it is doing (its socket is shut down both ways):
    /// for deadlines and evictions, where a peer cannot be trusted to take part in a close.
    void drop(ConnId id);
    /// Calls `close` for connections websocketpp has finished with without telling (plain HTTP
    /// requests end that way). O(connections); the endpoint also sweeps at every accept.
    void sweep();
    /// Connections accepted and not yet gone.
    size_t connections() const;
    /// Stops accepting and starts the close handshake of every connection.
    void shutdown();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rtpm::server
