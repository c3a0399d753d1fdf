// Every connection of the cluster port, authenticated or not, and the handshake session of each
// one still in its handshake: the connection manager of Asio's server examples.
#pragma once

#include <asio.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "proto/net/connection.h"
#include "server/handshake.h"

namespace rtpm::server {

/// Owns the connections (the set keeps each alive until it closes). Lives on the I/O thread; not
/// thread-safe.
class PeerConnections {
public:
    /// A connection in its handshake (server/admission.h holds its budgets).
    struct Pending {
        HandshakeSession session;
        std::shared_ptr<asio::steady_timer> delay;  ///< a wrong token's answer waits on this
    };

    /// The id the next connection's handshake session gets (admission counts by it).
    uint64_t nextId() { return nextId_++; }
    /// A new connection, in its handshake with `session`.
    void add(std::shared_ptr<net::Connection> c, HandshakeSession session);
    /// The handshake of `c`, or null (authenticated, or ended).
    Pending* pending(const net::Connection& c);
    /// The connection whose handshake session is `sessionId`, or null.
    std::shared_ptr<net::Connection> withSession(uint64_t sessionId) const;
    /// Ends the handshake of `c` (its answer delay cancelled); its session id, or nullopt if it
    /// had none.
    std::optional<uint64_t> endPending(const net::Connection& c);
    /// `c` closed: forgotten. Returns true when no connection is left.
    bool remove(const net::Connection& c);
    /// The owning pointer of `c`, or null once it closed.
    std::shared_ptr<net::Connection> ownerOf(const net::Connection& c) const;
    /// Cancels every handshake's answer delay (the port closes).
    void cancelDelays();

    const std::set<std::shared_ptr<net::Connection>>& all() const { return connections_; }
    bool empty() const { return connections_.empty(); }

private:
    std::set<std::shared_ptr<net::Connection>> connections_;  // every peer, authenticated or not
    std::map<const net::Connection*, Pending> pending_;
    uint64_t nextId_ = 1;
};

}  // namespace rtpm::server
