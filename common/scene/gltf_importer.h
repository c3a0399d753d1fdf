// The glTF importer's parts, shared by its source files (not part of the scene library's interface):
// GltfImporter maps a tinygltf::Model to a Scene, checking every index and byte range first.
//
// Its members live by section: gltf_accessors.cpp (accessor and byte-range checks),
// gltf_materials.cpp (extensions, materials, textures), gltf_meshes.cpp (primitives to meshes),
// gltf_draco.cpp (Draco-compressed primitives), gltf_nodes.cpp (the node hierarchy: transforms, instances, cameras, lights; run()).
// gltf_loader.cpp parses the file with tinygltf and calls run().
#pragma once

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "common/scene/gltf_loader.h"
#include "common/scene/scene.h"
#include "common/scene/scene_files.h"

namespace rtpm::gltf {

// The vertex data readFloats reads, for the component types each may hold.
enum class Attribute { Position, Normal, TexCoord, InstanceVector };

// KHR_materials_pbrSpecularGlossiness in the metallic-roughness terms the renderer reads.
struct MetallicRoughness {
    Vec3 baseColor{1.0f};
    double metallic = 0.0;
    double roughness = 0.0;
};

inline bool finite3(Vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// `v` normalised, or `v` itself when it is already unit to float precision. Normalising a unit
// vector again may move it by an ulp; keeping it makes a scene that went through encodeGlb (the
// master's copy for cluster clients) load back with the very normals and light directions the
// master loaded, so the cluster's image equals rtpm-render's bit for bit.
inline Vec3 unitKeepingBits(Vec3 v) {
    const float len2 = glm::dot(v, v);
    return std::abs(len2 - 1.0f) <= 1e-6f ? v : v / std::sqrt(len2);
}

// The extension `name` of an element's extension map, nullptr when absent.
inline const tinygltf::Value* extension(const tinygltf::ExtensionMap& map, const char* name) {
    auto it = map.find(name);
    return it == map.end() ? nullptr : &it->second;
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

    // ---- accessors (gltf_accessors.cpp)
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
    std::vector<float> readInstanceRotations(int index, const std::string& element) const;

    // ---- extensions, materials, textures (gltf_materials.cpp)
    void checkExtensions();
    void readVariants();
    int primitiveMaterial(const tinygltf::Primitive& prim, const std::string& element) const;
    void convertMaterials();
    MetallicRoughness specularGlossiness(const tinygltf::Value& sg, const std::string& sgEl) const;
    tinygltf::TextureInfo specularGlossinessTexture(const tinygltf::Value& sg, const std::string& element) const;
    void readIorAndVolume(const tinygltf::Material& gm, const std::string& el, Material& m) const;
    void readSpecular(const tinygltf::Material& gm, const std::string& el, Material& m);
    void readEmission(const tinygltf::Material& gm, const std::string& el, Material& m, int& uvSet);
    void warnIgnored(const tinygltf::Material& gm, const std::string& el);
    TextureTransform textureTransform(const tinygltf::Value& ext, const std::string& element,
                                      int& uvSet) const;
    int textureFor(int gltfTexture, const std::string& element);
    std::vector<unsigned char> imageBytes(int source) const;
    /// The bytes of bufferView `view` (byteOffset, byteLength) after its index, its buffer and its
    /// range are checked; errors name `element` (what refers to the view).
    std::span<const unsigned char> viewBytes(int view, const std::string& element) const;
    void scaleByMeanOfTexture(const tinygltf::TextureInfo& info, const std::string& element, double& roughness,
                              double& metallic);
    uint32_t defaultMaterial();

    // ---- meshes (gltf_meshes.cpp)
    std::vector<uint32_t> convertMesh(int meshIndex);
    void readAccessors(const tinygltf::Primitive& prim, const std::string& el, int material, Mesh& mesh);
    // ---- KHR_draco_mesh_compression (gltf_draco.cpp)
    std::pair<const char*, size_t> dracoBytes(const tinygltf::Value& ext, const std::string& element) const;
    void decodeDraco(const tinygltf::Primitive& prim, const tinygltf::Value& ext, const std::string& element,
                     int material, Mesh& mesh);
    void readNormals(const tinygltf::Primitive& prim, const std::string& el, size_t positionFloats,
                     Mesh& mesh);
    void readUvs(const tinygltf::Primitive& prim, const std::string& el, int material, Mesh& mesh);
    /// `n` (3 floats a vertex; empty: the file has none) as the mesh's unit normals, or smooth
    /// normals from its triangles when empty or when one is zero-length (warned on `el`).
    void setNormals(const std::vector<float>& n, const std::string& el, Mesh& mesh);
    /// The TEXCOORD_n attribute the glTF material `material` reads (TEXCOORD_0 with a warning when
    /// its own set is missing); empty when the primitive has neither.
    std::string uvAttribute(const tinygltf::Primitive& prim, const std::string& el, int material);

    // ---- node hierarchy (gltf_nodes.cpp)
    void readWorld(const tinygltf::Value& world, const std::string& element);
    void visitNode(int node, const Mat4& parent, int depth);
    Mat4 localTransform(const tinygltf::Node& node, const std::string& element) const;
    void addGpuInstances(const tinygltf::Value& ext, const std::string& element, const Mat4& world,
                         const std::string& name, const std::vector<uint32_t>& meshes);

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

}  // namespace rtpm::gltf
