// TurboJPEG wrapper.
#include "server/viewer/jpeg_encoder.h"

#include <turbojpeg.h>

#include <stdexcept>

namespace rtpm::server {

JpegEncoder::JpegEncoder(int quality) : handle_(tjInitCompress()), quality_(quality) {
    if (!handle_) throw std::runtime_error("tjInitCompress failed");
}

JpegEncoder::~JpegEncoder() { tjDestroy(handle_); }

std::string JpegEncoder::encode(std::span<const uint8_t> rgb, int width, int height) {
    std::string bytes;
    encodeInto(rgb, width, height, bytes, 0);
    return bytes;
}

void JpegEncoder::encodeInto(std::span<const uint8_t> rgb, int width, int height, std::string& out, size_t offset) {
    if (width <= 0 || height <= 0 || rgb.size() != size_t(width) * size_t(height) * 3)
        throw std::invalid_argument("JpegEncoder: buffer does not hold width × height RGB pixels");
    // TJFLAG_NOREALLOC: TurboJPEG writes into our buffer, sized for the worst case, and never
    // allocates its own (the string keeps its capacity across frames).
    const unsigned long bound = tjBufSize(width, height, TJSAMP_420);
    if (bound == (unsigned long)-1) throw std::runtime_error(std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle_));
    out.resize(offset + bound);
    unsigned char* dst = reinterpret_cast<unsigned char*>(out.data() + offset);
    unsigned long size = bound;
    if (tjCompress2(handle_, rgb.data(), width, 0, height, TJPF_RGB, &dst, &size, TJSAMP_420, quality_,
                    TJFLAG_FASTDCT | TJFLAG_NOREALLOC) != 0)
        throw std::runtime_error(std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle_));
    out.resize(offset + size);
}

}  // namespace rtpm::server
