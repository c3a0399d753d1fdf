// The property every scene loader must keep on arbitrary bytes, shared by the libFuzzer target
// (scene_load_fuzz.cpp) and the bounded replay test any compiler runs.
#pragma once

#include <cstdint>
#include <exception>
#include <span>
#include <string>
#include <vector>

#include "common/scene/gltf_loader.h"
#include "common/scene/obj_loader.h"
#include "common/scene/scene.h"

namespace rtpm::testing {

/// Budget the fuzzed loads run under: a file that asks for more must be refused, so the
/// fuzzer's RSS limit (2 GiB) catches any allocation made before the budget was consulted.
constexpr uint64_t kFuzzSceneBytes = uint64_t(64) << 20;

/// Loads `bytes` as glTF/GLB and as OBJ text, in memory and without a folder (every external
/// reference must be refused). Returns "" when each load either threw SceneError or returned a
/// scene that passes Scene::validate; otherwise a description of what broke.
inline std::string checkSceneLoaders(std::span<const uint8_t> bytes) {
    SceneInputPolicy policy;
    policy.maxSceneBytes = kFuzzSceneBytes;
    auto check = [&](const char* what, auto&& load) -> std::string {
        try {
            Scene s = load();
            s.validate(what);
        } catch (const SceneError&) {
        } catch (const std::exception& e) {
            return std::string(what) + ": escaped " + typeid(e).name() + ": " + e.what();
        } catch (...) {
            return std::string(what) + ": escaped a non-standard exception";
        }
        return "";
    };
    const std::vector<uint8_t> v(bytes.begin(), bytes.end());
    std::string r = check("glTF", [&] { return loadGltfFromMemory(v, "fuzz.gltf", "", policy); });
    if (!r.empty()) return r;
    return check("OBJ", [&] {
        return loadObjFromMemory(std::string(v.begin(), v.end()), "fuzz.obj", "", policy);
    });
}

}  // namespace rtpm::testing
