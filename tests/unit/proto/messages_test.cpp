// Messages: round trips, truncation at every byte, golden bytes, hostile counts, stream splitting.
#include "proto/messages.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <limits>
#include <random>

#include "tests/fuzz/decode_check.h"

namespace rtpm::proto {
namespace {

std::string hex(std::span<const uint8_t> b) {
    std::string s;
    char buf[4];
    for (uint8_t v : b) {
        std::snprintf(buf, sizeof buf, "%02x", v);
        s += buf;
    }
    return s;
}

// A message that must be refused with `code`.
void expectRefused(const Message& m, ErrorCode code) {
    auto r = decodeMessage(encode(m));
    ASSERT_FALSE(r.ok()) << "type " << static_cast<int>(typeOf(m));
    EXPECT_EQ(r.error().code, code) << r.error().message;
}

// A message that decodes to itself.
template <class T>
void expectRoundTrips(const T& m) {
    auto back = decodeMessage(encode(m));
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(std::get<T>(*back), m);
}

// A FrameData of `pixels` Float32 pixels of set `set` in frame `frame` (pixels and the rest empty).
FrameData floatFrame(uint64_t frame, uint32_t set, uint32_t pixels) {
    FrameData fd;
    fd.frame = frame;
    fd.set = set;
    fd.encoding = PixelEncoding::Float32;
    fd.pixelCount = pixels;
    return fd;
}

TEST(Messages, EveryTypeRoundTrips) {
    std::vector<bool> seen(kMaxMessageType + 1, false);
    for (const Message& m : testing::sampleMessages()) {
        auto bytes = encode(m);
        auto back = decodeMessage(bytes);
        ASSERT_TRUE(back.ok()) << "type " << static_cast<int>(typeOf(m)) << ": "
                               << back.error().message;
        EXPECT_EQ(*back, m) << "type " << static_cast<int>(typeOf(m));
        seen[static_cast<size_t>(typeOf(m))] = true;
    }
    for (uint16_t t = 1; t <= kMaxMessageType; ++t) EXPECT_TRUE(seen[t]) << "no sample of type " << t;
}

TEST(Messages, TruncationAtEveryByteIsAnErrorNotACrash) {
    for (const Message& m : testing::sampleMessages()) {
        auto bytes = encode(m);
        const auto payload = std::span<const uint8_t>(bytes).subspan(kHeaderBytes);
        for (size_t n = 0; n < bytes.size(); ++n) {
            auto r = decodeMessage(std::span<const uint8_t>(bytes).first(n));
            ASSERT_FALSE(r.ok()) << "type " << static_cast<int>(typeOf(m)) << " cut at " << n;
            EXPECT_EQ(r.error().code, ErrorCode::Truncated);
        }
        // The payload alone, cut short, against its own type: never accepted.
        for (size_t n = 0; n < payload.size(); ++n)
            ASSERT_FALSE(decodePayload(typeOf(m), payload.first(n)).ok())
                << "type " << static_cast<int>(typeOf(m)) << " payload cut at " << n;
    }
}

TEST(Messages, HelloGoldenBytes) {
    auto bytes = encode(Hello{5, 8, "c1", 0x0123456789abcdefull});
    EXPECT_EQ(hex(bytes),
              "5254504d"   // magic 'RTPM'
              "0b00"       // version 11
              "0100"       // type Hello
              "00000000"   // flags
              "14000000"   // payload 20 bytes
              "0500"       // protocolVersion 5 (the value given)
              "08000000"   // cores 8
              "020000006331"       // "c1"
              "efcdab8967452301");  // settingsLayout (version 8)
}

TEST(Messages, HeartbeatIsABareHeaderAndRefusesAnyPayload) {
    EXPECT_EQ(hex(encode(Heartbeat{})), "5254504d" "0b00" "0d00" "00000000" "00000000");
    EXPECT_FALSE(decodePayload(MessageType::Heartbeat, std::vector<uint8_t>{0}).ok());
}

TEST(Messages, OnlyBusyRefusalsAreTransient) {
    EXPECT_TRUE(rejectIsTransient(RejectReason::Capacity));
    EXPECT_TRUE(rejectIsTransient(RejectReason::RateLimited));
    EXPECT_FALSE(rejectIsTransient(RejectReason::ServerFull));
    EXPECT_FALSE(rejectIsTransient(RejectReason::BadToken));
    EXPECT_FALSE(rejectIsTransient(RejectReason::VersionMismatch));
    EXPECT_FALSE(rejectIsTransient(RejectReason::ProtocolError));
}

TEST(Messages, ChallengeAndAuthGoldenBytes) {
    Challenge c;
    for (size_t i = 0; i < c.nonce.size(); ++i) c.nonce[i] = uint8_t(i);
    EXPECT_EQ(hex(encode(c)), "5254504d0b000b0000000000" "20000000"  // type 11, payload 32
                              "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f");
    Auth a;
    a.mac.fill(0xab);
    EXPECT_EQ(hex(encode(a)).substr(0, 32), "5254504d0b000c000000000020000000");  // type 12, payload 32
}

TEST(FrameSplitter, AllowOnlyRefusesOtherTypesAndSizesFromTheHeaderAlone) {
    // Before authentication a peer may send only a small Hello: a FrameData announcing 256 MiB
    // fails on its 16 header bytes, before any payload is buffered.
    Writer w;
    encodeHeader(Header{kMagic, kProtocolVersion, MessageType::FrameData, 0, 256u << 20}, w);
    FrameSplitter splitter;
    splitter.allowOnly(MessageType::Hello, 4096);
    splitter.feed(w.data());
    auto r = splitter.next();
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::NotAllowed);
    EXPECT_EQ(splitter.buffered(), kHeaderBytes);  // the header itself, nothing of the payload

    FrameSplitter small;
    small.allowOnly(MessageType::Auth, 32);
    Writer big;
    encodeHeader(Header{kMagic, kProtocolVersion, MessageType::Auth, 0, 33}, big);
    small.feed(big.data());
    EXPECT_EQ(small.next().error().code, ErrorCode::NotAllowed);

    FrameSplitter capped;  // after authentication: any type, but not above the connection's bound
    capped.capPayload(1000);
    auto okStats = encode(Stats{});
    capped.feed(okStats);
    ASSERT_TRUE(capped.next().ok());
    Writer bigData;
    encodeHeader(Header{kMagic, kProtocolVersion, MessageType::FrameData, 0, 1001}, bigData);
    capped.feed(bigData.data());
    EXPECT_EQ(capped.next().error().code, ErrorCode::NotAllowed);

    FrameSplitter lifted;
    lifted.allowOnly(MessageType::Hello, 4096);
    auto hello = encode(Hello{});
    lifted.feed(hello);
    ASSERT_TRUE(lifted.next().ok());
    lifted.allowAll();
    auto stats = encode(Stats{});
    lifted.feed(stats);
    auto s2 = lifted.next();
    ASSERT_TRUE(s2.ok());
    ASSERT_TRUE(s2->has_value());
}

TEST(Messages, FrameBeginGoldenBytes) {
    FrameBegin fb{5, 2, 3, {{1, 2, 3}, {0, 0, -1}, {0, 1, 0}, 0.5f}, FrameMode::Accumulate, {0, 7}};
    EXPECT_EQ(hex(encode(fb)),
              "5254504d0b000600" "00000000" "51000000"  // header v11, type 6, payload 81 bytes
              "0500000000000000"                        // frame 5
              "02000000" "03000000"                     // epoch 2, sceneVersion 3
              "0000803f" "00000040" "00004040"          // position (1, 2, 3)
              "00000000" "00000000" "000080bf"          // forward (0, 0, -1)
              "00000000" "0000803f" "00000000"          // up (0, 1, 0)
              "0000003f"                                // yfov 0.5
              "01"                                      // mode Accumulate
              "02000000" "00000000" "07000000"          // sets [0, 7]
              "01000000"                                // passBatches 1
              "01000000"                                // passPeriod 1
              "00000000");                              // no shared photons
}

TEST(Messages, SharedPhotonsRoundTripAndHostileOnesAreRefused) {
    auto reject = [](const Message& m, ErrorCode code) {
        auto r = decodeMessage(encode(m));
        ASSERT_FALSE(r.ok()) << "type " << static_cast<int>(typeOf(m));
        EXPECT_EQ(r.error().code, code) << r.error().message;
    };
    const PhotonRecord p{1.0f, -2.0f, 0.5f, 0x12345678u, 0x9abcdef0u};
    FrameBegin fb{9, 1, 1, {{1, 2, 3}, {0, 0, -1}, {0, 1, 0}, 0.5f}, FrameMode::Converging, {0, 4}};
    fb.shared = {SetShot{1, 2, {p, p}}, SetShot{3, 1, {p}}};
    expectRoundTrips(fb);
    FrameBegin bad = fb;
    std::swap(bad.shared[0], bad.shared[1]);  // not ascending
    reject(bad, ErrorCode::BadValue);
    bad = fb;
    bad.shared[1].set = 1;  // twice
    reject(bad, ErrorCode::BadValue);
    bad = fb;
    bad.shared[0].batches = 0;
    reject(bad, ErrorCode::BadValue);
    bad = fb;
    bad.shared[1].photons.clear();
    reject(bad, ErrorCode::BadValue);
    bad = fb;
    bad.shared[0].photons[1].y = std::numeric_limits<float>::quiet_NaN();
    reject(bad, ErrorCode::NonFinite);
    bad = fb;
    bad.shared[0].set = kMaxSets;
    reject(bad, ErrorCode::BadValue);

    FrameData fd = floatFrame(9, 4, 1);
    fd.pixels.assign(24, 0);
    fd.shotBatches = 3;
    fd.shot = {p, p, p};
    expectRoundTrips(fd);
    FrameData badData = fd;
    badData.shotBatches = 0;  // photons without batches
    reject(badData, ErrorCode::BadValue);
    badData = fd;
    badData.shot.clear();  // batches without photons
    reject(badData, ErrorCode::BadValue);
    badData = fd;
    badData.shotBatches = kMaxPassBatches + 1;
    reject(badData, ErrorCode::BadValue);
    badData = fd;
    badData.shot[2].x = std::numeric_limits<float>::infinity();
    reject(badData, ErrorCode::NonFinite);
}

// A set off its turn names the frame whose pixels it still shows and carries none (version 10):
// a FrameData that says so with pixels or own weights, names no earlier frame, or names one
// without saying so is refused.
TEST(Messages, UnchangedPixelsRoundTripAndInconsistentOnesAreRefused) {
    const auto reject = expectRefused;
    FrameData fd = floatFrame(9, 4, 2);
    fd.unchanged = true;
    fd.sameAs = 5;
    fd.errorSigma = 0.5;
    fd.errorRadiance = 2.0;
    fd.errorPixels = 1;
    expectRoundTrips(fd);
    EXPECT_EQ(encode(fd).size(), kHeaderBytes + 8 + 4 + 1 + 4 + 1 + 8 + 4 + 4 + 4 + 8 + 8 + 4 + 8 + 4 + 4 + 4);
    FrameData bad = fd;
    bad.pixels.assign(48, 0);
    reject(bad, ErrorCode::BadValue);
    bad = fd;
    bad.ownWeights.assign(2, 255);
    reject(bad, ErrorCode::BadValue);
    bad = fd;
    bad.noise.assign(2, 64);  // version 11: no noise without pixels either
    reject(bad, ErrorCode::BadValue);
    bad = fd;
    bad.sameAs = 9;  // not before its own frame
    reject(bad, ErrorCode::BadValue);
    bad = fd;
    bad.unchanged = false;  // a frame named, pixels absent
    reject(bad, ErrorCode::BadValue);
    bad = fd;
    bad.unchanged = false;
    bad.sameAs = 0;  // no pixels where the encoding needs 48 bytes
    reject(bad, ErrorCode::LengthTooLarge);
    // The flag is one byte, 0 or 1.
    auto bytes = encode(fd);
    bytes[kHeaderBytes + 17] = 2;
    auto r = decodeMessage(bytes);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::BadValue) << r.error().message;
}

TEST(Messages, FrameDataClaimingTwoBillionPixelsInTenBytesIsRejected) {
    Writer w;
    w.u64(1);        // frame
    w.u32(0);        // set
    w.u8(static_cast<uint8_t>(PixelEncoding::Rgb9e5));
    w.u32(1u << 31); // pixel count
    w.u8(0);         // not unchanged
    w.u64(0);        // sameAs
    w.u32(10);       // payload bytes
    for (int i = 0; i < 10; ++i) w.u8(0);
    auto r = decodePayload(MessageType::FrameData, w.data());
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::LengthTooLarge);

    // The byte array's own length may not exceed what is there either.
    Writer v;
    v.u64(1);
    v.u32(0);
    v.u8(static_cast<uint8_t>(PixelEncoding::Float32));
    v.u32(1);
    v.u8(0);
    v.u64(0);
    v.u32(0x7FFFFFFFu);
    for (int i = 0; i < 24; ++i) v.u8(0);
    EXPECT_EQ(decodePayload(MessageType::FrameData, v.data()).error().code, ErrorCode::LengthTooLarge);
}

// Version 4: the own weights are absent or one byte per pixel, the error figures finite and ≥ 0,
// passBatches within [1, kMaxPassBatches]; version 6: passPeriod within [1, kMaxPassPeriod].
TEST(Messages, ProgressiveFieldsAreValidated) {
    const auto reject = expectRefused;
    FrameData fd = floatFrame(1, 0, 2);
    fd.pixels.assign(48, 0);
    fd.ownWeights = {0, 255};
    fd.errorSigma = 0.5;
    fd.errorRadiance = 10.0;
    fd.errorPixels = 2;
    expectRoundTrips(fd);
    FrameData bad = fd;
    bad.ownWeights = {7};
    reject(bad, ErrorCode::BadValue);
    bad = fd;
    bad.errorSigma = -1.0;
    reject(bad, ErrorCode::BadValue);
    bad = fd;
    bad.errorRadiance = std::numeric_limits<double>::infinity();
    reject(bad, ErrorCode::NonFinite);
    bad = fd;
    bad.errorPixels = 3;
    reject(bad, ErrorCode::BadValue);
    FrameBegin fb{5, 2, 3, {{1, 2, 3}, {0, 0, -1}, {0, 1, 0}, 0.5f}, FrameMode::Converging, {0}};
    fb.passBatches = 0;
    reject(fb, ErrorCode::BadValue);
    fb.passBatches = kMaxPassBatches + 1;
    reject(fb, ErrorCode::BadValue);
    fb.passBatches = 1;
    fb.passPeriod = 0;
    reject(fb, ErrorCode::BadValue);
    fb.passPeriod = kMaxPassPeriod + 1;
    reject(fb, ErrorCode::BadValue);
    fb.passPeriod = kMaxPassPeriod;
    auto turns = decodeMessage(encode(fb));
    ASSERT_TRUE(turns.ok()) << turns.error().message;
    EXPECT_EQ(std::get<FrameBegin>(*turns).passPeriod, kMaxPassPeriod);
}

TEST(Messages, HostileSetCountIsRejectedBeforeAllocating) {
    Writer w;
    w.u32(1);           // client id
    w.u32(0xFFFFFFFFu); // sets
    EXPECT_EQ(decodePayload(MessageType::Welcome, w.data()).error().code, ErrorCode::LengthTooLarge);
    Writer e;
    e.u32(1);
    e.u8(0);
    e.str("ring");
    e.u32(0);
    e.u32(60000);  // edits: 60000 claimed, none present
    EXPECT_EQ(decodePayload(MessageType::Scene, e.data()).error().code, ErrorCode::LengthTooLarge);
}

TEST(Messages, FieldValidationRejectsBadValues) {
    auto reject = [](const Message& m, ErrorCode code) {
        auto r = decodeMessage(encode(m));
        ASSERT_FALSE(r.ok()) << "type " << static_cast<int>(typeOf(m));
        EXPECT_EQ(r.error().code, code) << r.error().message;
    };
    CameraState nanCam;
    nanCam.position.x = std::numeric_limits<float>::quiet_NaN();
    reject(FrameBegin{1, 0, 0, nanCam, FrameMode::Interaction, {}}, ErrorCode::NonFinite);
    CameraState wideCam;
    wideCam.yfov = 3.5f;
    reject(FrameBegin{1, 0, 0, wideCam, FrameMode::Interaction, {}}, ErrorCode::BadValue);
    reject(FrameBegin{1, 0, 0, {}, static_cast<FrameMode>(kMaxFrameMode + 1), {}}, ErrorCode::BadEnum);
    reject(Welcome{1, {4, 4}}, ErrorCode::BadValue);
    reject(Welcome{1, {kMaxSets}}, ErrorCode::BadValue);
    reject(Hello{1, 1, std::string(kMaxNameBytes + 1, 'x')}, ErrorCode::LengthTooLarge);
    reject(Hello{1, 0, ""}, ErrorCode::BadValue);
    reject(Reject{static_cast<RejectReason>(0), ""}, ErrorCode::BadEnum);
    reject(Bye{static_cast<ByeReason>(99), ""}, ErrorCode::BadEnum);
    Settings s;
    s.render.interleave = 0;
    reject(s, ErrorCode::BadValue);
    s = Settings{};
    s.render.photons.rMax = -1.0f;
    reject(s, ErrorCode::BadValue);
    s = Settings{};
    s.encoding = static_cast<PixelEncoding>(9);
    reject(s, ErrorCode::BadEnum);
    s = Settings{};
    s.render.photons.estimator = static_cast<CausticEstimatorKind>(2);
    reject(s, ErrorCode::BadEnum);
    s = Settings{};
    s.render.photons.progressiveGamma = 0.0f;
    reject(s, ErrorCode::BadValue);
    s.render.photons.progressiveGamma = 16.5f;
    reject(s, ErrorCode::BadValue);
    s.render.photons.progressiveGamma = std::numeric_limits<float>::quiet_NaN();
    reject(s, ErrorCode::NonFinite);
    reject(Scene{1, Scene::Source::Builtin, "", {}, {}}, ErrorCode::BadValue);
    reject(Scene{1, Scene::Source::Gltf, "ring", {1}, {}}, ErrorCode::BadValue);
    // The world light (version 5): a map 2:1 with exactly its texels, finite and ≥ 0; a colour
    // only for a uniform sky.
    auto sky = [](Scene::Environment kind, uint32_t w, uint32_t h, std::vector<float> texels, Vec3f colour = {}) {
        Scene s{1, Scene::Source::Builtin, "ring", {}, {}};
        s.environment = kind;
        s.environmentWidth = w;
        s.environmentHeight = h;
        s.environmentTexels = std::move(texels);
        s.environmentColour = colour;
        return s;
    };
    reject(sky(Scene::Environment::Map, 4, 4, std::vector<float>(48, 1.0f)), ErrorCode::BadValue);
    reject(sky(Scene::Environment::Map, 4, 2, {}), ErrorCode::LengthTooLarge);
    std::vector<float> texels(24, 1.0f);
    texels[5] = -1.0f;
    reject(sky(Scene::Environment::Map, 4, 2, texels), ErrorCode::BadValue);
    texels[5] = std::numeric_limits<float>::infinity();
    reject(sky(Scene::Environment::Map, 4, 2, texels), ErrorCode::NonFinite);
    reject(sky(Scene::Environment::None, 0, 0, {}, {1, 1, 1}), ErrorCode::BadValue);
    reject(sky(Scene::Environment::Uniform, 0, 0, {}, {1, -1, 1}), ErrorCode::BadValue);
    reject(sky(Scene::Environment::Uniform, 2, 1, {0, 0, 0, 0, 0, 0}, {1, 1, 1}), ErrorCode::BadValue);
    reject(Edit{1, MaterialEdit{0, MaterialKind::Diffuse, {2, 0, 0}, 1.5f, {}, {}}}, ErrorCode::BadValue);
    reject(Edit{1, LightEdit{0, {}, {0, 0, 0}, {1, 1, 1}}}, ErrorCode::BadValue);
    reject(Stats{1, -1.0f, 0, 0, 0, 0, 0, 0, 1}, ErrorCode::BadValue);
    reject(FrameData{1, 0, PixelEncoding::Float32, 2, std::vector<uint8_t>(47)}, ErrorCode::LengthTooLarge);
    reject(FrameData{1, kMaxSets, PixelEncoding::Rgb8, 0, {}}, ErrorCode::BadValue);
}

TEST(Messages, FixedSizePayloadsHaveTheDocumentedSizes) {
    // PROTOCOL.md §5.5 and §5.9 state these sizes.
    EXPECT_EQ(encode(Settings{}).size(), kHeaderBytes + kSettingsPayloadBytes);
    EXPECT_EQ(encode(Stats{}).size(), kHeaderBytes + 52);
    EXPECT_EQ(encode(Edit{1, CameraEdit{}}).size(), kHeaderBytes + 4 + 41);
    EXPECT_EQ(encode(Edit{1, LightEdit{}}).size(), kHeaderBytes + 4 + 41);
    EXPECT_EQ(encode(Edit{1, MaterialEdit{}}).size(), kHeaderBytes + 4 + 46);
    EXPECT_EQ(encode(Edit{1, TransformEdit{}}).size(), kHeaderBytes + 4 + 69);
}

TEST(Messages, TrailingPayloadBytesAreRejected) {
    auto bytes = encode(Bye{ByeReason::Normal, "x"});
    bytes.push_back(0);
    // Fix the header's length so only the payload is too long for its message.
    bytes[12] = static_cast<uint8_t>(bytes.size() - kHeaderBytes);
    EXPECT_EQ(decodeMessage(bytes).error().code, ErrorCode::TrailingBytes);
}

TEST(Messages, TryEncodeRefusesOversizePayloads) {
    // A 5000-byte name is over Hello's 4 KiB payload limit (and its own 256-byte field limit).
    auto r = tryEncode(Hello{1, 1, std::string(5000, 'n')});
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::PayloadTooLarge);
}

TEST(FrameSplitter, YieldsEveryMessageUnderArbitraryChunking) {
    const auto samples = testing::sampleMessages();
    std::vector<uint8_t> stream;
    for (const Message& m : samples) {
        auto b = encode(m);
        stream.insert(stream.end(), b.begin(), b.end());
    }
    std::mt19937 rng(5);
    for (int trial = 0; trial < 50; ++trial) {
        FrameSplitter splitter;
        std::vector<Message> got;
        size_t pos = 0;
        while (pos < stream.size()) {
            size_t n = std::min<size_t>(stream.size() - pos, 1 + rng() % (trial < 10 ? 3 : 200));
            splitter.feed(std::span<const uint8_t>(stream).subspan(pos, n));
            pos += n;
            for (;;) {
                auto r = splitter.next();
                ASSERT_TRUE(r.ok()) << r.error().message;
                if (!r->has_value()) break;
                got.push_back(std::move(**r));
            }
        }
        ASSERT_EQ(got, samples);
        EXPECT_EQ(splitter.buffered(), 0u);
    }
}

TEST(FrameSplitter, FailsOnAnOversizeHeaderWithoutWaitingForThePayload) {
    Writer w;
    encodeHeader(Header{kMagic, kProtocolVersion, MessageType::Hello, 0, 1u << 30}, w);
    FrameSplitter splitter;
    splitter.feed(w.data());
    auto r = splitter.next();
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::PayloadTooLarge);
    // Sticky: valid bytes afterwards do not revive the stream.
    auto hello = encode(Hello{});
    splitter.feed(hello);
    EXPECT_FALSE(splitter.next().ok());
    EXPECT_TRUE(splitter.failed());
}

TEST(FrameSplitter, BufferedCountsAHeaderWhosePayloadIsStillAwaited) {
    // Found by decode_fuzz: a valid message followed by a lone valid header reported 0 bytes
    // buffered once the header was decoded, as if the stream ended on a message boundary.
    auto bytes = encode(Reject{RejectReason::BadToken, "token does not match"});
    Writer w;
    encodeHeader(Header{kMagic, kProtocolVersion, MessageType::Scene, 0, 1000}, w);
    bytes.insert(bytes.end(), w.data().begin(), w.data().end());
    FrameSplitter splitter;
    splitter.feed(bytes);
    auto first = splitter.next();
    ASSERT_TRUE(first.ok());
    ASSERT_TRUE(first->has_value());
    auto second = splitter.next();
    ASSERT_TRUE(second.ok());
    EXPECT_FALSE(second->has_value());
    EXPECT_EQ(splitter.buffered(), kHeaderBytes);
}

TEST(FrameSplitter, GarbageStreamFailsWithBadMagic) {
    FrameSplitter splitter;
    const std::vector<uint8_t> junk = {'G', 'E', 'T', ' ', '/', ' ', 'H', 'T', 'T', 'P',
                                       '/', '1', '.', '1', '\r', '\n'};
    splitter.feed(junk);
    EXPECT_EQ(splitter.next().error().code, ErrorCode::BadMagic);
}

TEST(FrameSplitter, InvalidPayloadIsFatal) {
    auto bytes = encode(Welcome{1, {3}});
    bytes.back() = 0xFF;  // set 0xFF000003 is out of range
    FrameSplitter splitter;
    splitter.feed(bytes);
    auto r = splitter.next();
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::BadValue);
}

// The Settings message is its rows (proto/settings_rows.h): every row's value travels in its type
// and comes back exactly at both its limits; past a limit (and for a u64 past 2^53, where a double
// would round) the decoder refuses it naming the row, as validateSettings would.
TEST(SettingsRows, EveryRowTravelsWithinItsLimitsAndIsRefusedByNameBeyondThem) {
    size_t bytes = 1;
    for (const SettingRow* row : kSettingsRows) bytes += wireBytes(row->wire);
    EXPECT_EQ(bytes, kSettingsPayloadBytes);
    for (const SettingRow* row : kSettingsRows) {
        Settings base;
        base.render.interleave = 1;  // within any image size the width and height rows allow
        for (double v : {row->min, row->max}) {
            Settings s = base;
            row->set(s.render, v);
            auto back = decodeMessage(encode(s));
            ASSERT_TRUE(back.ok()) << row->name << " = " << v << ": " << back.error().message;
            EXPECT_EQ(std::get<Settings>(*back), s) << row->name;
            EXPECT_EQ(row->get(std::get<Settings>(*back).render), row->get(s.render)) << row->name;
        }
        const double step = row->integer ? 1.0 : std::max(1e-3, 1e-3 * row->max);
        for (double v : {row->min - step, row->max + step}) {
            if (v < 0.0 && row->integer) continue;  // not a value of an unsigned field
            Settings s = base;
            row->set(s.render, v);
            if (row->get(s.render) == row->min || row->get(s.render) == row->max) continue;  // a switch's bool
            auto back = decodeMessage(encode(s));
            ASSERT_FALSE(back.ok()) << row->name << " = " << v << " accepted";
            EXPECT_NE(back.error().message.find("settings: " + std::string(row->name)), std::string::npos)
                << back.error().message;
        }
    }
    // A seed above 2^53 (which a double would round to 2^53, the row's max) is refused.
    Settings s;
    auto bytesOf = encode(s);
    size_t at = kHeaderBytes + 1;
    for (const SettingRow* row : kSettingsRows) {
        if (row->flag == "--seed") break;
        at += wireBytes(row->wire);
    }
    const uint64_t seed = (uint64_t(1) << 53) + 1;
    for (int i = 0; i < 8; ++i) bytesOf[at + size_t(i)] = uint8_t(seed >> (8 * i));
    auto r = decodeMessage(bytesOf);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("settings: seed must be in"), std::string::npos) << r.error().message;
    // The rule between rows: M within the image.
    s = Settings{};
    s.render.width = 2;
    auto m = decodeMessage(encode(s));
    ASSERT_FALSE(m.ok());
    EXPECT_NE(m.error().message.find("interleave M = 3 exceeds the image size"), std::string::npos)
        << m.error().message;
}

// Every setting a client renders by reaches it as it was set; the master's alone (exposure) does not.
TEST(SettingsRows, EveryRowRoundTripsAwayFromItsDefault) {
    RenderSettings rs;
    rs.width = 321;
    rs.height = 123;
    rs.interleave = 4;
    rs.filter = 5;
    rs.exposure = 1.5f;
    rs.eye.maxDepth = 7;
    rs.eye.areaLightSamples = 9;
    rs.photons.photonsPerBatch = 12345;
    rs.photons.selective = false;
    rs.photons.diffuseBounces = 0;
    rs.photons.maxDepth = 11;
    rs.photons.k = 33;
    rs.photons.rMax = 0.125f;
    rs.photons.capPhotons = 777;
    rs.photons.seed = 0xfeedbeefull;
    rs.photons.tree = PhotonTree::UniformGrid;
    rs.photons.gatherVisibility = true;
    rs.photons.estimator = CausticEstimatorKind::Knn;
    rs.photons.progressiveGamma = 0.75f;
    rs.eye.glossySamples = 2;
    auto back = decodeMessage(encode(Settings{PixelEncoding::Float32, rs}));
    ASSERT_TRUE(back.ok()) << back.error().message;
    const Settings& s = std::get<Settings>(*back);
    EXPECT_EQ(s.encoding, PixelEncoding::Float32);
    RenderSettings expected = rs;
    expected.exposure = RenderSettings{}.exposure;  // the master's output stage alone
    EXPECT_EQ(s.render, expected);
    for (const SettingRow* row : kSettingsRows)
        EXPECT_NE(row->get(s.render), row->defaultValue) << row->name << " left at its default by this test";
}

// Two builds whose settings rows differ have different layouts; the fingerprint follows a row's
// flag, type and limits (PROTOCOL.md §5.1 gives the algorithm a peer recomputes).
TEST(SettingsRows, TheLayoutFingerprintIsThatOfTheRowsInOrder) {
    uint64_t h = 0xcbf29ce484222325ull;
    auto byte = [&h](uint8_t b) {
        h ^= b;
        h *= 0x100000001b3ull;
    };
    for (const SettingRow* row : kSettingsRows) {
        for (char c : row->flag) byte(uint8_t(c));
        byte(0);
        byte(uint8_t(row->wire));
        for (double v : {row->min, row->max}) {
            uint64_t bits = 0;
            std::memcpy(&bits, &v, 8);
            for (int i = 0; i < 8; ++i) byte(uint8_t(bits >> (8 * i)));
        }
    }
    EXPECT_EQ(h, kSettingsLayout);
    EXPECT_EQ(Hello{}.settingsLayout, kSettingsLayout);
    // The rows are the fixed settings and then the live knobs that have a wire type, in table order.
    size_t i = 0;
    for (const SettingRow& row : kFixedSettings) {
        if (row.wire != WireType::None) {
            EXPECT_EQ(kSettingsRows[i++], &row) << row.name;
        }
    }
    for (const KnobRow& row : kKnobs) {
        if (row.wire != WireType::None) {
            EXPECT_EQ(kSettingsRows[i++], &row) << row.name;
        }
    }
    EXPECT_EQ(i, kSettingsRowCount);
}

}  // namespace
}  // namespace rtpm::proto
