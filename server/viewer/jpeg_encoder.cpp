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
    // TJFLAG_NOREALLOC: TurboJPEG writes into a buffer of ours sized for the worst case (~1.2 MB at
    // 640×480) and never allocates its own. That buffer stays at its size across frames: sizing
    // `out` to the bound every frame zero-filled it (a memset costing ~5 % of the encode), copying
    // the JPEG (~20–60 kB) out costs a few microseconds.
    const unsigned long bound = tjBufSize(width, height, TJSAMP_420);
    if (bound == (unsigned long)-1) throw std::runtime_error(std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle_));
    if (scratch_.size() < bound) scratch_.resize(bound);
    unsigned char* dst = reinterpret_cast<unsigned char*>(scratch_.data());
    unsigned long size = bound;
    if (tjCompress2(handle_, rgb.data(), width, 0, height, TJPF_RGB, &dst, &size, TJSAMP_420, quality_,
                    TJFLAG_FASTDCT | TJFLAG_NOREALLOC) != 0)
        throw std::runtime_error(std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle_));
    out.resize(offset);
    out.append(scratch_.data(), size);
}

}  // namespace rtpm::server
