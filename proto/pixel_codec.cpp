// Pixel codec: float32, 8-bit and RGB9E5 (optionally zstd caustic plane) payloads of FrameData.
#include "proto/pixel_codec.h"

#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "common/core/rgb9e5.h"

namespace rtpm::proto {
namespace {

// Pixel words: RGB9E5 with OpenGL's exponent bias 15 (EXT_texture_shared_exponent).
using PixelWord = Rgb9e5<15>;
static_assert(PixelWord::max() == kRgb9e5Max);

// Non-finite and negative radiance are not representable (and are bugs upstream): encode 0.
inline float sanitize(float v) { return (v > 0.0f && v <= 3.0e38f) ? v : 0.0f; }


inline void putU32(uint8_t* p, uint32_t v) {
    p[0] = static_cast<uint8_t>(v);
    p[1] = static_cast<uint8_t>(v >> 8);
    p[2] = static_cast<uint8_t>(v >> 16);
    p[3] = static_cast<uint8_t>(v >> 24);
}
inline uint32_t getU32(const uint8_t* p) {
    return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
           static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}

// Zstd on the caustic plane pays off only when the plane is sparse; a quarter of zero words is
// where level 1 starts to save more than its own cost on typical caustic images.
constexpr double kZstdMinZeroFraction = 0.25;
constexpr int kZstdLevel = 1;

struct CCtxDeleter {
    void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxDeleter {
    void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};

// Level 1 with a content checksum: the decoder then detects any corrupted frame, not only the
// ones that break zstd's structure (xxhash64 costs little next to the compression itself).
ZSTD_CCtx* threadCCtx() {
    thread_local std::unique_ptr<ZSTD_CCtx, CCtxDeleter> ctx = [] {
        std::unique_ptr<ZSTD_CCtx, CCtxDeleter> c(ZSTD_createCCtx());
        ZSTD_CCtx_setParameter(c.get(), ZSTD_c_compressionLevel, kZstdLevel);
        ZSTD_CCtx_setParameter(c.get(), ZSTD_c_checksumFlag, 1);
        return c;
    }();
    return ctx.get();
}
ZSTD_DCtx* threadDCtx() {
    thread_local std::unique_ptr<ZSTD_DCtx, DCtxDeleter> ctx(ZSTD_createDCtx());
    return ctx.get();
}

// Smallest possible zstd frame: 4 magic + 2 frame header + 3 block header.
constexpr size_t kMinZstdFrame = 9;

uint8_t toByte(float v) {
    float c = std::min(sanitize(v), 1.0f);
    return static_cast<uint8_t>(c * 255.0f + 0.5f);
}

}  // namespace

uint32_t packRgb9e5(float r, float g, float b) {
    return PixelWord::pack(sanitize(r), sanitize(g), sanitize(b));
}

void unpackRgb9e5(uint32_t word, float rgb[3]) { PixelWord::unpack(word, rgb); }

size_t bytesPerPixel(PixelEncoding encoding) {
    switch (encoding) {
        case PixelEncoding::Float32: return 24;
        case PixelEncoding::Rgb8: return 6;
        case PixelEncoding::Rgb9e5: return 8;
        case PixelEncoding::Rgb9e5Zstd: return 8;
    }
    return 0;
}

EncodedPixels encodePixels(ConstPixelView pixels, PixelEncoding requested) {
    const size_t n = pixels.size();
    EncodedPixels out;
    out.encoding = requested;
    switch (requested) {
        case PixelEncoding::Float32: {
            out.bytes.resize(n * 24);
            uint8_t* p = out.bytes.data();
            for (size_t i = 0; i < n; ++i) {
                const float* px = pixels.direct(i);  // direct then caustic: six floats
                for (int c = 0; c < 6; ++c) putU32(p, std::bit_cast<uint32_t>(sanitize(px[c]))), p += 4;
            }
            return out;
        }
        case PixelEncoding::Rgb8: {
            out.bytes.resize(n * 6);
            uint8_t* p = out.bytes.data();
            for (size_t i = 0; i < n; ++i) {
                const float* px = pixels.direct(i);
                for (int c = 0; c < 6; ++c) *p++ = toByte(px[c]);
            }
            return out;
        }
        case PixelEncoding::Rgb9e5:
        case PixelEncoding::Rgb9e5Zstd: break;
    }
    // Planar: the direct plane, then the caustic plane, so the (often zero) caustic words are
    // contiguous for zstd.
    out.encoding = PixelEncoding::Rgb9e5;
    out.bytes.resize(n * 8);
    uint8_t* direct = out.bytes.data();
    uint8_t* caustic = direct + n * 4;
    size_t zeros = 0;
    for (size_t i = 0; i < n; ++i) {
        const float* d = pixels.direct(i);
        const float* k = pixels.caustic(i);
        putU32(direct + 4 * i, packRgb9e5(d[0], d[1], d[2]));
        uint32_t c = packRgb9e5(k[0], k[1], k[2]);
        zeros += (c & 0x07FFFFFFu) == 0;
        // Canonical zero (exponent 0 too) so every zero word is identical for the compressor.
        putU32(caustic + 4 * i, (c & 0x07FFFFFFu) ? c : 0u);
    }
    if (requested != PixelEncoding::Rgb9e5Zstd || n == 0 ||
        static_cast<double>(zeros) < kZstdMinZeroFraction * static_cast<double>(n)) {
        return out;
    }
    std::vector<uint8_t> packed(n * 4 + ZSTD_compressBound(n * 4));
    std::memcpy(packed.data(), direct, n * 4);
    size_t z = ZSTD_compress2(threadCCtx(), packed.data() + n * 4, packed.size() - n * 4, caustic,
                              n * 4);
    if (ZSTD_isError(z) || z >= n * 4) return out;  // incompressible after all: stay plain
    packed.resize(n * 4 + z);
    out.encoding = PixelEncoding::Rgb9e5Zstd;
    out.bytes = std::move(packed);
    return out;
}

Status checkUnchangedPixels(uint64_t pixelCount, size_t payloadBytes, size_t payloadLimit) {
    if (pixelCount > payloadLimit / 4)
        return Error{ErrorCode::LengthTooLarge, std::to_string(pixelCount) + " unchanged pixels, more than a payload holds"};
    if (payloadBytes != 0)
        return Error{ErrorCode::BadValue, std::to_string(payloadBytes) + " bytes for unchanged pixels (must be none)"};
    return okStatus();
}

Status checkPixelPayloadSize(PixelEncoding encoding, uint64_t pixelCount, size_t payloadBytes) {
    if (static_cast<uint8_t>(encoding) > kMaxPixelEncoding) {
        return Error{ErrorCode::BadEnum,
                     "pixel encoding " + std::to_string(static_cast<int>(encoding))};
    }
    if (encoding == PixelEncoding::Rgb9e5Zstd) {
        // No pixels, no frame: an empty payload is the only canonical form.
        if (pixelCount == 0 && payloadBytes != 0)
            return Error{ErrorCode::LengthTooLarge, "0 pixels with a non-empty zstd payload"};
        const uint64_t minBytes = pixelCount * 4 + (pixelCount ? kMinZstdFrame : 0);
        if (payloadBytes < minBytes)
            return Error{ErrorCode::LengthTooLarge,
                         std::to_string(pixelCount) + " pixels need at least " +
                             std::to_string(minBytes) + " bytes in RGB9E5+zstd, payload has " +
                             std::to_string(payloadBytes)};
        // The zstd plane is sent only when it is smaller than the plain one (encodePixels), so
        // an honest payload is below plain Rgb9e5's 8·n: a frame padded with empty blocks is not.
        if (pixelCount > 0 && payloadBytes >= pixelCount * 8)
            return Error{ErrorCode::LengthTooLarge,
                         std::to_string(pixelCount) + " pixels in RGB9E5+zstd must take fewer than " +
                             std::to_string(pixelCount * 8) + " bytes (plain RGB9E5), payload has " +
                             std::to_string(payloadBytes)};
        return okStatus();
    }
    const uint64_t want = pixelCount * bytesPerPixel(encoding);
    if (payloadBytes != want)
        return Error{ErrorCode::LengthTooLarge, std::to_string(pixelCount) + " pixels need " +
                                                    std::to_string(want) + " bytes, payload has " +
                                                    std::to_string(payloadBytes)};
    return okStatus();
}

Status decodePixels(PixelEncoding encoding, std::span<const uint8_t> payload, PixelView out) {
    const size_t n = out.size();
    if (Status s = checkPixelPayloadSize(encoding, n, payload.size()); !s) return s;
    const uint8_t* p = payload.data();
    switch (encoding) {
        case PixelEncoding::Float32:
            for (size_t i = 0; i < n; ++i) {
                float* px = out.direct(i);
                for (int c = 0; c < 6; ++c) px[c] = sanitize(std::bit_cast<float>(getU32(p))), p += 4;
            }
            return okStatus();
        case PixelEncoding::Rgb8:
            for (size_t i = 0; i < n; ++i) {
                float* px = out.direct(i);
                for (int c = 0; c < 6; ++c) px[c] = static_cast<float>(*p++) * (1.0f / 255.0f);
            }
            return okStatus();
        case PixelEncoding::Rgb9e5:
            for (size_t i = 0; i < n; ++i) {
                unpackRgb9e5(getU32(p + 4 * i), out.direct(i));
                unpackRgb9e5(getU32(p + 4 * (n + i)), out.caustic(i));
            }
            return okStatus();
        case PixelEncoding::Rgb9e5Zstd: break;
    }
    for (size_t i = 0; i < n; ++i) unpackRgb9e5(getU32(p + 4 * i), out.direct(i));
    if (n == 0) return okStatus();
    std::span<const uint8_t> frame = payload.subspan(n * 4);
    // The frame must announce exactly the caustic plane and fill the rest of the payload: a
    // frame that decompresses to more would be cut, one that is followed by junk is malformed.
    const unsigned long long content = ZSTD_getFrameContentSize(frame.data(), frame.size());
    if (content != n * 4)
        return Error{ErrorCode::Corrupt, "zstd caustic plane: frame announces " +
                                             std::to_string(static_cast<long long>(content)) +
                                             " bytes, expected " + std::to_string(n * 4)};
    const size_t frameBytes = ZSTD_findFrameCompressedSize(frame.data(), frame.size());
    if (ZSTD_isError(frameBytes) || frameBytes != frame.size())
        return Error{ErrorCode::Corrupt, "zstd caustic plane: frame size does not match payload"};
    // Decompress into the caustic floats' storage as scratch would need a copy; use a buffer.
    std::vector<uint8_t> plane(n * 4);
    const size_t got =
        ZSTD_decompressDCtx(threadDCtx(), plane.data(), plane.size(), frame.data(), frame.size());
    if (ZSTD_isError(got) || got != n * 4)
        return Error{ErrorCode::Corrupt,
                     std::string("zstd caustic plane: ") +
                         (ZSTD_isError(got) ? ZSTD_getErrorName(got) : "short output")};
    for (size_t i = 0; i < n; ++i) unpackRgb9e5(getU32(plane.data() + 4 * i), out.caustic(i));
    return okStatus();
}

}  // namespace rtpm::proto
