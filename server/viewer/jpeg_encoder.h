// JPEG encoding of live frames with libjpeg-turbo's TurboJPEG API (chosen by tests/bench/viewer_encode_bench).
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace rtpm::server {

/// Encodes 8-bit RGB images to baseline JPEG (4:2:0, fast DCT). Reuses one compressor and one
/// output buffer. Not thread-safe: one per thread.
class JpegEncoder {
public:
    explicit JpegEncoder(int quality = 85);
    ~JpegEncoder();
    JpegEncoder(const JpegEncoder&) = delete;
    JpegEncoder& operator=(const JpegEncoder&) = delete;

    /// JPEG bytes of `rgb` (width·height·3, rows from the top). Throws std::runtime_error with
    /// libjpeg-turbo's message on failure, std::invalid_argument on a size mismatch.
    std::string encode(std::span<const uint8_t> rgb, int width, int height);

private:
    void* handle_ = nullptr;
    int quality_;
};

}  // namespace rtpm::server
