// Listening addresses and bind errors a user can act on (listen_address.h).
#include "proto/net/listen_address.h"

#include <stdexcept>

namespace rtpm::net {

std::pair<std::string, uint16_t> parseListenAddress(const std::string& flag, const std::string& text) {
    auto refuse = [&] {
        throw std::invalid_argument(flag + " " + text +
                                    ": expects HOST:PORT, e.g. 127.0.0.1:8080, 0.0.0.0:8080 for every interface or "
                                    "[::1]:8080 (port 0 = any free port)");
    };
    const size_t colon = text.rfind(':');
    if (colon == std::string::npos) refuse();
    std::string host = text.substr(0, colon);
    const std::string port = text.substr(colon + 1);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
    else if (host.find(':') != std::string::npos) refuse();  // an IPv6 address needs its brackets
    if (host.empty()) host = "127.0.0.1";
    if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
        std::stoul(port) > 65535)
        refuse();
    return {host, static_cast<uint16_t>(std::stoul(port))};
}

asio::ip::tcp::endpoint listenEndpoint(const std::string& what, const std::string& host, uint16_t port) {
    asio::io_context io;
    asio::ip::tcp::resolver resolver(io);
    asio::error_code ec;
    const auto results = resolver.resolve(host, std::to_string(port), asio::ip::resolver_base::passive, ec);
    if (ec || results.empty())
        throw std::runtime_error(what + " " + host +
                                 ": expects an IP address or a host name that resolves (e.g. 127.0.0.1, 0.0.0.0 "
                                 "for every interface, ::, localhost): " +
                                 (ec ? ec.message() : std::string("no address")));
    // A name may resolve to several addresses (localhost: ::1 and 127.0.0.1); IPv4 first, as the
    // default 127.0.0.1 and most clients' "localhost" reach it.
    for (const auto& r : results)
        if (r.endpoint().address().is_v4()) return r.endpoint();
    return results.begin()->endpoint();
}

std::string listenErrorText(const std::string& what, const asio::ip::tcp::endpoint& endpoint,
                            const std::error_code& ec) {
    const std::string address =
        (endpoint.address().is_v6() ? "[" + endpoint.address().to_string() + "]" : endpoint.address().to_string()) +
        ":" + std::to_string(endpoint.port());
    if (ec == asio::error::address_in_use)
        return what + ": port " + std::to_string(endpoint.port()) + " on " + endpoint.address().to_string() +
               " is already in use (another rtpm-server?): choose another port, or port 0 for any free one";
    if (ec == std::errc::address_not_available)
        return what + ": cannot listen on " + address + ": the address is not one of this machine's (" +
               ec.message() + "); use one of its addresses, or 0.0.0.0 for every interface";
    if (ec == asio::error::access_denied || ec == std::errc::permission_denied)
        return what + ": cannot listen on " + address + ": " + ec.message() +
               " (ports below 1024 need privileges: choose a port above 1023)";
    return what + ": cannot listen on " + address + ": " + ec.message();
}

}  // namespace rtpm::net
