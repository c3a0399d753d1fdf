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
/// on the thread that runs it). Connections are named by ids that are never reused.
class WsEndpoint {
public:
    using ConnId = uint64_t;
    struct HttpReply {
        int status = 404;
        std::vector<std::pair<std::string, std::string>> headers;
        std::string body;
    };
    struct Handlers {
        /// A plain HTTP request (method, path without the query).
        std::function<HttpReply(const std::string& method, const std::string& path)> http;
        /// A WebSocket upgrade: 0 accepts, else the HTTP status to refuse with.
        std::function<int(const std::string& path, const std::string& origin, const std::string& host)> validate;
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
    void close(ConnId id, uint16_t code, const std::string& reason);
    /// Stops accepting and starts the close handshake of every connection.
    void shutdown();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rtpm::server
