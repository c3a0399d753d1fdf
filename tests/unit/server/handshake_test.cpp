// Hello validation: type, version, token; constant-time token comparison.
#include "server/handshake.h"

#include <gtest/gtest.h>

namespace rtpm::server {
namespace {

proto::Hello hello(std::string token) {
    proto::Hello h;
    h.protocolVersion = proto::kProtocolVersion;
    h.authToken = std::move(token);
    h.clientName = "w1";
    h.cores = 2;
    return h;
}

TEST(Handshake, HelloWithTheTokenIsAccepted) {
    HandshakeResult r = checkHello(hello("s3cret-token"), "s3cret-token", false);
    EXPECT_TRUE(r.accepted);
    EXPECT_EQ(r.clientName, "w1");
}

TEST(Handshake, WrongTokenVersionOrTypeIsRefusedWithItsReason) {
    EXPECT_EQ(checkHello(hello("s3cret-tokex"), "s3cret-token", false).reason, proto::RejectReason::BadToken);
    EXPECT_FALSE(checkHello(hello("s3cret"), "s3cret-token", false).accepted);
    proto::Hello old = hello("s3cret-token");
    old.protocolVersion = proto::kProtocolVersion + 1;
    EXPECT_EQ(checkHello(old, "s3cret-token", false).reason, proto::RejectReason::VersionMismatch);
    HandshakeResult notHello = checkHello(proto::Stats{}, "s3cret-token", false);
    EXPECT_FALSE(notHello.accepted);
    EXPECT_EQ(notHello.reason, proto::RejectReason::ProtocolError);
}

TEST(Handshake, InsecureModeAcceptsAnyTokenAndNamesUnnamedClients) {
    proto::Hello h = hello("anything");
    h.clientName.clear();
    HandshakeResult r = checkHello(h, "", true);
    EXPECT_TRUE(r.accepted);
    EXPECT_EQ(r.clientName, "unnamed");
}

TEST(Handshake, TokenMatchesOnlyEqualStrings) {
    EXPECT_TRUE(tokenMatches("abc", "abc"));
    EXPECT_FALSE(tokenMatches("abc", "abd"));
    EXPECT_FALSE(tokenMatches("abc", "abcd"));
    EXPECT_FALSE(tokenMatches("abc", ""));
    EXPECT_TRUE(tokenMatches("", ""));
}

TEST(Handshake, ClientNamesCannotForgeOrFloodLogLines) {
    // Before: a name with newlines wrote whole fake lines into the master's log.
    proto::Hello h = hello("s3cret-token");
    h.clientName = "w1\nrtpm-server: client 7 (admin, 10.0.0.1, 64 cores) joined\r\x1b[2J" + std::string(200, 'x');
    HandshakeResult r = checkHello(h, "s3cret-token", false);
    ASSERT_TRUE(r.accepted);
    for (unsigned char c : r.clientName) EXPECT_FALSE(c < 0x20 || c == 0x7F) << r.clientName;
    EXPECT_NE(r.clientName.find("w1\\nrtpm-server"), std::string::npos) << r.clientName;
    EXPECT_LE(r.clientName.size(), kMaxLoggedNameBytes + 32);
}

}  // namespace
}  // namespace rtpm::server
