// Hello validation: message type, protocol version, token.
#include "server/handshake.h"

#include "common/core/printable_text.h"

#include <algorithm>

namespace rtpm::server {

bool tokenMatches(const std::string& expected, const std::string& given) {
    // Every byte is compared whatever differs first.
    const size_t n = std::max(expected.size(), given.size());
    size_t diff = expected.size() ^ given.size();
    for (size_t i = 0; i < n; ++i) {
        const unsigned char a = i < expected.size() ? static_cast<unsigned char>(expected[i]) : 0;
        const unsigned char b = i < given.size() ? static_cast<unsigned char>(given[i]) : 0;
        diff |= static_cast<size_t>(a ^ b);
    }
    return diff == 0;
}

HandshakeResult checkHello(const proto::Message& first, const std::string& token, bool insecureNoToken) {
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
    if (!insecureNoToken && !tokenMatches(token, hello->authToken)) {
        r.reason = proto::RejectReason::BadToken;
        r.text = "wrong token";
        return r;
    }
    r.accepted = true;
    // The name only ever reaches logs: escaped and bounded here, where it enters, so no log line
    // can be forged or flooded through it.
    r.clientName = hello->clientName.empty() ? "unnamed" : printableText(hello->clientName, kMaxLoggedNameBytes);
    return r;
}

}  // namespace rtpm::server
