// Where a server listens: the address a flag names, resolved, and the errors of binding it told
// as what to do (the master's --listen/--port and the viewer's --http share them).
#pragma once

#include <asio.hpp>

#include <cstdint>
#include <string>
#include <utility>

namespace rtpm::net {

/// Splits "HOST:PORT" or "[v6]:PORT" (port 0-65535; an empty HOST is 127.0.0.1), the value of
/// flag `flag` (e.g. "--http"). Throws std::invalid_argument naming the flag, the value and the
/// form expected, e.g. for "8080".
std::pair<std::string, uint16_t> parseListenAddress(const std::string& flag, const std::string& text);

/// The endpoint for listening on `host` (an IP address, or a host name that resolves, e.g.
/// "localhost") and `port`. `what` names the flags in messages ("--listen", "--http").
/// Throws std::runtime_error "--listen foo: expects an IP address or a host name that resolves
/// (…): <resolver's reason>". Blocks on name resolution.
asio::ip::tcp::endpoint listenEndpoint(const std::string& what, const std::string& host, uint16_t port);

/// The message for a failed bind or listen of `endpoint` (given as `what`, e.g. "--port 7411"):
/// a busy port names it and suggests another or port 0; an address that is not this machine's
/// says so; a privileged port says so.
std::string listenErrorText(const std::string& what, const asio::ip::tcp::endpoint& endpoint,
                            const std::error_code& ec);

}  // namespace rtpm::net
