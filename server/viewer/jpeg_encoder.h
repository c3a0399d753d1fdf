// JPEG encoding of live frames with libjpeg-turbo's TurboJPEG API (chosen by tests/bench/viewer_encode_bench).
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace rtpm::server {

/// Encodes 8-bit RGB images to baseline JPEG (4:2:0, fast DCT). Reuses one compressor; encodeInto
/// writes into the caller's buffer (no allocation once it has grown). Not thread-safe: one per thread.
class JpegEncoder {
public:
    explicit JpegEncoder(int quality = 85);
    ~JpegEncoder();
    JpegEncoder(const JpegEncoder&) = delete;
    JpegEncoder& operator=(const JpegEncoder&) = delete;

    /// JPEG bytes of `rgb` (width·height·3, rows from the top). Throws std::runtime_error with
    /// libjpeg-turbo's message on failure, std::invalid_argument on a size mismatch.
    std::string encode(std::span<const uint8_t> rgb, int width, int height);
    /// The same, written into `out` from byte `offset` on (out is resized to offset + JPEG size;
    /// bytes before offset are kept). Same errors as encode().
    void encodeInto(std::span<const uint8_t> rgb, int width, int height, std::string& out, size_t offset);

private:
    void* handle_ = nullptr;
    int quality_;
    std::string scratch_;  ///< TurboJPEG's output, kept at its worst-case size (see encodeInto)
};

}  // namespace rtpm::server
