// Tests of the glTF extensions that change what a file's data means: KHR_mesh_quantization,
// KHR_materials_variants, KHR_materials_pbrSpecularGlossiness, KHR_draco_mesh_compression.
#include "common/scene/gltf_loader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>

#include "common/scene/scene_loader.h"
#include "tests/support/gltf_builder.h"

namespace rtpm {
namespace {

using testgltf::GltfBuilder;

Scene loadText(const std::string& json, const GltfOptions& options = {}) {
    return loadGltfFromMemory(std::vector<uint8_t>(json.begin(), json.end()), "test.gltf", "", {}, options);
}

// The SceneError loading `json` raises (fails the test when it loads).
SceneError loadError(const std::string& json, const GltfOptions& options = {}) {
    try {
        loadText(json, options);
    } catch (const SceneError& e) {
        return e;
    }
    ADD_FAILURE() << "loaded without error";
    return SceneError("", "", "");
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string allWarnings(const Scene& s) {
    std::string all;
    for (const std::string& w : s.warnings) all += w + "\n";
    return all;
}

// World-space corners of every triangle, in scene order.
std::vector<Vec3> worldTriangles(const Scene& s) {
    std::vector<Vec3> out;
    for (const Instance& inst : s.instances)
        for (uint32_t i : s.meshes[inst.mesh].indices)
            out.push_back(Vec3(inst.transform * glm::vec4(s.meshes[inst.mesh].positions[i], 1.0f)));
    return out;
}

// ---- KHR_mesh_quantization ------------------------------------------------------------------

// A tetrahedron-ish fan of 4 vertices in [-1.5, 2.5]³ with unit normals and uvs 0/1.
const std::vector<float> kPositions{-1.5f, 0.5f, 2.5f, 2.5f, -1.5f, 0.0f, 0.25f, 2.5f, -1.5f, 1.0f, 1.0f, 1.0f};
const std::vector<float> kNormals{0.6f, 0.8f, 0.0f, 0.0f, -1.0f, 0.0f, 0.0f, 0.6f, -0.8f, 1.0f, 0.0f, 0.0f};
const std::vector<float> kUvs{0, 0, 1, 0, 1, 1, 0, 1};
const std::vector<uint32_t> kIndices{0, 1, 2, 0, 2, 3};

std::string meshFile(GltfBuilder& b, int pos, int nrm, int uv, const std::string& node, const std::string& extensions) {
    const int idx = b.indices(kIndices);
    return b.json(extensions + R"("scene":0,"scenes":[{"nodes":[0]}],"nodes":[)" + node +
                  R"(],"meshes":[{"primitives":[{"attributes":{"POSITION":)" + std::to_string(pos) +
                  R"(,"NORMAL":)" + std::to_string(nrm) + R"(,"TEXCOORD_0":)" + std::to_string(uv) +
                  R"(},"indices":)" + std::to_string(idx) + "}]}]");
}

TEST(GltfQuantization, QuantizedMeshLoadsTheSameTrianglesAsItsFloatVersion) {
    GltfBuilder f;
    const std::string floatFile = meshFile(f, f.floats(kPositions, "VEC3"), f.floats(kNormals, "VEC3"),
                                           f.floats(kUvs, "VEC2"), R"({"mesh":0})", "");
    // As gltfpack writes it: positions as normalized UNSIGNED_SHORT over the bounding cube, the
    // node's translation and uniform scale mapping [0, 1] back onto it; normals as normalized
    // SHORT, uvs as plain UNSIGNED_SHORT integers.
    const float lo = -1.5f, extent = 4.0f;
    std::vector<uint16_t> qp;
    for (float p : kPositions) qp.push_back(uint16_t(std::lround((p - lo) / extent * 65535.0f)));
    std::vector<int16_t> qn;
    for (float n : kNormals) qn.push_back(int16_t(std::lround(n * 32767.0f)));
    std::vector<uint16_t> qt;
    for (float t : kUvs) qt.push_back(uint16_t(t));
    GltfBuilder q;
    const int pa = q.integers(qp, 5123, "VEC3", true), na = q.integers(qn, 5122, "VEC3", true),
              ta = q.integers(qt, 5123, "VEC2", false);
    const std::string node = R"({"mesh":0,"translation":[-1.5,-1.5,-1.5],"scale":[4,4,4]})";
    const std::string quantizedFile = meshFile(
        q, pa, na, ta, node, R"("extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"],)");

    const Scene fs = loadText(floatFile), qs = loadText(quantizedFile);
    const std::vector<Vec3> ft = worldTriangles(fs), qt3 = worldTriangles(qs);
    ASSERT_EQ(ft.size(), kIndices.size());
    ASSERT_EQ(qt3.size(), ft.size());
    // One quantization step is 4 m / 65535 = 6.1e-5 m; rounding is at most half of it.
    for (size_t i = 0; i < ft.size(); ++i)
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(qt3[i][c], ft[i][c], 3.1e-5f) << "corner " << i;
    ASSERT_EQ(qs.meshes.size(), 1u);
    for (size_t v = 0; v < 4; ++v) {
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(qs.meshes[0].normals[v][c], fs.meshes[0].normals[v][c], 1e-4f);
        EXPECT_EQ(qs.meshes[0].uvs[v], fs.meshes[0].uvs[v]);
    }
    EXPECT_FALSE(contains(allWarnings(qs), "KHR_mesh_quantization")) << allWarnings(qs);
}

TEST(GltfQuantization, TypeTheExtensionDoesNotAllowIsRefusedByName) {
    // NORMAL as normalized UNSIGNED_BYTE: the extension allows only (normalized) BYTE and SHORT.
    GltfBuilder b;
    std::vector<uint8_t> qn;
    for (float n : kNormals) qn.push_back(uint8_t(std::lround((n + 1.0f) * 127.5f)));
    const int pa = b.floats(kPositions, "VEC3"), na = b.integers(qn, 5121, "VEC3", true), ta = b.floats(kUvs, "VEC2");
    const SceneError e =
        loadError(meshFile(b, pa, na, ta, R"({"mesh":0})", R"("extensionsUsed":["KHR_mesh_quantization"],)"));
    EXPECT_EQ(e.file, "test.gltf");
    EXPECT_EQ(e.element, "meshes[0].primitives[0].attributes.NORMAL");
    EXPECT_TRUE(contains(e.what(), "normalized UNSIGNED_BYTE")) << e.what();
    EXPECT_TRUE(contains(e.what(), "allowed: FLOAT, normalized BYTE, normalized SHORT")) << e.what();
}

TEST(GltfQuantization, IntegerPositionsWithoutTheExtensionNameIt) {
    GltfBuilder b;
    const std::vector<int16_t> qp{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
    const int pa = b.integers(qp, 5122, "VEC3", false), na = b.floats(kNormals, "VEC3"), ta = b.floats(kUvs, "VEC2");
    const SceneError e = loadError(meshFile(b, pa, na, ta, R"({"mesh":0})", ""));
    EXPECT_EQ(e.element, "meshes[0].primitives[0].attributes.POSITION");
    EXPECT_TRUE(contains(e.what(), "is SHORT, which POSITION may not be")) << e.what();
    EXPECT_TRUE(contains(e.what(), "KHR_mesh_quantization allows it")) << e.what();
    // Listed, the same file loads: the integers themselves, in the node's frame.
    GltfBuilder b2;
    const int pa2 = b2.integers(qp, 5122, "VEC3", false), na2 = b2.floats(kNormals, "VEC3"), ta2 = b2.floats(kUvs, "VEC2");
    const Scene s = loadText(meshFile(b2, pa2, na2, ta2, R"({"mesh":0})", R"("extensionsUsed":["KHR_mesh_quantization"],)"));
    EXPECT_EQ(s.meshes[0].positions[3], Vec3(1, 1, 0));
}

// ---- Draco ------------------------------------------------------------------------------------

// kPositions / kNormals / kUvs / kIndices as Draco bytes (the library's own encoder): with
// `quantizationBits` 0 the floats are kept exactly, else positions are quantized to that many bits.
std::string dracoBytes(int quantizationBits) {
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(int(kIndices.size() / 3));
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int nrm = builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
    const int tex = builder.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32);
    for (size_t f = 0; f < kIndices.size() / 3; ++f) {
        const uint32_t a = kIndices[3 * f], b = kIndices[3 * f + 1], c = kIndices[3 * f + 2];
        const draco::FaceIndex face{uint32_t(f)};
        builder.SetAttributeValuesForFace(pos, face, &kPositions[3 * a], &kPositions[3 * b], &kPositions[3 * c]);
        builder.SetAttributeValuesForFace(nrm, face, &kNormals[3 * a], &kNormals[3 * b], &kNormals[3 * c]);
        builder.SetAttributeValuesForFace(tex, face, &kUvs[2 * a], &kUvs[2 * b], &kUvs[2 * c]);
    }
    std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);  // keeps the faces' order
    if (quantizationBits > 0) encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, quantizationBits);
    draco::EncoderBuffer out;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());
    // The unique ids the attributes got, in the order added: 0, 1, 2 (the file below names them).
    EXPECT_EQ(mesh->attribute(pos)->unique_id(), 0u);
    EXPECT_EQ(mesh->attribute(tex)->unique_id(), 2u);
    return std::string(out.data(), out.size());
}

// A file whose one primitive is `bytes` as a Draco bufferView; its accessors carry counts and
// no data, as the extension has them.
std::string dracoFile(const std::string& bytes) {
    GltfBuilder b;
    const int view = b.raw(bytes.data(), bytes.size());
    const int pos = b.dataless(4, "VEC3"), nrm = b.dataless(4, "VEC3"), uv = b.dataless(4, "VEC2");
    const int idx = b.dataless(6, "SCALAR", 5125);
    return b.json(R"("extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"],)"
                  R"("scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":)" +
                  std::to_string(pos) + R"(,"NORMAL":)" + std::to_string(nrm) + R"(,"TEXCOORD_0":)" + std::to_string(uv) +
                  R"(},"indices":)" + std::to_string(idx) +
                  R"(,"extensions":{"KHR_draco_mesh_compression":{"bufferView":)" + std::to_string(view) +
                  R"(,"attributes":{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2}}}}]}])");
}

TEST(GltfDraco, ADracoMeshLoadsAsTheSameMeshUncompressed) {
    GltfBuilder b;
    const Scene plain = loadText(meshFile(b, b.floats(kPositions, "VEC3"), b.floats(kNormals, "VEC3"),
                                          b.floats(kUvs, "VEC2"), R"({"mesh":0})", ""));
    const Scene draco = loadText(dracoFile(dracoBytes(0)));
    ASSERT_EQ(draco.meshes.size(), 1u);
    EXPECT_EQ(worldTriangles(draco), worldTriangles(plain));
    // Per corner, the normal and uv the uncompressed file gives (Draco may merge or reorder points).
    const Mesh &d = draco.meshes[0], &p = plain.meshes[0];
    ASSERT_EQ(d.indices.size(), p.indices.size());
    ASSERT_EQ(d.normals.size(), d.positions.size());
    ASSERT_EQ(d.uvs.size(), d.positions.size());
    for (size_t k = 0; k < d.indices.size(); ++k) {
        EXPECT_EQ(d.normals[d.indices[k]], p.normals[p.indices[k]]) << "corner " << k;
        EXPECT_EQ(d.uvs[d.indices[k]], p.uvs[p.indices[k]]) << "corner " << k;
    }
}

TEST(GltfDraco, QuantizedPositionsComeBackWithinTheirQuantizationStep) {
    const Scene s = loadText(dracoFile(dracoBytes(11)));
    GltfBuilder b;
    const Scene plain = loadText(meshFile(b, b.floats(kPositions, "VEC3"), b.floats(kNormals, "VEC3"),
                                          b.floats(kUvs, "VEC2"), R"({"mesh":0})", ""));
    const std::vector<Vec3> got = worldTriangles(s), want = worldTriangles(plain);
    ASSERT_EQ(got.size(), want.size());
    const float step = 4.0f / float((1 << 11) - 1);  // the positions span 4 m on every axis
    for (size_t i = 0; i < got.size(); ++i)
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[i][c], want[i][c], step) << "corner " << i;
}

TEST(GltfDraco, BrokenDracoDataIsRefusedNamingThePrimitive) {
    std::string bytes = dracoBytes(0);
    bytes.resize(bytes.size() / 2);  // a file cut short
    const SceneError broken = loadError(dracoFile(bytes));
    EXPECT_EQ(broken.element, "meshes[0].primitives[0].extensions.KHR_draco_mesh_compression");
    EXPECT_TRUE(contains(broken.what(), "does not decode")) << broken.what();

    std::string badId = dracoFile(dracoBytes(0));
    badId.replace(badId.rfind(R"("TEXCOORD_0":2)"), 14, R"("TEXCOORD_0":7)");  // the extension's own map
    const SceneError badIdError = loadError(badId);
    EXPECT_TRUE(contains(badIdError.what(), "Draco id 7 is not in the decoded mesh")) << badIdError.what();

    std::string noView = dracoFile(dracoBytes(0));
    noView.replace(noView.find(R"("bufferView":0,"attributes")"), 14, R"("bufferView":9)");
    const SceneError view = loadError(noView);
    EXPECT_TRUE(contains(view.what(), "out of range")) << view.what();
}

// ---- KHR_materials_variants --------------------------------------------------------------------

// One quad whose default material is "red"; variants Red, Green, Blue map to materials 0, 1, 2.
std::string variantsFile() {
    GltfBuilder b;
    const float centre[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 1, 0};
    const std::string prim = b.quadPrimitive(centre, u, v);
    return b.json(R"("extensionsUsed":["KHR_materials_variants"],
"extensions":{"KHR_materials_variants":{"variants":[{"name":"Red"},{"name":"Green"},{"name":"Blue"}]}},
"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"materials":[{"name":"red","pbrMetallicRoughness":{"baseColorFactor":[1,0,0,1],"metallicFactor":0}},
{"name":"green","pbrMetallicRoughness":{"baseColorFactor":[0,1,0,1],"metallicFactor":0}},
{"name":"blue","pbrMetallicRoughness":{"baseColorFactor":[0,0,1,1],"metallicFactor":0}}],
"meshes":[{"primitives":[)" +
                  prim + R"(,"material":0,"extensions":{"KHR_materials_variants":{"mappings":[
{"material":1,"variants":[1]},{"material":2,"variants":[2]},{"material":0,"variants":[0]}]}}}]}])");
}

std::string meshMaterialName(const Scene& s) { return s.materials[s.meshes.at(0).material].name; }

TEST(GltfVariants, DefaultVariantUsesThePrimitivesOwnMaterial) {
    const Scene s = loadText(variantsFile());
    EXPECT_EQ(meshMaterialName(s), "red");
    EXPECT_FALSE(contains(allWarnings(s), "KHR_materials_variants")) << allWarnings(s);
}

TEST(GltfVariants, NamedVariantSelectsItsMaterials) {
    GltfOptions options;
    options.variant = "Blue";
    EXPECT_EQ(meshMaterialName(loadText(variantsFile(), options)), "blue");
    options.variant = "Green";
    EXPECT_EQ(meshMaterialName(loadText(variantsFile(), options)), "green");
    options.variant = "Red";
    EXPECT_EQ(meshMaterialName(loadText(variantsFile(), options)), "red");
}

TEST(GltfVariants, UnknownVariantIsRefusedListingTheFilesVariants) {
    GltfOptions options;
    options.variant = "Purple";
    const SceneError e = loadError(variantsFile(), options);
    EXPECT_EQ(e.element, "extensions.KHR_materials_variants");
    EXPECT_TRUE(contains(e.what(), "'Purple'")) << e.what();
    EXPECT_TRUE(contains(e.what(), "'Red', 'Green', 'Blue'")) << e.what();
}

TEST(GltfVariants, MappingToAMissingMaterialNamesTheMapping) {
    std::string json = variantsFile();
    json.replace(json.find(R"({"material":2,)"), 14, R"({"material":9,)");
    const SceneError e = loadError(json);
    EXPECT_EQ(e.element, "meshes[0].primitives[0].extensions.KHR_materials_variants.mappings[1].material");
}

TEST(GltfVariants, LoadSceneAppliesTheVariantAndRefusesItOnOtherScenes) {
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("rtpm_variants_" + std::to_string(::getpid()) + ".gltf");
    std::ofstream(path) << variantsFile();
    SceneOverrides overrides;
    overrides.variant = "Green";
    EXPECT_EQ(meshMaterialName(loadScene(path.string(), overrides)), "green");
    overrides.variant = "Nope";
    EXPECT_THROW(loadScene(path.string(), overrides), SceneError);
    std::filesystem::remove(path);
    overrides.variant = "Green";
    try {
        loadScene("RING", overrides);
        ADD_FAILURE() << "a built-in scene took a variant";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.element, "variant");
    }
}

// ---- KHR_materials_pbrSpecularGlossiness ------------------------------------------------------

TEST(GltfSpecularGlossiness, MaterialsAreConvertedToMetallicRoughnessWithOneWarning) {
    GltfBuilder b;
    const float centre[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 1, 0};
    const std::string prim = b.quadPrimitive(centre, u, v);
    const std::string json = b.json(R"("extensionsUsed":["KHR_materials_pbrSpecularGlossiness"],
"scene":0,"scenes":[{"nodes":[0,1,2]}],"nodes":[{"mesh":0},{"mesh":1},{"mesh":2}],
"materials":[
{"name":"plastic","extensions":{"KHR_materials_pbrSpecularGlossiness":{"diffuseFactor":[0.5,0.5,0.5,1],"specularFactor":[0.04,0.04,0.04],"glossinessFactor":0.5}}},
{"name":"gold","extensions":{"KHR_materials_pbrSpecularGlossiness":{"diffuseFactor":[0,0,0,1],"specularFactor":[1,0.766,0.336],"glossinessFactor":1}}},
{"name":"lacquer","extensions":{"KHR_materials_pbrSpecularGlossiness":{"diffuseFactor":[0.8,0.2,0.2,1],"specularFactor":[0.2,0.2,0.2],"glossinessFactor":0.3}}}],
"meshes":[{"primitives":[)" + prim + R"(,"material":0}]},{"primitives":[)" + prim +
                                    R"(,"material":1}]},{"primitives":[)" + prim + R"(,"material":2}]}])");
    const Scene s = loadText(json);
    ASSERT_EQ(s.materials.size(), 3u);
    // A dielectric's specular (0.04) gives metallic 0: a plastic whose base colour is the diffuse
    // colour (a Lambertian before the coat was modelled).
    EXPECT_EQ(s.materials[0].type, MaterialType::Plastic);
    EXPECT_EQ(s.materials[0].metallic, 0.0f);
    EXPECT_NEAR(s.materials[0].roughness, 0.5f, 1e-6f);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.materials[0].baseColor[c], 0.5f, 1e-6f);
    // Black diffuse, coloured specular, glossiness 1: metallic 1, roughness 0, a mirror of the
    // specular colour.
    EXPECT_EQ(s.materials[1].type, MaterialType::Mirror);
    EXPECT_NEAR(s.materials[1].baseColor.x, 1.0f, 1e-5f);
    EXPECT_NEAR(s.materials[1].baseColor.y, 0.766f, 1e-5f);
    EXPECT_NEAR(s.materials[1].baseColor.z, 0.336f, 1e-5f);
    // Worked by hand: brightnesses D = 0.46840, S = 0.2, metallic 0.30617 (below 0.99
    // here, roughness 0.7), base colour (0.92352, 0.27043, 0.27043): a plastic mixing in that
    // much of the metal lobe.
    EXPECT_EQ(s.materials[2].type, MaterialType::Plastic);
    EXPECT_NEAR(s.materials[2].metallic, 0.30617f, 1e-4f);
    EXPECT_NEAR(s.materials[2].roughness, 0.7f, 1e-6f);
    EXPECT_NEAR(s.materials[2].baseColor.x, 0.92352f, 1e-4f);
    EXPECT_NEAR(s.materials[2].baseColor.y, 0.27043f, 1e-4f);
    EXPECT_NEAR(s.materials[2].baseColor.z, 0.27043f, 1e-4f);
    size_t lines = 0;
    for (const std::string& w : s.warnings)
        if (contains(w, "KHR_materials_pbrSpecularGlossiness")) {
            ++lines;
            EXPECT_TRUE(contains(w, "3 material(s) converted")) << w;
        }
    EXPECT_EQ(lines, 1u) << allWarnings(s);
}

TEST(GltfSpecularGlossiness, OutOfRangeFactorIsRefusedByName) {
    GltfBuilder b;
    const float centre[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 1, 0};
    const std::string prim = b.quadPrimitive(centre, u, v);
    const SceneError e = loadError(b.json(R"("scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"materials":[{"extensions":{"KHR_materials_pbrSpecularGlossiness":{"specularFactor":[2,0,0]}}}],
"meshes":[{"primitives":[)" + prim + R"(,"material":0}]}])"));
    EXPECT_EQ(e.element, "materials[0].extensions.KHR_materials_pbrSpecularGlossiness.specularFactor");
}

// ---- metallicRoughnessTexture -------------------------------------------------------------------

// Blender writes factors 1 and 1 beside a texture that holds the values: the material takes the
// texture's mean (green: roughness, blue: metallic, stored linear), so a textured dielectric is not
// read as a rough metal that would drop its base-colour texture.
TEST(GltfMetallicRoughnessTexture, TheFactorsAreScaledByTheTexturesMean) {
    GltfBuilder b;
    const float centre[3] = {0, 0, 0}, u[3] = {1, 0, 0}, v[3] = {0, 1, 0};
    const std::string prim = b.quadPrimitive(centre, u, v);
    // Two texels: green 128 and 64 (mean 96/255), blue 0 and 51 (mean 25.5/255 = 0.1).
    const int mr = b.image(testgltf::pngBytes(2, 1, {255, 128, 0, 255, 64, 51}), "image/png");
    const int colour = b.image(testgltf::pngBytes(1, 1, {200, 100, 50}), "image/png");
    const Scene s = loadText(b.json(R"("scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[)" + prim + R"(,"material":0}]}],
"textures":[{"source":)" + std::to_string(mr) + R"(},{"source":)" + std::to_string(colour) + R"(}],
"materials":[{"pbrMetallicRoughness":{"metallicFactor":1,"roughnessFactor":1,
 "metallicRoughnessTexture":{"index":0},"baseColorTexture":{"index":1}}}])"));
    ASSERT_EQ(s.materials.size(), 1u);
    const Material& m = s.materials[0];
    EXPECT_EQ(m.type, MaterialType::Plastic);
    EXPECT_NEAR(m.roughness, 96.0f / 255.0f, 1e-6f);
    EXPECT_NEAR(m.metallic, 25.5f / 255.0f, 1e-6f);
    EXPECT_GE(m.baseColorTexture, 0) << "a plastic shows its base-colour texture";
    EXPECT_TRUE(contains(allWarnings(s), "metallicRoughnessTexture: its mean used (roughness x 0.376, metallic x 0.100)"))
        << allWarnings(s);
}

}  // namespace
}  // namespace rtpm
