// Hello and Auth validation: message type, protocol version, the MAC over the nonce and the Hello.
#include "server/handshake.h"

#include "common/core/printable_text.h"

namespace rtpm::server {

HandshakeResult checkHello(const proto::Message& first) {
    HandshakeResult r;
    const auto* hello = std::get_if<proto::Hello>(&first);
    if (!hello) {
        r.reason = proto::RejectReason::ProtocolError;
        r.text = std::string("first message must be Hello, got ") + proto::messageTypeName(proto::typeOf(first));
        return r;
    }
    if (hello->protocolVersion != proto::kProtocolVersion) {
        r.reason = proto::RejectReason::VersionMismatch;
        r.text = "protocol version " + std::to_string(hello->protocolVersion) + ", server speaks " +
                 std::to_string(proto::kProtocolVersion);
        return r;
    }
    r.accepted = true;
    // The name only ever reaches logs: escaped and bounded here, where it enters, so no log line
    // can be forged or flooded through it.
    r.clientName = hello->clientName.empty() ? "unnamed" : printableText(hello->clientName, kMaxLoggedNameBytes);
    return r;
}

HandshakeResult checkAuth(const proto::Message& second, const proto::Hello& hello, const proto::Nonce& nonce,
                          const std::string& token, bool insecureNoToken) {
    HandshakeResult r;
    const auto* auth = std::get_if<proto::Auth>(&second);
    if (!auth) {
        r.reason = proto::RejectReason::ProtocolError;
        r.text = std::string("expected Auth after the Challenge, got ") + proto::messageTypeName(proto::typeOf(second));
        return r;
    }
    if (!insecureNoToken && !proto::macEquals(proto::authMac(token, nonce, hello), auth->mac)) {
        r.reason = proto::RejectReason::BadToken;
        r.text = "authentication failed (the client's token differs from the server's)";
        return r;
    }
    r.accepted = true;
    return r;
}

}  // namespace rtpm::server
