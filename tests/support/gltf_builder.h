// Writes small glTF 2.0 files for tests: binary data as an embedded base64 buffer, the rest as
// JSON text the test spells out (so each test shows exactly the extension syntax it exercises).
#pragma once

#include <stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace rtpm::testgltf {

/// 8-bit sRGB PNG of `rgb` (w × h × 3 bytes, row 0 at the top), as exporters embed textures.
/// Throws std::runtime_error if stb cannot encode it.
inline std::vector<uint8_t> pngBytes(int w, int h, const std::vector<uint8_t>& rgb) {
    std::vector<uint8_t> png;
    auto append = [](void* context, void* data, int size) {
        auto* out = static_cast<std::vector<uint8_t>*>(context);
        out->insert(out->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
    };
    if (!stbi_write_png_to_func(append, &png, w, h, 3, rgb.data(), w * 3) || png.empty())
        throw std::runtime_error("cannot encode a test PNG");
    return png;
}

/// Standard base64 (RFC 4648) of `bytes`, as data URIs need.
inline std::string base64(const std::string& bytes) {
    static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        const uint32_t v = (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8) |
                           uint8_t(bytes[i + 2]);
        for (int k = 3; k >= 0; --k) out += kAlphabet[(v >> (6 * k)) & 63];
    }
    if (i + 1 == bytes.size()) {
        const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += "==";
    } else if (i + 2 == bytes.size()) {
        const uint32_t v = (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8);
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += kAlphabet[(v >> 6) & 63];
        out += "=";
    }
    return out;
}

/// Collects buffer data, buffer views, accessors and images; json() wraps them around the
/// test's own top-level members (scenes, nodes, meshes, materials, textures, extensions, …).
class GltfBuilder {
public:
    /// FLOAT accessor of `type` ("SCALAR", "VEC2", "VEC3", "VEC4") over `values`; returns its index.
    /// VEC3 accessors get min/max (POSITION requires them).
    int floats(const std::vector<float>& values, const std::string& type) {
        const int comps = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : 4;
        const int view = addView(values.data(), values.size() * sizeof(float));
        std::string acc = R"({"bufferView":)" + std::to_string(view) + R"(,"componentType":5126,"count":)" +
                          std::to_string(values.size() / size_t(comps)) + R"(,"type":")" + type + "\"";
        if (comps == 3 && !values.empty()) {
            float lo[3] = {values[0], values[1], values[2]}, hi[3] = {values[0], values[1], values[2]};
            for (size_t i = 0; i < values.size(); ++i) {
                lo[i % 3] = std::min(lo[i % 3], values[i]);
                hi[i % 3] = std::max(hi[i % 3], values[i]);
            }
            acc += R"(,"min":[)" + num(lo[0]) + "," + num(lo[1]) + "," + num(lo[2]) + R"(],"max":[)" +
                   num(hi[0]) + "," + num(hi[1]) + "," + num(hi[2]) + "]";
        }
        accessors_.push_back(acc + "}");
        return int(accessors_.size() - 1);
    }
    /// Integer accessor (KHR_mesh_quantization's forms) of `type` ("VEC2", "VEC3", …) over `values`,
    /// stored as `componentType` (5120 BYTE, 5121 UNSIGNED_BYTE, 5122 SHORT, 5123 UNSIGNED_SHORT,
    /// matching T), with the accessor's `normalized` flag; returns its index.
    template <typename T>
    int integers(const std::vector<T>& values, int componentType, const std::string& type, bool normalized) {
        const int comps = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : 4;
        const int view = addView(values.data(), values.size() * sizeof(T));
        accessors_.push_back(R"({"bufferView":)" + std::to_string(view) + R"(,"componentType":)" +
                             std::to_string(componentType) + R"(,"normalized":)" + (normalized ? "true" : "false") +
                             R"(,"count":)" + std::to_string(values.size() / size_t(comps)) + R"(,"type":")" +
                             type + "\"}");
        return int(accessors_.size() - 1);
    }
    /// UNSIGNED_INT index accessor; returns its index.
    int indices(const std::vector<uint32_t>& values) {
        const int view = addView(values.data(), values.size() * sizeof(uint32_t));
        accessors_.push_back(R"({"bufferView":)" + std::to_string(view) +
                             R"(,"componentType":5125,"count":)" + std::to_string(values.size()) +
                             R"(,"type":"SCALAR"})");
        return int(accessors_.size() - 1);
    }
    /// Bytes stored in a buffer view of their own (e.g. a Draco mesh); returns the view's index.
    int raw(const void* data, size_t bytes) { return addView(data, bytes); }
    /// An accessor without a bufferView, as KHR_draco_mesh_compression's primitives have them:
    /// `count` elements of `type`, FLOAT unless `componentType` says otherwise; returns its index.
    int dataless(size_t count, const std::string& type, int componentType = 5126) {
        accessors_.push_back(R"({"componentType":)" + std::to_string(componentType) + R"(,"count":)" +
                             std::to_string(count) + R"(,"type":")" + type + "\"}");
        return int(accessors_.size() - 1);
    }
    /// An image stored in a buffer view (`mime` e.g. "image/png"); returns its index in "images".
    int image(const std::vector<uint8_t>& encoded, const std::string& mime) {
        const int view = addView(encoded.data(), encoded.size());
        images_.push_back(R"({"bufferView":)" + std::to_string(view) + R"(,"mimeType":")" + mime + "\"}");
        return int(images_.size() - 1);
    }
    /// A quad mesh primitive's attributes in the plane through `centre` spanned by ±u, ±v
    /// (front face towards cross(u, v)), uv (0,0)…(1,1) with v = 0 at the −v edge. Returns the
    /// primitive JSON without its material: {"attributes":{…},"indices":n
    std::string quadPrimitive(const float centre[3], const float u[3], const float v[3]) {
        std::vector<float> p, n, t;
        const float su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
        const float nx = u[1] * v[2] - u[2] * v[1], ny = u[2] * v[0] - u[0] * v[2], nz = u[0] * v[1] - u[1] * v[0];
        const float nl = std::sqrt(nx * nx + ny * ny + nz * nz);
        for (int k = 0; k < 4; ++k) {
            for (int c = 0; c < 3; ++c) p.push_back(centre[c] + su[k] * u[c] + sv[k] * v[c]);
            n.insert(n.end(), {nx / nl, ny / nl, nz / nl});
            t.insert(t.end(), {0.5f * (su[k] + 1.0f), 0.5f * (sv[k] + 1.0f)});
        }
        const int pa = floats(p, "VEC3"), na = floats(n, "VEC3"), ta = floats(t, "VEC2");
        const int ia = indices({0, 1, 2, 0, 2, 3});
        return R"({"attributes":{"POSITION":)" + std::to_string(pa) + R"(,"NORMAL":)" + std::to_string(na) +
               R"(,"TEXCOORD_0":)" + std::to_string(ta) + R"(},"indices":)" + std::to_string(ia);
    }
    /// The whole file: `members` are the test's own top-level members, comma-separated, without
    /// the enclosing braces (e.g. R"("scene":0,"scenes":[…],"nodes":[…],"meshes":[…])").
    std::string json(const std::string& members) const {
        std::string out = R"({"asset":{"version":"2.0"},)" + members;
        if (!bin_.empty())
            out += R"(,"buffers":[{"byteLength":)" + std::to_string(bin_.size()) +
                   R"(,"uri":"data:application/octet-stream;base64,)" + base64(bin_) + R"("}])";
        out += R"(,"bufferViews":[)" + join(views_) + "]";
        out += R"(,"accessors":[)" + join(accessors_) + "]";
        if (!images_.empty()) out += R"(,"images":[)" + join(images_) + "]";
        return out + "}";
    }
    /// A float as JSON with enough digits to round-trip.
    static std::string num(double v) {
        char buf[40];
        std::snprintf(buf, sizeof buf, "%.9g", v);
        return buf;
    }

private:
    int addView(const void* data, size_t bytes) {
        while (bin_.size() % 4) bin_.push_back('\0');
        views_.push_back(R"({"buffer":0,"byteOffset":)" + std::to_string(bin_.size()) + R"(,"byteLength":)" +
                         std::to_string(bytes) + "}");
        bin_.append(static_cast<const char*>(data), bytes);
        return int(views_.size() - 1);
    }
    static std::string join(const std::vector<std::string>& parts) {
        std::string out;
        for (size_t i = 0; i < parts.size(); ++i) out += (i ? "," : "") + parts[i];
        return out;
    }
    std::string bin_;
    std::vector<std::string> views_, accessors_, images_;
};

}  // namespace rtpm::testgltf
