// glTF 2.0 import: tinygltf parses, the importer (gltf_importer.h) checks every index and byte
// range and maps to Scene.
//
// tinygltf is trusted only for JSON/GLB framing. Everything it leaves unchecked (accessor
// ranges, strides, component types, node indices, image buffer views) is checked before
// a byte is read, so malformed files end in SceneError, never a crash or a huge allocation.
// This file holds tinygltf's implementation, its file-system callbacks and the JSON pre-scan.
#define TINYGLTF_IMPLEMENTATION
#include "common/scene/gltf_importer.h"

#include "common/scene/gltf_loader.h"

#include "common/core/printable_text.h"
#include "common/scene/scene_files.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <regex>
#include <string_view>

namespace rtpm {

namespace {

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

// tinygltf refuses a primitive whose indices accessor has no bufferView, which is how every
// Draco-compressed primitive comes (KHR_draco_mesh_compression: the triangles are in the Draco data,
// which gltf_draco.cpp decodes). The JSON with those primitives' "indices" left out, or nothing when
// no primitive has the extension (or the text is not JSON: tinygltf then names the error).
std::optional<std::string> withoutDracoIndices(const unsigned char* json, size_t n) {
    const std::string_view text(reinterpret_cast<const char*>(json), n);
    if (text.find("KHR_draco_mesh_compression") == std::string_view::npos) return std::nullopt;
    nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
    if (doc.is_discarded() || !doc.is_object() || !doc.contains("meshes") || !doc["meshes"].is_array())
        return std::nullopt;
    bool changed = false;
    for (nlohmann::json& mesh : doc["meshes"]) {
        if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
        for (nlohmann::json& prim : mesh["primitives"]) {
            if (!prim.is_object() || !prim.contains("extensions") || !prim["extensions"].is_object() ||
                !prim["extensions"].contains("KHR_draco_mesh_compression"))
                continue;
            changed = prim.erase("indices") > 0 || changed;
        }
    }
    if (!changed) return std::nullopt;
    return doc.dump();
}

// `bytes` (a GLB whose JSON chunk is `jsonBytes` long) with `json` as its JSON chunk, padded with
// spaces to 4 bytes; the chunks after it copied as they are.
std::vector<uint8_t> glbWithJson(const std::vector<uint8_t>& bytes, size_t jsonBytes, std::string json) {
    while (json.size() % 4) json.push_back(' ');
    const size_t restFrom = std::min(bytes.size(), 20 + jsonBytes);
    std::vector<uint8_t> out(bytes.begin(), bytes.begin() + 12);
    const uint32_t total = uint32_t(std::min<size_t>(UINT32_MAX, 20 + json.size() + (bytes.size() - restFrom)));
    const uint32_t length = uint32_t(json.size()), kind = 0x4E4F534A;  // "JSON"
    std::memcpy(out.data() + 8, &total, 4);
    out.insert(out.end(), reinterpret_cast<const uint8_t*>(&length), reinterpret_cast<const uint8_t*>(&length) + 4);
    out.insert(out.end(), reinterpret_cast<const uint8_t*>(&kind), reinterpret_cast<const uint8_t*>(&kind) + 4);
    out.insert(out.end(), json.begin(), json.end());
    out.insert(out.end(), bytes.begin() + std::ptrdiff_t(restFrom), bytes.end());
    return out;
}

// tinygltf (2.7) checks a GLB's BIN chunk against the file without the chunk's own 8-byte header
// and then copies up to 8 bytes past the end: the chunks are checked here first. Nothing for a
// file too short to hold a JSON chunk (tinygltf refuses it).
void checkGlbChunks(const std::vector<uint8_t>& glb, const std::string& fileName) {
    if (glb.size() < 20) return;
    uint32_t length = 0, jsonLength = 0;
    std::memcpy(&length, glb.data() + 8, 4);
    std::memcpy(&jsonLength, glb.data() + 12, 4);
    const uint64_t end = std::min<uint64_t>(length, glb.size());
    const uint64_t binAt = 20ull + jsonLength;
    if (binAt >= end) return;  // no BIN chunk (or a JSON chunk tinygltf refuses)
    uint32_t binLength = 0;
    if (binAt + 8 <= end) std::memcpy(&binLength, glb.data() + binAt, 4);
    if (binAt + 8 > end || binAt + 8 + binLength > end)
        throw SceneError(fileName, "GLB", "the BIN chunk (" + std::to_string(binLength) + " bytes at byte " +
                                              std::to_string(binAt) + ") runs past the end of the file (" +
                                              std::to_string(end) + " bytes)");
}

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
    // The JSON text: the whole file, or a GLB's first chunk (bounds checked; tinygltf rejects a
    // malformed header itself).
    const unsigned char* jsonText = bytes.data();
    size_t jsonBytes = bytes.size();
    if (binary) {
        uint32_t chunkLength = 0;
        if (bytes.size() >= 20) std::memcpy(&chunkLength, bytes.data() + 12, 4);
        jsonText = bytes.data() + std::min<size_t>(20, bytes.size());
        jsonBytes = std::min<size_t>(chunkLength, bytes.size() - std::min<size_t>(20, bytes.size()));
    }
    {
        const JsonScan scan = scanJson(jsonText, jsonBytes);
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
    std::vector<uint8_t> rewritten;  // the file without its Draco primitives' index accessors
    if (std::optional<std::string> json = withoutDracoIndices(jsonText, jsonBytes))
        rewritten = binary ? glbWithJson(bytes, jsonBytes, std::move(*json))
                           : std::vector<uint8_t>(json->begin(), json->end());
    const std::vector<uint8_t>& parsed = rewritten.empty() ? bytes : rewritten;
    if (binary) checkGlbChunks(parsed, fileName);
    try {
        if (binary) {
            ok = loader.LoadBinaryFromMemory(&model, &err, &warn, parsed.data(),
                                             unsigned(std::min<size_t>(parsed.size(), UINT32_MAX)),
                                             ctx.base);
        } else {
            ok = loader.LoadASCIIFromString(&model, &err, &warn,
                                            reinterpret_cast<const char*>(parsed.data()),
                                            unsigned(std::min<size_t>(parsed.size(), UINT32_MAX)),
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
    gltf::GltfImporter importer(model, files, options);
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
