// Hostile scene files: references outside the scene's folder, non-regular files, and small files
// that announce huge arrays. Each case is a failure found by hand against the loaders (issue 13).
#include "common/scene/scene_files.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/scene/gltf_loader.h"
#include "common/scene/obj_loader.h"
#include "common/scene/scene_loader.h"

namespace rtpm {
namespace {

namespace fs = std::filesystem;

// <tmp>/rtpm_files_<test>_<pid>/{scene/, outside/}: the scene folder and a sibling it must not reach.
class Sandbox {
public:
    Sandbox() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        root_ = fs::temp_directory_path() /
                ("rtpm_files_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
        fs::remove_all(root_);
        fs::create_directories(root_ / "scene");
        fs::create_directories(root_ / "outside");
    }
    ~Sandbox() {
        std::error_code ec;
        fs::remove_all(root_, ec);
    }
    fs::path scene() const { return root_ / "scene"; }
    fs::path outside() const { return root_ / "outside"; }
    std::string write(const fs::path& p, const std::string& bytes) const {
        std::ofstream(p, std::ios::binary) << bytes;
        return p.string();
    }

private:
    fs::path root_;
};

// The bytes of one triangle (3 float VEC3 positions).
std::string triangleBytes() {
    const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    return std::string(reinterpret_cast<const char*>(p), sizeof p);
}

// A one-triangle glTF whose POSITION data is the external buffer `uri` of `byteLength` bytes.
std::string gltfWithBuffer(const std::string& uri, size_t byteLength = 36) {
    return R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"materials":[{"emissiveFactor":[1,1,1]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],
"bufferViews":[{"buffer":0,"byteLength":)" +
           std::to_string(byteLength) + R"(}],"buffers":[{"byteLength":)" +
           std::to_string(byteLength) + R"(,"uri":")" + uri + R"("}]})";
}

// A glTF whose POSITION accessor has `count` elements and no bufferView (a 300-byte file).
std::string gltfWithoutBufferView(const std::string& count, const std::string& attribute = "POSITION") {
    std::string attrs = attribute == "POSITION" ? R"("POSITION":0)" : R"("POSITION":1,")" + attribute + R"(":0)";
    return R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"materials":[{"emissiveFactor":[1,1,1]}],
"meshes":[{"primitives":[{"attributes":{)" + attrs + R"(},"material":0}]}],
"accessors":[{"componentType":5126,"count":)" + count + R"(,"type":"VEC3"},
{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"buffers":[{"byteLength":36,"uri":"tri.bin"}]})";
}

// Loads `path` expecting a SceneError; returns its text (empty, with a failure, if none).
std::string loadError(const std::string& path, const SceneInputPolicy& policy = {}) {
    try {
        SceneOverrides light;
        light.light = PointLightOverride{};
        Scene s = loadScene(path, light, policy);
        ADD_FAILURE() << path << " loaded (" << s.triangleCount() << " triangles)";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.file, path);
        return e.what();
    }
    return {};
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// What a refusal must never say about the file outside: its size, content or resolved place.
// The reference as the scene wrote it (quoted in the error) is the scene's own text: dropped.
void expectRevealsNothing(std::string error, const fs::path& outsideFile, const std::string& uri = "") {
    for (size_t at; !uri.empty() && (at = error.find("'" + uri + "'")) != std::string::npos;)
        error.erase(at, uri.size() + 2);
    std::error_code ec;
    const auto size = fs::file_size(outsideFile, ec);
    if (!ec) {
        EXPECT_FALSE(contains(error, " " + std::to_string(size))) << error;
    }
    EXPECT_FALSE(contains(error, fs::weakly_canonical(outsideFile).string())) << error;
    EXPECT_FALSE(contains(error, "root:")) << error;
    EXPECT_FALSE(contains(error, "requestedBytes")) << error;
}

TEST(SceneFiles, GltfBufferOutsideTheSceneFolderIsRefusedInEveryDisguise) {
    Sandbox box;
    const std::string secret = box.write(box.outside() / "secret.bin", triangleBytes());
    fs::create_symlink("../outside/secret.bin", box.scene() / "link.bin");
    fs::create_directories(box.scene() / "sub");
    fs::create_symlink(box.outside(), box.scene() / "sub" / "dirlink");
    const std::vector<std::string> uris = {
        "../outside/secret.bin",            // plain ..
        "%2e%2e/outside/secret.bin",        // percent-encoded ..
        "%2E%2E%2Foutside%2Fsecret.bin",    // percent-encoded separators too
        "link.bin",                         // symlink to a file outside
        "sub/dirlink/secret.bin",           // through a symlinked folder
        "sub/dirlink/../../outside/secret.bin",
        secret,                             // absolute
        "/etc/passwd", "../../../../../../../../etc/passwd",
        "scene/../../outside/secret.bin",
    };
    for (const std::string& uri : uris) {
        const std::string path = box.write(box.scene() / "s.gltf", gltfWithBuffer(uri));
        const std::string err = loadError(path);
        EXPECT_TRUE(contains(err, "outside the scene's folder")) << uri << ": " << err;
        EXPECT_TRUE(contains(err, "--allow-scene-dir")) << err;
        expectRevealsNothing(err, secret, uri);
        expectRevealsNothing(err, "/etc/passwd", uri);
    }
    // /etc/passwd with its exact length: before, the size-mismatch error disclosed the length.
    std::error_code ec;
    const auto passwdBytes = fs::file_size("/etc/passwd", ec);
    if (!ec && passwdBytes > 0) {
        const std::string path =
            box.write(box.scene() / "p.gltf", gltfWithBuffer("../../../../../../etc/passwd", passwdBytes - 1));
        expectRevealsNothing(loadError(path), "/etc/passwd", "../../../../../../etc/passwd");
    }
}

TEST(SceneFiles, AllowedFolderOpensTheOutsideFileAndInsideFilesStillLoad) {
    Sandbox box;
    box.write(box.outside() / "secret.bin", triangleBytes());
    box.write(box.scene() / "tri.bin", triangleBytes());
    SceneOverrides light;
    light.light = PointLightOverride{};
    // A file in the scene's own folder, also by a name with percent-encoding.
    EXPECT_EQ(loadScene(box.write(box.scene() / "in.gltf", gltfWithBuffer("tri.bin")), light)
                  .triangleCount(), 1u);
    EXPECT_EQ(loadScene(box.write(box.scene() / "pc.gltf", gltfWithBuffer("tri%2Ebin")), light)
                  .triangleCount(), 1u);
    // The outside folder once it is allowed (the way --allow-scene-dir passes it).
    const std::string out = box.write(box.scene() / "out.gltf", gltfWithBuffer("../outside/secret.bin"));
    SceneInputPolicy allow;
    allow.allowedDirs = {box.outside().string()};
    EXPECT_EQ(loadScene(out, light, allow).triangleCount(), 1u);
    // A sibling whose name merely starts like the scene folder is not inside it.
    fs::create_directories(box.scene().string() + "2");
    box.write(box.scene().string() + "2/tri.bin", triangleBytes());
    const std::string sib = box.write(box.scene() / "sib.gltf", gltfWithBuffer("../scene2/tri.bin"));
    EXPECT_TRUE(contains(loadError(sib), "outside the scene's folder"));
}

TEST(SceneFiles, DevicesFifosAndFoldersAreNotRead) {
    Sandbox box;
    ASSERT_EQ(::mkfifo((box.scene() / "fifo.bin").c_str(), 0600), 0);
    fs::create_directories(box.scene() / "dir.bin");
    // /dev/zero is refused as outside; allowed, it is refused as not a regular file.
    const std::string zero = box.write(box.scene() / "z.gltf", gltfWithBuffer("/dev/zero"));
    EXPECT_TRUE(contains(loadError(zero), "outside the scene's folder"));
    SceneInputPolicy allowDev;
    allowDev.allowedDirs = {"/dev"};
    EXPECT_TRUE(contains(loadError(zero, allowDev), "not a regular file"));
    // A FIFO inside the folder: refused at once (before, the load waited for a writer forever).
    const std::string fifo = box.write(box.scene() / "f.gltf", gltfWithBuffer("fifo.bin"));
    EXPECT_TRUE(contains(loadError(fifo), "not a regular file"));
    const std::string dir = box.write(box.scene() / "d.gltf", gltfWithBuffer("dir.bin"));
    EXPECT_FALSE(loadError(dir).empty());
    // The scene file itself.
    ASSERT_EQ(::mkfifo((box.scene() / "scene.gltf").c_str(), 0600), 0);
    EXPECT_TRUE(contains(loadError((box.scene() / "scene.gltf").string()), "not a regular file"));
}

TEST(SceneFiles, ImageUriOutsideIsAnErrorNotAWarning) {
    Sandbox box;
    box.write(box.scene() / "tri.bin", triangleBytes());
    box.write(box.outside() / "t.png", "not really a png");
    std::string g = gltfWithBuffer("tri.bin");
    g.insert(g.rfind('}'), R"(,"images":[{"uri":"../outside/t.png"}],"textures":[{"source":0}])");
    g.replace(g.find(R"("emissiveFactor":[1,1,1])"), 24,
              R"("emissiveFactor":[1,1,1],"pbrMetallicRoughness":{"baseColorTexture":{"index":0}})");
    const std::string err = loadError(box.write(box.scene() / "img.gltf", g));
    EXPECT_TRUE(contains(err, "outside the scene's folder")) << err;
}

// Peak memory of this process (kB); loads below must not move it by hundreds of MB.
long maxRssKb() {
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss;
}

TEST(SceneFiles, SmallFilesAnnouncingHugeArraysAreRefusedBeforeAllocating) {
    Sandbox box;
    box.write(box.scene() / "tri.bin", triangleBytes());
    const long before = maxRssKb();
    // 2^24 positions without a bufferView (a 300-byte file; before: 1.8 GB and 5.6 M triangles).
    std::string err = loadError(box.write(box.scene() / "a.gltf", gltfWithoutBufferView("16777216")));
    EXPECT_TRUE(contains(err, "no bufferView")) << err;
    // 357913941 × 12 bytes passed the old 4 GiB sanity check and ran out of memory.
    err = loadError(box.write(box.scene() / "b.gltf", gltfWithoutBufferView("357913941")));
    EXPECT_TRUE(contains(err, "no bufferView")) << err;
    // Indices without a bufferView: all zero, every triangle degenerate.
    std::string idx = gltfWithoutBufferView("3");
    idx.replace(idx.find(R"("POSITION":0)"), 12, R"("POSITION":1},"indices":0,"x":{)");
    err = loadError(box.write(box.scene() / "i.gltf", idx));
    EXPECT_TRUE(contains(err, "bufferView")) << err;  // tinygltf or the importer refuses it
    // The same counts as a NORMAL accessor without bufferView: refused before it is read.
    for (const char* count : {"16777216", "357913941", "4294967296"}) {
        err = loadError(box.write(box.scene() / "c.gltf", gltfWithoutBufferView(count, "NORMAL")));
        EXPECT_TRUE(contains(err, "count differs from POSITION")) << count << ": " << err;
    }
    EXPECT_LT(maxRssKb() - before, 150 * 1024) << "kB of peak memory grew";
}

TEST(SceneFiles, LargeDataUriIsChargedBeforeDecoding) {
    Sandbox box;
    // 3 MB of base64 ("AAAA" = 3 zero bytes) with a valid triangle in front.
    const size_t bytes = 3u << 20;
    std::string uri = "data:application/octet-stream;base64,";
    uri += "AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA";  // 33 zero bytes
    uri.append((bytes - 33) / 3 * 4, 'A');
    const size_t decoded = 33 + (bytes - 33) / 3 * 3;
    const std::string path = box.write(box.scene() / "d.gltf", gltfWithBuffer(uri, decoded));
    SceneInputPolicy small;
    small.maxSceneBytes = 2u << 20;
    const std::string err = loadError(path, small);
    EXPECT_TRUE(contains(err, "--max-scene-bytes")) << err;
    SceneInputPolicy enough;
    enough.maxSceneBytes = 16u << 20;
    SceneOverrides light;
    light.light = PointLightOverride{};
    EXPECT_NO_THROW(loadScene(path, light, enough));
}

// A glTF of `count` empty nodes: ~20 bytes of JSON each, far more once parsed.
std::string gltfOfNodes(size_t count) {
    std::string json = R"({"asset":{"version":"2.0"},"nodes":[)";
    json.reserve(json.size() + count * 13 + 8);
    for (size_t i = 0; i < count; ++i) json += i ? R"(,{"name":"n"})" : R"({"name":"n"})";
    return json + "]}";
}

TEST(SceneFiles, NodeCountsAreChargedBeforeParsing) {
    Sandbox box;
    // 100 k nodes: 1.3 MB of JSON that fit a 32 MiB budget as bytes but not once parsed.
    const std::string path = box.write(box.scene() / "nodes.gltf", gltfOfNodes(100000));
    SceneInputPolicy small;
    small.maxSceneBytes = 32u << 20;
    std::string err = loadError(path, small);
    EXPECT_TRUE(contains(err, "--max-scene-bytes")) << err;
    EXPECT_TRUE(contains(err, "nodes (100000 JSON objects")) << err;
    // A million nodes (13 MB) against the default budget: refused before tinygltf parses them.
    const std::string million = box.write(box.scene() / "million.gltf", gltfOfNodes(1000000));
    const auto t0 = std::chrono::steady_clock::now();
    err = loadError(million);
    EXPECT_TRUE(contains(err, "nodes (1000000 JSON objects")) << err;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
    // A few thousand nodes are well within it: the file loads (an empty scene, said so).
    const Scene few = loadScene(box.write(box.scene() / "few.gltf", gltfOfNodes(2000)));
    EXPECT_EQ(few.triangleCount(), 0u);
}

// CRC-32 (ISO-HDLC), for the PNG chunk below.
uint32_t crc32(const std::string& bytes) {
    uint32_t c = 0xFFFFFFFFu;
    for (unsigned char b : bytes) {
        c ^= b;
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return ~c;
}

std::string be32(uint32_t v) {
    return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
}

TEST(SceneFiles, TextureDimensionsAreChargedBeforeDecoding) {
    Sandbox box;
    // A PNG header announcing 8000 × 8000 RGB (768 MB of floats) and no pixel data.
    std::string ihdr = "IHDR" + be32(8000) + be32(8000) + std::string("\x08\x02\x00\x00\x00", 5);
    std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + be32(13) + ihdr + be32(crc32(ihdr));
    const std::string idat = "IDAT" + std::string("\x78\x9c\x03\x00\x00\x00\x00\x01", 8);
    png += be32(8) + idat + be32(crc32(idat)) + be32(0) + "IEND" + be32(crc32("IEND"));
    box.write(box.scene() / "big.png", png);
    const std::string obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl m\nf 1/1 2/1 3/1\n";
    box.write(box.scene() / "m.mtl", "newmtl m\nKd 1 1 1\nmap_Kd big.png\n");
    const std::string path = box.write(box.scene() / "t.obj", obj);
    const std::string err = loadError(path);
    EXPECT_TRUE(contains(err, "--max-scene-bytes")) << err;
    EXPECT_TRUE(contains(err, "map_Kd")) << err;
}

TEST(SceneFiles, ObjMaterialLibrariesAndTexturesAreConfined) {
    Sandbox box;
    const std::string faces = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n";
    box.write(box.outside() / "x.mtl", "newmtl m\nKd 1 0 0\n");
    box.write(box.scene() / "ok.mtl", "newmtl m\nKd 0 1 0\n");
    box.write(box.scene() / "zero.mtl", "newmtl m\nKd 1 1 1\nmap_Kd /dev/zero\n");
    box.write(box.scene() / "up.mtl", "newmtl m\nKd 1 1 1\nmap_Kd ../outside/t.png\n");
    fs::create_symlink("../outside/x.mtl", box.scene() / "link.mtl");
    ASSERT_EQ(::mkfifo((box.scene() / "fifo.mtl").c_str(), 0600), 0);
    auto obj = [&](const std::string& name, const std::string& mtllib) {
        return box.write(box.scene() / name, "mtllib " + mtllib + "\n" + faces);
    };
    for (const char* lib : {"../outside/x.mtl", "link.mtl", "/dev/zero", "/etc/passwd"}) {
        const std::string err = loadError(obj("a.obj", lib));
        EXPECT_TRUE(contains(err, "outside the scene's folder")) << lib << ": " << err;
        expectRevealsNothing(err, "/etc/passwd", lib);
    }
    for (const char* lib : {"zero.mtl", "up.mtl"}) {
        const std::string err = loadError(obj("b.obj", lib));
        EXPECT_TRUE(contains(err, "map_Kd")) << err;
        EXPECT_TRUE(contains(err, "outside the scene's folder")) << err;
    }
    EXPECT_TRUE(contains(loadError(obj("c.obj", "fifo.mtl")), "not a regular file"));
    // Inside, and outside once allowed.
    SceneOverrides light;
    light.light = PointLightOverride{};
    Scene ok = loadScene(obj("d.obj", "ok.mtl"), light);
    ASSERT_FALSE(ok.materials.empty());
    EXPECT_EQ(ok.materials[0].baseColor, Vec3(0, 1, 0));
    SceneInputPolicy allow;
    allow.allowedDirs = {box.outside().string()};
    Scene out = loadScene(obj("e.obj", "../outside/x.mtl"), light, allow);
    EXPECT_EQ(out.materials[0].baseColor, Vec3(1, 0, 0));
}

TEST(SceneFiles, InMemoryScenesReadNoFilesAndReferencesWithControlBytesAreRefused) {
    const std::string g = gltfWithBuffer("tri.bin");
    try {
        loadGltfFromMemory(std::vector<uint8_t>(g.begin(), g.end()), "mem.gltf", "");
        ADD_FAILURE() << "loaded";
    } catch (const SceneError& e) {
        EXPECT_TRUE(contains(e.what(), "without a folder")) << e.what();
    }
    Sandbox box;
    SceneFiles files((box.scene() / "x.gltf").string(), SceneInputPolicy{});
    EXPECT_THROW(files.resolve(std::string("tri.bin\0/../../etc/passwd", 26), "uri"), SceneError);
    EXPECT_THROW(files.resolve("a\nb", "uri"), SceneError);
    EXPECT_EQ(files.resolve("a/../b.bin", "uri"), fs::canonical(box.scene()) / "b.bin");
    // The budget saturates instead of wrapping.
    SceneInputPolicy tiny;
    tiny.maxSceneBytes = 100;
    SceneFiles budget("x", "", tiny);
    budget.charge(60, "a");
    EXPECT_THROW(budget.charge(41, "b"), SceneError);
    EXPECT_THROW(budget.charge(UINT64_MAX, "c"), SceneError);
    budget.charge(40, "d");
    EXPECT_EQ(budget.used(), 100u);
}

}  // namespace
}  // namespace rtpm
