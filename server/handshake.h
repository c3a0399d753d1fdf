// The master's side of the handshake: Hello → Challenge → Auth → Welcome (PROTOCOL.md §7).
#pragma once

#include <string>

#include "proto/auth.h"
#include "proto/messages.h"

namespace rtpm::server {

/// Bytes of a client name kept for logs (after escaping; see printableText).
constexpr size_t kMaxLoggedNameBytes = 64;

/// Outcome of a handshake step.
struct HandshakeResult {
    bool accepted = false;
    proto::RejectReason reason = proto::RejectReason::ProtocolError;  ///< when refused
    std::string text;        ///< when refused: what to tell the peer and the log
    std::string clientName;  ///< checkHello accepted: the name to log ("unnamed" if empty), escaped
};

/// Step 1: `first` must be a Hello of this protocol version. Pure.
HandshakeResult checkHello(const proto::Message& first);

/// Step 2: `second` must be an Auth whose MAC is authMac(token, nonce, hello), compared in
/// constant time; with `insecureNoToken` any Auth is accepted. Pure.
HandshakeResult checkAuth(const proto::Message& second, const proto::Hello& hello, const proto::Nonce& nonce,
                          const std::string& token, bool insecureNoToken);

}  // namespace rtpm::server
