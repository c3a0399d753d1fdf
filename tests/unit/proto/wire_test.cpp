// Wire primitives: little-endian layout, bounds-checked reads, sticky errors, header validation.
#include "proto/wire.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace rtpm::proto {
namespace {

TEST(Wire, WriterIsLittleEndianFieldByField) {
    Writer w;
    w.u8(0x01);
    w.u16(0x0302);
    w.u32(0x07060504u);
    w.u64(0x0F0E0D0C0B0A0908ull);
    w.f32(1.0f);  // 0x3F800000
    w.str("ab");
    const std::vector<uint8_t> want = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09,
                                       0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F, 0x00, 0x00, 0x80,
                                       0x3F, 0x02, 0x00, 0x00, 0x00, 'a',  'b'};
    EXPECT_EQ(w.data(), want);
}

TEST(Wire, ReaderRoundTripsEveryPrimitive) {
    Writer w;
    w.u8(200);
    w.u16(65000);
    w.u32(4000000000u);
    w.u64(0x123456789ABCDEF0ull);
    w.i32(-5);
    w.f32(-2.5f);
    w.f64(1e300);
    w.str("hello");
    const std::vector<uint8_t> blob = {9, 8, 7};
    w.bytes(blob);
    auto bytes = w.take();
    Reader r(bytes);
    uint8_t a;
    uint16_t b;
    uint32_t c;
    uint64_t d;
    int32_t e;
    float f;
    double g;
    std::string s;
    std::vector<uint8_t> v;
    EXPECT_TRUE(r.u8(a) && r.u16(b) && r.u32(c) && r.u64(d) && r.i32(e) && r.f32(f) && r.f64(g) &&
                r.str(s, 16, "s") && r.bytes(v, 16, "v"));
    EXPECT_TRUE(r.finish("all").ok());
    EXPECT_EQ(a, 200);
    EXPECT_EQ(b, 65000);
    EXPECT_EQ(c, 4000000000u);
    EXPECT_EQ(d, 0x123456789ABCDEF0ull);
    EXPECT_EQ(e, -5);
    EXPECT_EQ(f, -2.5f);
    EXPECT_EQ(g, 1e300);
    EXPECT_EQ(s, "hello");
    EXPECT_EQ(v, blob);
}

TEST(Wire, ReaderNeverReadsPastTheEndAndTheFirstErrorSticks) {
    const std::vector<uint8_t> bytes = {1, 2, 3};
    Reader r(bytes);
    uint32_t x = 77;
    EXPECT_FALSE(r.u32(x));
    EXPECT_EQ(x, 0u);
    EXPECT_EQ(r.error().code, ErrorCode::Truncated);
    uint8_t y = 5;
    EXPECT_FALSE(r.u8(y));  // a byte is there, but the reader has failed
    EXPECT_EQ(y, 0);
    EXPECT_EQ(r.position(), 0u);
    EXPECT_FALSE(r.finish("x").ok());
}

TEST(Wire, HostileLengthsFailBeforeAllocating) {
    Writer w;
    w.u32(0xFFFFFFF0u);  // claims 4 GiB of string
    w.u8('x');
    auto bytes = w.take();
    std::string s;
    Reader r(bytes);
    EXPECT_FALSE(r.str(s, std::numeric_limits<uint32_t>::max(), "name"));
    EXPECT_EQ(r.error().code, ErrorCode::LengthTooLarge);
    EXPECT_TRUE(s.empty());

    Reader limited(bytes);
    EXPECT_FALSE(limited.str(s, 16, "name"));
    EXPECT_NE(limited.error().message.find("name"), std::string::npos);

    // A count of 2^31 elements of 4 bytes in a 5-byte buffer.
    Writer c;
    c.u32(1u << 31);
    c.u8(0);
    auto cb = c.take();
    Reader rc(cb);
    uint32_t n = 1;
    EXPECT_FALSE(rc.count(n, std::numeric_limits<uint32_t>::max(), 4, "sets"));
    EXPECT_EQ(n, 0u);
    EXPECT_EQ(rc.error().code, ErrorCode::LengthTooLarge);
}

TEST(Wire, NonFiniteFloatsAreRejectedWhereFiniteIsRequired) {
    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                      -std::numeric_limits<float>::infinity()}) {
        Writer w;
        w.f32(bad);
        auto bytes = w.take();
        Reader r(bytes);
        float v = 1.0f;
        EXPECT_FALSE(r.f32Finite(v, "yfov"));
        EXPECT_EQ(v, 0.0f);
        EXPECT_EQ(r.error().code, ErrorCode::NonFinite);
    }
}

TEST(Wire, TrailingBytesAreAnError) {
    const std::vector<uint8_t> bytes = {1, 2};
    Reader r(bytes);
    uint8_t a;
    EXPECT_TRUE(r.u8(a));
    Status s = r.finish("msg");
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().code, ErrorCode::TrailingBytes);
}

std::vector<uint8_t> header(uint32_t magic, uint16_t version, uint16_t type, uint32_t flags,
                            uint32_t payload) {
    Writer w;
    w.u32(magic);
    w.u16(version);
    w.u16(type);
    w.u32(flags);
    w.u32(payload);
    return w.take();
}

TEST(Wire, HeaderIsSixteenBytesStartingWithRTPM) {
    Writer w;
    encodeHeader(Header{kMagic, kProtocolVersion, MessageType::FrameData, 0, 0x01020304u}, w);
    const std::vector<uint8_t> want = {'R', 'T', 'P', 'M', 11, 0, 7, 0, 0, 0, 0, 0, 4, 3, 2, 1};
    EXPECT_EQ(w.data(), want);
    auto h = decodeHeader(w.data());
    ASSERT_TRUE(h.ok()) << h.error().message;
    EXPECT_EQ(h->type, MessageType::FrameData);
    EXPECT_EQ(h->payloadBytes, 0x01020304u);
}

TEST(Wire, HeaderErrorsAreTyped) {
    auto code = [](const std::vector<uint8_t>& b) { return decodeHeader(b).error().code; };
    EXPECT_EQ(code({1, 2, 3}), ErrorCode::Truncated);
    EXPECT_EQ(code(header(0x4D505453u, 1, 1, 0, 0)), ErrorCode::BadMagic);
    EXPECT_EQ(code(header(kMagic, 12, 1, 0, 0)), ErrorCode::BadVersion);
    EXPECT_EQ(code(header(kMagic, 10, 1, 0, 0)), ErrorCode::BadVersion);  // version 10 peers (no per-pixel noise)
    EXPECT_EQ(code(header(kMagic, 9, 1, 0, 0)), ErrorCode::BadVersion);  // version 9 peers (every waiting set's pixels resent)
    EXPECT_EQ(code(header(kMagic, 8, 1, 0, 0)), ErrorCode::BadVersion);  // version 8 peers (no Relight frames)
    EXPECT_EQ(code(header(kMagic, 7, 1, 0, 0)), ErrorCode::BadVersion);  // version 7 peers (Settings by field, no plastics)
    EXPECT_EQ(code(header(kMagic, 6, 1, 0, 0)), ErrorCode::BadVersion);  // version 6 peers (no Edit frames)
    EXPECT_EQ(code(header(kMagic, 5, 1, 0, 0)), ErrorCode::BadVersion);  // version 5 peers (no turns in still passes)
    EXPECT_EQ(code(header(kMagic, 4, 1, 0, 0)), ErrorCode::BadVersion);  // version 4 peers (no shared photons, no world light)
    EXPECT_EQ(code(header(kMagic, 3, 1, 0, 0)), ErrorCode::BadVersion);  // version 3 peers (SPPM fields)
    EXPECT_EQ(code(header(kMagic, 2, 1, 0, 0)), ErrorCode::BadVersion);  // version 2 peers (token in Hello)
    EXPECT_EQ(code(header(kMagic, 1, 1, 0, 0)), ErrorCode::BadVersion);  // version 1 peers
    EXPECT_EQ(code(header(kMagic, 0, 1, 0, 0)), ErrorCode::BadVersion);
    EXPECT_EQ(code(header(kMagic, kProtocolVersion, 0, 0, 0)), ErrorCode::UnknownType);
    EXPECT_EQ(code(header(kMagic, kProtocolVersion, kMaxMessageType + 1, 0, 0)), ErrorCode::UnknownType);
    EXPECT_EQ(code(header(kMagic, kProtocolVersion, 1, 1, 0)), ErrorCode::BadFlags);
}

TEST(Wire, OversizePayloadIsRejectedFromTheHeaderAlone) {
    for (uint16_t t = 1; t <= kMaxMessageType; ++t) {
        const uint32_t limit = payloadLimit(static_cast<MessageType>(t));
        if (static_cast<MessageType>(t) != MessageType::Heartbeat) ASSERT_GT(limit, 0u);
        EXPECT_TRUE(decodeHeader(header(kMagic, kProtocolVersion, t, 0, limit)).ok()) << "type " << t;
        auto over = decodeHeader(header(kMagic, kProtocolVersion, t, 0, limit + 1));
        ASSERT_FALSE(over.ok());
        EXPECT_EQ(over.error().code, ErrorCode::PayloadTooLarge);
    }
    EXPECT_EQ(decodeHeader(header(kMagic, kProtocolVersion, 1, 0, 0xFFFFFFFFu)).error().code,
              ErrorCode::PayloadTooLarge);
}

}  // namespace
}  // namespace rtpm::proto
