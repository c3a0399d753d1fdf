// loadEnvironment: an OpenEXR or Radiance HDR file decoded from memory into a checked Environment.
#include "common/scene/environment_loader.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <stb_image.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <limits>

#include "common/scene/scene.h"
#include "common/scene/scene_files.h"

namespace rtpm {

namespace {

const char* const kElement = "environment";

/// An in-memory file for OpenEXR (it reads through an IStream, never a path, so the bytes read
/// are those the budget admitted).
class MemoryStream : public Imf::IStream {
public:
    MemoryStream(const std::vector<uint8_t>& bytes, const char* name) : Imf::IStream(name), bytes_(bytes) {}
    bool read(char c[], int n) override {
        if (n < 0 || pos_ + uint64_t(n) > bytes_.size()) throw std::runtime_error("file ends early");
        std::memcpy(c, bytes_.data() + pos_, size_t(n));
        pos_ += uint64_t(n);
        return pos_ < bytes_.size();
    }
    uint64_t tellg() override { return pos_; }
    void seekg(uint64_t pos) override { pos_ = pos; }

private:
    const std::vector<uint8_t>& bytes_;
    uint64_t pos_ = 0;
};

/// Charges decoded bytes against what the budget has left.
struct Budget {
    const std::string& file;
    uint64_t left;
    void charge(uint64_t bytes, const char* what) {
        if (bytes > left)
            throw SceneError(file, kElement,
                             std::string(what) + " needs " + std::to_string(bytes) +
                                 " bytes, more than --max-scene-bytes leaves after the scene (" +
                                 std::to_string(left) + ")");
        left -= bytes;
    }
};

void checkSize(const std::string& file, int64_t width, int64_t height) {
    if (width <= 0 || height <= 0 || width != 2 * height || uint64_t(width) * uint64_t(height) > kMaxEnvironmentTexels) {
        Texture probe;  // the size rule and its message live in validateEnvironmentMap
        probe.width = int(std::clamp<int64_t>(width, 0, std::numeric_limits<int>::max()));
        probe.height = int(std::clamp<int64_t>(height, 0, std::numeric_limits<int>::max()));
        validateEnvironmentMap(probe, file);
        throw SceneError(file, kElement, "map size unsupported");
    }
}

Texture decodeExr(const std::vector<uint8_t>& bytes, const std::string& file, Budget& budget) {
    Texture map;
    try {
        MemoryStream stream(bytes, file.c_str());
        Imf::InputFile in(stream);
        const Imath::Box2i dw = in.header().dataWindow();
        const int64_t width = int64_t(dw.max.x) - dw.min.x + 1, height = int64_t(dw.max.y) - dw.min.y + 1;
        checkSize(file, width, height);
        const Imf::ChannelList& channels = in.header().channels();
        const bool rgb = channels.findChannel("R") && channels.findChannel("G") && channels.findChannel("B");
        const bool grey = !rgb && channels.findChannel("Y");
        if (!rgb && !grey)
            throw SceneError(file, kElement, "the EXR has neither R, G, B nor Y channels");
        budget.charge(uint64_t(width) * uint64_t(height) * 3 * sizeof(float), "the decoded map");
        map.width = int(width);
        map.height = int(height);
        map.rgb.assign(size_t(width) * size_t(height) * 3, 0.0f);
        Imf::FrameBuffer fb;
        const size_t xs = 3 * sizeof(float), ys = xs * size_t(width);
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < (rgb ? 3 : 1); ++c)
            fb.insert(rgb ? names[c] : "Y", Imf::Slice::Make(Imf::FLOAT, map.rgb.data() + c, dw, xs, ys));
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        if (grey)
            for (size_t p = 0; p < map.rgb.size(); p += 3) map.rgb[p + 1] = map.rgb[p + 2] = map.rgb[p];
    } catch (const SceneError&) {
        throw;
    } catch (const std::exception& e) {
        throw SceneError(file, kElement, std::string("cannot decode the OpenEXR file: ") + e.what());
    }
    return map;
}

Texture decodeHdr(const std::vector<uint8_t>& bytes, const std::string& file, Budget& budget) {
    const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
    const int length = int(bytes.size());
    int width = 0, height = 0, nch = 0;
    if (!stbi_info_from_memory(data, length, &width, &height, &nch))
        throw SceneError(file, kElement, std::string("cannot decode the Radiance HDR file: ") + stbi_failure_reason());
    checkSize(file, width, height);
    budget.charge(uint64_t(width) * uint64_t(height) * 3 * sizeof(float), "the decoded map");
    float* px = stbi_loadf_from_memory(data, length, &width, &height, &nch, 3);
    if (!px) throw SceneError(file, kElement, std::string("cannot decode the Radiance HDR file: ") + stbi_failure_reason());
    Texture map;
    map.width = width;
    map.height = height;
    map.rgb.assign(px, px + size_t(width) * size_t(height) * 3);
    stbi_image_free(px);
    return map;
}

void checkValue(const std::string& file, const char* what, float v) {
    if (!(std::isfinite(v) && v >= 0.0f && v <= kMaxRadiantValue))
        throw SceneError(file, kElement,
                         std::string(what) + " " + std::to_string(v) + " is not a finite value in [0, 1e26]");
}

}  // namespace

Environment loadEnvironment(const EnvironmentOverride& request, uint64_t budgetBytes) {
    const std::string name = request.file.empty() ? std::string("--env-color") : request.file;
    checkValue(name, "--env-strength", request.strength);
    if (request.file.empty()) {
        for (int c = 0; c < 3; ++c) checkValue(name, "--env-color component", request.colour[c]);
        const Vec3 radiance = request.colour * request.strength;
        if (!finite(radiance) || maxComponent(radiance) > kMaxRadiantValue)
            throw SceneError(name, kElement, "--env-color times --env-strength exceeds 1e26");
        return Environment::uniform(radiance);
    }
    Budget budget{request.file, budgetBytes};
    const std::vector<uint8_t> bytes = readRegularFile(
        request.file, request.file, kElement, [&](uint64_t size) { budget.charge(size, "the file"); });
    static constexpr uint8_t kExrMagic[4] = {0x76, 0x2f, 0x31, 0x01};
    if (bytes.size() > size_t(std::numeric_limits<int>::max()))
        throw SceneError(request.file, kElement, "file too large");
    Texture map;
    if (bytes.size() >= 4 && std::equal(kExrMagic, kExrMagic + 4, bytes.begin()))
        map = decodeExr(bytes, request.file, budget);
    else if (stbi_is_hdr_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), int(bytes.size())))
        map = decodeHdr(bytes, request.file, budget);
    else
        throw SceneError(request.file, kElement,
                         "neither an OpenEXR nor a Radiance HDR file: an environment map holds linear "
                         "radiance (convert an 8-bit image with e.g. oiiotool IN -o OUT.exr)");
    validateEnvironmentMap(map, request.file);
    // The sampling tables: two doubles per texel.
    budget.charge(uint64_t(map.width) * uint64_t(map.height) * 2 * sizeof(double), "the map's sampling tables");
    if (request.strength != 1.0f) {
        for (float& v : map.rgb) v *= request.strength;
        validateEnvironmentMap(map, request.file);  // a product beyond 1e26 is refused
    }
    return Environment::fromMap(map);
}

Environment defaultSky() {
    // Rows of 0.7°: coarser rows show as bands in the background and in mirrors (8-bit steps).
    constexpr int kHeight = 256, kWidth = 2 * kHeight;
    Texture map;
    map.width = kWidth;
    map.height = kHeight;
    map.rgb.resize(size_t(kWidth) * kHeight * 3);
    for (int j = 0; j < kHeight; ++j) {
        // Sine of the row centre's elevation: 1 at the zenith, 0 at the horizon, −1 at the nadir;
        // the radiance is linear in it on each side, continuous across the horizon.
        const float elevation = std::cos(kPi * (float(j) + 0.5f) / float(kHeight));
        const float value = 0.06f + (elevation > 0.0f ? 0.06f : 0.03f) * elevation;
        for (int i = 0; i < kWidth; ++i)
            for (int c = 0; c < 3; ++c) map.rgb[(size_t(j) * kWidth + size_t(i)) * 3 + size_t(c)] = value;
    }
    return Environment::fromMap(map);
}

}  // namespace rtpm
