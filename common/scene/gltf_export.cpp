// GLB export of a Scene: the inverse of gltf_loader's mapping, built as a tinygltf::Model.
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

#include "common/scene/gltf_export.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include <glm/gtc/type_ptr.hpp>
#include <glm/gtx/quaternion.hpp>
#include <stb_image_write.h>

#include "common/core/output_file.h"

namespace rtpm {

namespace {

using tinygltf::Value;

// Appends raw bytes to the single buffer, 4-byte aligned, and returns a new bufferView.
int addView(tinygltf::Model& model, const void* data, size_t bytes, int target) {
    auto& buf = model.buffers[0].data;
    while (buf.size() % 4 != 0) buf.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buf.size();
    view.byteLength = bytes;
    view.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    buf.insert(buf.end(), p, p + bytes);
    model.bufferViews.push_back(view);
    return int(model.bufferViews.size() - 1);
}

int addAccessor(tinygltf::Model& model, int view, int componentType, int type, size_t count) {
    tinygltf::Accessor acc;
    acc.bufferView = view;
    acc.byteOffset = 0;
    acc.componentType = componentType;
    acc.type = type;
    acc.count = count;
    model.accessors.push_back(acc);
    return int(model.accessors.size() - 1);
}

void useExtension(tinygltf::Model& model, const std::string& name) {
    if (std::find(model.extensionsUsed.begin(), model.extensionsUsed.end(), name) == model.extensionsUsed.end())
        model.extensionsUsed.push_back(name);
}

float linearToSrgb(float c) {
    c = std::clamp(c, 0.0f, 1.0f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

std::vector<unsigned char> encodePng(const Texture& t, const std::string& name) {
    std::vector<unsigned char> px(size_t(t.width) * size_t(t.height) * 3);
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = (unsigned char)std::lround(255.0f * linearToSrgb(t.rgb[i]));
    std::vector<unsigned char> png;
    auto append = [](void* context, void* data, int size) {
        auto* out = static_cast<std::vector<unsigned char>*>(context);
        out->insert(out->end(), static_cast<unsigned char*>(data), static_cast<unsigned char*>(data) + size);
    };
    if (!stbi_write_png_to_func(append, &png, t.width, t.height, 3, px.data(), t.width * 3))
        throw SceneError(name, "texture " + t.name, "cannot encode PNG");
    return png;
}

// Appends `node` to the model as a root node of its one scene.
void addRootNode(tinygltf::Model& model, tinygltf::Node node) {
    model.nodes.push_back(std::move(node));
    model.scenes[0].nodes.push_back(int(model.nodes.size() - 1));
}

// Material `m` in glTF terms (metallic-roughness and the KHR extensions the loader reads back);
// the extensions it uses are listed in `model`.
tinygltf::Material exportMaterial(tinygltf::Model& model, const Material& m) {
    tinygltf::Material gm;
    gm.name = m.name;
    auto& pbr = gm.pbrMetallicRoughness;
    pbr.baseColorFactor = {m.baseColor.x, m.baseColor.y, m.baseColor.z, 1.0};
    pbr.metallicFactor = 0.0;
    pbr.roughnessFactor = 1.0;
    // A Lambertian is glTF's dielectric base without its coat (KHR_materials_specular factor 0),
    // a Plastic the base with its coat: each loads back as itself.
    auto specularFactor = [&](float f) {
        gm.extensions["KHR_materials_specular"] = Value(Value::Object{{"specularFactor", Value(double(f))}});
        useExtension(model, "KHR_materials_specular");
    };
    if (m.type == MaterialType::Diffuse && !m.unlit) specularFactor(0.0f);
    if (m.type == MaterialType::Plastic) {
        pbr.metallicFactor = double(m.metallic);
        pbr.roughnessFactor = double(m.roughness);
        if (m.specular != 1.0f) specularFactor(m.specular);
    } else if (m.type == MaterialType::Mirror) {
        pbr.metallicFactor = 1.0;
        pbr.roughnessFactor = double(m.roughness);
    } else if (m.type == MaterialType::Dielectric) {
        if (!m.isPartlyDiffuse()) pbr.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
        pbr.roughnessFactor = double(m.roughness);
        gm.extensions["KHR_materials_transmission"] =
            Value(Value::Object{{"transmissionFactor", Value(double(m.transmission))}});
        gm.extensions["KHR_materials_ior"] = Value(Value::Object{{"ior", Value(double(m.ior))}});
        useExtension(model, "KHR_materials_transmission");
        useExtension(model, "KHR_materials_ior");
        if (glm::any(glm::greaterThan(m.absorption, Vec3(0.0f)))) {
            // attenuationColor is the transmittance after attenuationDistance = 1 m, kept in
            // double (the loader reads it so) so that σ loads back as the same float.
            double dist = 1.0;
            // Keep the colour representable: for strong absorption use a shorter distance.
            float maxSigma = std::max(m.absorption.x, std::max(m.absorption.y, m.absorption.z));
            if (maxSigma > 20.0f) dist = 20.0 / double(maxSigma);
            Value::Array colour;
            for (int c = 0; c < 3; ++c) colour.push_back(Value(std::exp(-double(m.absorption[c]) * dist)));
            gm.extensions["KHR_materials_volume"] = Value(Value::Object{
                {"thicknessFactor", Value(1.0)},
                {"attenuationDistance", Value(dist)},
                {"attenuationColor", Value(std::move(colour))}});
            useExtension(model, "KHR_materials_volume");
        }
    }
    if (m.type == MaterialType::Diffuse && m.unlit) {
        gm.extensions["KHR_materials_unlit"] = Value(Value::Object{});
        useExtension(model, "KHR_materials_unlit");
        if (std::find(model.extensionsRequired.begin(), model.extensionsRequired.end(),
                      "KHR_materials_unlit") == model.extensionsRequired.end())
            model.extensionsRequired.push_back("KHR_materials_unlit");
    }
    if (m.baseColorTexture >= 0 &&
        (m.type == MaterialType::Diffuse || m.type == MaterialType::Plastic || m.isPartlyDiffuse())) {
        pbr.baseColorTexture.index = m.baseColorTexture;
        if (!m.baseColorTransform.isIdentity()) {
            const TextureTransform& t = m.baseColorTransform;
            pbr.baseColorTexture.extensions["KHR_texture_transform"] = Value(Value::Object{
                {"offset", Value(Value::Array{Value(double(t.offset.x)), Value(double(t.offset.y))})},
                {"rotation", Value(double(t.rotation))},
                {"scale", Value(Value::Array{Value(double(t.scale.x)), Value(double(t.scale.y))})}});
            useExtension(model, "KHR_texture_transform");
        }
    }
    if (m.isEmissive() && m.emissiveTexture >= 0) gm.emissiveTexture.index = m.emissiveTexture;
    if (m.isEmissive()) {
        // A power-of-two strength: factor × strength gives the emission back exactly, so a
        // cluster client renders the very radiance the master loaded.
        const float peak = std::max(m.emission.x, std::max(m.emission.y, m.emission.z));
        const float strength = std::exp2(std::ceil(std::log2(peak)));
        Vec3 factor = m.emission / strength;
        if (peak <= 1.0f) {
            factor = m.emission;
        } else {
            gm.extensions["KHR_materials_emissive_strength"] =
                Value(Value::Object{{"emissiveStrength", Value(double(strength))}});
            useExtension(model, "KHR_materials_emissive_strength");
        }
        gm.emissiveFactor = {factor.x, factor.y, factor.z};
    } else {
        gm.emissiveFactor = {0.0, 0.0, 0.0};
    }
    return gm;
}

// The TRIANGLES primitive of `mesh`: its arrays appended to the buffer, one accessor each.
tinygltf::Primitive exportPrimitive(tinygltf::Model& model, const Mesh& mesh) {
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.material = int(mesh.material);
    int pv = addView(model, mesh.positions.data(), mesh.positions.size() * sizeof(Vec3),
                     TINYGLTF_TARGET_ARRAY_BUFFER);
    int pa = addAccessor(model, pv, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, mesh.positions.size());
    // POSITION requires min/max.
    Vec3 lo(1e30f), hi(-1e30f);
    for (Vec3 p : mesh.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    model.accessors[size_t(pa)].minValues = {lo.x, lo.y, lo.z};
    model.accessors[size_t(pa)].maxValues = {hi.x, hi.y, hi.z};
    prim.attributes["POSITION"] = pa;
    if (!mesh.normals.empty()) {
        int nv = addView(model, mesh.normals.data(), mesh.normals.size() * sizeof(Vec3),
                         TINYGLTF_TARGET_ARRAY_BUFFER);
        prim.attributes["NORMAL"] =
            addAccessor(model, nv, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, mesh.normals.size());
    }
    if (!mesh.uvs.empty()) {
        int uv = addView(model, mesh.uvs.data(), mesh.uvs.size() * sizeof(Vec2), TINYGLTF_TARGET_ARRAY_BUFFER);
        prim.attributes["TEXCOORD_0"] =
            addAccessor(model, uv, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, mesh.uvs.size());
    }
    int iv = addView(model, mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t),
                     TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    prim.indices = addAccessor(model, iv, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                               mesh.indices.size());
    return prim;
}

// Light `l` as a KHR_lights_punctual light and the root node that places it.
void exportLight(tinygltf::Model& model, const Light& l) {
    tinygltf::Light gl;
    gl.name = l.name;
    // A power-of-two intensity: colour × intensity gives the light's value back exactly.
    const float peak = std::max(l.intensity.x, std::max(l.intensity.y, l.intensity.z));
    const float scale = peak > 0.0f ? std::exp2(std::ceil(std::log2(peak))) : 1.0f;
    gl.intensity = peak > 0.0f ? scale : 0.0;
    Vec3 colour = peak > 0.0f ? l.intensity / scale : Vec3(1.0f);
    gl.color = {colour.x, colour.y, colour.z};
    gl.type = l.type == LightType::Point ? "point" : l.type == LightType::Spot ? "spot" : "directional";
    if (l.type == LightType::Spot) {
        gl.spot.innerConeAngle = l.innerConeAngle;
        gl.spot.outerConeAngle = l.outerConeAngle;
    }
    model.lights.push_back(gl);
    tinygltf::Node node;
    node.name = l.name;
    node.translation = {l.position.x, l.position.y, l.position.z};
    if (l.type != LightType::Point) {
        // A matrix whose local −Z column is exactly the light's direction (a quaternion would
        // round it): the loader reads the direction back bit for bit. Columns: an orthonormal
        // right and up around back = −direction, then the position.
        const Vec3 back = -l.direction;
        const Vec3 helper = std::abs(back.y) < 0.9f ? Vec3(0, 1, 0) : Vec3(1, 0, 0);
        const Vec3 right = glm::normalize(glm::cross(helper, back));
        const Vec3 up = glm::cross(back, right);
        const Mat4 m(glm::vec4(right, 0.0f), glm::vec4(up, 0.0f), glm::vec4(back, 0.0f),
                     glm::vec4(l.position, 1.0f));
        const float* mp = glm::value_ptr(m);
        node.matrix.assign(mp, mp + 16);
        node.translation.clear();
    }
    node.extensions["KHR_lights_punctual"] =
        Value(Value::Object{{"light", Value(int(model.lights.size() - 1))}});
    addRootNode(model, std::move(node));
}

// Camera `c` as the file's one perspective camera and the root node that places it.
void exportCamera(tinygltf::Model& model, const Camera& c) {
    tinygltf::Camera gc;
    gc.type = "perspective";
    gc.perspective.yfov = c.yfov;
    gc.perspective.znear = 0.001;
    gc.perspective.zfar = 1000.0;
    model.cameras.push_back(gc);
    // Columns: right, up, back (−forward), position: local −Z looks along `forward`.
    Vec3 f = glm::normalize(c.forward);
    Vec3 right = glm::normalize(glm::cross(f, c.up));
    Vec3 up = glm::cross(right, f);
    Mat4 m(glm::vec4(right, 0.0f), glm::vec4(up, 0.0f), glm::vec4(-f, 0.0f), glm::vec4(c.position, 1.0f));
    tinygltf::Node node;
    node.name = "camera";
    node.camera = 0;
    const float* mp = glm::value_ptr(m);
    node.matrix.assign(mp, mp + 16);
    addRootNode(model, std::move(node));
}

// The world light as rtpm_world's value: {"uniform": [r, g, b]} (W/(m²·sr)), or {"map": {"bufferView",
// "width", "height"}} with the map's linear texels as little-endian float32 RGB, row-major from the top.
tinygltf::Value worldValue(tinygltf::Model& model, const Environment& world) {
    if (!world.hasMap()) {
        const Vec3 c = world.uniformRadiance();
        return tinygltf::Value(tinygltf::Value::Object{
            {"uniform", tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(double(c.x)), tinygltf::Value(double(c.y)),
                                                               tinygltf::Value(double(c.z))})}});
    }
    const std::vector<float>& texels = world.texels();
    const int view = addView(model, texels.data(), texels.size() * sizeof(float), 0);
    return tinygltf::Value(tinygltf::Value::Object{
        {"map", tinygltf::Value(tinygltf::Value::Object{{"bufferView", tinygltf::Value(view)},
                                                        {"width", tinygltf::Value(world.width())},
                                                        {"height", tinygltf::Value(world.height())}})}});
}

}  // namespace

std::vector<uint8_t> encodeGlb(const Scene& scene, bool withWorld) {
    scene.validate(scene.name);
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "rtpm";
    model.buffers.emplace_back();
    model.scenes.emplace_back();
    model.scenes[0].name = scene.name;
    model.defaultScene = 0;
    // glTF has no world light: the scene's extras carry it (rtpm_world), or say it has none, so
    // that loading the file back adds no default sky (loadScene).
    if (scene.environment.empty())
        model.scenes[0].extras = tinygltf::Value(tinygltf::Value::Object{{"rtpm_world", tinygltf::Value(std::string("none"))}});
    else if (withWorld)
        model.scenes[0].extras = tinygltf::Value(tinygltf::Value::Object{{"rtpm_world", worldValue(model, scene.environment)}});

    for (size_t ti = 0; ti < scene.textures.size(); ++ti) {
        std::vector<unsigned char> png = encodePng(scene.textures[ti], scene.name);
        tinygltf::Image img;
        img.name = scene.textures[ti].name;
        img.mimeType = "image/png";
        img.bufferView = addView(model, png.data(), png.size(), 0);
        model.images.push_back(img);
        tinygltf::Texture tex;
        tex.source = int(ti);
        model.textures.push_back(tex);
    }

    for (const Material& m : scene.materials) model.materials.push_back(exportMaterial(model, m));

    for (const Mesh& mesh : scene.meshes) {
        tinygltf::Primitive prim = exportPrimitive(model, mesh);
        tinygltf::Mesh gmesh;
        gmesh.name = mesh.name;
        gmesh.primitives.push_back(prim);
        model.meshes.push_back(gmesh);
    }

    for (const Instance& inst : scene.instances) {
        tinygltf::Node node;
        node.name = inst.name;
        node.mesh = int(inst.mesh);
        bool identity = inst.transform == Mat4(1.0f);
        if (!identity) {
            const float* m = glm::value_ptr(inst.transform);  // column-major, as glTF
            node.matrix.assign(m, m + 16);
        }
        addRootNode(model, std::move(node));
    }

    for (const Light& l : scene.lights) exportLight(model, l);
    if (!model.lights.empty()) useExtension(model, "KHR_lights_punctual");

    if (scene.camera) exportCamera(model, *scene.camera);

    if (model.buffers[0].data.empty()) model.buffers.clear();
    tinygltf::TinyGLTF writer;
    std::ostringstream out;
    if (!writer.WriteGltfSceneToStream(&model, out, false, true))
        throw SceneError(scene.name, "file", "GLB serialisation failed");
    std::string s = out.str();
    return std::vector<uint8_t>(s.begin(), s.end());
}

void exportGlb(const Scene& scene, const std::string& path) {
    std::vector<uint8_t> bytes = encodeGlb(scene, /*withWorld=*/true);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw OutputError(path + ": cannot open for writing");
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!out) throw OutputError(path + ": write failed");
}

}  // namespace rtpm
