// websocketpp server on the caller's io_context (built as C++17: see ws_endpoint.h).
#include "server/viewer/ws_endpoint.h"

#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <map>
#include <stdexcept>

#include "proto/net/listen_address.h"

namespace rtpm::server {

namespace {
using WsServer = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;
}  // namespace

struct WsEndpoint::Impl {
    WsServer ws;
    Handlers h;
    uint16_t boundPort = 0;
    ConnId nextId = 1;
    std::map<ConnId, Hdl> byId;
    std::map<Hdl, ConnId, std::owner_less<Hdl>> byHdl;

    WsServer::connection_ptr con(ConnId id) const {
        auto it = byId.find(id);
        if (it == byId.end()) return nullptr;
        asio::error_code ec;
        auto c = const_cast<WsServer&>(ws).get_con_from_hdl(it->second, ec);
        return ec ? nullptr : c;
    }

    void forget(Hdl hdl) {
        auto it = byHdl.find(hdl);
        if (it == byHdl.end()) return;
        const ConnId id = it->second;
        byHdl.erase(it);
        byId.erase(id);
        if (h.close) h.close(id);
    }

    // A new TCP connection (websocketpp's pre-init: accepted, nothing read yet).
    void accepted(Hdl hdl) {
        sweep();
        asio::error_code ec;
        WsServer::connection_ptr c = ws.get_con_from_hdl(hdl, ec);
        if (ec || !c) return;
        asio::ip::tcp::socket& sock = c->get_raw_socket();
        // An IPv4 peer of a dual-stack socket as IPv4: the form a browser names in its Origin.
        auto text = [](const asio::ip::address& a) {
            if (a.is_v6() && a.to_v6().is_v4_mapped())
                return asio::ip::make_address_v4(asio::ip::v4_mapped, a.to_v6()).to_string();
            return a.to_string();
        };
        Peer peer;
        const auto remote = sock.remote_endpoint(ec);
        if (!ec) peer.remote = text(remote.address());
        const auto local = sock.local_endpoint(ec);
        if (!ec) peer.local = text(local.address());
        const ConnId id = nextId++;
        if (!peer.remote.empty() && h.accept(id, peer)) {
            byId.emplace(id, hdl);
            byHdl.emplace(hdl, id);
            return;
        }
        // Refused: a bare answer if the fresh socket's buffer takes it, then both ways shut, so
        // websocketpp's first read ends the connection (a flood costs one small write each).
        static const char kRefused[] =
            "HTTP/1.1 503 Service Unavailable\r\nConnection: close\r\nContent-Length: 0\r\n\r\n";
        sock.non_blocking(true, ec);
        sock.write_some(asio::buffer(kRefused, sizeof kRefused - 1), ec);
        sock.shutdown(asio::ip::tcp::socket::shutdown_both, ec);
    }

    void sweep() {
        for (auto it = byId.begin(); it != byId.end();) {
            if (!it->second.expired()) {
                ++it;
                continue;
            }
            const ConnId id = it->first;
            byHdl.erase(it->second);
            it = byId.erase(it);
            if (h.close) h.close(id);
        }
    }
};

WsEndpoint::WsEndpoint(asio::io_context& io, const std::string& host, uint16_t port, size_t maxMessageBytes,
                       size_t maxBodyBytes, Handlers handlers)
    : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.h = std::move(handlers);
    WsServer& ws = m.ws;
    ws.clear_access_channels(websocketpp::log::alevel::all);
    ws.clear_error_channels(websocketpp::log::elevel::all);
    ws.init_asio(&io);
    ws.set_reuse_addr(true);
    ws.set_max_message_size(maxMessageBytes);
    ws.set_max_http_body_size(maxBodyBytes);
    ws.set_listen_backlog(16);
    ws.set_http_handler([&m](Hdl hdl) {
        WsServer::connection_ptr c = m.ws.get_con_from_hdl(hdl);
        std::string path = c->get_resource();
        path = path.substr(0, path.find_first_of("?#"));
        auto it = m.byHdl.find(hdl);
        HttpReply r = m.h.http(it == m.byHdl.end() ? 0 : it->second, c->get_request().get_method(), path);
        for (const auto& [k, v] : r.headers) c->append_header(k, v);
        c->set_body(std::move(r.body));
        c->set_status(static_cast<websocketpp::http::status_code::value>(r.status));
    });
    ws.set_tcp_pre_init_handler([&m](Hdl hdl) { m.accepted(hdl); });
    ws.set_validate_handler([&m](Hdl hdl) {
        WsServer::connection_ptr c = m.ws.get_con_from_hdl(hdl);
        auto it = m.byHdl.find(hdl);
        if (it == m.byHdl.end()) return false;
        const int status = m.h.validate(it->second, c->get_resource(), c->get_request_header("Origin"));
        if (status == 0) return true;
        c->set_status(static_cast<websocketpp::http::status_code::value>(status));
        return false;
    });
    ws.set_open_handler([&m](Hdl hdl) {
        auto it = m.byHdl.find(hdl);
        if (it != m.byHdl.end() && m.h.open) m.h.open(it->second);
    });
    ws.set_close_handler([&m](Hdl hdl) { m.forget(hdl); });
    ws.set_fail_handler([&m](Hdl hdl) { m.forget(hdl); });
    ws.set_message_handler([&m](Hdl hdl, WsServer::message_ptr msg) {
        auto it = m.byHdl.find(hdl);
        if (it == m.byHdl.end()) return;
        m.h.message(it->second, std::move(msg->get_raw_payload()),
                    msg->get_opcode() != websocketpp::frame::opcode::text);
    });
    const asio::ip::tcp::endpoint endpoint = net::listenEndpoint("--http", host, port);
    asio::error_code ec;
    ws.listen(endpoint, ec);
    if (ec) throw std::runtime_error(net::listenErrorText("--http " + host + ":" + std::to_string(port), endpoint, ec));
    auto ep = ws.get_local_endpoint(ec);
    if (ec) throw std::runtime_error(ec.message());
    m.boundPort = ep.port();
    ws.start_accept(ec);
    if (ec) throw std::runtime_error("cannot accept: " + ec.message());
}

WsEndpoint::~WsEndpoint() = default;

uint16_t WsEndpoint::port() const { return impl_->boundPort; }

bool WsEndpoint::send(ConnId id, const char* data, size_t size, bool binary) {
    auto c = impl_->con(id);
    if (!c || c->get_state() != websocketpp::session::state::open) return false;
    return !c->send(data, size, binary ? websocketpp::frame::opcode::binary : websocketpp::frame::opcode::text);
}

size_t WsEndpoint::buffered(ConnId id) const {
    auto c = impl_->con(id);
    return c ? c->get_buffered_amount() : 0;
}

void WsEndpoint::close(ConnId id, uint16_t code, const std::string& reason) {
    auto c = impl_->con(id);
    if (!c) return;
    asio::error_code ec;
    c->close(code, reason, ec);
}

void WsEndpoint::drop(ConnId id) {
    auto c = impl_->con(id);
    if (!c) return;
    asio::error_code ec;
    c->get_raw_socket().shutdown(asio::ip::tcp::socket::shutdown_both, ec);
}

void WsEndpoint::sweep() { impl_->sweep(); }

size_t WsEndpoint::connections() const { return impl_->byId.size(); }

void WsEndpoint::shutdown() {
    asio::error_code ec;
    impl_->ws.stop_listening(ec);
    for (const auto& [id, hdl] : impl_->byId) {
        asio::error_code e;
        impl_->ws.close(hdl, websocketpp::close::status::going_away, "server stopping", e);
    }
}

}  // namespace rtpm::server
