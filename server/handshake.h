// The master's side of the handshake: what a new peer's first message must be to join.
#pragma once

#include <string>

#include "proto/messages.h"

namespace rtpm::server {

/// Bytes of a client name kept for logs (after escaping; see printableText).
constexpr size_t kMaxLoggedNameBytes = 64;

/// Outcome of a peer's first message.
struct HandshakeResult {
    bool accepted = false;
    proto::RejectReason reason = proto::RejectReason::ProtocolError;  ///< when refused
    std::string text;        ///< when refused: what to tell the peer and the log
    std::string clientName;  ///< when accepted: the name to log ("unnamed" if empty)
};

/// Decides whether `first` admits its peer: it must be a Hello of this protocol version whose
/// token matches `token` (compared in constant time), unless `insecureNoToken`. Pure.
HandshakeResult checkHello(const proto::Message& first, const std::string& token, bool insecureNoToken);

/// Constant-time equality of a secret and a candidate: the time depends only on their lengths.
bool tokenMatches(const std::string& expected, const std::string& given);

}  // namespace rtpm::server
