// Image decoding through stb_image, sRGB to linear, charged to the scene's budget first.
#include "common/scene/texture_decode.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <stb_image.h>

namespace rtpm {

namespace {

constexpr uint64_t kMaxTexels = uint64_t(1) << 26;

float srgbToLinear(float c) {
    c = std::clamp(std::isfinite(c) ? c : 0.0f, 0.0f, 1.0f);
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

}  // namespace

Texture decodeSrgbTexture(const std::vector<uint8_t>& encoded, const std::string& formatHint,
                          const std::string& file, const std::string& element, SceneFiles* files, bool srgb) {
    if (encoded.empty()) throw SceneError(file, element, "image data is empty");
    // stb_image recognises the format from its signature (PNG, JPEG, BMP, TGA, GIF, …); the hint
    // only names what was expected in the error message.
    if (encoded.size() > size_t(std::numeric_limits<int>::max()))
        throw SceneError(file, element, "image data is too large");
    const auto* bytes = reinterpret_cast<const stbi_uc*>(encoded.data());
    const int length = int(encoded.size());
    int width = 0, height = 0, nch = 0;
    if (!stbi_info_from_memory(bytes, length, &width, &height, &nch))
        throw SceneError(file, element, "cannot decode image (" + formatHint + "): " + stbi_failure_reason());
    if (width <= 0 || height <= 0 || nch <= 0 || uint64_t(width) * uint64_t(height) > kMaxTexels)
        throw SceneError(file, element,
                         "image size " + std::to_string(width) + "x" + std::to_string(height) + " unsupported");
    // The decoded texture is charged before any pixel is decoded (the decode needs as much again).
    if (files) files->charge(uint64_t(width) * uint64_t(height) * 3 * sizeof(float), element);
    // Values as stored, scaled to [0, 1]; 16-bit images keep their precision.
    const size_t count = size_t(width) * size_t(height) * size_t(nch);
    std::vector<float> pixels(count);
    auto take = [&](auto* px, float scale) {
        if (!px) throw SceneError(file, element, "cannot decode image (" + formatHint + "): " + stbi_failure_reason());
        for (size_t i = 0; i < count; ++i) pixels[i] = float(px[i]) * scale;
        stbi_image_free(px);
    };
    if (stbi_is_16_bit_from_memory(bytes, length))
        take(stbi_load_16_from_memory(bytes, length, &width, &height, &nch, 0), 1.0f / 65535.0f);
    else
        take(stbi_load_from_memory(bytes, length, &width, &height, &nch, 0), 1.0f / 255.0f);
    Texture tex;
    tex.name = element;
    tex.width = width;
    tex.height = height;
    const size_t texels = size_t(tex.width) * size_t(tex.height);
    tex.rgb.resize(texels * 3);
    for (size_t p = 0; p < texels; ++p)
        for (size_t c = 0; c < 3; ++c)
            tex.rgb[p * 3 + c] = srgb ? srgbToLinear(pixels[p * size_t(nch) + (nch >= 3 ? c : 0)])
                                      : pixels[p * size_t(nch) + (nch >= 3 ? c : 0)];
    return tex;
}

}  // namespace rtpm
