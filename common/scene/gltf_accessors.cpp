// glTF accessors: every index, byte range, stride and component type checked before a byte is
// read; values dequantized to floats (KHR_mesh_quantization) or widened to 32-bit indices.
#include "common/scene/gltf_importer.h"

#include <algorithm>
#include <cstring>

namespace rtpm::gltf {

namespace {

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

}  // namespace

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

}  // namespace rtpm::gltf
