// Hello and Auth validation (message type, protocol version, the MAC over the nonce and the Hello)
// and the per-connection handshake state machine built on them.
#include "server/handshake.h"

#include <cstdio>

#include "common/core/printable_text.h"

namespace rtpm::server {

namespace {

std::string hex64(uint64_t v) {
    char buf[19];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

}  // namespace

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
    if (hello->settingsLayout != proto::kSettingsLayout) {
        r.reason = proto::RejectReason::VersionMismatch;
        r.text = "the client's settings rows (fingerprint " + hex64(hello->settingsLayout) +
                 ") differ from the server's (" + hex64(proto::kSettingsLayout) +
                 "): build both from the same common/core/knobs.h";
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

HandshakeStep HandshakeSession::refuse(proto::RejectReason reason, std::string text) {
    refused_ = true;
    return {HandshakeStep::Action::Refuse, reason, std::move(text)};
}

HandshakeStep HandshakeSession::onMessage(const proto::Message& m, const std::string& token, bool insecureNoToken) {
    if (refused_) return {};
    if (!hello_) {
        HandshakeResult h = checkHello(m);
        if (!h.accepted) return refuse(h.reason, std::move(h.text));
        hello_ = std::get<proto::Hello>(m);
        name_ = std::move(h.clientName);
        nonce_ = proto::makeNonce();
        return {HandshakeStep::Action::Challenge, {}, {}};
    }
    HandshakeResult h = checkAuth(m, *hello_, nonce_, token, insecureNoToken);
    if (!h.accepted && h.reason == proto::RejectReason::BadToken) {
        refused_ = true;
        return {HandshakeStep::Action::RefuseLater, h.reason, std::move(h.text)};
    }
    if (!h.accepted) return refuse(h.reason, std::move(h.text));
    return {HandshakeStep::Action::Authenticated, {}, {}};
}

}  // namespace rtpm::server
