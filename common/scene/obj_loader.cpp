// Wavefront OBJ + MTL import: a line-checking pre-scan, then tinyobjloader, then the MTL mapping.
#include "common/scene/obj_loader.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include "common/core/printable_text.h"
#include "common/scene/scene_files.h"
#include "common/scene/texture_decode.h"

namespace rtpm {

namespace {

bool finite3(Vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

float maxc(Vec3 v) { return std::max(v.x, std::max(v.y, v.z)); }

std::string lineEl(size_t line) { return "line " + std::to_string(line); }

// tinyobjloader reads bad numbers as 0 and only warns (at the file's last line) about face
// indices out of range, so the file is checked here first, line by line, to name the culprit.
void prescanObj(const std::string& text, const std::string& file) {
    size_t counts[3] = {0, 0, 0};  // v, vt, vn
    struct FaceRef {
        size_t line;
        long index[3];  // v, vt, vn (0 = absent)
        size_t seen[3];
    };
    std::vector<FaceRef> refs;
    std::istringstream in(text);
    std::string line;
    size_t lineNo = 0;
    while (std::getline(in, line)) {
        ++lineNo;
        size_t p = line.find_first_not_of(" \t");
        if (p == std::string::npos || line[p] == '#') continue;
        std::istringstream ls(line.substr(p));
        std::string key;
        ls >> key;
        int kind = key == "v" ? 0 : key == "vt" ? 1 : key == "vn" ? 2 : -1;
        if (kind >= 0) {
            size_t need = kind == 1 ? 1 : 3;
            size_t got = 0;
            std::string tok;
            while (ls >> tok && got < need) {
                char* end = nullptr;
                double d = std::strtod(tok.c_str(), &end);
                if (end == tok.c_str() || *end != '\0')
                    throw SceneError(file, lineEl(lineNo), "'" + tok + "' is not a number");
                if (!std::isfinite(d))
                    throw SceneError(file, lineEl(lineNo), "vertex value is not finite (NaN or Inf)");
                ++got;
            }
            if (got < need)
                throw SceneError(file, lineEl(lineNo), "'" + key + "' needs " + std::to_string(need) +
                                                           " numbers");
            ++counts[kind];
        } else if (key == "f" || key == "l" || key == "p") {
            std::string tok;
            size_t corners = 0;
            while (ls >> tok) {
                FaceRef r{lineNo, {0, 0, 0}, {counts[0], counts[1], counts[2]}};
                size_t start = 0;
                for (int part = 0; part < 3 && start <= tok.size(); ++part) {
                    size_t slash = tok.find('/', start);
                    std::string s = tok.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
                    if (!s.empty()) {
                        char* end = nullptr;
                        errno = 0;
                        long v = std::strtol(s.c_str(), &end, 10);
                        // Beyond any count a file can define (and −LONG_MIN is no long): refused.
                        if (end == s.c_str() || *end != '\0' || v == 0 || errno == ERANGE)
                            throw SceneError(file, lineEl(lineNo), "bad index '" + tok + "'");
                        r.index[part] = v;
                    } else if (part == 0) {
                        throw SceneError(file, lineEl(lineNo), "missing vertex index in '" + tok + "'");
                    }
                    if (slash == std::string::npos) break;
                    start = slash + 1;
                }
                refs.push_back(r);
                ++corners;
            }
            if (key == "f" && corners < 3)
                throw SceneError(file, lineEl(lineNo), "face with fewer than 3 vertices");
        }
    }
    static const char* kNames[3] = {"vertex", "texture coordinate", "normal"};
    for (const FaceRef& r : refs)
        for (int k = 0; k < 3; ++k) {
            long v = r.index[k];
            if (v == 0) continue;
            // Positive: 1-based into the whole file; negative: relative to the ones seen so far.
            bool ok = v > 0 ? size_t(v) <= counts[k] : size_t(-v) <= r.seen[k];
            if (!ok)
                throw SceneError(file, lineEl(r.line),
                                 std::string(kNames[k]) + " index " + std::to_string(v) +
                                     " out of range (" + std::to_string(counts[k]) + " defined)");
        }
}

// tinyobjloader's MaterialReader for `mtllib`: the library is resolved and read through
// SceneFiles (confined, regular file, budget). A refusal is kept and rethrown after parsing.
class ConfinedMtlReader : public tinyobj::MaterialReader {
public:
    explicit ConfinedMtlReader(SceneFiles& files) : files_(files) {}
    bool operator()(const std::string& matId, std::vector<tinyobj::material_t>* materials,
                    std::map<std::string, int>* matMap, std::string* warn, std::string* err) override {
        const std::string el = "mtllib '" + printableText(matId) + "'";
        try {
            const std::filesystem::path r = files_.resolve(matId, el);
            if (!SceneFiles::exists(r)) {
                if (warn) *warn += "material library " + el + " not found\n";
                return false;
            }
            const std::vector<uint8_t> bytes = files_.read(r, el);
            std::istringstream in(std::string(bytes.begin(), bytes.end()));
            tinyobj::LoadMtl(matMap, materials, &in, warn, err);
            return true;
        } catch (const SceneError& e) {
            if (!refusal) refusal = e;
            return false;
        }
    }
    std::optional<SceneError> refusal;

private:
    SceneFiles& files_;
};

Material convertMaterial(const tinyobj::material_t& m, SceneFiles& files, Scene& scene) {
    const std::string& file = files.sceneFile();
    Material out;
    out.name = m.name;
    const Vec3 kd(m.diffuse[0], m.diffuse[1], m.diffuse[2]);
    const Vec3 ks(m.specular[0], m.specular[1], m.specular[2]);
    const Vec3 tf(m.transmittance[0], m.transmittance[1], m.transmittance[2]);
    const Vec3 ke(m.emission[0], m.emission[1], m.emission[2]);
    const std::string el = "material '" + printableText(m.name) + "'";
    if (!finite3(kd) || !finite3(ks) || !finite3(tf) || !finite3(ke) || !std::isfinite(m.ior) ||
        !std::isfinite(m.dissolve))
        throw SceneError(file, el, "non-finite value");
    if (glm::any(glm::lessThan(ke, Vec3(0.0f)))) throw SceneError(file, el, "negative Ke");
    out.emission = ke;

    const bool mirror = m.illum == 3 || m.illum == 5 || (maxc(ks) >= 0.99f && maxc(kd) <= 0.01f) ||
                        (m.metallic >= 0.99f && m.roughness <= 0.01f);
    const bool glass = m.illum == 4 || m.illum == 6 || m.illum == 7 || m.illum == 9 ||
                       (m.dissolve < 1.0f && m.ior > 1.0f);
    if (glass) {
        out.type = MaterialType::Dielectric;
        out.baseColor = Vec3(1.0f);
        if (m.ior > 1.0f) {
            out.ior = m.ior;
        } else {
            out.ior = 1.5f;
            scene.warnings.push_back(file + ": " + el + ": no Ni > 1 for a transparent material; ior 1.5 used");
        }
        if (out.ior > 4.0f) throw SceneError(file, el, "Ni " + std::to_string(m.ior) + " above 4");
        if (maxc(tf) > 0.0f)
            for (int c = 0; c < 3; ++c)
                out.absorption[c] = -std::log(std::clamp(tf[c], 1e-4f, 1.0f));  // per metre
    } else if (mirror) {
        out.type = MaterialType::Mirror;
        Vec3 r = m.illum == 3 || m.illum == 5 || maxc(ks) >= 0.99f ? ks : kd;
        out.baseColor = glm::clamp(r, Vec3(0.0f), Vec3(1.0f));
    } else {
        out.type = MaterialType::Diffuse;
        out.baseColor = glm::clamp(kd, Vec3(0.0f), Vec3(1.0f));
        if (!m.diffuse_texname.empty()) {
            const std::string mapEl = el + " map_Kd";
            const std::filesystem::path tp = files.resolve(m.diffuse_texname, mapEl);
            if (!SceneFiles::exists(tp)) {
                scene.warnings.push_back(file + ": " + mapEl + " '" + printableText(m.diffuse_texname) +
                                         "' not found; ignored");
            } else {
                std::vector<uint8_t> bytes = files.read(tp, mapEl);
                Texture t = decodeSrgbTexture(bytes, m.diffuse_texname, file, mapEl, &files);
                t.name = m.diffuse_texname;
                out.baseColorTexture = int32_t(scene.textures.size());
                scene.textures.push_back(std::move(t));
            }
        }
    }
    if (!m.bump_texname.empty() || !m.specular_texname.empty() || !m.normal_texname.empty())
        scene.warnings.push_back(file + ": " + el + ": bump/normal/specular maps ignored");
    return out;
}

}  // namespace

namespace {

// Parses the OBJ text of files.sceneFile() (already charged to `files`) and its MTL libraries.
Scene loadObjText(const std::string& text, SceneFiles& files) {
    const std::string& path = files.sceneFile();
    if (text.empty()) throw SceneError(path, "file", "file is empty (0 bytes)");
    if (text.find('\0') != std::string::npos)
        throw SceneError(path, "file", "binary data (NUL byte) in an OBJ text file");
    prescanObj(text, path);

    std::filesystem::path p(path);
    // tinyobjloader keeps a few floats per value and one index triple per corner, each within a
    // small multiple of the text that wrote it: charge that multiple before parsing.
    files.charge(uint64_t(text.size()) * 2, "OBJ arrays");
    tinyobj::attrib_t attrib;
    std::vector<tinyobj::shape_t> shapes;
    std::vector<tinyobj::material_t> mtls;
    std::string warn, err;
    ConfinedMtlReader mtlReader(files);
    std::istringstream in(text);
    const bool parsed = tinyobj::LoadObj(&attrib, &shapes, &mtls, &warn, &err, &in, &mtlReader,
                                         /*triangulate=*/true, /*default_vcols_fallback=*/false);
    if (mtlReader.refusal) throw *mtlReader.refusal;
    if (!parsed)
        throw SceneError(path, "OBJ", err.empty() ? "cannot parse" : printableText(err, 400));

    Scene scene;
    scene.name = p.stem().string();
    if (!warn.empty()) scene.warnings.push_back(path + ": " + printableText(warn, 400));
    for (size_t i = 0; i < mtls.size(); ++i) scene.materials.push_back(convertMaterial(mtls[i], files, scene));
    const uint32_t defaultMat = uint32_t(scene.materials.size());
    {
        Material d;
        d.name = "default";
        d.baseColor = Vec3(0.8f);
        scene.materials.push_back(d);
    }

    const size_t nv = attrib.vertices.size() / 3, nn = attrib.normals.size() / 3,
                 nt = attrib.texcoords.size() / 2;
    // Per-OBJ-vertex smooth normals for corners without a `vn`, accumulated over all faces.
    std::vector<Vec3> objNormals;
    auto position = [&](int i) {
        return Vec3(attrib.vertices[3 * size_t(i)], attrib.vertices[3 * size_t(i) + 1],
                    attrib.vertices[3 * size_t(i) + 2]);
    };
    for (const auto& sh : shapes)
        for (const auto& idx : sh.mesh.indices)
            if (idx.vertex_index < 0 || size_t(idx.vertex_index) >= nv ||
                (idx.normal_index >= 0 && size_t(idx.normal_index) >= nn) ||
                (idx.texcoord_index >= 0 && size_t(idx.texcoord_index) >= nt))
                throw SceneError(path, "shape '" + sh.name + "'", "face index out of range");
    bool anyMissingNormal = false;
    for (const auto& sh : shapes)
        for (const auto& idx : sh.mesh.indices) anyMissingNormal |= idx.normal_index < 0;
    if (anyMissingNormal) {
        objNormals.assign(nv, Vec3(0.0f));
        for (const auto& sh : shapes)
            for (size_t t = 0; t + 2 < sh.mesh.indices.size(); t += 3) {
                int a = sh.mesh.indices[t].vertex_index, b = sh.mesh.indices[t + 1].vertex_index,
                    c = sh.mesh.indices[t + 2].vertex_index;
                Vec3 g = glm::cross(position(b) - position(a), position(c) - position(a));
                objNormals[size_t(a)] += g;
                objNormals[size_t(b)] += g;
                objNormals[size_t(c)] += g;
            }
        for (Vec3& n : objNormals) {
            float len = glm::length(n);
            n = len > 0.0f && std::isfinite(len) ? n / len : Vec3(0, 0, 1);
        }
    }

    for (const auto& sh : shapes) {
        // Split the shape by material; corners are deduplicated on (v, vt, vn).
        std::map<int, Mesh> byMaterial;
        std::map<int, std::map<std::tuple<int, int, int>, uint32_t>> remap;
        const size_t faces = sh.mesh.indices.size() / 3;
        for (size_t f = 0; f < faces; ++f) {
            int mat = f < sh.mesh.material_ids.size() ? sh.mesh.material_ids[f] : -1;
            if (mat < 0 || size_t(mat) >= mtls.size()) mat = -1;
            Mesh& mesh = byMaterial[mat];
            auto& rm = remap[mat];
            for (int k = 0; k < 3; ++k) {
                const tinyobj::index_t& idx = sh.mesh.indices[3 * f + size_t(k)];
                auto key = std::make_tuple(idx.vertex_index, idx.texcoord_index, idx.normal_index);
                auto it = rm.find(key);
                if (it == rm.end()) {
                    uint32_t id = uint32_t(mesh.positions.size());
                    mesh.positions.push_back(position(idx.vertex_index));
                    Vec3 n = idx.normal_index >= 0
                                 ? Vec3(attrib.normals[3 * size_t(idx.normal_index)],
                                        attrib.normals[3 * size_t(idx.normal_index) + 1],
                                        attrib.normals[3 * size_t(idx.normal_index) + 2])
                                 : objNormals[size_t(idx.vertex_index)];
                    float len = glm::length(n);
                    mesh.normals.push_back(len > 1e-12f && std::isfinite(len) ? n / len : Vec3(0, 0, 1));
                    // OBJ's v runs upwards; Texture rows run downwards (glTF convention).
                    mesh.uvs.push_back(idx.texcoord_index >= 0
                                           ? Vec2(attrib.texcoords[2 * size_t(idx.texcoord_index)],
                                                  1.0f - attrib.texcoords[2 * size_t(idx.texcoord_index) + 1])
                                           : Vec2(0.0f));
                    it = rm.emplace(key, id).first;
                }
                mesh.indices.push_back(it->second);
            }
        }
        for (auto& [mat, mesh] : byMaterial) {
            mesh.name = sh.name + (mat >= 0 ? "/" + mtls[size_t(mat)].name : "");
            mesh.material = mat >= 0 ? uint32_t(mat) : defaultMat;
            Instance inst;
            inst.name = mesh.name;
            inst.mesh = uint32_t(scene.meshes.size());
            scene.instances.push_back(inst);
            scene.meshes.push_back(std::move(mesh));
        }
    }
    if (scene.meshes.empty()) throw SceneError(path, "faces", "no triangles in the OBJ file");
    return scene;
}

}  // namespace

Scene loadObj(const std::string& path, const SceneInputPolicy& policy) {
    SceneFiles files(path, policy);
    const std::vector<uint8_t> bytes = files.read(path, "file");
    return loadObjText(std::string(bytes.begin(), bytes.end()), files);
}

Scene loadObjFromMemory(const std::string& text, const std::string& fileName,
                        const std::string& baseDir, const SceneInputPolicy& policy) {
    SceneFiles files(fileName, baseDir, policy);
    files.charge(text.size(), "file");
    return loadObjText(text, files);
}

}  // namespace rtpm
