// Registry of authenticated clients.
#include "server/client_registry.h"

#include <algorithm>

namespace rtpm::server {

ClientId ClientRegistry::add(std::shared_ptr<net::Connection> connection, std::string name, unsigned cores) {
    const ClientId id = nextId_++;
    byConnection_[connection.get()] = id;
    joinOrder_.push_back(id);
    clients_[id] = ClientInfo{id, std::move(connection), std::move(name), cores};
    return id;
}

std::optional<ClientInfo> ClientRegistry::remove(const net::Connection& connection) {
    auto it = byConnection_.find(&connection);
    if (it == byConnection_.end()) return std::nullopt;
    const ClientId id = it->second;
    byConnection_.erase(it);
    joinOrder_.erase(std::find(joinOrder_.begin(), joinOrder_.end(), id));
    auto c = clients_.find(id);
    ClientInfo info = std::move(c->second);
    clients_.erase(c);
    return info;
}

ClientInfo* ClientRegistry::find(const net::Connection& connection) {
    auto it = byConnection_.find(&connection);
    return it == byConnection_.end() ? nullptr : &clients_.at(it->second);
}

ClientInfo* ClientRegistry::find(ClientId id) {
    auto it = clients_.find(id);
    return it == clients_.end() ? nullptr : &it->second;
}

std::string ClientRegistry::describe(const net::Connection& connection) const {
    auto it = byConnection_.find(&connection);
    if (it == byConnection_.end()) return "peer " + connection.peer() + " (not authenticated)";
    const ClientInfo& c = clients_.at(it->second);
    return "client " + std::to_string(c.id) + " (" + c.name + ", " + connection.peer() + ")";
}

}  // namespace rtpm::server
