// Pixel codec: RGB9E5 accuracy, every encoding round trips, zstd on sparse caustics, hostile payloads.
#include "proto/pixel_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <cstring>
#include <random>

namespace rtpm::proto {
namespace {

// A set's worth of pixels like the RING scene: smooth direct light, caustics on ~8% of pixels.
std::vector<PixelPair> causticBuffer(size_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<PixelPair> px(n);
    for (size_t i = 0; i < n; ++i) {
        float d = 0.05f + 0.5f * u(rng);
        px[i].direct[0] = d;
        px[i].direct[1] = 0.9f * d;
        px[i].direct[2] = 0.8f * d;
        const bool lit = (i / 37) % 12 == 0;  // runs of caustic pixels, like a focused ring
        for (float& c : px[i].caustic) c = lit ? 4.0f * u(rng) : 0.0f;
    }
    return px;
}

TEST(PixelCodec, Rgb9e5ErrorIsBelowHalfAMantissaStepOfTheLargestChannel) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> ex(-12.0f, 15.5f);
    for (int i = 0; i < 100000; ++i) {
        float in[3] = {std::exp2(ex(rng)), std::exp2(ex(rng)), std::exp2(ex(rng))};
        if (i % 7 == 0) in[i % 3] = 0.0f;
        float out[3];
        unpackRgb9e5(packRgb9e5(in[0], in[1], in[2]), out);
        const float maxc = std::max({in[0], in[1], in[2]});
        // Step of the shared exponent: 2^(floor(log2 max) + 1 − 9) (can double after rounding up).
        const float step = std::exp2(std::floor(std::log2(maxc)) + 1 - 9);
        for (int c = 0; c < 3; ++c) ASSERT_LE(std::abs(out[c] - in[c]), step) << in[c];
    }
}

TEST(PixelCodec, Rgb9e5ClampsAndZeroesWhatItCannotRepresent) {
    float out[3];
    unpackRgb9e5(packRgb9e5(1e30f, std::numeric_limits<float>::infinity(), -3.0f), out);
    EXPECT_EQ(out[0], kRgb9e5Max);
    EXPECT_EQ(out[1], 0.0f);
    EXPECT_EQ(out[2], 0.0f);
    unpackRgb9e5(packRgb9e5(std::numeric_limits<float>::quiet_NaN(), 1.0f, 0.0f), out);
    EXPECT_EQ(out[0], 0.0f);
    EXPECT_EQ(out[1], 1.0f);
    EXPECT_EQ(packRgb9e5(0.0f, 0.0f, 0.0f) & 0x07FFFFFFu, 0u);
}

TEST(PixelCodec, EveryRgb9e5WordDecodesFinite) {
    // All 32 exponents with extreme mantissas: every bit pattern a peer can send.
    for (uint32_t e = 0; e < 32; ++e)
        for (uint32_t m : {0u, 1u, 256u, 511u}) {
            float out[3];
            unpackRgb9e5(m | m << 9 | m << 18 | e << 27, out);
            for (float v : out) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f && v <= kRgb9e5Max);
        }
}

TEST(PixelCodec, EveryEncodingRoundTripsWithinItsPrecision) {
    auto px = causticBuffer(5000, 2);
    for (PixelEncoding e : {PixelEncoding::Float32, PixelEncoding::Rgb8, PixelEncoding::Rgb9e5,
                            PixelEncoding::Rgb9e5Zstd}) {
        EncodedPixels enc = encodePixels(px, e);
        std::vector<PixelPair> back(px.size());
        Status s = decodePixels(enc.encoding, enc.bytes, back);
        ASSERT_TRUE(s.ok()) << s.error().message;
        for (size_t i = 0; i < px.size(); ++i)
            for (int c = 0; c < 3; ++c) {
                const float d = px[i].direct[c], k = px[i].caustic[c];
                if (e == PixelEncoding::Float32) {
                    ASSERT_EQ(back[i].direct[c], d);
                    ASSERT_EQ(back[i].caustic[c], k);
                } else if (e == PixelEncoding::Rgb8) {
                    ASSERT_NEAR(back[i].direct[c], std::min(d, 1.0f), 0.5f / 255 + 1e-6f);
                    ASSERT_NEAR(back[i].caustic[c], std::min(k, 1.0f), 0.5f / 255 + 1e-6f);
                } else {
                    ASSERT_NEAR(back[i].direct[c], d, d * 2.0f / 256);
                    ASSERT_NEAR(back[i].caustic[c], k, 4.0f / 256);
                }
            }
    }
}

TEST(PixelCodec, SparseCausticPlaneIsCompressedAndDensePlaneIsNot) {
    auto sparse = causticBuffer(19200, 3);  // one set of 640×480 at M = 4
    EncodedPixels z = encodePixels(sparse, PixelEncoding::Rgb9e5Zstd);
    EXPECT_EQ(z.encoding, PixelEncoding::Rgb9e5Zstd);
    EXPECT_LT(z.bytes.size(), sparse.size() * 6);  // below the paper's 8-bit budget

    std::vector<PixelPair> dense(19200);
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> u(0.1f, 1.0f);
    for (auto& p : dense)
        for (int c = 0; c < 3; ++c) p.direct[c] = u(rng), p.caustic[c] = u(rng);
    EncodedPixels plain = encodePixels(dense, PixelEncoding::Rgb9e5Zstd);
    EXPECT_EQ(plain.encoding, PixelEncoding::Rgb9e5);
    EXPECT_EQ(plain.bytes.size(), dense.size() * 8);
}

TEST(PixelCodec, NonFiniteFloat32PayloadDecodesToZero) {
    std::vector<PixelPair> px(2, PixelPair{{1, 2, 3}, {4, 5, 6}});
    EncodedPixels enc = encodePixels(px, PixelEncoding::Float32);
    const uint32_t nan = 0x7FC00000u, inf = 0x7F800000u;
    std::memcpy(enc.bytes.data() + 4, &nan, 4);
    std::memcpy(enc.bytes.data() + 24 + 20, &inf, 4);
    std::vector<PixelPair> back(2);
    ASSERT_TRUE(decodePixels(PixelEncoding::Float32, enc.bytes, back).ok());
    EXPECT_EQ(back[0].direct[1], 0.0f);
    EXPECT_EQ(back[1].caustic[2], 0.0f);
    EXPECT_EQ(back[1].caustic[1], 5.0f);
}

TEST(PixelCodec, SizeMismatchesAndCorruptFramesAreErrors) {
    auto px = causticBuffer(1000, 5);
    std::vector<PixelPair> back(px.size());
    for (PixelEncoding e : {PixelEncoding::Float32, PixelEncoding::Rgb8, PixelEncoding::Rgb9e5}) {
        EncodedPixels enc = encodePixels(px, e);
        enc.bytes.pop_back();
        EXPECT_FALSE(decodePixels(e, enc.bytes, back).ok());
        enc.bytes.push_back(0);
        enc.bytes.push_back(0);
        EXPECT_FALSE(decodePixels(e, enc.bytes, back).ok());
    }
    EncodedPixels z = encodePixels(px, PixelEncoding::Rgb9e5Zstd);
    ASSERT_EQ(z.encoding, PixelEncoding::Rgb9e5Zstd);
    // One pixel fewer: the frame then announces 4 bytes more than the plane holds.
    std::vector<PixelPair> fewer(px.size() - 1);
    EXPECT_EQ(decodePixels(z.encoding, z.bytes, fewer).error().code, ErrorCode::Corrupt);
    auto cut = z.bytes;
    cut.pop_back();
    EXPECT_FALSE(decodePixels(z.encoding, cut, back).ok());
    auto junk = z.bytes;
    junk.push_back(0);
    EXPECT_FALSE(decodePixels(z.encoding, junk, back).ok());
    auto flipped = z.bytes;
    flipped[px.size() * 4 + 12] ^= 0x5A;  // inside the compressed block
    EXPECT_FALSE(decodePixels(z.encoding, flipped, back).ok());  // the frame carries a checksum
    EXPECT_FALSE(checkPixelPayloadSize(PixelEncoding::Rgb9e5Zstd, 1u << 31, 10).ok());
    EXPECT_FALSE(checkPixelPayloadSize(static_cast<PixelEncoding>(7), 0, 0).ok());
    EXPECT_FALSE(checkPixelPayloadSize(PixelEncoding::Rgb9e5Zstd, 0, 5).ok());
    EXPECT_TRUE(checkPixelPayloadSize(PixelEncoding::Rgb9e5Zstd, 0, 0).ok());
    // Issue 13: a zstd frame padded with empty blocks to 64 MiB per set took the master from
    // 0.3 ms to 700 ms per frame. An honest payload is smaller than plain RGB9E5 (8 B/px).
    EXPECT_LT(z.bytes.size(), px.size() * 8);
    EXPECT_FALSE(checkPixelPayloadSize(PixelEncoding::Rgb9e5Zstd, px.size(), px.size() * 8).ok());
    EXPECT_FALSE(checkPixelPayloadSize(PixelEncoding::Rgb9e5Zstd, px.size(), 64u << 20).ok());
    EXPECT_TRUE(checkPixelPayloadSize(PixelEncoding::Rgb9e5Zstd, px.size(), px.size() * 8 - 1).ok());
}

}  // namespace
TEST(PixelCodec, OnlyTheNegotiatedEncodingAnswersASettingsRequest) {
    using E = PixelEncoding;
    // Issue 13: the master asked for rgb9e5-zstd and accepted float32.
    EXPECT_FALSE(encodingAnswers(E::Rgb9e5Zstd, E::Float32));
    EXPECT_TRUE(encodingAnswers(E::Rgb9e5Zstd, E::Rgb9e5Zstd));
    EXPECT_TRUE(encodingAnswers(E::Rgb9e5Zstd, E::Rgb9e5));  // "compress when it pays"
    for (E requested : {E::Float32, E::Rgb8, E::Rgb9e5})
        for (E sent : {E::Float32, E::Rgb8, E::Rgb9e5, E::Rgb9e5Zstd})
            EXPECT_EQ(encodingAnswers(requested, sent), requested == sent);
}

}  // namespace rtpm::proto
