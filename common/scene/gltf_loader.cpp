// glTF 2.0 import: tinygltf parses, this file checks every index and byte range and maps to Scene.
//
// tinygltf is trusted only for JSON/GLB framing. Everything it leaves unchecked (accessor
// ranges, strides, component types, node indices, image buffer views) is checked here before
// a byte is read, so malformed files end in SceneError, never a crash or a huge allocation.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

#include "common/scene/gltf_loader.h"

#include "common/core/printable_text.h"
#include "common/scene/scene_files.h"
#include "common/scene/scene_loader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <regex>
#include <set>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

namespace rtpm {

namespace {

// Deepest node hierarchy followed; deeper (or cyclic) hierarchies are errors.
constexpr int kMaxNodeDepth = 1024;
// Most mesh instances a scene may hold (nodes × primitives, EXT_mesh_gpu_instancing included):
// each costs an Embree instance and a transform, ~300 bytes, so this bounds them to ~1 GB.
constexpr size_t kMaxInstances = size_t(1) << 22;

const std::set<std::string>& supportedExtensions() {
    static const std::set<std::string> kSupported = {
        "KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior",
        "KHR_materials_volume", "KHR_materials_emissive_strength", "KHR_texture_transform",
        "KHR_materials_unlit", "EXT_mesh_gpu_instancing", "KHR_mesh_quantization",
        "KHR_materials_variants", "KHR_materials_pbrSpecularGlossiness"};
    return kSupported;
}

// ---- file system callbacks: every external file goes through SceneFiles (confined to the
// allowed folders, regular files only, bounded by the budget); no shell expansion (tinygltf's
// default uses wordexp) and never the working directory (tinygltf's second search path).
struct FsContext {
    SceneFiles* files = nullptr;
    std::string base;                                  // tinygltf's basedir, '/'-terminated
    std::map<std::string, std::filesystem::path> resolved;  // tinygltf's path → resolved file
    std::optional<SceneError> refusal;                 // first reference refused
};

const char* kExternalFile = "buffers/images (external file)";

bool fsFileExists(const std::string& path, void* user) {
    auto* ctx = static_cast<FsContext*>(user);
    // tinygltf tries basedir + uri, then "./" + uri: only the first is ours to answer.
    if (ctx->base.empty() ? path.rfind("./", 0) == 0 : path.rfind(ctx->base, 0) != 0) return false;
    // tinygltf has percent-decoded the URI already (dlib::urldecode).
    const std::string reference = path.substr(ctx->base.size());
    try {
        std::filesystem::path r = ctx->files->resolve(reference, kExternalFile);
        ctx->resolved[path] = r;
        return SceneFiles::exists(r);
    } catch (const SceneError& e) {
        if (!ctx->refusal) ctx->refusal = e;
        return false;
    }
}

std::string fsExpandPath(const std::string& path, void*) { return path; }

bool fsReadWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void* user) {
    auto* ctx = static_cast<FsContext*>(user);
    auto found = ctx->resolved.find(path);
    try {
        if (found == ctx->resolved.end()) throw SceneError(ctx->files->sceneFile(), kExternalFile, "not resolved");
        *out = ctx->files->read(found->second, kExternalFile);
        return true;
    } catch (const SceneError& e) {
        if (!ctx->refusal) ctx->refusal = e;
        if (err) *err += "refused";
        return false;
    }
}

bool fsWriteWholeFile(std::string* err, const std::string&, const std::vector<unsigned char>&,
                      void*) {
    if (err) *err += "writing is not supported by the loader";
    return false;
}

// Deferred image decoding: tinygltf hands buffer-view images over as a pointer computed from an
// unchecked byteOffset/byteLength, so those bytes are never touched here; they are read later
// from a checked range. Data-URI and external images arrive as a valid vector and are kept as is.
bool keepEncodedImage(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
    image->as_is = true;
    if (image->bufferView == -1 && bytes != nullptr && size > 0)
        image->image.assign(bytes, bytes + size);
    return true;
}

// tinygltf's error text names the place loosely; pick the glTF element it mentions.
std::string elementFromTinygltfError(const std::string& err) {
    static const std::regex kIndexed(
        R"((buffers?|bufferViews?|accessors?|meshes|mesh|nodes?|scenes?|materials?|textures?|images?|samplers?|cameras?|skins?|animations?|lights?)\[(\d+)\])",
        std::regex::icase);
    std::smatch m;
    if (std::regex_search(err, m, kIndexed)) {
        std::string kind = m[1].str();
        std::transform(kind.begin(), kind.end(), kind.begin(), ::tolower);
        if (kind.back() != 's' && kind != "mesh") kind += "s";
        if (kind == "mesh") kind = "meshes";
        return kind + "[" + m[2].str() + "]";
    }
    static const std::regex kNamed(
        R"(\b(buffers?|bufferViews?|accessors?|meshes|nodes|scenes|materials|textures|images|cameras|asset|extensionsRequired)\b)",
        std::regex::icase);
    if (std::regex_search(err, m, kNamed)) {
        std::string kind = m[1].str();
        if (kind == "Buffer" || kind == "buffer") kind = "buffers";
        return kind;
    }
    if (err.find("File not found") != std::string::npos ||
        err.find("File read error") != std::string::npos ||
        err.find("File size mismatch") != std::string::npos ||
        err.find("File is empty") != std::string::npos)
        return "buffers (external file)";
    if (err.find("JSON") != std::string::npos || err.find("json") != std::string::npos)
        return "JSON";
    if (err.find("glTF Binary") != std::string::npos || err.find("magic") != std::string::npos ||
        err.find("Chunk") != std::string::npos || err.find("binary") != std::string::npos ||
        err.find("GLB") != std::string::npos)
        return "GLB container";
    return "document";
}

// tinygltf converts `extras` and `extensions` recursively: a hostile file nesting arrays a
// million deep would overflow the stack. Real glTF nests a handful of levels.
constexpr int kMaxJsonDepth = 256;

// One pass over the JSON text in [p, p + n), ignoring brackets inside strings: its nesting
// depth and the characters of string values that are data: URIs (tinygltf decodes those into
// buffers and images before anything else could look at them).
// What one JSON object of the scene file costs once parsed, charged to the budget before parsing:
// tinygltf's DOM entry and its typed copy (a tinygltf::Node with its strings, maps and `extras`
// Value is ~0.5 KiB), then our instance and transform. Issue-sized measure: a million-node file
// (44 MB of JSON) took 1.8 GB in the master, ~1.8 KiB a node; 1 KiB is a floor of that.
constexpr uint64_t kBytesPerJsonObject = 1024;

struct JsonScan {
    int depth = 0;
    uint64_t dataUriChars = 0;
    /// JSON objects inside each top-level member ("nodes", "accessors"...), in file order.
    std::vector<std::pair<std::string, uint64_t>> objectsIn;
};

JsonScan scanJson(const unsigned char* p, size_t n) {
    JsonScan scan;
    int depth = 0;
    bool inString = false;
    size_t stringStart = 0;
    std::string member;  // the top-level member being scanned (the last string at depth 1)
    for (size_t i = 0; i < n; ++i) {
        unsigned char c = p[i];
        if (inString) {
            if (c == '\\') {
                ++i;
            } else if (c == '"') {
                inString = false;
                if (i - stringStart >= 5 && std::memcmp(p + stringStart, "data:", 5) == 0)
                    scan.dataUriChars += i - stringStart;
                if (depth == 1) member.assign(reinterpret_cast<const char*>(p + stringStart), std::min<size_t>(i - stringStart, 64));
            }
        } else if (c == '"') {
            inString = true;
            stringStart = i + 1;
        } else if (c == '[' || c == '{') {
            scan.depth = std::max(scan.depth, ++depth);
            if (c == '{' && depth >= 3) {
                if (scan.objectsIn.empty() || scan.objectsIn.back().first != member) scan.objectsIn.emplace_back(member, 0);
                ++scan.objectsIn.back().second;
            }
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    return scan;
}

std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r')) s.pop_back();
    return s;
}

bool finite3(Vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// `v` normalised, or `v` itself when it is already unit to float precision. Normalising a unit
// vector again may move it by an ulp; keeping it makes a scene that went through encodeGlb (the
// master's copy for cluster clients) load back with the very normals and light directions the
// master loaded, so the cluster's image equals rtpm-render's bit for bit.
Vec3 unitKeepingBits(Vec3 v) {
    const float len2 = glm::dot(v, v);
    return std::abs(len2 - 1.0f) <= 1e-6f ? v : v / std::sqrt(len2);
}

// ---- accessor reading -----------------------------------------------------------------

int componentBytes(int componentType) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
        default: return 0;
    }
}

int componentCount(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR: return 1;
        case TINYGLTF_TYPE_VEC2: return 2;
        case TINYGLTF_TYPE_VEC3: return 3;
        case TINYGLTF_TYPE_VEC4: return 4;
        case TINYGLTF_TYPE_MAT2: return 4;
        case TINYGLTF_TYPE_MAT3: return 9;
        case TINYGLTF_TYPE_MAT4: return 16;
        default: return 0;
    }
}

std::string componentTypeName(int componentType) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
        case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
        case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
        default: return std::to_string(componentType);
    }
}

// The vertex data readFloats reads, for the component types each may hold.
enum class Attribute { Position, Normal, TexCoord, InstanceVector };

const char* attributeName(Attribute a) {
    switch (a) {
        case Attribute::Position: return "POSITION";
        case Attribute::Normal: return "NORMAL";
        case Attribute::TexCoord: return "TEXCOORD_n";
        default: return "TRANSLATION/SCALE";
    }
}

// The (componentType, normalized) pairs attribute `a` may use: FLOAT always; texture coordinates
// also normalized UNSIGNED_BYTE/SHORT (glTF 2.0 core); with KHR_mesh_quantization, the
// extension's table: positions and texture coordinates any of BYTE, UNSIGNED_BYTE, SHORT,
// UNSIGNED_SHORT, normalized or not; normals normalized BYTE or SHORT. Integer values are
// dequantized at load (normalized: c/255, c/65535, max(c/127, −1), max(c/32767, −1); otherwise
// the integer itself); the node's transform carries the scale and offset exporters put there.
std::vector<std::pair<int, bool>> allowedForms(Attribute a, bool quantization) {
    constexpr int kByte = TINYGLTF_COMPONENT_TYPE_BYTE, kUByte = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                  kShort = TINYGLTF_COMPONENT_TYPE_SHORT, kUShort = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    std::vector<std::pair<int, bool>> forms{{TINYGLTF_COMPONENT_TYPE_FLOAT, false}};
    if (a == Attribute::TexCoord && !quantization) forms.insert(forms.end(), {{kUByte, true}, {kUShort, true}});
    if (!quantization) return forms;
    if (a == Attribute::Normal) forms.insert(forms.end(), {{kByte, true}, {kShort, true}});
    if (a == Attribute::Position || a == Attribute::TexCoord)
        for (int type : {kByte, kUByte, kShort, kUShort}) forms.insert(forms.end(), {{type, true}, {type, false}});
    return forms;
}

std::string formName(int componentType, bool normalized) {
    return (normalized && componentType != TINYGLTF_COMPONENT_TYPE_FLOAT ? "normalized " : "") +
           componentTypeName(componentType);
}

class GltfImporter {
public:
    GltfImporter(const tinygltf::Model& model, SceneFiles& files, const GltfOptions& options)
        : model_(model), file_(files.sceneFile()), files_(&files), options_(options) {}

    Scene run();

private:
    [[noreturn]] void fail(const std::string& element, const std::string& message) const {
        throw SceneError(file_, element, message);
    }
    void warn(const std::string& message) { scene_.warnings.push_back(file_ + ": " + message); }

    // Byte range of accessor `index` after every bound is checked. Returns a pointer to the first
    // element (nullptr for an accessor without bufferView, which reads as zeros) and its stride.
    struct View {
        const unsigned char* data = nullptr;
        size_t stride = 0;
        size_t count = 0;
        int componentType = 0;
        int components = 0;
        bool normalized = false;
    };
    View checkedAccessor(int index, const std::string& element,
                         std::initializer_list<int> allowedTypes,
                         std::initializer_list<int> allowedComponents) const;
    /// The accessor's values as floats, dequantized; refuses component types `attribute` may not use.
    std::vector<float> readFloats(int index, const std::string& element, int type, Attribute attribute) const;
    std::vector<uint32_t> readIndices(int index, const std::string& element) const;

    void checkExtensions();
    void readVariants();
    int primitiveMaterial(const tinygltf::Primitive& prim, const std::string& element) const;
    void convertMaterials();
    TextureTransform textureTransform(const tinygltf::Value& ext, const std::string& element,
                                      int& uvSet) const;
    void addGpuInstances(const tinygltf::Value& ext, const std::string& element, const Mat4& world,
                         const std::string& name, const std::vector<uint32_t>& meshes);
    std::vector<float> readInstanceRotations(int index, const std::string& element) const;
    int textureFor(int gltfTexture, const std::string& element);
    std::vector<uint32_t> convertMesh(int meshIndex);
    void visitNode(int node, const Mat4& parent, int depth);
    Mat4 localTransform(const tinygltf::Node& node, const std::string& element) const;
    uint32_t defaultMaterial();

    const tinygltf::Model& model_;
    std::string file_;
    SceneFiles* files_;  // the budget every decoded array is charged to before allocation
    GltfOptions options_;
    bool quantization_ = false;             // KHR_mesh_quantization listed: integer attributes allowed
    std::vector<std::string> variantNames_;  // KHR_materials_variants, in file order
    int variant_ = -1;                       // the chosen variant, -1: the default materials
    Scene scene_;
    std::map<int, std::vector<uint32_t>> meshPrimitives_;  // glTF mesh → rtpm meshes
    std::map<int, int32_t> imageTextures_;                  // glTF image → Scene::textures
    std::vector<uint8_t> onPath_;                           // cycle detection in the hierarchy
    std::vector<int> materialUvSet_;                        // glTF material → TEXCOORD_n its textures use
    int defaultMaterial_ = -1;
};

GltfImporter::View GltfImporter::checkedAccessor(int index, const std::string& element,
                                                 std::initializer_list<int> allowedTypes,
                                                 std::initializer_list<int> allowedComponents) const {
    if (index < 0 || size_t(index) >= model_.accessors.size())
        fail(element, "accessor index " + std::to_string(index) + " out of range (" +
                          std::to_string(model_.accessors.size()) + " accessors)");
    const tinygltf::Accessor& acc = model_.accessors[size_t(index)];
    const std::string accName = "accessors[" + std::to_string(index) + "]";
    if (std::find(allowedTypes.begin(), allowedTypes.end(), acc.type) == allowedTypes.end())
        fail(element, accName + " has an unexpected type (" + std::to_string(acc.type) + ")");
    if (std::find(allowedComponents.begin(), allowedComponents.end(), acc.componentType) ==
        allowedComponents.end())
        fail(element, accName + " has unsupported componentType " +
                          componentTypeName(acc.componentType));
    if (acc.sparse.isSparse) fail(element, accName + " is sparse (not supported)");
    View v;
    v.count = acc.count;
    v.componentType = acc.componentType;
    v.components = componentCount(acc.type);
    v.normalized = acc.normalized;
    const size_t elemBytes = size_t(componentBytes(acc.componentType)) * size_t(v.components);
    if (acc.count == 0) fail(element, accName + " has count 0");
    if (acc.count > (uint64_t(1) << 32))
        fail(element, accName + " count " + std::to_string(acc.count) + " is absurd");
    if (acc.bufferView < 0) {
        // Spec: no bufferView means all zeros (the file holds none of it): the count is bounded
        // only by the budget, charged by the caller before it allocates.
        return v;
    }
    if (size_t(acc.bufferView) >= model_.bufferViews.size())
        fail(element, accName + " bufferView " + std::to_string(acc.bufferView) + " out of range");
    const tinygltf::BufferView& bv = model_.bufferViews[size_t(acc.bufferView)];
    const std::string bvName = "bufferViews[" + std::to_string(acc.bufferView) + "]";
    if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
        fail(element, bvName + " buffer " + std::to_string(bv.buffer) + " out of range");
    const tinygltf::Buffer& buf = model_.buffers[size_t(bv.buffer)];
    const uint64_t bufBytes = buf.data.size();
    if (uint64_t(bv.byteOffset) > bufBytes || uint64_t(bv.byteLength) > bufBytes - bv.byteOffset)
        fail(element, bvName + " range [" + std::to_string(bv.byteOffset) + ", +" +
                          std::to_string(bv.byteLength) + ") exceeds buffer of " +
                          std::to_string(bufBytes) + " bytes");
    size_t stride = bv.byteStride == 0 ? elemBytes : bv.byteStride;
    if (stride < elemBytes || stride > 252)
        fail(element, bvName + " byteStride " + std::to_string(bv.byteStride) +
                          " is invalid for elements of " + std::to_string(elemBytes) + " bytes");
    if (acc.byteOffset % size_t(componentBytes(acc.componentType)) != 0)
        fail(element, accName + " byteOffset " + std::to_string(acc.byteOffset) +
                          " is not aligned to its component size");
    // Bytes needed: offset + stride·(count−1) + element, all in 64 bits (count ≤ 2^32, stride ≤ 252).
    const uint64_t need = uint64_t(acc.byteOffset) + uint64_t(stride) * (uint64_t(acc.count) - 1) +
                          uint64_t(elemBytes);
    if (uint64_t(acc.byteOffset) > uint64_t(bv.byteLength) || need > uint64_t(bv.byteLength))
        fail(element, accName + " count " + std::to_string(acc.count) + " needs " +
                          std::to_string(need) + " bytes but " + bvName + " has " +
                          std::to_string(bv.byteLength));
    v.data = buf.data.data() + bv.byteOffset + acc.byteOffset;
    v.stride = stride;
    return v;
}

float readComponent(const unsigned char* p, int componentType, bool normalized) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: {
            float f;
            std::memcpy(&f, p, 4);
            return f;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? float(*p) / 255.0f : float(*p);
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            float f = float(int8_t(*p));
            return normalized ? std::max(f / 127.0f, -1.0f) : f;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            uint16_t s;
            std::memcpy(&s, p, 2);
            return normalized ? float(s) / 65535.0f : float(s);
        }
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            int16_t s;
            std::memcpy(&s, p, 2);
            return normalized ? std::max(float(s) / 32767.0f, -1.0f) : float(s);
        }
        default: return 0.0f;
    }
}

std::vector<float> GltfImporter::readFloats(int index, const std::string& element, int type,
                                            Attribute attribute) const {
    View v = checkedAccessor(index, element, {type},
                             {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
    const bool normalized = v.normalized && v.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT;
    const auto allowed = allowedForms(attribute, quantization_);
    if (std::find(allowed.begin(), allowed.end(), std::make_pair(v.componentType, normalized)) == allowed.end()) {
        std::string list;
        for (const auto& [ct, n] : allowed) list += (list.empty() ? "" : ", ") + formName(ct, n);
        const auto quantized = allowedForms(attribute, true);
        const bool quantizationWouldAllow =
            !quantization_ &&
            std::find(quantized.begin(), quantized.end(), std::make_pair(v.componentType, normalized)) != quantized.end();
        fail(element, "accessors[" + std::to_string(index) + "] is " + formName(v.componentType, normalized) +
                          ", which " + attributeName(attribute) + " may not be (allowed: " + list + ")" +
                          (quantizationWouldAllow ? "; KHR_mesh_quantization allows it, but the file does "
                                                    "not list that extension in extensionsUsed"
                                                  : ""));
    }
    files_->charge(uint64_t(v.count) * uint64_t(v.components) * sizeof(float), element);
    std::vector<float> out(v.count * size_t(v.components), 0.0f);
    if (!v.data) return out;
    const size_t cb = size_t(componentBytes(v.componentType));
    for (size_t i = 0; i < v.count; ++i)
        for (int c = 0; c < v.components; ++c) {
            float f = readComponent(v.data + i * v.stride + size_t(c) * cb, v.componentType,
                                    v.normalized);
            if (!std::isfinite(f))
                fail(element, "element " + std::to_string(i) + " is not finite (NaN or Inf)");
            out[i * size_t(v.components) + size_t(c)] = f;
        }
    return out;
}

std::vector<uint32_t> GltfImporter::readIndices(int index, const std::string& element) const {
    View v = checkedAccessor(index, element, {TINYGLTF_TYPE_SCALAR},
                             {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
    files_->charge(uint64_t(v.count) * sizeof(uint32_t), element);
    std::vector<uint32_t> out(v.count, 0u);
    if (!v.data) return out;
    for (size_t i = 0; i < v.count; ++i) {
        const unsigned char* p = v.data + i * v.stride;
        switch (v.componentType) {
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: out[i] = *p; break;
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
                uint16_t s;
                std::memcpy(&s, p, 2);
                out[i] = s;
                break;
            }
            default: std::memcpy(&out[i], p, 4); break;
        }
    }
    return out;
}

// ---- extensions, materials, textures ----------------------------------------------------

void GltfImporter::checkExtensions() {
    for (const std::string& ext : model_.extensionsRequired) {
        if (ext == "KHR_draco_mesh_compression")
            fail("extensionsRequired",
                 "the meshes are Draco-compressed (KHR_draco_mesh_compression), which is not supported; "
                 "export the file without mesh compression (Blender's glTF exporter: untick "
                 "Data > Compression)");
        if (!supportedExtensions().count(ext))
            fail("extensionsRequired", "extension " + ext + " is required but not supported");
    }
    auto listed = [&](const char* name) {
        return std::count(model_.extensionsUsed.begin(), model_.extensionsUsed.end(), name) +
                   std::count(model_.extensionsRequired.begin(), model_.extensionsRequired.end(), name) >
               0;
    };
    quantization_ = listed("KHR_mesh_quantization");
    std::string unsupported;
    for (const std::string& ext : model_.extensionsUsed)
        if (!supportedExtensions().count(ext)) unsupported += (unsupported.empty() ? "" : ", ") + ext;
    if (!unsupported.empty()) warn("extensionsUsed: ignored unsupported extensions: " + unsupported);
}

double numberOr(const tinygltf::Value& obj, const char* key, double fallback) {
    if (!obj.IsObject() || !obj.Has(key)) return fallback;
    const tinygltf::Value& v = obj.Get(key);
    return v.IsNumber() ? v.GetNumberAsDouble() : fallback;
}

std::optional<glm::dvec3> dvec3Of(const tinygltf::Value& obj, const char* key) {
    if (!obj.IsObject() || !obj.Has(key)) return std::nullopt;
    const tinygltf::Value& v = obj.Get(key);
    if (!v.IsArray() || v.ArrayLen() < 3) return std::nullopt;
    glm::dvec3 out;
    for (int i = 0; i < 3; ++i) {
        if (!v.Get(i).IsNumber()) return std::nullopt;
        out[i] = v.Get(i).GetNumberAsDouble();
    }
    return out;
}

const tinygltf::Value* extension(const tinygltf::ExtensionMap& map, const char* name) {
    auto it = map.find(name);
    return it == map.end() ? nullptr : &it->second;
}

int GltfImporter::textureFor(int gltfTexture, const std::string& element) {
    if (gltfTexture < 0 || size_t(gltfTexture) >= model_.textures.size())
        fail(element, "texture index " + std::to_string(gltfTexture) + " out of range");
    int source = model_.textures[size_t(gltfTexture)].source;
    if (source < 0) {
        warn(element + ": texture " + std::to_string(gltfTexture) +
             " has no supported image source; ignored");
        return -1;
    }
    if (size_t(source) >= model_.images.size())
        fail("textures[" + std::to_string(gltfTexture) + "]",
             "image index " + std::to_string(source) + " out of range");
    auto found = imageTextures_.find(source);
    if (found != imageTextures_.end()) return found->second;

    const tinygltf::Image& img = model_.images[size_t(source)];
    const std::string imgEl = "images[" + std::to_string(source) + "]";
    std::vector<unsigned char> encoded;
    if (img.bufferView >= 0) {
        if (size_t(img.bufferView) >= model_.bufferViews.size())
            fail(imgEl, "bufferView " + std::to_string(img.bufferView) + " out of range");
        const tinygltf::BufferView& bv = model_.bufferViews[size_t(img.bufferView)];
        if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
            fail(imgEl, "buffer of its bufferView out of range");
        const auto& data = model_.buffers[size_t(bv.buffer)].data;
        if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset)
            fail(imgEl, "bufferView " + std::to_string(img.bufferView) + " exceeds its buffer");
        encoded.assign(data.begin() + std::ptrdiff_t(bv.byteOffset),
                       data.begin() + std::ptrdiff_t(bv.byteOffset + bv.byteLength));
    } else {
        encoded = img.image;
    }
    if (encoded.empty()) {
        warn(imgEl + ": image data unavailable (missing file?); texture ignored");
        imageTextures_[source] = -1;
        return -1;
    }

    Texture tex = decodeSrgbTexture(encoded, img.mimeType == "image/jpeg" ? "jpg" : "png", file_, imgEl,
                                    files_);
    if (!img.name.empty()) tex.name = img.name;
    int32_t id = int32_t(scene_.textures.size());
    scene_.textures.push_back(std::move(tex));
    imageTextures_[source] = id;
    return id;
}

// KHR_materials_pbrSpecularGlossiness in the metallic-roughness terms the renderer reads.
struct MetallicRoughness {
    Vec3 baseColor{1.0f};
    double metallic = 0.0;
    double roughness = 0.0;
};

// Specular-glossiness → metallic-roughness, the rule of the Khronos sample converter that came with
// the extension ("convert between workflows"), restated: roughness is 1 − glossiness. A
// dielectric reflects F0 = 0.04 at normal incidence, so the perceived brightness (√(0.299 r² +
// 0.587 g² + 0.114 b²)) of a specular colour below 0.04 means metallic 0. Otherwise metallic m is
// the root in [0, 1] of the quadratic that makes the specular and diffuse brightnesses of a
// metal-rough surface with metallic m match the file's: 0.04 m² + b m + (0.04 − S) = 0 with
// b = D (1 − s) / 0.96 + S − 0.08, where S and D are the specular's and diffuse's brightness and
// s the specular colour's largest channel. The base colour blends the colour that explains the
// diffuse (diffuse (1 − s) / 0.96 / (1 − m)) and the one that explains the specular
// ((specular − 0.04 (1 − m)) / m) with weight m², clamped to [0, 1]. Pure, O(1).
MetallicRoughness fromSpecularGlossiness(Vec3 diffuse, Vec3 specular, double glossiness) {
    constexpr double kDielectricF0 = 0.04, kEpsilon = 1e-6;
    auto brightness = [](Vec3 c) {
        return std::sqrt(0.299 * double(c.x) * c.x + 0.587 * double(c.y) * c.y + 0.114 * double(c.z) * c.z);
    };
    const double specularStrength = std::max({specular.x, specular.y, specular.z});
    const double oneMinusS = 1.0 - specularStrength;
    const double d = brightness(diffuse), sp = brightness(specular);
    MetallicRoughness out;
    out.roughness = std::clamp(1.0 - glossiness, 0.0, 1.0);
    if (sp >= kDielectricF0) {
        const double a = kDielectricF0;
        const double b = d * oneMinusS / (1.0 - kDielectricF0) + sp - 2.0 * kDielectricF0;
        const double c = kDielectricF0 - sp;
        const double disc = std::max(b * b - 4.0 * a * c, 0.0);
        out.metallic = std::clamp((-b + std::sqrt(disc)) / (2.0 * a), 0.0, 1.0);
    }
    const double m = out.metallic;
    const glm::dvec3 fromDiffuse =
        glm::dvec3(diffuse) * (oneMinusS / (1.0 - kDielectricF0) / std::max(1.0 - m, kEpsilon));
    const glm::dvec3 fromSpecular =
        (glm::dvec3(specular) - glm::dvec3(kDielectricF0 * (1.0 - m))) / std::max(m, kEpsilon);
    out.baseColor = Vec3(glm::clamp(glm::mix(fromDiffuse, fromSpecular, m * m), glm::dvec3(0.0), glm::dvec3(1.0)));
    return out;
}

// KHR_materials_variants: the file's variant names, and the one options_.variant names.
void GltfImporter::readVariants() {
    const std::string el = "extensions.KHR_materials_variants";
    if (const tinygltf::Value* ext = extension(model_.extensions, "KHR_materials_variants")) {
        if (!ext->IsObject() || !ext->Has("variants") || !ext->Get("variants").IsArray())
            fail(el, "must be an object with a variants array");
        const tinygltf::Value& variants = ext->Get("variants");
        for (size_t i = 0; i < variants.ArrayLen(); ++i) {
            const tinygltf::Value& v = variants.Get(int(i));
            if (!v.IsObject() || !v.Has("name") || !v.Get("name").IsString())
                fail(el + ".variants[" + std::to_string(i) + "]", "must be an object with a name string");
            variantNames_.push_back(v.Get("name").Get<std::string>());
        }
    }
    if (options_.variant.empty()) return;
    for (size_t i = 0; i < variantNames_.size(); ++i)
        if (variantNames_[i] == options_.variant) variant_ = int(i);
    if (variant_ >= 0) return;
    if (variantNames_.empty())
        fail(el, "no material variant named '" + printableText(options_.variant, 80) +
                     "': the file defines no variants (KHR_materials_variants)");
    std::string names;
    for (const std::string& n : variantNames_) names += (names.empty() ? "'" : ", '") + printableText(n, 80) + "'";
    fail(el, "no material variant named '" + printableText(options_.variant, 80) + "'; the file's variants: " + names);
}

// The glTF material a primitive uses: its KHR_materials_variants mapping for the chosen variant,
// else its own `material` (the default variant); -1 for none. Every mapping is checked, chosen or not.
int GltfImporter::primitiveMaterial(const tinygltf::Primitive& prim, const std::string& element) const {
    int material = prim.material;
    const tinygltf::Value* ext = extension(prim.extensions, "KHR_materials_variants");
    if (!ext) return material;
    const std::string el = element + ".extensions.KHR_materials_variants";
    if (!ext->IsObject() || !ext->Has("mappings") || !ext->Get("mappings").IsArray())
        fail(el, "must be an object with a mappings array");
    const tinygltf::Value& mappings = ext->Get("mappings");
    for (size_t j = 0; j < mappings.ArrayLen(); ++j) {
        const tinygltf::Value& m = mappings.Get(int(j));
        const std::string mEl = el + ".mappings[" + std::to_string(j) + "]";
        if (!m.IsObject() || !m.Has("material") || !m.Get("material").IsNumber() || !m.Has("variants") ||
            !m.Get("variants").IsArray())
            fail(mEl, "must be an object with a material index and a variants array");
        const int mat = m.Get("material").GetNumberAsInt();
        if (mat < 0 || size_t(mat) >= model_.materials.size())
            fail(mEl + ".material", "material index " + std::to_string(mat) + " out of range (" +
                                        std::to_string(model_.materials.size()) + " materials)");
        const tinygltf::Value& vs = m.Get("variants");
        for (size_t k = 0; k < vs.ArrayLen(); ++k) {
            const int v = vs.Get(int(k)).IsNumber() ? vs.Get(int(k)).GetNumberAsInt() : -1;
            if (v < 0 || size_t(v) >= variantNames_.size())
                fail(mEl + ".variants[" + std::to_string(k) + "]",
                     "not a variant index (the file defines " + std::to_string(variantNames_.size()) + " variants)");
            if (v == variant_) material = mat;
        }
    }
    return material;
}

void GltfImporter::convertMaterials() {
    size_t specularGlossinessMaterials = 0;
    std::vector<std::string> specularGlossinessTextures;  // materials whose texture is dropped
    for (size_t mi = 0; mi < model_.materials.size(); ++mi) {
        const tinygltf::Material& gm = model_.materials[mi];
        const std::string el = "materials[" + std::to_string(mi) + "]";
        Material m;
        m.name = gm.name.empty() ? el : gm.name;
        const auto& pbr = gm.pbrMetallicRoughness;
        Vec3 base(1.0f);
        if (pbr.baseColorFactor.size() >= 3)
            base = Vec3(float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]),
                        float(pbr.baseColorFactor[2]));
        if (!finite3(base)) fail(el + ".pbrMetallicRoughness.baseColorFactor", "not finite");
        // The metallic-roughness parameters the model below reads, from the file's
        // pbrMetallicRoughness or converted from KHR_materials_pbrSpecularGlossiness.
        double metallic = pbr.metallicFactor, roughness = pbr.roughnessFactor;
        tinygltf::TextureInfo baseTexture = pbr.baseColorTexture;
        std::string baseTextureEl = el + ".pbrMetallicRoughness.baseColorTexture";
        if (const tinygltf::Value* sg = extension(gm.extensions, "KHR_materials_pbrSpecularGlossiness")) {
            const std::string sgEl = el + ".extensions.KHR_materials_pbrSpecularGlossiness";
            if (!sg->IsObject()) fail(sgEl, "must be an object");
            // An array of `n` numbers in [0, 1] (a number when n = 1), `fallback` when absent.
            auto factor = [&](const char* key, size_t n, std::vector<double> fallback) {
                if (!sg->Has(key)) return fallback;
                const tinygltf::Value& v = sg->Get(key);
                auto number = [&](const tinygltf::Value& x, double& out) {
                    if (!x.IsNumber()) return false;
                    out = x.GetNumberAsDouble();
                    return out >= 0.0 && out <= 1.0;
                };
                bool ok = n == 1 ? number(v, fallback[0]) : v.IsArray() && v.ArrayLen() == n;
                for (size_t i = 0; n > 1 && ok && i < n; ++i) ok = number(v.Get(int(i)), fallback[i]);
                if (!ok)
                    fail(sgEl + "." + key, n == 1 ? "must be a number in [0, 1]"
                                                  : "must be " + std::to_string(n) + " numbers in [0, 1]");
                return fallback;
            };
            const std::vector<double> diffuse = factor("diffuseFactor", 4, {1, 1, 1, 1});
            const std::vector<double> specular = factor("specularFactor", 3, {1, 1, 1});
            const double glossiness = factor("glossinessFactor", 1, {1})[0];
            const MetallicRoughness mr = fromSpecularGlossiness(
                Vec3(float(diffuse[0]), float(diffuse[1]), float(diffuse[2])),
                Vec3(float(specular[0]), float(specular[1]), float(specular[2])), glossiness);
            base = mr.baseColor;
            metallic = mr.metallic;
            roughness = mr.roughness;
            baseTexture = tinygltf::TextureInfo();
            baseTextureEl = sgEl + ".diffuseTexture";
            if (sg->Has("diffuseTexture")) {
                const tinygltf::Value& t = sg->Get("diffuseTexture");
                if (!t.IsObject() || !t.Has("index") || !t.Get("index").IsNumber())
                    fail(baseTextureEl, "must be an object with a texture index");
                baseTexture.index = t.Get("index").GetNumberAsInt();
                if (t.Has("texCoord")) {
                    if (!t.Get("texCoord").IsNumber() || t.Get("texCoord").GetNumberAsInt() < 0)
                        fail(baseTextureEl + ".texCoord", "must be a non-negative integer");
                    baseTexture.texCoord = t.Get("texCoord").GetNumberAsInt();
                }
                if (t.Has("extensions") && t.Get("extensions").IsObject() &&
                    t.Get("extensions").Has("KHR_texture_transform"))
                    baseTexture.extensions["KHR_texture_transform"] = t.Get("extensions").Get("KHR_texture_transform");
            }
            if (sg->Has("specularGlossinessTexture")) specularGlossinessTextures.push_back(el);
            ++specularGlossinessMaterials;
        }
        base = glm::clamp(base, Vec3(0.0f), Vec3(1.0f));
        m.baseColor = base;

        const tinygltf::Value* transmission = extension(gm.extensions, "KHR_materials_transmission");
        double transmissionFactor =
            transmission ? numberOr(*transmission, "transmissionFactor", 0.0) : 0.0;
        if (!std::isfinite(transmissionFactor) || transmissionFactor < 0.0 || transmissionFactor > 1.0)
            fail(el + ".extensions.KHR_materials_transmission", "transmissionFactor " +
                                                                    std::to_string(transmissionFactor) +
                                                                    " outside [0, 1]");
        // The texture coordinate set the material's textures are read from (see convertMesh).
        int uvSet = -1;
        // Base-colour texture with its KHR_texture_transform, for the materials that use it.
        auto useBaseColorTexture = [&] {
            if (baseTexture.index < 0) return;
            const std::string& texEl = baseTextureEl;
            m.baseColorTexture = textureFor(baseTexture.index, texEl);
            uvSet = baseTexture.texCoord;
            if (const tinygltf::Value* tt = extension(baseTexture.extensions, "KHR_texture_transform"))
                m.baseColorTransform = textureTransform(*tt, texEl + ".extensions.KHR_texture_transform", uvSet);
        };
        if (extension(gm.extensions, "KHR_materials_unlit")) {
            // Unlit wins over every other model: the file asks for the colour as it is.
            m.type = MaterialType::Diffuse;
            m.unlit = true;
            useBaseColorTexture();
        } else if (transmissionFactor > 0.0) {
            m.type = MaterialType::Dielectric;
            m.transmission = float(transmissionFactor);
            if (m.transmission >= 1.0f) {
                m.baseColor = Vec3(1.0f);  // clear glass: the tint is not modelled
            } else {
                useBaseColorTexture();  // the Lambertian share's albedo
                if (metallic > 0.0)
                    warn(el + ": metallicFactor " + std::to_string(metallic) +
                         " ignored on a partly transmissive material (dielectric + Lambertian mix)");
            }
            if (transmission && transmission->Has("transmissionTexture"))
                warn(el + ": transmissionTexture ignored (transmissionFactor used everywhere)");
            const tinygltf::Value* iorExt = extension(gm.extensions, "KHR_materials_ior");
            m.ior = float(iorExt ? numberOr(*iorExt, "ior", 1.5) : 1.5);
            if (!std::isfinite(m.ior) || m.ior < 1.0f || m.ior > 4.0f)
                fail(el + ".extensions.KHR_materials_ior", "ior " + std::to_string(m.ior) +
                                                                " outside [1, 4]");
            if (const tinygltf::Value* vol = extension(gm.extensions, "KHR_materials_volume")) {
                double dist = numberOr(*vol, "attenuationDistance",
                                       std::numeric_limits<double>::infinity());
                // Read in double: the master's GLB (gltf_export.cpp) writes exp(−σ·d) in double, so
                // σ comes back to the same float on a cluster client.
                const glm::dvec3 color = dvec3Of(*vol, "attenuationColor").value_or(glm::dvec3(1.0));
                if (!(dist > 0.0) || !std::isfinite(color.x) || !std::isfinite(color.y) || !std::isfinite(color.z))
                    fail(el + ".extensions.KHR_materials_volume",
                         "attenuationDistance must be > 0 and attenuationColor finite");
                if (std::isfinite(dist)) {
                    // Beer–Lambert: transmittance after `dist` metres is attenuationColor.
                    for (int c = 0; c < 3; ++c) {
                        const double col = std::clamp(color[c], 1e-30, 1.0);
                        m.absorption[c] = float(-std::log(col) / dist);
                    }
                }
            }
        } else if (metallic >= 0.99 && roughness <= 0.01) {
            m.type = MaterialType::Mirror;
        } else {
            m.type = MaterialType::Diffuse;
            useBaseColorTexture();
        }
        if (gm.emissiveFactor.size() >= 3) {
            Vec3 e(float(gm.emissiveFactor[0]), float(gm.emissiveFactor[1]),
                   float(gm.emissiveFactor[2]));
            double strength = 1.0;
            if (const tinygltf::Value* es = extension(gm.extensions, "KHR_materials_emissive_strength"))
                strength = numberOr(*es, "emissiveStrength", 1.0);
            e *= float(strength);
            if (!finite3(e) || glm::any(glm::lessThan(e, Vec3(0.0f))))
                fail(el + ".emissiveFactor", "emission must be finite and non-negative");
            m.emission = e;
        }
        if (gm.emissiveTexture.index >= 0 && m.isEmissive()) {
            // Per glTF the emission is emissiveFactor × the (sRGB) emissive texture.
            const std::string texEl = el + ".emissiveTexture";
            m.emissiveTexture = textureFor(gm.emissiveTexture.index, texEl);
            if (extension(gm.emissiveTexture.extensions, "KHR_texture_transform"))
                warn(texEl + ": KHR_texture_transform ignored on emissive textures");
            if (uvSet < 0) {
                uvSet = gm.emissiveTexture.texCoord;
            } else if (gm.emissiveTexture.texCoord != uvSet) {
                warn(texEl + ": uses TEXCOORD_" + std::to_string(gm.emissiveTexture.texCoord) +
                     " but the base colour uses TEXCOORD_" + std::to_string(uvSet) +
                     "; the latter is used for both");
            }
        }
        // What the material model has no place for, named once per material.
        std::string ignored;
        auto note = [&](bool present, const char* what) {
            if (present) ignored += (ignored.empty() ? "" : ", ") + std::string(what);
        };
        note(gm.normalTexture.index >= 0, "normalTexture");
        note(gm.occlusionTexture.index >= 0, "occlusionTexture");
        note(pbr.metallicRoughnessTexture.index >= 0, "metallicRoughnessTexture");
        note(!gm.alphaMode.empty() && gm.alphaMode != "OPAQUE", "alphaMode (rendered opaque)");
        if (!ignored.empty()) warn(el + ": ignored " + ignored);
        materialUvSet_.push_back(std::max(uvSet, 0));
        scene_.materials.push_back(std::move(m));
    }
    if (specularGlossinessMaterials > 0) {
        std::string line = "KHR_materials_pbrSpecularGlossiness: " + std::to_string(specularGlossinessMaterials) +
                           " material(s) converted to metallic-roughness (approximate: diffuse and specular "
                           "colours folded into one base colour and a metallic factor, roughness = 1 - glossiness)";
        if (!specularGlossinessTextures.empty()) {
            line += "; specularGlossinessTexture ignored on ";
            for (size_t i = 0; i < specularGlossinessTextures.size() && i < 8; ++i)
                line += (i ? ", " : "") + specularGlossinessTextures[i];
            if (specularGlossinessTextures.size() > 8) line += ", ...";
        }
        warn(line);
    }
}

TextureTransform GltfImporter::textureTransform(const tinygltf::Value& ext, const std::string& element,
                                                int& uvSet) const {
    // KHR_texture_transform: offset [2], rotation (radians), scale [2], texCoord (overrides the
    // textureInfo's set).
    TextureTransform t;
    auto vec2Of = [&](const char* key, Vec2 fallback) {
        if (!ext.Has(key)) return fallback;
        const tinygltf::Value& v = ext.Get(key);
        if (!v.IsArray() || v.ArrayLen() != 2 || !v.Get(0).IsNumber() || !v.Get(1).IsNumber())
            fail(element + "." + key, "must be an array of 2 numbers");
        return Vec2(float(v.Get(0).GetNumberAsDouble()), float(v.Get(1).GetNumberAsDouble()));
    };
    if (!ext.IsObject()) fail(element, "must be an object");
    t.offset = vec2Of("offset", Vec2(0.0f));
    t.scale = vec2Of("scale", Vec2(1.0f));
    t.rotation = float(numberOr(ext, "rotation", 0.0));
    if (!std::isfinite(t.offset.x) || !std::isfinite(t.offset.y) || !std::isfinite(t.scale.x) ||
        !std::isfinite(t.scale.y) || !std::isfinite(t.rotation))
        fail(element, "offset, rotation and scale must be finite");
    if (ext.Has("texCoord")) {
        const tinygltf::Value& tc = ext.Get("texCoord");
        if (!tc.IsNumber() || tc.GetNumberAsInt() < 0)
            fail(element + ".texCoord", "must be a non-negative integer");
        uvSet = tc.GetNumberAsInt();
    }
    return t;
}

uint32_t GltfImporter::defaultMaterial() {
    if (defaultMaterial_ < 0) {
        Material m;
        m.name = "default";
        m.baseColor = Vec3(0.8f);
        defaultMaterial_ = int(scene_.materials.size());
        scene_.materials.push_back(m);
    }
    return uint32_t(defaultMaterial_);
}

// ---- meshes -------------------------------------------------------------------------------

std::vector<uint32_t> GltfImporter::convertMesh(int meshIndex) {
    auto found = meshPrimitives_.find(meshIndex);
    if (found != meshPrimitives_.end()) return found->second;
    const std::string meshEl = "meshes[" + std::to_string(meshIndex) + "]";
    if (meshIndex < 0 || size_t(meshIndex) >= model_.meshes.size())
        fail(meshEl, "mesh index out of range (" + std::to_string(model_.meshes.size()) + " meshes)");
    const tinygltf::Mesh& gmesh = model_.meshes[size_t(meshIndex)];
    std::vector<uint32_t> result;
    for (size_t pi = 0; pi < gmesh.primitives.size(); ++pi) {
        const tinygltf::Primitive& prim = gmesh.primitives[pi];
        const std::string el = meshEl + ".primitives[" + std::to_string(pi) + "]";
        if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) {
            warn(el + ": mode " + std::to_string(prim.mode) + " is not TRIANGLES; primitive skipped");
            continue;
        }
        if (!prim.targets.empty()) warn(el + ": morph targets ignored");
        auto posIt = prim.attributes.find("POSITION");
        if (posIt == prim.attributes.end()) fail(el + ".attributes", "no POSITION attribute");
        Mesh mesh;
        mesh.name = (gmesh.name.empty() ? meshEl : gmesh.name) +
                    (gmesh.primitives.size() > 1 ? "/" + std::to_string(pi) : "");
        // Without a bufferView (and sparse is refused) every position is the origin and every
        // index 0: nothing to render, whatever the count claims.
        auto noData = [&](int accessor) {
            return accessor >= 0 && size_t(accessor) < model_.accessors.size() &&
                   model_.accessors[size_t(accessor)].bufferView < 0;
        };
        if (noData(posIt->second))
            fail(el + ".attributes.POSITION", "accessors[" + std::to_string(posIt->second) +
                                                  "] has no bufferView (every vertex would be the origin)");
        if (noData(prim.indices))
            fail(el + ".indices", "accessors[" + std::to_string(prim.indices) +
                                      "] has no bufferView (every triangle would be degenerate)");
        std::vector<float> p = readFloats(posIt->second, el + ".attributes.POSITION", TINYGLTF_TYPE_VEC3, Attribute::Position);
        size_t nv = p.size() / 3;
        // Every other attribute has one element per vertex: compare counts before reading.
        for (const char* attribute : {"NORMAL", "TEXCOORD_0"}) {
            auto it = prim.attributes.find(attribute);
            if (it != prim.attributes.end() && it->second >= 0 &&
                size_t(it->second) < model_.accessors.size() &&
                model_.accessors[size_t(it->second)].count != nv)
                fail(el + ".attributes." + attribute, "count differs from POSITION count");
        }
        // The mesh's own arrays: positions, normals (read or computed), texture coordinates.
        files_->charge(uint64_t(nv) * (2 * sizeof(Vec3) + sizeof(Vec2)), el);
        mesh.positions.resize(nv);
        for (size_t i = 0; i < nv; ++i) mesh.positions[i] = Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]);

        if (prim.indices >= 0) {
            mesh.indices = readIndices(prim.indices, el + ".indices");
            for (size_t i = 0; i < mesh.indices.size(); ++i)
                if (mesh.indices[i] >= nv)
                    fail(el + ".indices", "index " + std::to_string(mesh.indices[i]) + " at position " +
                                              std::to_string(i) + " out of range (" +
                                              std::to_string(nv) + " vertices)");
        } else {
            files_->charge(uint64_t(nv) * sizeof(uint32_t), el + ".indices");
            mesh.indices.resize(nv);
            for (size_t i = 0; i < nv; ++i) mesh.indices[i] = uint32_t(i);
        }
        if (mesh.indices.size() % 3 != 0) {
            warn(el + ": index count " + std::to_string(mesh.indices.size()) +
                 " not a multiple of 3; trailing indices dropped");
            mesh.indices.resize(mesh.indices.size() / 3 * 3);
        }
        if (mesh.indices.empty()) {
            warn(el + ": no triangles; primitive skipped");
            continue;
        }

        auto nIt = prim.attributes.find("NORMAL");
        bool needNormals = true;
        if (nIt != prim.attributes.end()) {
            std::vector<float> n = readFloats(nIt->second, el + ".attributes.NORMAL", TINYGLTF_TYPE_VEC3, Attribute::Normal);
            if (n.size() != p.size())
                fail(el + ".attributes.NORMAL", "count differs from POSITION count");
            mesh.normals.resize(nv);
            needNormals = false;
            for (size_t i = 0; i < nv; ++i) {
                Vec3 v(n[3 * i], n[3 * i + 1], n[3 * i + 2]);
                float len = glm::length(v);
                if (!(len > 1e-12f)) {
                    needNormals = true;
                    break;
                }
                mesh.normals[i] = unitKeepingBits(v);
            }
            if (needNormals) warn(el + ".attributes.NORMAL: zero-length normals; recomputed");
        }
        if (needNormals) mesh.normals = smoothVertexNormals(mesh.positions, mesh.indices);

        // One uv set per mesh: the one its material's textures name (TEXCOORD_0 by default).
        const int material = primitiveMaterial(prim, el);
        const int uvSet = material >= 0 && size_t(material) < materialUvSet_.size()
                              ? materialUvSet_[size_t(material)]
                              : 0;
        const std::string uvName = "TEXCOORD_" + std::to_string(uvSet);
        auto uvIt = prim.attributes.find(uvName);
        if (uvIt == prim.attributes.end() && uvSet != 0 && prim.attributes.count("TEXCOORD_0")) {
            warn(el + ": material uses " + uvName + ", which is missing; TEXCOORD_0 used instead");
            uvIt = prim.attributes.find("TEXCOORD_0");
        }
        if (uvIt != prim.attributes.end()) {
            const std::string uvEl = el + ".attributes." + uvIt->first;
            std::vector<float> uv = readFloats(uvIt->second, uvEl, TINYGLTF_TYPE_VEC2, Attribute::TexCoord);
            if (uv.size() / 2 != nv)
                fail(uvEl, "count differs from POSITION count");
            mesh.uvs.resize(nv);
            for (size_t i = 0; i < nv; ++i) mesh.uvs[i] = Vec2(uv[2 * i], uv[2 * i + 1]);
        }

        if (material >= 0) {
            if (size_t(material) >= model_.materials.size())
                fail(el + ".material", "material index " + std::to_string(material) + " out of range");
            mesh.material = uint32_t(material);
        } else {
            mesh.material = defaultMaterial();
        }
        result.push_back(uint32_t(scene_.meshes.size()));
        scene_.meshes.push_back(std::move(mesh));
    }
    meshPrimitives_[meshIndex] = result;
    return result;
}

// ---- node hierarchy -------------------------------------------------------------------------

Mat4 GltfImporter::localTransform(const tinygltf::Node& node, const std::string& el) const {
    auto check = [&](const std::vector<double>& v, size_t n, const char* what) {
        if (!v.empty() && v.size() != n)
            fail(el + "." + what, "must have " + std::to_string(n) + " numbers");
        for (double d : v)
            if (!std::isfinite(d)) fail(el + "." + what, "not finite");
    };
    check(node.matrix, 16, "matrix");
    check(node.translation, 3, "translation");
    check(node.rotation, 4, "rotation");
    check(node.scale, 3, "scale");
    if (node.matrix.size() == 16) {
        Mat4 m;
        for (int i = 0; i < 16; ++i) glm::value_ptr(m)[i] = float(node.matrix[size_t(i)]);  // column-major
        return m;
    }
    Mat4 t(1.0f), r(1.0f), s(1.0f);
    if (node.translation.size() == 3)
        t = glm::translate(Mat4(1.0f), Vec3(float(node.translation[0]), float(node.translation[1]),
                                            float(node.translation[2])));
    if (node.rotation.size() == 4) {
        // glTF stores (x, y, z, w); glm::quat's constructor takes (w, x, y, z).
        glm::quat q(float(node.rotation[3]), float(node.rotation[0]), float(node.rotation[1]),
                    float(node.rotation[2]));
        float len = glm::length(q);
        if (!(len > 1e-12f)) fail(el + ".rotation", "zero quaternion");
        r = glm::mat4_cast(q / len);
    }
    if (node.scale.size() == 3)
        s = glm::scale(Mat4(1.0f), Vec3(float(node.scale[0]), float(node.scale[1]), float(node.scale[2])));
    return t * r * s;
}

std::vector<float> GltfImporter::readInstanceRotations(int index, const std::string& element) const {
    // EXT_mesh_gpu_instancing: ROTATION is a VEC4 quaternion (x, y, z, w) of FLOAT or normalized
    // BYTE / SHORT.
    View v = checkedAccessor(index, element, {TINYGLTF_TYPE_VEC4},
                             {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                              TINYGLTF_COMPONENT_TYPE_SHORT});
    if (v.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !v.normalized)
        fail(element, "integer rotations must be normalized");
    std::vector<float> out(v.count * 4, 0.0f);
    if (!v.data) return out;
    const size_t cb = size_t(componentBytes(v.componentType));
    for (size_t i = 0; i < v.count; ++i)
        for (size_t c = 0; c < 4; ++c) {
            const float f = readComponent(v.data + i * v.stride + c * cb, v.componentType, v.normalized);
            if (!std::isfinite(f)) fail(element, "element " + std::to_string(i) + " is not finite");
            out[i * 4 + c] = f;
        }
    return out;
}

void GltfImporter::addGpuInstances(const tinygltf::Value& ext, const std::string& el, const Mat4& world,
                                   const std::string& name, const std::vector<uint32_t>& meshes) {
    // Instance k is placed at world · T_k · R_k · S_k (the node's transform, then the instance's
    // TRS, as the extension defines); every primitive of the node's mesh gets one Instance per k,
    // all sharing that primitive's Mesh (one Embree BVH, many instances).
    if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject())
        fail(el, "missing attributes object");
    const tinygltf::Value& attrs = ext.Get("attributes");
    size_t count = 0;
    auto accessorOf = [&](const char* key) -> int {
        if (!attrs.Has(key)) return -1;
        const tinygltf::Value& v = attrs.Get(key);
        if (!v.IsNumber() || v.GetNumberAsInt() < 0) fail(el + ".attributes." + key, "not an accessor index");
        const int index = v.GetNumberAsInt();
        if (size_t(index) >= model_.accessors.size())
            fail(el + ".attributes." + key, "accessor index " + std::to_string(index) + " out of range");
        const size_t n = model_.accessors[size_t(index)].count;
        if (count != 0 && n != count)
            fail(el + ".attributes." + key, "count " + std::to_string(n) + " differs from the other attributes' " +
                                                std::to_string(count));
        count = n;
        return index;
    };
    const int tIndex = accessorOf("TRANSLATION");
    const int rIndex = accessorOf("ROTATION");
    const int sIndex = accessorOf("SCALE");
    if (count == 0) fail(el + ".attributes", "no TRANSLATION, ROTATION or SCALE accessor");
    if (count * meshes.size() > kMaxInstances - std::min(kMaxInstances, scene_.instances.size()))
        fail(el, std::to_string(count) + " instances exceed the limit of " + std::to_string(kMaxInstances) +
                     " mesh instances per scene");
    const std::vector<float> tr = tIndex >= 0 ? readFloats(tIndex, el + ".attributes.TRANSLATION", TINYGLTF_TYPE_VEC3, Attribute::InstanceVector)
                                              : std::vector<float>();
    const std::vector<float> rot = rIndex >= 0 ? readInstanceRotations(rIndex, el + ".attributes.ROTATION")
                                               : std::vector<float>();
    const std::vector<float> sc = sIndex >= 0 ? readFloats(sIndex, el + ".attributes.SCALE", TINYGLTF_TYPE_VEC3, Attribute::InstanceVector)
                                              : std::vector<float>();
    scene_.instances.reserve(scene_.instances.size() + count * meshes.size());
    for (size_t k = 0; k < count; ++k) {
        Mat4 local(1.0f);
        if (!tr.empty()) local = glm::translate(local, Vec3(tr[3 * k], tr[3 * k + 1], tr[3 * k + 2]));
        if (!rot.empty()) {
            // Stored (x, y, z, w); glm::quat takes (w, x, y, z).
            glm::quat q(rot[4 * k + 3], rot[4 * k], rot[4 * k + 1], rot[4 * k + 2]);
            const float len = glm::length(q);
            if (!(len > 1e-12f)) fail(el + ".attributes.ROTATION", "element " + std::to_string(k) + " is a zero quaternion");
            local = local * glm::mat4_cast(q / len);
        }
        if (!sc.empty()) local = glm::scale(local, Vec3(sc[3 * k], sc[3 * k + 1], sc[3 * k + 2]));
        const Mat4 m = world * local;
        if (!(std::abs(glm::determinant(glm::mat3(m))) > 0.0f))
            fail(el, "instance " + std::to_string(k) + " has a singular transform (zero scale)");
        for (uint32_t meshId : meshes) {
            Instance inst;
            inst.name = name + "#" + std::to_string(k);
            inst.mesh = meshId;
            inst.transform = m;
            scene_.instances.push_back(std::move(inst));
        }
    }
}

void GltfImporter::visitNode(int nodeIndex, const Mat4& parent, int depth) {
    const std::string el = "nodes[" + std::to_string(nodeIndex) + "]";
    if (nodeIndex < 0 || size_t(nodeIndex) >= model_.nodes.size())
        fail(el, "node index out of range (" + std::to_string(model_.nodes.size()) + " nodes)");
    if (depth > kMaxNodeDepth) fail(el, "node hierarchy deeper than " + std::to_string(kMaxNodeDepth));
    if (onPath_[size_t(nodeIndex)]) fail(el, "node hierarchy has a cycle");
    onPath_[size_t(nodeIndex)] = 1;
    const tinygltf::Node& node = model_.nodes[size_t(nodeIndex)];
    const Mat4 world = parent * localTransform(node, el);
    const std::string name = node.name.empty() ? el : node.name;

    const tinygltf::Value* gpuInstancing = extension(node.extensions, "EXT_mesh_gpu_instancing");
    if (node.mesh >= 0) {
        if (node.skin >= 0) warn(el + ": skin ignored (mesh used in its bind pose)");
        if (gpuInstancing) {
            addGpuInstances(*gpuInstancing, el + ".extensions.EXT_mesh_gpu_instancing", world, name,
                            convertMesh(node.mesh));
        } else {
            for (uint32_t meshId : convertMesh(node.mesh)) {
                Instance inst;
                inst.name = name;
                inst.mesh = meshId;
                inst.transform = world;
                scene_.instances.push_back(inst);
            }
        }
        if (scene_.instances.size() > kMaxInstances)
            fail(el, "more than " + std::to_string(kMaxInstances) + " mesh instances in the scene");
    } else if (gpuInstancing) {
        warn(el + ": EXT_mesh_gpu_instancing on a node without a mesh; ignored");
    }
    Vec3 origin = Vec3(world * glm::vec4(0, 0, 0, 1));
    glm::mat3 lin(world);
    if (node.camera >= 0) {
        if (size_t(node.camera) >= model_.cameras.size())
            fail(el + ".camera", "camera index " + std::to_string(node.camera) + " out of range");
        const tinygltf::Camera& gc = model_.cameras[size_t(node.camera)];
        const std::string camEl = "cameras[" + std::to_string(node.camera) + "]";
        if (gc.type != "perspective") {
            warn(camEl + ": camera type '" + gc.type + "' unsupported; ignored");
        } else if (!scene_.camera) {
            Vec3 fwd = lin * Vec3(0, 0, -1);
            Vec3 up = lin * Vec3(0, 1, 0);
            double yfov = gc.perspective.yfov;
            if (!(yfov > 1e-4 && yfov < 3.1)) fail(camEl + ".perspective.yfov", "outside (0, pi)");
            if (!finite3(fwd) || glm::length(fwd) < 1e-12f || glm::length(glm::cross(fwd, up)) < 1e-12f)
                fail(el, "camera node transform is degenerate");
            scene_.camera = Camera::lookAt(origin, origin + glm::normalize(fwd), glm::normalize(up),
                                           float(yfov));
        }
    }
    if (const tinygltf::Value* lp = extension(node.extensions, "KHR_lights_punctual")) {
        const std::string lightEl = el + ".extensions.KHR_lights_punctual";
        if (!lp->IsObject() || !lp->Has("light") || !lp->Get("light").IsNumber())
            fail(lightEl, "missing light index");
        int li = lp->Get("light").GetNumberAsInt();
        if (li < 0 || size_t(li) >= model_.lights.size())
            fail(lightEl, "light index " + std::to_string(li) + " out of range");
        const tinygltf::Light& gl = model_.lights[size_t(li)];
        const std::string glEl = "extensions.KHR_lights_punctual.lights[" + std::to_string(li) + "]";
        Light l;
        l.name = gl.name.empty() ? glEl : gl.name;
        Vec3 color(1.0f);
        if (gl.color.size() >= 3) color = Vec3(float(gl.color[0]), float(gl.color[1]), float(gl.color[2]));
        l.intensity = color * float(gl.intensity);
        if (!finite3(l.intensity) || glm::any(glm::lessThan(l.intensity, Vec3(0.0f))))
            fail(glEl, "intensity and color must be finite and non-negative");
        l.position = origin;
        Vec3 dir = lin * Vec3(0, 0, -1);
        if (gl.type != "point") {
            if (!finite3(dir) || !(glm::length(dir) > 1e-12f)) fail(el, "light node transform is degenerate");
            l.direction = unitKeepingBits(dir);
        }
        if (gl.type == "point") {
            l.type = LightType::Point;
        } else if (gl.type == "directional") {
            l.type = LightType::Directional;
        } else if (gl.type == "spot") {
            l.type = LightType::Spot;
            float inner = float(gl.spot.innerConeAngle), outer = float(gl.spot.outerConeAngle);
            if (!std::isfinite(inner) || !std::isfinite(outer) || outer <= 0.0f)
                fail(glEl + ".spot", "cone angles must be finite and outer > 0");
            outer = std::min(outer, 1.5707964f);
            inner = std::clamp(inner, 0.0f, outer);
            if (inner >= outer) {
                warn(glEl + ".spot: innerConeAngle >= outerConeAngle; inner set just below outer");
                inner = outer * 0.999f;
            }
            l.innerConeAngle = inner;
            l.outerConeAngle = outer;
        } else {
            fail(glEl + ".type", "unknown light type '" + gl.type + "'");
        }
        if (gl.range > 0.0) warn(glEl + ": range ignored (physical inverse-square falloff)");
        scene_.lights.push_back(l);
    }
    for (int child : node.children) visitNode(child, world, depth + 1);
    onPath_[size_t(nodeIndex)] = 0;
}

Scene GltfImporter::run() {
    checkExtensions();
    readVariants();
    convertMaterials();
    onPath_.assign(model_.nodes.size(), 0);
    std::vector<int> roots;
    if (!model_.scenes.empty()) {
        int s = model_.defaultScene >= 0 ? model_.defaultScene : 0;
        if (size_t(s) >= model_.scenes.size())
            fail("scene", "default scene " + std::to_string(s) + " out of range");
        roots = model_.scenes[size_t(s)].nodes;
        scene_.name = model_.scenes[size_t(s)].name;
    } else {
        // No scenes: every node that is nobody's child is a root.
        std::vector<uint8_t> isChild(model_.nodes.size(), 0);
        for (const auto& n : model_.nodes)
            for (int c : n.children)
                if (c >= 0 && size_t(c) < isChild.size()) isChild[size_t(c)] = 1;
        for (size_t i = 0; i < model_.nodes.size(); ++i)
            if (!isChild[i]) roots.push_back(int(i));
    }
    for (int r : roots) visitNode(r, Mat4(1.0f), 0);
    if (scene_.name.empty()) scene_.name = std::filesystem::path(file_).stem().string();
    if (!model_.animations.empty()) warn("animations ignored");
    return std::move(scene_);
}

}  // namespace

namespace {

// Parses `bytes` (the scene file, already charged to `files`) and imports it; every external
// file goes through `files`.
Scene loadGltfBytes(const std::vector<uint8_t>& bytes, SceneFiles& files, const GltfOptions& options) {
    const std::string& fileName = files.sceneFile();
    if (bytes.empty()) throw SceneError(fileName, "file", "file is empty (0 bytes)");
    FsContext ctx;
    ctx.files = &files;
    if (!files.baseDir().empty()) {
        ctx.base = files.baseDir().string();
        if (ctx.base.back() != '/') ctx.base += '/';
    }
    tinygltf::TinyGLTF loader;
    loader.SetFsCallbacks(
        tinygltf::FsCallbacks{&fsFileExists, &fsExpandPath, &fsReadWholeFile, &fsWriteWholeFile, &ctx});
    loader.SetImageLoader(&keepEncodedImage, nullptr);
    tinygltf::Model model;
    std::string err, warn;
    bool ok = false;
    const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    {
        // The JSON text: the whole file, or a GLB's first chunk (bounds checked; tinygltf
        // rejects a malformed header itself).
        const unsigned char* json = bytes.data();
        size_t jsonBytes = bytes.size();
        if (binary) {
            uint32_t chunkLength = 0;
            if (bytes.size() >= 20) std::memcpy(&chunkLength, bytes.data() + 12, 4);
            json = bytes.data() + std::min<size_t>(20, bytes.size());
            jsonBytes = std::min<size_t>(chunkLength, bytes.size() - std::min<size_t>(20, bytes.size()));
        }
        const JsonScan scan = scanJson(json, jsonBytes);
        if (scan.depth > kMaxJsonDepth)
            throw SceneError(fileName, "JSON", "nesting deeper than " + std::to_string(kMaxJsonDepth) + " levels");
        // Base64 decodes 4 characters into 3 bytes: charge what the data: URIs will become.
        files.charge(scan.dataUriChars / 4 * 3, "data: URIs");
        // Every object (node, accessor, material…) before tinygltf parses it: a file of a
        // million tiny nodes is refused here, naming them, not after gigabytes of parsing.
        for (const auto& [member, objects] : scan.objectsIn)
            files.charge(objects * kBytesPerJsonObject,
                         printableText(member, 40) + " (" + std::to_string(objects) + " JSON objects at " +
                             std::to_string(kBytesPerJsonObject) + " bytes each once parsed)");
    }
    try {
        if (binary) {
            ok = loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(),
                                             unsigned(std::min<size_t>(bytes.size(), UINT32_MAX)),
                                             ctx.base);
        } else {
            ok = loader.LoadASCIIFromString(&model, &err, &warn,
                                            reinterpret_cast<const char*>(bytes.data()),
                                            unsigned(std::min<size_t>(bytes.size(), UINT32_MAX)),
                                            ctx.base);
        }
    } catch (const std::exception& e) {
        ok = false;
        err += e.what();
    }
    // A refused reference is an error even where tinygltf would only warn (images).
    if (ctx.refusal) throw *ctx.refusal;
    if (!ok) {
        if (err.empty()) err = "cannot parse glTF";
        err = printableText(trimmed(err), 400);
        if (!binary && bytes[0] != '{' && bytes[0] != ' ' && bytes[0] != '\n' && bytes[0] != '\t' &&
            bytes[0] != '\r')
            throw SceneError(fileName, "JSON", "not a glTF file (neither JSON nor GLB): " + err);
        throw SceneError(fileName, elementFromTinygltfError(err), err);
    }
    GltfImporter importer(model, files, options);
    Scene scene = importer.run();
    if (!warn.empty())
        scene.warnings.insert(scene.warnings.begin(), fileName + ": " + printableText(trimmed(warn), 400));
    return scene;
}

}  // namespace

Scene loadGltfFromMemory(const std::vector<uint8_t>& bytes, const std::string& fileName,
                         const std::string& baseDir, const SceneInputPolicy& policy,
                         const GltfOptions& options) {
    SceneFiles files(fileName, baseDir, policy);
    files.charge(bytes.size(), "file");
    return loadGltfBytes(bytes, files, options);
}

Scene loadGltf(const std::string& path, const SceneInputPolicy& policy, const GltfOptions& options) {
    SceneFiles files(path, policy);
    const std::vector<uint8_t> bytes = files.read(path, "file");
    return loadGltfBytes(bytes, files, options);
}

}  // namespace rtpm
