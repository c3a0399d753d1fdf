// The cluster port's connections and their handshakes.
#include "server/peer_connections.h"

namespace rtpm::server {

void PeerConnections::add(std::shared_ptr<net::Connection> c, HandshakeSession session) {
    pending_.emplace(c.get(), Pending{std::move(session), nullptr});
    connections_.insert(std::move(c));
}

PeerConnections::Pending* PeerConnections::pending(const net::Connection& c) {
    auto it = pending_.find(&c);
    return it == pending_.end() ? nullptr : &it->second;
}

std::shared_ptr<net::Connection> PeerConnections::withSession(uint64_t sessionId) const {
    for (const auto& [conn, p] : pending_)
        if (p.session.id() == sessionId) return ownerOf(*conn);
    return nullptr;
}

std::optional<uint64_t> PeerConnections::endPending(const net::Connection& c) {
    auto it = pending_.find(&c);
    if (it == pending_.end()) return std::nullopt;
    const uint64_t id = it->second.session.id();
    if (it->second.delay) it->second.delay->cancel();
    pending_.erase(it);
    return id;
}

bool PeerConnections::remove(const net::Connection& c) {
    for (auto it = connections_.begin(); it != connections_.end(); ++it)
        if (it->get() == &c) {
            connections_.erase(it);
            break;
        }
    return connections_.empty();
}

std::shared_ptr<net::Connection> PeerConnections::ownerOf(const net::Connection& c) const {
    for (const auto& p : connections_)
        if (p.get() == &c) return p;
    return nullptr;
}

void PeerConnections::cancelDelays() {
    for (auto& [conn, p] : pending_)
        if (p.delay) p.delay->cancel();
}

}  // namespace rtpm::server
