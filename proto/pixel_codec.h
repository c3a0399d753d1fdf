// Encoding of the two RGB values per pixel a client streams (direct and caustic radiance).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "proto/wire.h"

namespace rtpm::proto {

/// How the pixels of a FrameData payload are encoded (PROTOCOL.md §6). Append-only ids.
enum class PixelEncoding : uint8_t {
    Float32 = 0,     ///< 24 B/px: d.r d.g d.b c.r c.g c.b as f32, pixel by pixel (exact)
    Rgb8 = 1,        ///< 6 B/px: linear values clamped to [0, 1], round(v·255) (the paper's budget)
    Rgb9e5 = 2,      ///< 8 B/px: direct plane then caustic plane, one RGB9E5 u32 per pixel each
    Rgb9e5Zstd = 3,  ///< as Rgb9e5, but the caustic plane is one zstd frame (sparse caustics)
};
inline constexpr uint8_t kMaxPixelEncoding = 3;

/// Direct radiance (everything but caustics) and caustic radiance of one pixel, linear
/// W/(m²·sr). 24 bytes, no padding, the decoder's output and the encoder's input.
struct PixelPair {
    float direct[3];
    float caustic[3];
};
static_assert(sizeof(PixelPair) == 24, "PixelPair is six packed floats");

/// Pixels in the caller's own memory, so the codec reads the renderer's buffer and writes the
/// master's without an intermediate copy: pixel i's direct RGB is the three floats at
/// base + i·stride, its caustic RGB the three floats after them. `F` is float or const float.
/// proto/bridge builds views over common's PixelRadiance; pixelView() over PixelPair.
template <class F>
struct BasicPixelView {
    F* base = nullptr;
    size_t count = 0;
    size_t stride = 6;  ///< floats from one pixel to the next, ≥ 6
    size_t size() const { return count; }
    F* direct(size_t i) const { return base + i * stride; }
    F* caustic(size_t i) const { return base + i * stride + 3; }
};
using PixelView = BasicPixelView<float>;
using ConstPixelView = BasicPixelView<const float>;

inline PixelView pixelView(std::span<PixelPair> p) { return {p.empty() ? nullptr : p[0].direct, p.size(), 6}; }
inline ConstPixelView pixelView(std::span<const PixelPair> p) {
    return {p.empty() ? nullptr : p[0].direct, p.size(), 6};
}

/// Largest value RGB9E5 represents: (511/512)·2^16. Larger inputs are clamped to it.
inline constexpr float kRgb9e5Max = 65408.0f;

/// Packs a linear RGB triple into the shared-exponent RGB9E5 word (OpenGL
/// EXT_texture_shared_exponent): bits [8:0] R, [17:9] G, [26:18] B mantissas, [31:27] exponent
/// (bias 15). Negative and non-finite inputs become 0; values above kRgb9e5Max are clamped.
/// Error: at most half a unit of the largest channel's 9-bit mantissa (≤ 2^-9 relative to it).
uint32_t packRgb9e5(float r, float g, float b);
/// Inverse of packRgb9e5; every word decodes to three finite values in [0, kRgb9e5Max].
void unpackRgb9e5(uint32_t word, float rgb[3]);

/// A payload and the encoding it actually uses.
struct EncodedPixels {
    PixelEncoding encoding = PixelEncoding::Rgb9e5;
    std::vector<uint8_t> bytes;
};

/// Encodes `pixels` (row-major order of an interleaving set). `requested` Rgb9e5Zstd means
/// "RGB9E5, with the caustic plane zstd-compressed when at least a quarter of its words are zero
/// and compression saves bytes"; otherwise the result is plain Rgb9e5. Other encodings are used
/// as requested. Negative and non-finite inputs are encoded as 0 in every encoding.
/// Thread-safe (zstd contexts are per thread). Cost: O(pixels); zstd level 1 on the caustic plane.
EncodedPixels encodePixels(ConstPixelView pixels, PixelEncoding requested);
inline EncodedPixels encodePixels(std::span<const PixelPair> pixels, PixelEncoding requested) {
    return encodePixels(pixelView(pixels), requested);
}

/// Checks that a payload of `payloadBytes` can hold `pixelCount` pixels in `encoding`: exact size
/// for the fixed-size encodings, for Rgb9e5Zstd at least the direct plane plus a minimal zstd
/// frame. Cheap; the message decoder calls it so hostile counts fail before any allocation.
Status checkPixelPayloadSize(PixelEncoding encoding, uint64_t pixelCount, size_t payloadBytes);
/// The same for pixels a FrameData says are unchanged (PROTOCOL.md §5.7): no bytes, and no more
/// pixels than a payload of at most `payloadLimit` bytes could carry (four bytes a pixel at least,
/// RGB9E5+zstd), so a count that costs the sender nothing still bounds what a reader allocates.
Status checkUnchangedPixels(uint64_t pixelCount, size_t payloadBytes, size_t payloadLimit);

/// Whether a FrameData in `sent` answers Settings.encoding `requested` (PROTOCOL.md §6): the same
/// encoding, or plain Rgb9e5 for Rgb9e5Zstd ("compress when it pays"). Pure.
inline bool encodingAnswers(PixelEncoding requested, PixelEncoding sent) {
    return sent == requested || (requested == PixelEncoding::Rgb9e5Zstd && sent == PixelEncoding::Rgb9e5);
}

/// Decodes `payload` holding `out.size()` pixels in `encoding` into `out`. Fails (never asserts)
/// on a size mismatch or a zstd frame that is corrupt or does not hold exactly the caustic plane.
/// Every decoded value is finite and ≥ 0 (non-finite Float32 inputs become 0). On error `out`
/// is left in an unspecified but finite state. Thread-safe. Cost: O(pixels).
Status decodePixels(PixelEncoding encoding, std::span<const uint8_t> payload, PixelView out);
inline Status decodePixels(PixelEncoding encoding, std::span<const uint8_t> payload,
                           std::span<PixelPair> out) {
    return decodePixels(encoding, payload, pixelView(out));
}

/// Bytes per pixel of the fixed-size encodings (Rgb9e5Zstd: the uncompressed bound, 8).
size_t bytesPerPixel(PixelEncoding encoding);

}  // namespace rtpm::proto
