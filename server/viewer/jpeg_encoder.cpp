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
    if (width <= 0 || height <= 0 || rgb.size() != size_t(width) * size_t(height) * 3)
        throw std::invalid_argument("JpegEncoder: buffer does not hold width × height RGB pixels");
    unsigned char* out = nullptr;
    unsigned long size = 0;
    if (tjCompress2(handle_, rgb.data(), width, 0, height, TJPF_RGB, &out, &size, TJSAMP_420, quality_,
                    TJFLAG_FASTDCT) != 0) {
        std::string why = tjGetErrorStr2(handle_);
        tjFree(out);
        throw std::runtime_error("JPEG encoding failed: " + why);
    }
    std::string bytes(reinterpret_cast<const char*>(out), size);
    tjFree(out);
    return bytes;
}

}  // namespace rtpm::server
