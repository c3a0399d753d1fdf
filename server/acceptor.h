// The master's listening socket: bind, the TLS context, the accept loop and the cheap refusal.
#pragma once

#include <asio.hpp>
#include <asio/ssl.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "proto/messages.h"

namespace rtpm::server {

/// Binds `address:port` at construction and hands every accepted socket to `onSocket` until
/// close(). With a certificate and key, connections run over TLS (tls() is the context).
/// Lives on the I/O thread; not thread-safe.
class Acceptor {
public:
    using OnSocket = std::function<void(asio::ip::tcp::socket)>;

    /// Throws std::invalid_argument for a bad certificate or key (or only one of them) and
    /// std::runtime_error when it cannot listen (naming the address and the fix: listen_address.h).
    Acceptor(asio::io_context& io, const std::string& address, uint16_t port, const std::string& tlsCert,
             const std::string& tlsKey, OnSocket onSocket);

    uint16_t port() const { return acceptor_.local_endpoint().port(); }
    /// The TLS context every connection uses, or null without TLS.
    asio::ssl::context* tls() const { return tls_.get(); }

    void start();
    /// Sockets accepted from now on are closed and the loop ends; the port stays bound.
    void stopAccepting() { closed_ = true; }
    /// Stops accepting and closes the listening socket.
    void close();

    /// Tells a peer it is refused without making a Connection of it (a flood costs one small write).
    static void refuseNow(asio::ip::tcp::socket& sock, proto::RejectReason reason, const std::string& text);

private:
    std::unique_ptr<asio::ssl::context> tls_;
    asio::ip::tcp::acceptor acceptor_;
    OnSocket onSocket_;
    bool closed_ = false;
};

}  // namespace rtpm::server
