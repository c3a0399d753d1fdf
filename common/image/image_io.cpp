// Image output and input: multi-layer EXR through OpenEXR, tone-mapped sRGB PNG through stb.
// (Not OpenImageIO: its Debian build loads ~400 MB of codec libraries — FFmpeg, OpenCV, OpenVDB,
// GDAL — that the runtime image would have to carry for two file formats.)
#include "common/image/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImfTestFile.h>
#include <ImfThreading.h>
#include <half.h>
#include <stb_image.h>
#include <stb_image_write.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "common/core/output_file.h"
#include "common/image/frame_image.h"

namespace rtpm {

namespace {

void checkSize(const char* what, int width, int height, size_t floats) {
    if (width <= 0 || height <= 0)
        throw std::invalid_argument(std::string(what) + ": image size " + std::to_string(width) + "×" +
                                    std::to_string(height) + " is not positive");
    if (floats != size_t(width) * size_t(height) * 3)
        throw std::invalid_argument(std::string(what) + ": " + std::to_string(floats) +
                                    " floats given, expected width·height·3 = " +
                                    std::to_string(size_t(width) * size_t(height) * 3));
}

float finiteOrZero(float v) { return std::isfinite(v) ? v : 0.0f; }

// Flushes `path`'s data to disk, so the rename that follows never publishes an empty file after
// a crash.
bool syncFile(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false;
    const bool ok = ::fsync(fd) == 0;
    ::close(fd);
    return ok;
}

// Runs `write` on a temporary file beside `path`, flushes it and renames it over `path`; on any
// failure the temporary file is removed and `path` is left as it was.
void writeThroughTemporary(const std::string& path, const std::function<void(const std::string& tmp)>& write) {
    const std::string tmp = temporaryPathBeside(path);
    auto removeTmp = [&] {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
    };
    try {
        write(tmp);
    } catch (...) {
        removeTmp();
        throw;
    }
    if (!syncFile(tmp)) {
        const std::string why = std::strerror(errno);
        removeTmp();
        throw std::runtime_error(path + ": cannot flush to disk: " + why);
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        removeTmp();
        throw std::runtime_error(path + ": cannot move the written image into place: " + ec.message());
    }
}

}  // namespace

ImageOutputPaths imageOutputPaths(const std::string& out) {
    std::filesystem::path p(out);
    std::error_code ec;
    if (!out.empty() && (out.back() == '/' || std::filesystem::is_directory(p, ec)))
        throw OutputError("--out " + out + ": names a folder: give the image's file name in it, ending in .exr (or "
                          ".png), e.g. " + (p / "image.exr").lexically_normal().string());
    std::string ext = p.extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (ext != ".exr" && ext != ".png")
        throw OutputError("--out " + out + ": the image is written as an EXR with a PNG beside it: give a path ending "
                          "in .exr (or .png), e.g. " + p.replace_extension(".exr").string());
    ImageOutputPaths paths;
    paths.exr = std::filesystem::path(out).replace_extension(".exr").string();
    paths.png = std::filesystem::path(out).replace_extension(".png").string();
    return paths;
}

void writeExr(const std::string& path, int width, int height, std::span<const ImageLayer> layers,
              bool half, const ExrAttributes& attributes) {
    if (layers.empty()) throw std::invalid_argument(path + ": no layers to write");
    // The header's own fields (Imf::Header's required attributes) must not be replaced by text.
    static const std::set<std::string> kReserved = {"channels", "compression", "dataWindow", "displayWindow",
                                                    "lineOrder", "pixelAspectRatio", "screenWindowCenter",
                                                    "screenWindowWidth", "tiles", "type", "name", "version",
                                                    "chunkCount"};
    for (const auto& [name, value] : attributes)
        if (name.empty() || kReserved.count(name))
            throw std::invalid_argument(path + ": attribute name '" + name + "' is reserved by OpenEXR");
    std::set<std::string> names;
    for (const ImageLayer& layer : layers) {
        checkSize(path.c_str(), width, height, layer.rgb.size());
        if (!names.insert(layer.name).second)
            throw std::invalid_argument(path + ": layer '" + layer.name + "' given twice");
    }
    // One plane per channel (OpenEXR slices) in the file's pixel type: OpenEXR converts types
    // when it reads, not when it writes. Non-finite values become 0.
    const size_t pixels = size_t(width) * size_t(height);
    std::vector<std::vector<float>> floatPlanes;
    std::vector<std::vector<::half>> halfPlanes;
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    // zlib's fastest level: the image written at the end of a run is on the run's critical path
    // (a 320×240 image of four layers: 8.3 ms against 16.2 ms at OpenEXR's default level 6 on
    // two threads, for a file 12 % larger, 605 against 538 kB).
    header.zipCompressionLevel() = 1;
    for (const auto& [name, value] : attributes) header.insert(name, Imf::StringAttribute(value));
    Imf::FrameBuffer frameBuffer;
    for (const ImageLayer& layer : layers) {
        for (size_t c = 0; c < 3; ++c) {
            const std::string name = (layer.name.empty() ? "" : layer.name + ".") + "RGB"[c];
            char* base = nullptr;
            size_t bytes = 0;
            if (half) {
                std::vector<::half>& plane = halfPlanes.emplace_back(pixels);
                for (size_t p = 0; p < pixels; ++p) plane[p] = ::half(finiteOrZero(layer.rgb[p * 3 + c]));
                base = reinterpret_cast<char*>(plane.data());
                bytes = sizeof(::half);
            } else {
                std::vector<float>& plane = floatPlanes.emplace_back(pixels);
                for (size_t p = 0; p < pixels; ++p) plane[p] = finiteOrZero(layer.rgb[p * 3 + c]);
                base = reinterpret_cast<char*>(plane.data());
                bytes = sizeof(float);
            }
            const Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
            header.channels().insert(name, Imf::Channel(type));
            frameBuffer.insert(name, Imf::Slice(type, base, bytes, bytes * size_t(width)));
        }
    }
    // OpenEXR compresses the file's blocks on its own worker threads, none by default: one per
    // core (a 320×240 image of four layers took 24 ms on one thread).
    static std::once_flag threads;
    std::call_once(threads, [] { Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency()))); });
    writeThroughTemporary(path, [&](const std::string& tmp) {
        try {
            Imf::OutputFile file(tmp.c_str(), header);
            file.setFrameBuffer(frameBuffer);
            file.writePixels(height);
        } catch (const std::exception& e) {
            throw std::runtime_error(path + ": cannot write EXR: " + e.what());
        }
    });
}

void writeExr(const std::string& path, const FrameImage& frame, bool half, const ExrAttributes& attributes) {
    const ImageLayer layers[] = {{"", frame.final()},
                                 {"direct", frame.direct()},
                                 {"caustic", frame.caustic()},
                                 {"caustic_filtered", frame.causticFiltered()}};
    writeExr(path, frame.width(), frame.height(), layers, half, attributes);
}

std::vector<float> ExrImage::layerRgb(const std::string& name) const {
    const std::string prefix = name.empty() ? "" : name + ".";
    const std::vector<float>& r = channels.at(prefix + "R");
    const std::vector<float>& g = channels.at(prefix + "G");
    const std::vector<float>& b = channels.at(prefix + "B");
    std::vector<float> rgb(r.size() * 3);
    for (size_t i = 0; i < r.size(); ++i) {
        rgb[3 * i + 0] = r[i];
        rgb[3 * i + 1] = g[i];
        rgb[3 * i + 2] = b[i];
    }
    return rgb;
}

namespace {

ExrImage readOpenExr(const std::string& path) {
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i window = file.header().dataWindow();
        ExrImage img;
        img.width = window.max.x - window.min.x + 1;
        img.height = window.max.y - window.min.y + 1;
        if (img.width <= 0 || img.height <= 0) throw std::runtime_error("image has no pixels");
        const size_t pixels = size_t(img.width) * size_t(img.height);
        Imf::FrameBuffer frameBuffer;
        for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) {
            if (it.channel().xSampling != 1 || it.channel().ySampling != 1)
                throw std::runtime_error(std::string("channel ") + it.name() + " is subsampled (unsupported)");
            img.channelNames.push_back(it.name());
            std::vector<float>& plane = img.channels[it.name()];
            plane.assign(pixels, 0.0f);
            // The slice origin is shifted so that data-window pixel (min.x, min.y) lands at plane[0].
            char* base = reinterpret_cast<char*>(plane.data()) -
                         (ptrdiff_t(window.min.x) + ptrdiff_t(window.min.y) * img.width) * ptrdiff_t(sizeof(float));
            frameBuffer.insert(it.name(), Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * size_t(img.width)));
        }
        if (img.channelNames.empty()) throw std::runtime_error("image has no channels");
        for (auto it = file.header().begin(); it != file.header().end(); ++it)
            if (const auto* text = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
                img.attributes[it.name()] = text->value();
        file.setFrameBuffer(frameBuffer);
        file.readPixels(window.min.y, window.max.y);
        return img;
    } catch (const std::exception& e) {
        throw std::runtime_error(path + ": cannot read EXR: " + e.what());
    }
}

/// PNG, JPEG, HDR, … through stb_image: 8- and 16-bit values scaled to [0, 1] (no transfer curve
/// applied, as stored), channels named Y, YA, RGB or RGBA.
ExrImage readStbImage(const std::string& path) {
    std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) throw std::runtime_error(path + ": cannot open image");
    int w = 0, h = 0, nch = 0;
    if (!stbi_info_from_file(f.get(), &w, &h, &nch))
        throw std::runtime_error(path + ": cannot decode image: " + stbi_failure_reason());
    std::vector<float> data;
    const size_t n = size_t(w) * size_t(h) * size_t(nch);
    auto decode = [&](auto* px, float scale) {
        if (!px) throw std::runtime_error(path + ": cannot decode image: " + stbi_failure_reason());
        data.resize(n);
        for (size_t i = 0; i < n; ++i) data[i] = float(px[i]) * scale;
        stbi_image_free(px);
    };
    if (stbi_is_hdr_from_file(f.get())) {
        stbi_hdr_to_ldr_gamma(1.0f);
        decode(stbi_loadf_from_file(f.get(), &w, &h, &nch, 0), 1.0f);
    } else if (stbi_is_16_bit_from_file(f.get())) {
        decode(stbi_load_from_file_16(f.get(), &w, &h, &nch, 0), 1.0f / 65535.0f);
    } else {
        decode(stbi_load_from_file(f.get(), &w, &h, &nch, 0), 1.0f / 255.0f);
    }
    static const char* const kNames[4][4] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    ExrImage img;
    img.width = w;
    img.height = h;
    const size_t pixels = size_t(w) * size_t(h);
    for (int c = 0; c < nch; ++c) {
        img.channelNames.push_back(kNames[nch - 1][c]);
        std::vector<float>& plane = img.channels[img.channelNames.back()];
        plane.resize(pixels);
        for (size_t p = 0; p < pixels; ++p) plane[p] = data[p * size_t(nch) + size_t(c)];
    }
    return img;
}

}  // namespace

ExrImage readExr(const std::string& path) {
    bool exr = false;
    try {
        exr = Imf::isOpenExrFile(path.c_str());
    } catch (const std::exception&) {
    }
    return exr ? readOpenExr(path) : readStbImage(path);
}

float linearToSrgb(float v) {
    v = std::clamp(v, 0.0f, 1.0f);
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

float autoExposureScale(std::span<const float> rgb) {
    const size_t n = rgb.size() / 3;
    if (n == 0) return 1.0f;
    std::vector<float> lum(n);
    for (size_t i = 0; i < n; ++i)
        lum[i] = finiteOrZero(0.2126f * rgb[3 * i] + 0.7152f * rgb[3 * i + 1] + 0.0722f * rgb[3 * i + 2]);
    const size_t k = std::min(n - 1, size_t(std::floor(0.99 * double(n - 1) + 0.5)));
    std::nth_element(lum.begin(), lum.begin() + std::ptrdiff_t(k), lum.end());
    const float p99 = lum[k];
    return p99 > 0.0f && std::isfinite(1.0f / p99) ? 1.0f / p99 : 1.0f;
}

float writePng(const std::string& path, int width, int height, std::span<const float> rgb,
               const ToneMap& toneMap) {
    checkSize(path.c_str(), width, height, rgb.size());
    const float scale = toneMap.exposureStops ? std::exp2(*toneMap.exposureStops)
                                              : autoExposureScale(rgb) * std::exp2(toneMap.stopsAboveAuto);
    std::vector<unsigned char> bytes(rgb.size());
    for (size_t i = 0; i < rgb.size(); ++i)
        bytes[i] = static_cast<unsigned char>(std::lround(255.0f * linearToSrgb(finiteOrZero(rgb[i] * scale))));
    writeThroughTemporary(path, [&](const std::string& tmp) {
        if (!stbi_write_png(tmp.c_str(), width, height, 3, bytes.data(), width * 3))
            throw std::runtime_error(path + ": cannot write PNG");
    });
    return scale;
}

std::string numberedPath(const std::string& out, uint64_t frame, const char* ext) {
    std::filesystem::path p(out);
    char buf[32];
    std::snprintf(buf, sizeof buf, "_%05llu", static_cast<unsigned long long>(frame));
    return (p.parent_path() / (p.stem().string() + buf + ext)).string();
}

}  // namespace rtpm
