// The glTF node hierarchy: node transforms (matrix or TRS), mesh instances (EXT_mesh_gpu_instancing
// included), the first perspective camera, KHR_lights_punctual lights; run() drives the import.
#include "common/scene/gltf_importer.h"

#include <algorithm>
#include <cstring>
#include <filesystem>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

namespace rtpm::gltf {

namespace {


// Deepest node hierarchy followed; deeper (or cyclic) hierarchies are errors.
constexpr int kMaxNodeDepth = 1024;
// Most mesh instances a scene may hold (nodes × primitives, EXT_mesh_gpu_instancing included):
// each costs an Embree instance and a transform, ~300 bytes, so this bounds them to ~1 GB.
constexpr size_t kMaxInstances = size_t(1) << 22;

}  // namespace

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

// The world light rtpm's own export wrote (encodeGlb with its world): a uniform radiance or an
// equirectangular map of float32 texels in a buffer view, every bound and value checked.
void GltfImporter::readWorld(const tinygltf::Value& world, const std::string& el) {
    if (world.Has("uniform")) {
        const tinygltf::Value& u = world.Get("uniform");
        if (!u.IsArray() || u.ArrayLen() != 3) fail(el + ".uniform", "not an array of 3 numbers");
        Vec3 c(0.0f);
        for (int i = 0; i < 3; ++i) {
            const tinygltf::Value& v = u.Get(i);
            c[i] = v.IsNumber() ? float(v.GetNumberAsDouble()) : -1.0f;
            if (!(c[i] >= 0.0f) || !std::isfinite(c[i])) fail(el + ".uniform", "values must be finite and >= 0");
        }
        scene_.environment = Environment::uniform(c);
        return;
    }
    if (!world.Has("map")) fail(el, "neither uniform nor map");
    const tinygltf::Value& m = world.Get("map");
    auto integer = [&](const char* key) {
        const tinygltf::Value& v = m.Get(key);
        if (!v.IsInt() || v.GetNumberAsInt() < 0) fail(el + ".map." + key, "missing or not a non-negative integer");
        return v.GetNumberAsInt();
    };
    const int view = integer("bufferView"), width = integer("width"), height = integer("height");
    const std::span<const unsigned char> bytes = viewBytes(view, el + ".map.bufferView");
    const uint64_t floats = uint64_t(width) * uint64_t(height) * 3;
    if (floats * sizeof(float) != bytes.size())
        fail(el + ".map", std::to_string(width) + " x " + std::to_string(height) + " RGB float texels do not fill " +
                              "bufferViews[" + std::to_string(view) + "] (" + std::to_string(bytes.size()) + " bytes)");
    files_->charge(floats * sizeof(float) * 2, el + ".map");  // the texels and the sampling tables
    Texture map;
    map.name = "world";
    map.width = width;
    map.height = height;
    map.rgb.resize(size_t(floats));
    std::memcpy(map.rgb.data(), bytes.data(), bytes.size());
    validateEnvironmentMap(map, file_);
    scene_.environment = Environment::fromMap(map);
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
        const tinygltf::Value& extras = model_.scenes[size_t(s)].extras;
        if (extras.IsObject() && extras.Has("rtpm_world")) {
            const tinygltf::Value& world = extras.Get("rtpm_world");
            scene_.worldless = world.IsString() && world.Get<std::string>() == "none";
            if (world.IsObject()) readWorld(world, "scenes[" + std::to_string(s) + "].extras.rtpm_world");
        }
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

}  // namespace rtpm::gltf
