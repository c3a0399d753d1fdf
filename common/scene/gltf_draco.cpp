// KHR_draco_mesh_compression: a primitive whose vertices and triangles are one Draco-compressed
// bufferView, decoded with Debian's libdraco into the same Mesh arrays the accessors would give.
#include "common/scene/gltf_importer.h"

#include <draco/compression/decode.h>

namespace rtpm::gltf {

namespace {

// The unique id the extension's `attributes` object gives `name`, -1 when it names none.
int dracoId(const tinygltf::Value& ext, const std::string& name) {
    const tinygltf::Value& attributes = ext.Get("attributes");
    if (!attributes.IsObject() || !attributes.Has(name)) return -1;
    const tinygltf::Value& id = attributes.Get(name);
    return id.IsInt() && id.GetNumberAsInt() >= 0 ? id.GetNumberAsInt() : -1;
}

}  // namespace

// The compressed bytes: extension.bufferView, every bound checked.
std::pair<const char*, size_t> GltfImporter::dracoBytes(const tinygltf::Value& ext, const std::string& el) const {
    const tinygltf::Value& bv = ext.Get("bufferView");
    if (!bv.IsInt()) fail(el, "bufferView missing or not an integer");
    const std::span<const unsigned char> bytes = viewBytes(bv.GetNumberAsInt(), el + ".bufferView");
    return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

void GltfImporter::decodeDraco(const tinygltf::Primitive& prim, const tinygltf::Value& ext, const std::string& primEl,
                               int material, Mesh& mesh) {
    const std::string el = primEl + ".extensions.KHR_draco_mesh_compression";
    if (!ext.IsObject()) fail(el, "not an object");
    const auto [bytes, length] = dracoBytes(ext, el);
    draco::DecoderBuffer buffer;
    buffer.Init(bytes, length);
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
    if (!decoded.ok()) fail(el, "Draco data does not decode: " + decoded.status().error_msg_string());
    const std::unique_ptr<draco::Mesh> dm = std::move(decoded).value();
    const size_t nv = dm->num_points(), nf = dm->num_faces();
    files_->charge(uint64_t(nv) * (2 * sizeof(Vec3) + sizeof(Vec2)) + uint64_t(nf) * 3 * sizeof(uint32_t), el);

    // Attribute `name` (`components` floats a vertex) into `out`; false when the file has none.
    auto read = [&](const std::string& name, int components, std::vector<float>& out) {
        if (!prim.attributes.count(name)) return false;
        const int id = dracoId(ext, name);
        if (id < 0) fail(el + ".attributes", name + " is a primitive attribute but has no Draco id");
        const draco::PointAttribute* a = dm->GetAttributeByUniqueId(uint32_t(id));
        if (!a) fail(el + ".attributes." + name, "Draco id " + std::to_string(id) + " is not in the decoded mesh");
        if (a->num_components() != components)
            fail(el + ".attributes." + name, std::to_string(a->num_components()) + " components, expected " +
                                                 std::to_string(components));
        out.resize(nv * size_t(components));
        for (size_t i = 0; i < nv; ++i)
            if (!a->ConvertValue<float>(a->mapped_index(draco::PointIndex(uint32_t(i))), int8_t(components),
                                        &out[i * size_t(components)]))
                fail(el + ".attributes." + name, "value " + std::to_string(i) + " does not convert to float");
        for (float f : out)
            if (!std::isfinite(f)) fail(el + ".attributes." + name, "non-finite value");
        return true;
    };
    std::vector<float> values;
    if (!read("POSITION", 3, values)) fail(primEl + ".attributes", "no POSITION attribute");
    mesh.positions.resize(nv);
    for (size_t i = 0; i < nv; ++i) mesh.positions[i] = Vec3(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
    mesh.indices.resize(nf * 3);
    for (size_t f = 0; f < nf; ++f) {
        const draco::Mesh::Face& face = dm->face(draco::FaceIndex(uint32_t(f)));
        for (int k = 0; k < 3; ++k) {
            const uint32_t index = face[k].value();
            if (index >= nv) fail(el, "face " + std::to_string(f) + " names point " + std::to_string(index) + " of " + std::to_string(nv));
            mesh.indices[3 * f + k] = index;
        }
    }
    values.clear();
    read("NORMAL", 3, values);  // none: smooth normals from the triangles
    setNormals(values, el + ".attributes.NORMAL", mesh);
    const std::string uvName = uvAttribute(prim, primEl, material);
    if (!uvName.empty() && read(uvName, 2, values)) {
        mesh.uvs.resize(nv);
        for (size_t i = 0; i < nv; ++i) mesh.uvs[i] = Vec2(values[2 * i], values[2 * i + 1]);
    }
}

}  // namespace rtpm::gltf
