// The master's side of the handshake: Hello → Challenge → Auth → Welcome (PROTOCOL.md §7), as
// pure checks and one state machine per connection (no sockets, no clock).
#pragma once

#include <cstdint>
#include <optional>
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

/// What the master does after a message of a connection in its handshake.
struct HandshakeStep {
    enum class Action {
        Challenge,      ///< send Challenge{nonce}; only an Auth may follow
        Refuse,         ///< send Reject{reason, text} and close
        RefuseLater,    ///< wrong token: Reject{BadToken, text} after a delay (guessing is slowed)
        Authenticated,  ///< the client joins
        Ignore,         ///< its refusal is already on the way
    };
    Action action = Action::Ignore;
    proto::RejectReason reason = proto::RejectReason::ProtocolError;  ///< Refuse, RefuseLater
    std::string text;                                                 ///< Refuse, RefuseLater
};

/// One connection's way through the handshake: Hello, then Auth, then either joined or refused.
/// Owns what the steps learn (the Hello, the nonce sent, the escaped name). Pure: the caller
/// sends, delays and closes. Not thread-safe.
class HandshakeSession {
public:
    /// `id` is the admission id of the connection; `source` its Admission::sourceKey.
    HandshakeSession(uint64_t id, std::string source) : id_(id), source_(std::move(source)) {}

    /// Feeds the next message: the first must be a Hello (→ Challenge with a fresh nonce), the
    /// second an Auth whose MAC is authMac(token, nonce, hello) (→ Authenticated; a wrong MAC →
    /// RefuseLater). After a refusal every message is ignored.
    HandshakeStep onMessage(const proto::Message& m, const std::string& token, bool insecureNoToken);

    /// The step of a refusal decided outside the state machine (rate limit, capacity).
    HandshakeStep refuse(proto::RejectReason reason, std::string text);

    uint64_t id() const { return id_; }
    const std::string& source() const { return source_; }
    /// The Hello arrived: the next message is the answer to the Challenge.
    bool awaitingAuth() const { return hello_.has_value() && !refused_; }
    /// Escaped client name (after the Hello), for logs.
    const std::string& name() const { return name_; }
    /// Cores the client announced (after the Hello).
    unsigned cores() const { return hello_ ? hello_->cores : 0; }
    const proto::Nonce& nonce() const { return nonce_; }

private:
    uint64_t id_;
    std::string source_;
    std::optional<proto::Hello> hello_;
    proto::Nonce nonce_{};
    std::string name_;
    bool refused_ = false;
};

}  // namespace rtpm::server
