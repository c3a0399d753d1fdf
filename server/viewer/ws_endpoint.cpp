// websocketpp server on the caller's io_context (built as C++17: see ws_endpoint.h).
#include "server/viewer/ws_endpoint.h"

#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <map>
#include <stdexcept>

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
        HttpReply r = m.h.http(c->get_request().get_method(), path);
        for (const auto& [k, v] : r.headers) c->append_header(k, v);
        c->set_body(std::move(r.body));
        c->set_status(static_cast<websocketpp::http::status_code::value>(r.status));
    });
    ws.set_validate_handler([&m](Hdl hdl) {
        WsServer::connection_ptr c = m.ws.get_con_from_hdl(hdl);
        const int status = m.h.validate(c->get_resource(), c->get_request_header("Origin"), c->get_request_header("Host"));
        if (status == 0) return true;
        c->set_status(static_cast<websocketpp::http::status_code::value>(status));
        return false;
    });
    ws.set_open_handler([&m](Hdl hdl) {
        const ConnId id = m.nextId++;
        m.byId.emplace(id, hdl);
        m.byHdl.emplace(hdl, id);
        if (m.h.open) m.h.open(id);
    });
    ws.set_close_handler([&m](Hdl hdl) { m.forget(hdl); });
    ws.set_fail_handler([&m](Hdl hdl) { m.forget(hdl); });
    ws.set_message_handler([&m](Hdl hdl, WsServer::message_ptr msg) {
        auto it = m.byHdl.find(hdl);
        if (it == m.byHdl.end()) return;
        m.h.message(it->second, std::move(msg->get_raw_payload()),
                    msg->get_opcode() != websocketpp::frame::opcode::text);
    });
    asio::error_code ec;
    asio::ip::address addr = asio::ip::make_address(host, ec);
    if (ec) throw std::runtime_error("'" + host + "' is not an IP address");
    ws.listen(asio::ip::tcp::endpoint(addr, port), ec);
    if (ec) throw std::runtime_error("cannot listen on " + host + ":" + std::to_string(port) + ": " + ec.message());
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

void WsEndpoint::shutdown() {
    asio::error_code ec;
    impl_->ws.stop_listening(ec);
    for (const auto& [id, hdl] : impl_->byId) {
        asio::error_code e;
        impl_->ws.close(hdl, websocketpp::close::status::going_away, "server stopping", e);
    }
}

}  // namespace rtpm::server
