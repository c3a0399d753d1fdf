// glTF extensions, materials and textures: the metallic-roughness model (and the extensions
// that extend or replace it) mapped to rtpm's Material; images decoded once per glTF image.
#include "common/scene/gltf_importer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <set>

#include "common/core/printable_text.h"
#include "common/scene/texture_decode.h"

namespace rtpm::gltf {

namespace {

const std::set<std::string>& supportedExtensions() {
    static const std::set<std::string> kSupported = {
        "KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior",
        "KHR_materials_volume", "KHR_materials_emissive_strength", "KHR_texture_transform",
        "KHR_materials_unlit", "EXT_mesh_gpu_instancing", "KHR_mesh_quantization",
        "KHR_materials_variants", "KHR_materials_pbrSpecularGlossiness", "KHR_materials_specular",
        "KHR_draco_mesh_compression"};
    return kSupported;
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

}  // namespace

void GltfImporter::checkExtensions() {
    for (const std::string& ext : model_.extensionsRequired) {
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

// Image `source`'s encoded bytes (from its buffer view or its file), every bound checked; empty
// when the file holds none (a missing external file).
std::vector<unsigned char> GltfImporter::imageBytes(int source) const {
    const tinygltf::Image& img = model_.images[size_t(source)];
    if (img.bufferView < 0) return img.image;
    const std::span<const unsigned char> bytes = viewBytes(img.bufferView, "images[" + std::to_string(source) + "]");
    return {bytes.begin(), bytes.end()};
}

std::span<const unsigned char> GltfImporter::viewBytes(int view, const std::string& element) const {
    if (view < 0 || size_t(view) >= model_.bufferViews.size())
        fail(element, "bufferView " + std::to_string(view) + " out of range (" +
                          std::to_string(model_.bufferViews.size()) + " bufferViews)");
    const tinygltf::BufferView& bv = model_.bufferViews[size_t(view)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
        fail(element, "buffer of bufferViews[" + std::to_string(view) + "] out of range");
    const std::vector<unsigned char>& data = model_.buffers[size_t(bv.buffer)].data;
    if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset)
        fail(element, "bufferViews[" + std::to_string(view) + "]: bytes " + std::to_string(bv.byteOffset) + " + " +
                          std::to_string(bv.byteLength) + " beyond its buffer's " + std::to_string(data.size()));
    return {data.data() + bv.byteOffset, bv.byteLength};
}

// `roughness` and `metallic` times the mean of the metallic-roughness texture `info` over its texels
// (green and blue, stored linear), with a warning naming the means; unchanged when it has no image.
void GltfImporter::scaleByMeanOfTexture(const tinygltf::TextureInfo& info, const std::string& element,
                                        double& roughness, double& metallic) {
    if (info.index < 0 || size_t(info.index) >= model_.textures.size())
        fail(element, "texture index " + std::to_string(info.index) + " out of range");
    const int source = model_.textures[size_t(info.index)].source;
    if (source < 0) return;
    if (size_t(source) >= model_.images.size())
        fail("textures[" + std::to_string(info.index) + "]", "image index " + std::to_string(source) + " out of range");
    const std::vector<unsigned char> encoded = imageBytes(source);
    if (encoded.empty()) return;
    const Texture tex = decodeSrgbTexture(encoded, model_.images[size_t(source)].mimeType == "image/jpeg" ? "jpg" : "png",
                                          file_, "images[" + std::to_string(source) + "]", files_, /*srgb=*/false);
    double g = 0.0, b = 0.0;
    for (size_t p = 0; p < tex.rgb.size(); p += 3) {
        g += tex.rgb[p + 1];
        b += tex.rgb[p + 2];
    }
    const double n = double(tex.rgb.size() / 3);
    roughness *= g / n;
    metallic *= b / n;
    char text[160];
    std::snprintf(text, sizeof text, ": its mean used (roughness x %.3f, metallic x %.3f); its variation over the "
                  "surface is not rendered", g / n, b / n);
    warn(element + text);
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
    const std::vector<unsigned char> encoded = imageBytes(source);
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
            const MetallicRoughness mr = specularGlossiness(*sg, sgEl);
            base = mr.baseColor;
            metallic = mr.metallic;
            roughness = mr.roughness;
            baseTextureEl = sgEl + ".diffuseTexture";
            baseTexture = specularGlossinessTexture(*sg, baseTextureEl);
            if (sg->Has("specularGlossinessTexture")) specularGlossinessTextures.push_back(el);
            ++specularGlossinessMaterials;
        }
        // A metallic-roughness texture scales the factors per texel; the material takes its mean
        // (one roughness and metallic per material), which keeps the look of the whole surface
        // where the factors alone (often 1 and 1 beside a texture) would make it a rough metal.
        if (pbr.metallicRoughnessTexture.index >= 0 && !extension(gm.extensions, "KHR_materials_pbrSpecularGlossiness"))
            scaleByMeanOfTexture(pbr.metallicRoughnessTexture, el + ".pbrMetallicRoughness.metallicRoughnessTexture",
                                 roughness, metallic);
        base = glm::clamp(base, Vec3(0.0f), Vec3(1.0f));
        m.baseColor = base;
        // The roughness of a metal or a transmissive material (GGX α = roughness², scene.h).
        auto checkedRoughness = [&](double r, const std::string& e) {
            if (!std::isfinite(r) || r < 0.0 || r > 1.0)
                fail(e + ".pbrMetallicRoughness.roughnessFactor", "roughnessFactor " + std::to_string(r) + " outside [0, 1]");
            return float(r);
        };

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
            m.roughness = checkedRoughness(roughness, el);
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
            readIorAndVolume(gm, el, m);
        } else if (metallic >= 0.99) {
            // A metal: a perfect mirror up to kSmoothRoughness, a GGX conductor above (Schlick's
            // Fresnel with F0 = the base colour, glTF's metal BRDF).
            m.type = MaterialType::Mirror;
            m.roughness = checkedRoughness(roughness, el);
        } else {
            // glTF's dielectric base: a Lambertian of the base colour under a dielectric coat
            // (F0 = 0.04), mixed with the metal lobe by metallicFactor (common/trace/plastic_bsdf.h).
            // KHR_materials_specular's specularFactor scales the coat; 0 leaves a Lambertian.
            m.type = MaterialType::Plastic;
            m.roughness = checkedRoughness(roughness, el);
            if (!std::isfinite(metallic) || metallic < 0.0 || metallic > 1.0)
                fail(el + ".pbrMetallicRoughness.metallicFactor",
                     "metallicFactor " + std::to_string(metallic) + " outside [0, 1]");
            m.metallic = float(metallic);
            readSpecular(gm, el, m);
            if (m.specular == 0.0f && m.metallic == 0.0f) m.type = MaterialType::Diffuse;
            useBaseColorTexture();
        }
        readEmission(gm, el, m, uvSet);
        warnIgnored(gm, el);
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

// KHR_materials_pbrSpecularGlossiness `sg` (at `sgEl`): its factors, checked, in metallic-roughness terms.
MetallicRoughness GltfImporter::specularGlossiness(const tinygltf::Value& sg, const std::string& sgEl) const {
    if (!sg.IsObject()) fail(sgEl, "must be an object");
    // An array of `n` numbers in [0, 1] (a number when n = 1), `fallback` when absent.
    auto factor = [&](const char* key, size_t n, std::vector<double> fallback) {
        if (!sg.Has(key)) return fallback;
        const tinygltf::Value& v = sg.Get(key);
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
    return fromSpecularGlossiness(Vec3(float(diffuse[0]), float(diffuse[1]), float(diffuse[2])),
                                  Vec3(float(specular[0]), float(specular[1]), float(specular[2])), glossiness);
}

// KHR_materials_pbrSpecularGlossiness `sg`: its diffuseTexture (at `element`) as a textureInfo; index -1 when absent.
tinygltf::TextureInfo GltfImporter::specularGlossinessTexture(const tinygltf::Value& sg,
                                                              const std::string& element) const {
    tinygltf::TextureInfo texture;
    if (sg.Has("diffuseTexture")) {
        const tinygltf::Value& t = sg.Get("diffuseTexture");
        if (!t.IsObject() || !t.Has("index") || !t.Get("index").IsNumber())
            fail(element, "must be an object with a texture index");
        texture.index = t.Get("index").GetNumberAsInt();
        if (t.Has("texCoord")) {
            if (!t.Get("texCoord").IsNumber() || t.Get("texCoord").GetNumberAsInt() < 0)
                fail(element + ".texCoord", "must be a non-negative integer");
            texture.texCoord = t.Get("texCoord").GetNumberAsInt();
        }
        if (t.Has("extensions") && t.Get("extensions").IsObject() &&
            t.Get("extensions").Has("KHR_texture_transform"))
            texture.extensions["KHR_texture_transform"] = t.Get("extensions").Get("KHR_texture_transform");
    }
    return texture;
}

// KHR_materials_specular of the opaque dielectric `gm` (at `el`) into m.specular; what the coat
// does not model (a coloured F0, textures, an index other than 1.5) is warned about.
void GltfImporter::readSpecular(const tinygltf::Material& gm, const std::string& el, Material& m) {
    if (const tinygltf::Value* sp = extension(gm.extensions, "KHR_materials_specular")) {
        const std::string spEl = el + ".extensions.KHR_materials_specular";
        if (!sp->IsObject()) fail(spEl, "must be an object");
        const double f = numberOr(*sp, "specularFactor", 1.0);
        if (!std::isfinite(f) || f < 0.0 || f > 1.0)
            fail(spEl + ".specularFactor", "specularFactor " + std::to_string(f) + " outside [0, 1]");
        m.specular = float(f);
        const glm::dvec3 colour = dvec3Of(*sp, "specularColorFactor").value_or(glm::dvec3(1.0));
        if (colour != glm::dvec3(1.0))
            warn(el + ": KHR_materials_specular specularColorFactor ignored (the coat's F0 is 0.04 in every channel)");
        if (sp->Has("specularTexture") || sp->Has("specularColorTexture"))
            warn(el + ": KHR_materials_specular textures ignored (specularFactor used everywhere)");
    }
    if (const tinygltf::Value* iorExt = extension(gm.extensions, "KHR_materials_ior")) {
        const double ior = numberOr(*iorExt, "ior", 1.5);
        if (ior != 1.5)
            warn(el + ": KHR_materials_ior " + std::to_string(ior) +
                 " ignored on an opaque material (the coat's index is 1.5, F0 = 0.04)");
    }
}

// KHR_materials_ior and KHR_materials_volume of the transmissive material `gm` (at `el`) into `m`.
void GltfImporter::readIorAndVolume(const tinygltf::Material& gm, const std::string& el, Material& m) const {
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
}

// The emission of `gm` (at `el`): emissiveFactor × KHR_materials_emissive_strength (× emissiveTexture).
// `uvSet` is the material's texture coordinate set so far (-1: none yet); the emissive texture's
// set becomes it when unset.
void GltfImporter::readEmission(const tinygltf::Material& gm, const std::string& el, Material& m, int& uvSet) {
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
}

// What the material model has no place for, named once per material.
void GltfImporter::warnIgnored(const tinygltf::Material& gm, const std::string& el) {
    std::string ignored;
    auto note = [&](bool present, const char* what) {
        if (present) ignored += (ignored.empty() ? "" : ", ") + std::string(what);
    };
    note(gm.normalTexture.index >= 0, "normalTexture");
    note(gm.occlusionTexture.index >= 0, "occlusionTexture");
    note(!gm.alphaMode.empty() && gm.alphaMode != "OPAQUE", "alphaMode (rendered opaque)");
    if (!ignored.empty()) warn(el + ": ignored " + ignored);
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

}  // namespace rtpm::gltf
