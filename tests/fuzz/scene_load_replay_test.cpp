// Bounded fuzzing of the scene loaders that runs under any compiler: seed files (hand-written,
// exported built-ins, hostile ones) and their mutations through the glTF/GLB and OBJ loaders
// (the libFuzzer target scene_load_fuzz runs the same check when clang is available).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_export.h"
#include "tests/fuzz/scene_load_check.h"

namespace rtpm::testing {
namespace {

std::vector<uint8_t> bytesOf(const std::string& s) { return {s.begin(), s.end()}; }

std::vector<uint8_t> readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return bytesOf(ss.str());
}

// A one-triangle glTF with an accessor of `count` elements, with or without its bufferView.
std::string triangle(const std::string& count, bool bufferView) {
    return R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"materials":[{"emissiveFactor":[1,1,1]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],
"accessors":[{)" + std::string(bufferView ? R"("bufferView":0,)" : "") +
           R"("componentType":5126,"count":)" + count + R"(,"type":"VEC3"}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]})";
}

// A one-triangle glTF using KHR_mesh_quantization (normalized SHORT positions),
// KHR_materials_variants (a mapping per variant) and KHR_materials_pbrSpecularGlossiness.
const char* kExtensionsTriangle = R"({"asset":{"version":"2.0"},
"extensionsUsed":["KHR_mesh_quantization","KHR_materials_variants","KHR_materials_pbrSpecularGlossiness"],
"extensionsRequired":["KHR_mesh_quantization"],
"extensions":{"KHR_materials_variants":{"variants":[{"name":"a"},{"name":"b"}]}},
"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0,"scale":[2,2,2],"translation":[0,1,0]}],
"materials":[{"emissiveFactor":[1,1,1]},
{"emissiveFactor":[1,0,0],"extensions":{"KHR_materials_pbrSpecularGlossiness":{"diffuseFactor":[0.8,0.2,0.2,1],
"specularFactor":[0.2,0.2,0.2],"glossinessFactor":0.3}}}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0,
"extensions":{"KHR_materials_variants":{"mappings":[{"material":1,"variants":[1]},{"material":0,"variants":[0]}]}}}]}],
"accessors":[{"bufferView":0,"componentType":5122,"normalized":true,"count":3,"type":"VEC3"}],
"bufferViews":[{"buffer":0,"byteLength":18}],
"buffers":[{"byteLength":20,"uri":"data:application/octet-stream;base64,AAAAAAAA/38AAAAAAAD/fwAAAAA="}]})";

std::vector<std::vector<uint8_t>> seeds() {
    const std::string data = RTPM_TEST_DATA_DIR;
    std::vector<std::vector<uint8_t>> out = {
        readFile(data + "/gltf/handmade.gltf"),
        readFile(data + "/obj/materials.obj"),
        readFile(data + "/obj/bad_index.obj"),
        encodeGlb(buildBuiltinScene("RING")),
        bytesOf(triangle("3", true)),
        bytesOf(triangle("16777216", false)),   // 2^24 without bufferView
        bytesOf(triangle("357913941", false)),  // passed the old 4 GiB check
        bytesOf(triangle("3", true).replace(triangle("3", true).find("data:"), 5, "../../etc/passwd#")),
        bytesOf("mtllib ../../etc/passwd\nmtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        bytesOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf -1 -2 -3\n"),
        bytesOf(kExtensionsTriangle),
        // handmade.gltf and gltf/corpus/glass_on_floor.gltf through gltf-pipeline -d (npm):
        // KHR_draco_mesh_compression, quantized.
        readFile(data + "/gltf/handmade_draco.glb"),
        readFile(data + "/gltf/glass_on_floor_draco.glb"),
    };
    for (const auto& s : out) EXPECT_FALSE(s.empty());
    return out;
}

TEST(SceneLoadFuzz, SeedsKeepTheLoaderProperty) {
    const auto all = seeds();
    for (size_t i = 0; i < all.size(); ++i) EXPECT_EQ(checkSceneLoaders(all[i]), "") << "seed " << i;
    // ctest sets this to seed the libFuzzer corpus.
    if (const char* dir = std::getenv("RTPM_FUZZ_CORPUS_DIR")) {
        std::filesystem::create_directories(dir);
        for (size_t i = 0; i < all.size(); ++i) {
            std::ofstream f(std::filesystem::path(dir) / ("seed_" + std::to_string(i)), std::ios::binary);
            f.write(reinterpret_cast<const char*>(all[i].data()), std::streamsize(all[i].size()));
            ASSERT_TRUE(f.good()) << dir;
        }
    }
}

TEST(SceneLoadFuzz, MutatedSeedsNeverBreakTheLoaders) {
    // Byte and bit flips, insertions, deletions, digit and bracket splats: the cheap half of what
    // libFuzzer does, bounded (a few thousand loads of small files).
    std::mt19937 rng(13);
    const auto base = seeds();
    const uint8_t splat[] = {'0', '9', '-', '[', ']', '{', '}', '"', '/', '.', 0x00, 0xFF};
    for (int i = 0; i < 3000; ++i) {
        // The RING GLB is large: mutate it a tenth as often as the small seeds.
        size_t pick = rng() % base.size();
        if (pick == 3 && rng() % 10 != 0) pick = 0;
        std::vector<uint8_t> b = base[pick];
        const int edits = 1 + int(rng() % 6);
        for (int e = 0; e < edits && !b.empty(); ++e) {
            const size_t at = rng() % b.size();
            switch (rng() % 5) {
                case 0: b[at] = uint8_t(rng()); break;
                case 1: b[at] ^= uint8_t(1u << (rng() % 8)); break;
                case 2: b.insert(b.begin() + std::ptrdiff_t(at), splat[rng() % sizeof splat]); break;
                case 3: b.erase(b.begin() + std::ptrdiff_t(at)); break;
                case 4: b[at] = splat[rng() % sizeof splat]; break;
            }
        }
        ASSERT_EQ(checkSceneLoaders(b), "") << "mutation " << i << " of seed " << pick;
    }
}

}  // namespace
}  // namespace rtpm::testing
