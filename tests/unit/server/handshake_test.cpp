// Handshake steps: Hello (type, version, name escaping), Auth (HMAC over nonce and Hello).
#include "server/handshake.h"

#include <gtest/gtest.h>

namespace rtpm::server {
namespace {

const std::string kToken = "5f2c8d0a9b7e4c1f3a6d8e2b0c9f7a14";

proto::Hello hello() {
    proto::Hello h;
    h.protocolVersion = proto::kProtocolVersion;
    h.clientName = "w1";
    h.cores = 2;
    return h;
}

TEST(Handshake, HelloOfThisVersionIsAccepted) {
    HandshakeResult r = checkHello(hello());
    EXPECT_TRUE(r.accepted);
    EXPECT_EQ(r.clientName, "w1");
}

TEST(Handshake, WrongVersionOrTypeIsRefusedWithItsReason) {
    proto::Hello old = hello();
    old.protocolVersion = proto::kProtocolVersion + 1;
    EXPECT_EQ(checkHello(old).reason, proto::RejectReason::VersionMismatch);
    HandshakeResult notHello = checkHello(proto::Stats{});
    EXPECT_FALSE(notHello.accepted);
    EXPECT_EQ(notHello.reason, proto::RejectReason::ProtocolError);
    proto::Hello unnamed = hello();
    unnamed.clientName.clear();
    EXPECT_EQ(checkHello(unnamed).clientName, "unnamed");
}

// A client built from other settings rows (a knob more, another type or limit) would read the
// Settings message differently: refused at the Hello, as another version is, naming both layouts.
TEST(Handshake, OtherSettingsRowsAreRefusedAsAVersionMismatch) {
    proto::Hello other = hello();
    other.settingsLayout = proto::kSettingsLayout ^ 1;
    const HandshakeResult r = checkHello(other);
    EXPECT_FALSE(r.accepted);
    EXPECT_EQ(r.reason, proto::RejectReason::VersionMismatch);
    EXPECT_NE(r.text.find("settings rows"), std::string::npos) << r.text;
    EXPECT_TRUE(checkHello(hello()).accepted);
}

TEST(Handshake, AuthWithTheTokensMacIsAccepted) {
    const proto::Nonce n = proto::makeNonce();
    const proto::Hello h = hello();
    EXPECT_TRUE(checkAuth(proto::Auth{proto::authMac(kToken, n, h)}, h, n, kToken, false).accepted);
}

TEST(Handshake, WrongTokenIsRefusedAsAuthenticationFailure) {
    const proto::Nonce n = proto::makeNonce();
    const proto::Hello h = hello();
    std::string wrong = kToken;
    wrong.back() = wrong.back() == '4' ? '5' : '4';
    HandshakeResult r = checkAuth(proto::Auth{proto::authMac(wrong, n, h)}, h, n, kToken, false);
    EXPECT_FALSE(r.accepted);
    EXPECT_EQ(r.reason, proto::RejectReason::BadToken);
    EXPECT_EQ(checkAuth(proto::Auth{}, h, n, kToken, false).reason, proto::RejectReason::BadToken);
    EXPECT_EQ(checkAuth(proto::Hello{}, h, n, kToken, false).reason, proto::RejectReason::ProtocolError);
}

TEST(Handshake, MacIsBoundToTheNonceAndEveryHelloField) {
    // A recorded Auth is worth nothing on a connection with another nonce, or for another Hello.
    const proto::Nonce n1 = proto::makeNonce(), n2 = proto::makeNonce();
    ASSERT_NE(n1, n2);
    const proto::Hello h = hello();
    const proto::Auth recorded{proto::authMac(kToken, n1, h)};
    EXPECT_FALSE(checkAuth(recorded, h, n2, kToken, false).accepted);
    proto::Hello moreCores = h;
    moreCores.cores = 64;
    EXPECT_FALSE(checkAuth(recorded, moreCores, n1, kToken, false).accepted);
    proto::Hello otherName = h;
    otherName.clientName = "w2";
    EXPECT_FALSE(checkAuth(recorded, otherName, n1, kToken, false).accepted);
}

TEST(Handshake, MacIsHmacSha256OfTheDocumentedBytes) {
    // PROTOCOL.md §7: HMAC-SHA256(token, str("rtpm client auth v3") ‖ nonce ‖ u16 version ‖
    // u32 cores ‖ str(name) ‖ u64 settingsLayout). Reference computed with `openssl dgst -sha256
    // -mac HMAC` over the same bytes (the nonce is 32 × 0x01, version 3, cores 2, name "w1",
    // layout 0x0123456789abcdef, token "key").
    proto::Nonce n;
    n.fill(0x01);
    proto::Hello h = hello();
    h.protocolVersion = 3;
    h.settingsLayout = 0x0123456789abcdefull;
    const proto::Mac mac = proto::authMac("key", n, h);
    std::string hex;
    for (uint8_t b : mac) {
        char buf[3];
        std::snprintf(buf, sizeof buf, "%02x", b);
        hex += buf;
    }
    EXPECT_EQ(hex, "7d98d91beecbd8e472924c98562d7abfb353b3ad0283758418ab1b5da1454bf6");
}

TEST(Handshake, InsecureModeAcceptsAnyAuth) {
    const proto::Nonce n = proto::makeNonce();
    EXPECT_TRUE(checkAuth(proto::Auth{}, hello(), n, "", true).accepted);
}

TEST(Handshake, ClientNamesCannotForgeOrFloodLogLines) {
    // Before: a name with newlines wrote whole fake lines into the master's log.
    proto::Hello h = hello();
    h.clientName = "w1\nrtpm-server: client 7 (admin, 10.0.0.1, 64 cores) joined\r\x1b[2J" + std::string(200, 'x');
    HandshakeResult r = checkHello(h);
    ASSERT_TRUE(r.accepted);
    for (unsigned char c : r.clientName) EXPECT_FALSE(c < 0x20 || c == 0x7F) << r.clientName;
    EXPECT_NE(r.clientName.find("w1\\nrtpm-server"), std::string::npos) << r.clientName;
    EXPECT_LE(r.clientName.size(), kMaxLoggedNameBytes + 32);
}

TEST(HandshakeSession, HelloThenTheTokensAuthJoins) {
    HandshakeSession s(7, "10.0.0.1");
    EXPECT_FALSE(s.awaitingAuth());
    EXPECT_EQ(s.onMessage(hello(), kToken, false).action, HandshakeStep::Action::Challenge);
    EXPECT_TRUE(s.awaitingAuth());
    EXPECT_EQ(s.name(), "w1");
    EXPECT_EQ(s.cores(), 2u);
    const proto::Auth auth{proto::authMac(kToken, s.nonce(), hello())};
    EXPECT_EQ(s.onMessage(auth, kToken, false).action, HandshakeStep::Action::Authenticated);
}

TEST(HandshakeSession, EachNonceIsFreshSoAnOldAnswerFails) {
    HandshakeSession first(1, "a"), second(2, "a");
    first.onMessage(hello(), kToken, false);
    second.onMessage(hello(), kToken, false);
    EXPECT_NE(first.nonce(), second.nonce());
    const proto::Auth replayed{proto::authMac(kToken, first.nonce(), hello())};
    EXPECT_EQ(second.onMessage(replayed, kToken, false).action, HandshakeStep::Action::RefuseLater);
}

TEST(HandshakeSession, WrongTokenIsAnsweredLaterAndThenEverythingIgnored) {
    HandshakeSession s(1, "a");
    s.onMessage(hello(), kToken, false);
    const HandshakeStep bad = s.onMessage(proto::Auth{}, kToken, false);
    EXPECT_EQ(bad.action, HandshakeStep::Action::RefuseLater);
    EXPECT_EQ(bad.reason, proto::RejectReason::BadToken);
    EXPECT_FALSE(s.awaitingAuth());
    EXPECT_EQ(s.onMessage(proto::Auth{}, kToken, false).action, HandshakeStep::Action::Ignore);
}

TEST(HandshakeSession, AuthBeforeHelloOrAnOldVersionIsRefusedAtOnce) {
    HandshakeSession early(1, "a");
    const HandshakeStep r = early.onMessage(proto::Auth{}, kToken, false);
    EXPECT_EQ(r.action, HandshakeStep::Action::Refuse);
    EXPECT_EQ(r.reason, proto::RejectReason::ProtocolError);
    proto::Hello old = hello();
    old.protocolVersion = proto::kProtocolVersion + 1;
    HandshakeSession s(2, "a");
    EXPECT_EQ(s.onMessage(old, kToken, false).reason, proto::RejectReason::VersionMismatch);
    EXPECT_EQ(s.onMessage(hello(), kToken, false).action, HandshakeStep::Action::Ignore);
    HandshakeSession twice(3, "a");
    twice.onMessage(hello(), kToken, false);
    EXPECT_EQ(twice.onMessage(hello(), kToken, false).action, HandshakeStep::Action::Refuse);
}

TEST(TokenStrength, ShortOrRepetitiveTokensAreRefusedRandomOnesAccepted) {
    EXPECT_TRUE(proto::tokenWeakness("s3cret").has_value());                 // 6 characters
    EXPECT_TRUE(proto::tokenWeakness("ab").has_value());
    EXPECT_TRUE(proto::tokenWeakness(std::string(40, 'a')).has_value());     // 0 bits
    EXPECT_TRUE(proto::tokenWeakness("cluster-test-token").has_value());     // ≈ 58 bits
    EXPECT_TRUE(proto::tokenWeakness(std::string(300, 'x') + "0123456789abcdef").has_value());  // too long
    EXPECT_FALSE(proto::tokenWeakness(kToken).has_value());                  // `openssl rand -hex 16`
    EXPECT_NE(proto::tokenWeakness("ab")->find("openssl rand"), std::string::npos);
    EXPECT_NEAR(proto::tokenEntropyBits("0123456789abcdef"), 64.0, 1e-9);
    EXPECT_EQ(proto::tokenEntropyBits("aaaa"), 0.0);
}

TEST(TokenStrength, RunsAndRepeatedRunsAreRefusedThoughEveryCharacterDiffers) {
    for (const char* run : {"abcdefghijklmnop", "0123456789abcdef", "ABCDEFGHIJKLMNOP", "ponmlkjihgfedcba",
                            "acegikmoqsuwy024", "0123456789abcdef0123456789abcdef",
                            "abcdefghijklmnopqrstuvwxyz012345"}) {
        auto weak = proto::tokenWeakness(run);
        ASSERT_TRUE(weak.has_value()) << run;
        EXPECT_NE(weak->find("run"), std::string::npos) << *weak;
    }
    EXPECT_EQ(proto::tokenStepEntropyBits("abcdefghijklmnop"), 0.0);
    // Random tokens pass: 32 hex digits, and 16 distinct characters of a larger alphabet.
    EXPECT_FALSE(proto::tokenWeakness("3e8a1f5c90d27b64e1c8a3f05d9b27e6").has_value());
    EXPECT_FALSE(proto::tokenWeakness("aZ3$kq9!Lm2@xW7#").has_value());
    EXPECT_GT(proto::tokenStepEntropyBits(kToken), 90.0);
}

}  // namespace
}  // namespace rtpm::server
