// glTF meshes: every TRIANGLES primitive becomes one rtpm Mesh (positions, indices, normals read or
// computed, the uv set its material names), converted once however many nodes use it.
#include "common/scene/gltf_importer.h"

#include "common/scene/vertex_normals.h"

namespace rtpm::gltf {

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
        if (!prim.attributes.count("POSITION")) fail(el + ".attributes", "no POSITION attribute");
        Mesh mesh;
        mesh.name = (gmesh.name.empty() ? meshEl : gmesh.name) +
                    (gmesh.primitives.size() > 1 ? "/" + std::to_string(pi) : "");
        const int material = primitiveMaterial(prim, el);
        if (const tinygltf::Value* draco = extension(prim.extensions, "KHR_draco_mesh_compression"))
            decodeDraco(prim, *draco, el, material, mesh);
        else
            readAccessors(prim, el, material, mesh);
        if (mesh.indices.empty()) {
            warn(el + ": no triangles; primitive skipped");
            continue;
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

// The primitive's vertices and triangles from its accessors: positions, indices (0, 1, 2, … when
// it has none; a trailing partial triangle dropped), normals and the uv set `material` uses.
void GltfImporter::readAccessors(const tinygltf::Primitive& prim, const std::string& el, int material, Mesh& mesh) {
    auto posIt = prim.attributes.find("POSITION");
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
    if (mesh.indices.empty()) return;

    readNormals(prim, el, p.size(), mesh);
    readUvs(prim, el, material, mesh);
}

// The primitive's NORMAL attribute into `mesh.normals` (unit), or smooth normals computed from the
// triangles when it is absent or holds a zero-length normal. `positionFloats`: 3 per vertex.
void GltfImporter::readNormals(const tinygltf::Primitive& prim, const std::string& el, size_t positionFloats,
                               Mesh& mesh) {
    std::vector<float> n;
    auto nIt = prim.attributes.find("NORMAL");
    if (nIt != prim.attributes.end()) {
        n = readFloats(nIt->second, el + ".attributes.NORMAL", TINYGLTF_TYPE_VEC3, Attribute::Normal);
        if (n.size() != positionFloats)
            fail(el + ".attributes.NORMAL", "count differs from POSITION count");
    }
    setNormals(n, el + ".attributes.NORMAL", mesh);
}

void GltfImporter::setNormals(const std::vector<float>& n, const std::string& el, Mesh& mesh) {
    const size_t nv = mesh.positions.size();
    bool needNormals = n.empty();
    if (!needNormals) {
        mesh.normals.resize(nv);
        for (size_t i = 0; i < nv && !needNormals; ++i) {
            const Vec3 v(n[3 * i], n[3 * i + 1], n[3 * i + 2]);
            if (!(glm::length(v) > 1e-12f)) needNormals = true;
            else mesh.normals[i] = unitKeepingBits(v);
        }
        if (needNormals) warn(el + ": zero-length normals; recomputed");
    }
    if (needNormals) mesh.normals = smoothVertexNormals(mesh.positions, mesh.indices);
}

std::string GltfImporter::uvAttribute(const tinygltf::Primitive& prim, const std::string& el, int material) {
    const int uvSet = material >= 0 && size_t(material) < materialUvSet_.size()
                          ? materialUvSet_[size_t(material)]
                          : 0;
    const std::string uvName = "TEXCOORD_" + std::to_string(uvSet);
    if (prim.attributes.count(uvName)) return uvName;
    if (uvSet != 0 && prim.attributes.count("TEXCOORD_0")) {
        warn(el + ": material uses " + uvName + ", which is missing; TEXCOORD_0 used instead");
        return "TEXCOORD_0";
    }
    return {};
}

void GltfImporter::readUvs(const tinygltf::Primitive& prim, const std::string& el, int material, Mesh& mesh) {
    const size_t nv = mesh.positions.size();
    const std::string uvName = uvAttribute(prim, el, material);
    if (uvName.empty()) return;
    const std::string uvEl = el + ".attributes." + uvName;
    std::vector<float> uv = readFloats(prim.attributes.at(uvName), uvEl, TINYGLTF_TYPE_VEC2, Attribute::TexCoord);
    if (uv.size() / 2 != nv)
        fail(uvEl, "count differs from POSITION count");
    mesh.uvs.resize(nv);
    for (size_t i = 0; i < nv; ++i) mesh.uvs[i] = Vec2(uv[2 * i], uv[2 * i + 1]);
}

}  // namespace rtpm::gltf
