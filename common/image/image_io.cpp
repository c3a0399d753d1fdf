// Image output and input through OpenImageIO: multi-layer EXR, tone-mapped sRGB PNG.
#include "common/image/image_io.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <stdexcept>

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

void writeImage(const std::string& path, const OIIO::ImageSpec& spec, OIIO::TypeDesc dataType,
                const void* data) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out)
        throw std::runtime_error(path + ": cannot create an image writer: " + OIIO::geterror());
    if (!out->open(path, spec)) throw std::runtime_error(path + ": cannot open for writing: " + out->geterror());
    if (!out->write_image(dataType, data)) {
        const std::string err = out->geterror();
        out->close();
        throw std::runtime_error(path + ": write failed: " + err);
    }
    if (!out->close()) throw std::runtime_error(path + ": close failed: " + out->geterror());
}

}  // namespace

void writeExr(const std::string& path, int width, int height, std::span<const ImageLayer> layers,
              bool half) {
    if (layers.empty()) throw std::invalid_argument(path + ": no layers to write");
    std::set<std::string> names;
    for (const ImageLayer& layer : layers) {
        checkSize(path.c_str(), width, height, layer.rgb.size());
        if (!names.insert(layer.name).second)
            throw std::invalid_argument(path + ": layer '" + layer.name + "' given twice");
    }
    const int nch = int(layers.size()) * 3;
    OIIO::ImageSpec spec(width, height, nch, half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    spec.channelnames.clear();
    for (const ImageLayer& layer : layers)
        for (const char* c : {"R", "G", "B"})
            spec.channelnames.push_back(layer.name.empty() ? std::string(c) : layer.name + "." + c);
    spec.alpha_channel = -1;
    spec.attribute("compression", "zip");
    // Interleave all layers pixel by pixel, the layout write_image expects.
    const size_t pixels = size_t(width) * size_t(height);
    std::vector<float> data(pixels * size_t(nch));
    for (size_t p = 0; p < pixels; ++p)
        for (size_t l = 0; l < layers.size(); ++l)
            for (size_t c = 0; c < 3; ++c)
                data[p * size_t(nch) + l * 3 + c] = finiteOrZero(layers[l].rgb[p * 3 + c]);
    writeImage(path, spec, OIIO::TypeDesc::FLOAT, data.data());
}

void writeExr(const std::string& path, const FrameImage& frame, bool half) {
    const ImageLayer layers[] = {{"", frame.final()},
                                 {"direct", frame.direct()},
                                 {"caustic", frame.caustic()},
                                 {"caustic_filtered", frame.causticFiltered()}};
    writeExr(path, frame.width(), frame.height(), layers, half);
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

ExrImage readExr(const std::string& path) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw std::runtime_error(path + ": cannot open image: " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    ExrImage img;
    img.width = spec.width;
    img.height = spec.height;
    const int nch = spec.nchannels;
    if (img.width <= 0 || img.height <= 0 || nch <= 0)
        throw std::runtime_error(path + ": image has no pixels or channels");
    const size_t pixels = size_t(img.width) * size_t(img.height);
    std::vector<float> data(pixels * size_t(nch));
    if (!in->read_image(0, 0, 0, nch, OIIO::TypeDesc::FLOAT, data.data()))
        throw std::runtime_error(path + ": cannot decode image: " + in->geterror());
    in->close();
    for (int c = 0; c < nch; ++c) {
        const std::string name = c < int(spec.channelnames.size()) ? spec.channelnames[size_t(c)]
                                                                   : "channel" + std::to_string(c);
        img.channelNames.push_back(name);
        std::vector<float>& plane = img.channels[name];
        plane.resize(pixels);
        for (size_t p = 0; p < pixels; ++p) plane[p] = data[p * size_t(nch) + size_t(c)];
    }
    return img;
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
    const float scale = toneMap.exposureStops ? std::exp2(*toneMap.exposureStops) : autoExposureScale(rgb);
    std::vector<unsigned char> bytes(rgb.size());
    for (size_t i = 0; i < rgb.size(); ++i)
        bytes[i] = static_cast<unsigned char>(std::lround(255.0f * linearToSrgb(finiteOrZero(rgb[i] * scale))));
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    writeImage(path, spec, OIIO::TypeDesc::UINT8, bytes.data());
    return scale;
}

std::string numberedPath(const std::string& out, uint64_t frame, const char* ext) {
    std::filesystem::path p(out);
    char buf[32];
    std::snprintf(buf, sizeof buf, "_%05llu", static_cast<unsigned long long>(frame));
    return (p.parent_path() / (p.stem().string() + buf + ext)).string();
}

}  // namespace rtpm
