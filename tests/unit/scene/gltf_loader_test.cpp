// Tests of the glTF importer and exporter: a hand-written file's values, round trips, broken files.
#include "common/scene/gltf_loader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <sstream>

#include <glm/gtc/matrix_transform.hpp>

#include "common/scene/gltf_export.h"
#include "common/scene/scene_loader.h"
#include "tests/support/scratch_dir.h"

namespace rtpm {
namespace {

namespace fs = std::filesystem;

const std::string kDataDir = RTPM_TEST_DATA_DIR;

std::string readText(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// A scratch directory per test, removed afterwards.
using testsupport::ScratchDir;

std::string base64(const std::string& bytes) {
    static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
        for (int k = 3; k >= 0; --k) out += kAlphabet[(v >> (6 * k)) & 63];
    }
    if (i + 1 == bytes.size()) {
        uint32_t v = uint8_t(bytes[i]) << 16;
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += "==";
    } else if (i + 2 == bytes.size()) {
        uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8);
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += kAlphabet[(v >> 6) & 63];
        out += "=";
    }
    return out;
}

// Minimal one-triangle glTF whose pieces a test can break: positions, indices, the POSITION
// accessor's componentType and count, and the buffer URI.
struct TriangleGltf {
    std::vector<float> positions{0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::vector<uint16_t> indices{0, 1, 2};
    int positionComponentType = 5126;
    std::string positionCount;  // empty: the real count
    std::string bufferUri;      // empty: embedded base64

    std::string json() const {
        std::string bytes(reinterpret_cast<const char*>(positions.data()), positions.size() * 4);
        size_t posBytes = bytes.size();
        bytes.append(reinterpret_cast<const char*>(indices.data()), indices.size() * 2);
        size_t idxBytes = indices.size() * 2;
        while (bytes.size() % 4) bytes.push_back('\0');
        std::string uri = bufferUri.empty() ? "data:application/octet-stream;base64," + base64(bytes) : bufferUri;
        std::string count = positionCount.empty() ? std::to_string(positions.size() / 3) : positionCount;
        return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
"nodes":[{"mesh":0}],
"materials":[{"emissiveFactor":[1,1,1]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"material":0}]}],
"accessors":[{"bufferView":0,"componentType":)" +
               std::to_string(positionComponentType) + R"(,"count":)" + count + R"(,"type":"VEC3"},
{"bufferView":1,"componentType":5123,"count":)" +
               std::to_string(indices.size()) + R"(,"type":"SCALAR"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":)" +
               std::to_string(posBytes) + R"(},{"buffer":0,"byteOffset":)" + std::to_string(posBytes) +
               R"(,"byteLength":)" + std::to_string(idxBytes) + R"(}],
"buffers":[{"byteLength":)" +
               std::to_string(bytes.size()) + R"(,"uri":")" + uri + R"("}]})";
    }
};

// Expects loadGltf(path) to throw a SceneError whose file is `path`, whose element contains
// `elementPart` (when given) and whose message names both.
void expectSceneError(const std::string& path, const std::string& elementPart = "") {
    try {
        Scene s = loadGltf(path);
        ADD_FAILURE() << path << " loaded without error (" << s.triangleCount() << " triangles)";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.file, path);
        EXPECT_FALSE(e.element.empty());
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(e.element), std::string::npos) << e.what();
        if (!elementPart.empty()) {
            EXPECT_NE(e.element.find(elementPart), std::string::npos) << e.what();
        }
    }
}

void expectNear3(Vec3 a, Vec3 b, float eps = 1e-5f) {
    EXPECT_NEAR(a.x, b.x, eps);
    EXPECT_NEAR(a.y, b.y, eps);
    EXPECT_NEAR(a.z, b.z, eps);
}

const Instance* instanceNamed(const Scene& s, const std::string& name) {
    for (const Instance& i : s.instances)
        if (i.name == name) return &i;
    return nullptr;
}

TEST(GltfLoader, HandWrittenFileLoadsCameraLightsMaterialsAndInstances) {
    const std::string path = kDataDir + "/gltf/handmade.gltf";
    Scene s = loadGltf(path);
    s.validate(path);
    EXPECT_EQ(s.name, "handmade");

    // Instancing: mesh 0 used by two nodes → one rtpm mesh, two instances.
    const Instance* a = instanceNamed(s, "mirrorA");
    const Instance* b = instanceNamed(s, "mirrorB");
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->mesh, b->mesh);
    // Mesh 2's LINES primitive is skipped: meshes are tri, glassTri, lampTri (3 in all).
    EXPECT_EQ(s.meshes.size(), 3u);
    EXPECT_EQ(s.instances.size(), 4u);
    expectNear3(Vec3(a->transform * glm::vec4(0, 0, 0, 1)), Vec3(1, 0, 0));
    // mirrorB: scale 2, then +90° about Y, then translate (−1, 0, 0): (1,0,0) → (0,0,−2) → (−1,0,−2).
    expectNear3(Vec3(b->transform * glm::vec4(1, 0, 0, 1)), Vec3(-1, 0, -2));
    // Hierarchy: parent (0,2,0) ∘ child (0,0,1).
    const Instance* g = instanceNamed(s, "glassChild");
    ASSERT_TRUE(g);
    expectNear3(Vec3(g->transform * glm::vec4(0, 0, 0, 1)), Vec3(0, 2, 1));
    const Instance* lamp = instanceNamed(s, "lamp");
    ASSERT_TRUE(lamp);
    expectNear3(Vec3(lamp->transform * glm::vec4(0, 0, 0, 1)), Vec3(0, 5, 0));

    // Materials (docs/ARCHITECTURE.md §9).
    const Material& mirror = s.materials[s.meshes[a->mesh].material];
    EXPECT_EQ(mirror.type, MaterialType::Mirror);
    expectNear3(mirror.baseColor, Vec3(0.9f, 0.8f, 0.7f));
    const Material& glass = s.materials[s.meshes[g->mesh].material];
    EXPECT_EQ(glass.type, MaterialType::Dielectric);
    EXPECT_NEAR(glass.ior, 1.33f, 1e-6f);
    // σ = −ln(colour) / distance, distance 2 m.
    expectNear3(glass.absorption, Vec3(-std::log(0.5f) / 2, -std::log(0.25f) / 2, 0.0f));
    const Material& lampMat = s.materials[s.meshes[lamp->mesh].material];
    EXPECT_EQ(lampMat.type, MaterialType::Plastic);  // metallic 0: glTF's dielectric base
    expectNear3(lampMat.emission, Vec3(4.0f, 2.0f, 1.0f));
    expectNear3(lampMat.baseColor, Vec3(0.5f));

    // Normals were missing: computed, unit, along the triangle's +Z geometric normal.
    for (Vec3 n : s.meshes[0].normals) expectNear3(n, Vec3(0, 0, 1));

    // Camera: local −Z turned +90° about Y looks along −X.
    ASSERT_TRUE(s.camera.has_value());
    expectNear3(s.camera->position, Vec3(0, 1, 5));
    expectNear3(s.camera->forward, Vec3(-1, 0, 0));
    expectNear3(s.camera->up, Vec3(0, 1, 0));
    EXPECT_NEAR(s.camera->yfov, 0.7f, 1e-6f);

    // Lights: W/sr times colour; spot direction = the node's −Z (turned −90° about X → −Y).
    ASSERT_EQ(s.lights.size(), 2u);
    EXPECT_EQ(s.lights[0].type, LightType::Point);
    expectNear3(s.lights[0].position, Vec3(0, 3, 0));
    expectNear3(s.lights[0].intensity, Vec3(8.0f, 4.0f, 2.0f));
    EXPECT_EQ(s.lights[1].type, LightType::Spot);
    expectNear3(s.lights[1].position, Vec3(0, 4, 0));
    expectNear3(s.lights[1].direction, Vec3(0, -1, 0));
    expectNear3(s.lights[1].intensity, Vec3(2.0f));
    EXPECT_NEAR(s.lights[1].innerConeAngle, 0.2f, 1e-6f);
    EXPECT_NEAR(s.lights[1].outerConeAngle, 0.5f, 1e-6f);

    // Warnings name the unsupported extension and the skipped LINES primitive.
    std::string all;
    for (const auto& w : s.warnings) all += w + "\n";
    EXPECT_NE(all.find("EXT_made_up_feature"), std::string::npos) << all;
    EXPECT_NE(all.find("meshes[2].primitives[1]"), std::string::npos) << all;
}

TEST(GltfLoader, RequiredUnsupportedExtensionIsAnError) {
    ScratchDir dir;
    std::string text = readText(kDataDir + "/gltf/handmade.gltf");
    text.insert(text.find('{') + 1, R"("extensionsRequired":["EXT_meshopt_compression"],)");
    expectSceneError(dir.write("required.gltf", text), "extensionsRequired");
}

// Export and load: a plastic comes back a plastic with its roughness, metallic and specular
// factor bit for bit (a cluster master sends its scene as a GLB), a Lambertian comes back a
// Lambertian (KHR_materials_specular factor 0).
TEST(GltfExport, PlasticAndLambertianRoundTripAsThemselves) {
    Scene s = loadScene("RING");
    s.materials[0].type = MaterialType::Diffuse;
    Material lambert = s.materials[0];
    Material p = s.materials[0];
    p.name = "satin";
    p.type = MaterialType::Plastic;
    p.roughness = 0.37f;
    p.metallic = 0.21f;
    p.specular = 0.6f;
    s.materials.push_back(p);
    s.meshes[0].material = uint32_t(s.materials.size() - 1);
    ScratchDir dir;
    const std::string path = dir.write("plastic.glb", "");
    exportGlb(s, path);
    const Scene back = loadScene(path);
    bool sawPlastic = false, sawLambert = false;
    for (const Material& m : back.materials) {
        if (m.name == "satin") {
            sawPlastic = true;
            EXPECT_EQ(m.type, MaterialType::Plastic);
            EXPECT_EQ(m.roughness, p.roughness);
            EXPECT_EQ(m.metallic, p.metallic);
            EXPECT_EQ(m.specular, p.specular);
            EXPECT_EQ(m.baseColor, p.baseColor);
        } else if (m.name == lambert.name) {
            sawLambert = true;
            EXPECT_EQ(m.type, MaterialType::Diffuse);
        }
    }
    EXPECT_TRUE(sawPlastic);
    EXPECT_TRUE(sawLambert);
}

// The world light goes into an exported file and comes back: a uniform radiance, and a map's
// texels bit for bit. The cluster's GLB (encodeGlb without the world) leaves it out; a map whose
// texels do not fill their buffer view is refused naming it.
TEST(GltfExport, TheWorldLightRoundTripsThroughGlb) {
    ScratchDir dir;
    Scene uniform = loadScene("RING");
    uniform.environment = Environment::uniform(Vec3(0.25f, 0.5f, 1.5f));
    const std::string u = dir.file("uniform.glb");
    exportGlb(uniform, u);
    const Scene backU = loadScene(u);
    EXPECT_FALSE(backU.worldless);
    ASSERT_FALSE(backU.environment.hasMap());
    EXPECT_EQ(backU.environment.uniformRadiance(), Vec3(0.25f, 0.5f, 1.5f));

    Texture map;
    map.width = 8;
    map.height = 4;
    for (int i = 0; i < map.width * map.height * 3; ++i) map.rgb.push_back(0.1f * float(i % 7) + 1.0f / 3.0f);
    Scene mapped = loadScene("RING");
    mapped.environment = Environment::fromMap(map);
    const std::string m = dir.file("map.glb");
    exportGlb(mapped, m);
    const Scene backM = loadScene(m);
    ASSERT_TRUE(backM.environment.hasMap());
    EXPECT_EQ(backM.environment.width(), 8);
    EXPECT_EQ(backM.environment.height(), 4);
    ASSERT_EQ(backM.environment.texels().size(), map.rgb.size());
    EXPECT_EQ(std::memcmp(backM.environment.texels().data(), map.rgb.data(), map.rgb.size() * sizeof(float)), 0);
    EXPECT_EQ(backM.environment.integral(), mapped.environment.integral());

    const Scene fromWire = loadGltfFromMemory(encodeGlb(mapped), "wire.glb", "");
    EXPECT_TRUE(fromWire.environment.empty());
    EXPECT_FALSE(fromWire.worldless);

    const std::string triangle = R"("asset":{"version":"2.0"},"scene":0,"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}])";
    expectSceneError(dir.write("short.gltf", "{" + triangle + R"(,"scenes":[{"nodes":[0],"extras":{"rtpm_world":
{"map":{"bufferView":0,"width":8,"height":4}}}}]})"), "rtpm_world.map");
    expectSceneError(dir.write("negative.gltf", "{" + triangle + R"(,"scenes":[{"nodes":[0],"extras":{"rtpm_world":
{"uniform":[1,-1,1]}}}]})"), "rtpm_world.uniform");
}

// A GLB whose BIN chunk claims 8 bytes more than the file holds (its header counted, as tinygltf
// does not): refused before tinygltf would copy past the end (found by the Draco fuzz seeds).
TEST(GltfLoader, AGlbBinChunkRunningPastTheEndIsRefused) {
    std::vector<uint8_t> glb = encodeGlb(loadScene("RING"));
    uint32_t jsonLength = 0, binLength = 0;
    std::memcpy(&jsonLength, glb.data() + 12, 4);
    ASSERT_GT(glb.size(), 28u + jsonLength);
    std::memcpy(&binLength, glb.data() + 20 + jsonLength, 4);
    binLength += 8;
    std::memcpy(glb.data() + 20 + jsonLength, &binLength, 4);
    try {
        loadGltfFromMemory(glb, "tampered.glb", "");
        ADD_FAILURE() << "loaded";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.element, "GLB");
        EXPECT_NE(std::string(e.what()).find("runs past the end of the file"), std::string::npos) << e.what();
    }
}

TEST(GltfExport, RingRoundTripsThroughGlb) {
    ScratchDir dir;
    Scene ring = loadScene("RING");
    const std::string path = dir.write("ring.glb", "");
    exportGlb(ring, path);
    Scene back = loadScene(path);
    EXPECT_EQ(back.triangleCount(), ring.triangleCount());
    ASSERT_EQ(back.meshes.size(), ring.meshes.size());
    ASSERT_EQ(back.materials.size(), ring.materials.size());
    for (size_t i = 0; i < ring.materials.size(); ++i) {
        EXPECT_EQ(back.materials[i].type, ring.materials[i].type) << i;
        expectNear3(back.materials[i].baseColor, ring.materials[i].baseColor);
        expectNear3(back.materials[i].emission, ring.materials[i].emission, 1e-2f);
    }
    for (size_t i = 0; i < ring.meshes.size(); ++i) {
        EXPECT_EQ(back.meshes[i].indices, ring.meshes[i].indices);
        ASSERT_EQ(back.meshes[i].positions.size(), ring.meshes[i].positions.size());
        for (size_t v = 0; v < ring.meshes[i].positions.size(); ++v)
            expectNear3(back.meshes[i].positions[v], ring.meshes[i].positions[v], 0.0f);
    }
    ASSERT_TRUE(back.camera && ring.camera);
    expectNear3(back.camera->position, ring.camera->position);
    expectNear3(back.camera->forward, ring.camera->forward);
    expectNear3(back.camera->up, ring.camera->up);
    EXPECT_NEAR(back.camera->yfov, ring.camera->yfov, 1e-6f);
    ASSERT_EQ(back.lights.size(), ring.lights.size());
}

TEST(GltfExport, LightsDielectricsAndTexturesRoundTrip) {
    ScratchDir dir;
    Scene s;
    s.name = "mixed";
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    m.uvs = {{0, 0}, {1, 0}, {0, 1}};
    m.indices = {0, 1, 2};
    s.meshes = {m, m};
    s.meshes[1].material = 1;
    Material glass;
    glass.type = MaterialType::Dielectric;
    glass.ior = 1.33f;
    glass.absorption = Vec3(3.0f, 16.0f, 38.0f);
    Material tex;
    tex.baseColorTexture = 0;
    tex.baseColor = Vec3(1.0f);
    s.materials = {glass, tex};
    Texture t;
    t.width = 2;
    t.height = 1;
    t.rgb = {0.0f, 0.5f, 1.0f, 0.2f, 0.2f, 0.2f};
    s.textures = {t};
    Instance i0;
    i0.mesh = 0;
    i0.transform = glm::translate(Mat4(1.0f), Vec3(1, 2, 3));
    Instance i1;
    i1.mesh = 1;
    s.instances = {i0, i1};
    Light spot;
    spot.type = LightType::Spot;
    spot.position = Vec3(0, 2, 0);
    spot.direction = glm::normalize(Vec3(1, -1, 0));
    spot.intensity = Vec3(3, 2, 1);
    spot.innerConeAngle = 0.1f;
    spot.outerConeAngle = 0.6f;
    Light sun;
    sun.type = LightType::Directional;
    sun.direction = Vec3(0, 0, 1);  // antiparallel to −Z: the degenerate rotation case
    sun.intensity = Vec3(5);
    s.lights = {spot, sun};
    s.camera = Camera::lookAt(Vec3(0, 0, 5), Vec3(0), Vec3(0, 1, 0), 0.8f);

    const std::string path = dir.write("mixed.glb", "");
    exportGlb(s, path);
    Scene b = loadGltf(path);
    ASSERT_EQ(b.materials.size(), 2u);
    EXPECT_EQ(b.materials[0].type, MaterialType::Dielectric);
    EXPECT_NEAR(b.materials[0].ior, 1.33f, 1e-6f);
    expectNear3(b.materials[0].absorption, glass.absorption, 1e-3f);
    ASSERT_EQ(b.textures.size(), 1u);
    ASSERT_EQ(b.materials[1].baseColorTexture, 0);
    // 8-bit sRGB storage: linear values come back within quantisation.
    for (size_t k = 0; k < t.rgb.size(); ++k) EXPECT_NEAR(b.textures[0].rgb[k], t.rgb[k], 4e-3f) << k;
    ASSERT_EQ(b.lights.size(), 2u);
    expectNear3(b.lights[0].direction, spot.direction);
    expectNear3(b.lights[0].intensity, spot.intensity);
    EXPECT_NEAR(b.lights[0].outerConeAngle, 0.6f, 1e-6f);
    expectNear3(b.lights[1].direction, sun.direction);
    expectNear3(Vec3(b.instances[0].transform * glm::vec4(0, 0, 0, 1)), Vec3(1, 2, 3));
    ASSERT_TRUE(b.camera);
    expectNear3(b.camera->forward, Vec3(0, 0, -1));
}

TEST(GltfLoader, EmptyFileIsAnError) {
    ScratchDir dir;
    expectSceneError(dir.write("empty.gltf", ""), "file");
    expectSceneError(dir.write("empty.glb", ""), "file");
}

TEST(GltfLoader, TruncatedGlbIsAnError) {
    ScratchDir dir;
    std::vector<uint8_t> glb = encodeGlb(loadScene("EGG"));
    std::string bytes(glb.begin(), glb.end());
    for (size_t cut : {size_t(3), size_t(11), size_t(20), bytes.size() / 2, bytes.size() - 1})
        expectSceneError(dir.write("cut" + std::to_string(cut) + ".glb", bytes.substr(0, cut)));
}

TEST(GltfLoader, TruncatedJsonIsAnError) {
    ScratchDir dir;
    std::string text = readText(kDataDir + "/gltf/handmade.gltf");
    expectSceneError(dir.write("cut.gltf", text.substr(0, text.size() / 2)), "JSON");
}

TEST(GltfLoader, WrongAccessorComponentTypeNamesTheAttribute) {
    ScratchDir dir;
    TriangleGltf t;
    t.positionComponentType = 5123;  // UNSIGNED_SHORT positions
    expectSceneError(dir.write("ushort.gltf", t.json()), "meshes[0].primitives[0].attributes.POSITION");
}

TEST(GltfLoader, IndexOutOfRangeNamesTheIndices) {
    ScratchDir dir;
    TriangleGltf t;
    t.indices = {0, 1, 7};
    expectSceneError(dir.write("index.gltf", t.json()), "meshes[0].primitives[0].indices");
}

TEST(GltfLoader, NanVertexNamesThePositions) {
    ScratchDir dir;
    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
        TriangleGltf t;
        t.positions[4] = bad;
        expectSceneError(dir.write("nan.gltf", t.json()), "meshes[0].primitives[0].attributes.POSITION");
    }
}

TEST(GltfLoader, MissingBufferFileIsAnError) {
    ScratchDir dir;
    TriangleGltf t;
    t.bufferUri = "missing.bin";
    expectSceneError(dir.write("missing.gltf", t.json()), "buffers");
}

TEST(GltfLoader, AbsurdAccessorCountIsRejectedBeforeAllocating) {
    ScratchDir dir;
    for (const char* count : {"2147483648", "4294967295", "18446744073709551615", "0", "-3", "1.5"}) {
        TriangleGltf t;
        t.positionCount = count;
        expectSceneError(dir.write("count.gltf", t.json()));
    }
}

TEST(GltfLoader, GarbageBytesAreAnError) {
    ScratchDir dir;
    std::mt19937 rng(12345);
    for (int trial = 0; trial < 20; ++trial) {
        std::string bytes(size_t(1 + rng() % 4096), '\0');
        for (char& c : bytes) c = char(rng() & 0xFF);
        if (trial % 2) std::memcpy(bytes.data(), "glTF", std::min<size_t>(4, bytes.size()));
        expectSceneError(dir.write(trial % 2 ? "garbage.glb" : "garbage.gltf", bytes));
    }
}

TEST(GltfLoader, DeepJsonNestingAndNodeCyclesAreErrors) {
    ScratchDir dir;
    std::string text = readText(kDataDir + "/gltf/handmade.gltf");
    std::string deep = text;
    deep.insert(deep.find('{') + 1, "\"extras\":" + std::string(100000, '[') + std::string(100000, ']') + ",");
    expectSceneError(dir.write("deep.gltf", deep), "JSON");
    // Node 3 (child of 2) names node 2 as its child: a cycle.
    std::string cyclic = text;
    size_t at = cyclic.find("\"name\": \"glassChild\"");
    ASSERT_NE(at, std::string::npos);
    cyclic.insert(at, "\"children\": [2], ");
    expectSceneError(dir.write("cycle.gltf", cyclic), "nodes[");
}

TEST(GltfLoader, MutatedFilesNeverCrash) {
    // Byte flips and cuts of a valid GLB and of the hand-written JSON: each either loads a
    // valid scene or throws SceneError — never anything else.
    std::vector<uint8_t> glb = encodeGlb(loadScene("RING"));
    std::string json = readText(kDataDir + "/gltf/handmade.gltf");
    std::mt19937 rng(7);
    for (int trial = 0; trial < 300; ++trial) {
        std::vector<uint8_t> bytes = trial % 2 ? glb : std::vector<uint8_t>(json.begin(), json.end());
        int flips = 1 + int(rng() % 8);
        for (int f = 0; f < flips; ++f) bytes[rng() % bytes.size()] = uint8_t(rng());
        if (rng() % 4 == 0) bytes.resize(rng() % bytes.size());
        try {
            Scene s = loadGltfFromMemory(bytes, "mutant", "");
            s.validate("mutant");
        } catch (const SceneError& e) {
            EXPECT_EQ(e.file, "mutant");
        }
    }
}

}  // namespace
}  // namespace rtpm
