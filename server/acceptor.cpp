// The listening socket and its TLS context; accepted sockets go to the peers room.
#include "server/acceptor.h"

#include <cstdio>
#include <stdexcept>

#include "proto/net/listen_address.h"

namespace rtpm::server {

namespace {

std::unique_ptr<asio::ssl::context> makeTls(const std::string& cert, const std::string& key) {
    if (cert.empty() != key.empty()) throw std::invalid_argument("--tls-cert and --tls-key go together");
    if (cert.empty()) return nullptr;
    auto tls = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_server);
    tls->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                     asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1);
    asio::error_code ec;
    tls->use_certificate_chain_file(cert, ec);
    if (ec) throw std::invalid_argument("--tls-cert " + cert + ": " + ec.message());
    tls->use_private_key_file(key, asio::ssl::context::pem, ec);
    if (ec) throw std::invalid_argument("--tls-key " + key + ": " + ec.message());
    return tls;
}

}  // namespace

Acceptor::Acceptor(asio::io_context& io, const std::string& address, uint16_t port, const std::string& tlsCert,
                   const std::string& tlsKey, OnSocket onSocket)
    : tls_(makeTls(tlsCert, tlsKey)), acceptor_(io), onSocket_(std::move(onSocket)) {
    const asio::ip::tcp::endpoint ep = net::listenEndpoint("--listen", address, port);
    asio::error_code ec;
    acceptor_.open(ep.protocol(), ec);
    if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor_.bind(ep, ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) throw std::runtime_error(net::listenErrorText("--port " + std::to_string(port), ep, ec));
}

void Acceptor::start() {
    acceptor_.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket sock) {
        if (ec) {
            if (ec != asio::error::operation_aborted && !closed_) {
                std::fprintf(stderr, "rtpm-server: accept failed: %s\n", ec.message().c_str());
                start();
            }
            return;
        }
        if (closed_) return;
        onSocket_(std::move(sock));
        start();
    });
}

void Acceptor::close() {
    closed_ = true;
    asio::error_code ec;
    acceptor_.close(ec);
}

void Acceptor::refuseNow(asio::ip::tcp::socket& sock, proto::RejectReason reason, const std::string& text) {
    asio::error_code ec;
    sock.non_blocking(true, ec);
    const auto bytes = proto::encode(proto::Reject{reason, text.substr(0, proto::kMaxTextBytes)});
    sock.write_some(asio::buffer(bytes), ec);  // a fresh socket's send buffer takes it whole
    sock.shutdown(asio::ip::tcp::socket::shutdown_send, ec);
    // Read what the peer already sent (its Hello) so the close ends with FIN, not a reset that
    // could destroy the Reject before the peer reads it.
    uint8_t drain[4096];
    sock.read_some(asio::buffer(drain), ec);
    sock.close(ec);
}

}  // namespace rtpm::server
