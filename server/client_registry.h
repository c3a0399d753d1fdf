// The master's registry of authenticated clients: ids, names, connections, join order.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "proto/net/connection.h"
#include "server/assignment.h"

namespace rtpm::server {

/// An authenticated client.
struct ClientInfo {
    ClientId id = 0;
    std::shared_ptr<net::Connection> connection;
    std::string name;
    unsigned cores = 0;
};

/// Authenticated clients by id and by connection, in join order. Ids are never reused.
/// Lives on the I/O thread; not thread-safe.
class ClientRegistry {
public:
    /// Registers an authenticated connection; returns its new id.
    ClientId add(std::shared_ptr<net::Connection> connection, std::string name, unsigned cores);
    /// Forgets the client of `connection`; returns its info, or nullopt if it was not a client.
    std::optional<ClientInfo> remove(const net::Connection& connection);

    /// The client of `connection`, or null for an unauthenticated peer.
    ClientInfo* find(const net::Connection& connection);
    ClientInfo* find(ClientId id);
    /// "client 3 (name, addr:port)" or "peer addr:port (not authenticated)", for log lines.
    std::string describe(const net::Connection& connection) const;

    /// Client ids in the order they joined (the assignment's deal order).
    const std::vector<ClientId>& joinOrder() const { return joinOrder_; }
    const std::map<ClientId, ClientInfo>& clients() const { return clients_; }
    size_t size() const { return clients_.size(); }
    bool empty() const { return clients_.empty(); }

private:
    std::map<ClientId, ClientInfo> clients_;
    std::map<const net::Connection*, ClientId> byConnection_;
    std::vector<ClientId> joinOrder_;
    ClientId nextId_ = 1;
};

}  // namespace rtpm::server
