// libFuzzer target: the glTF/GLB and OBJ loaders on arbitrary bytes end in SceneError or a valid
// scene, never a crash, a hang or an allocation beyond the scene budget.
#include <cstdio>
#include <cstdlib>

#include "tests/fuzz/scene_load_check.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string violated = rtpm::testing::checkSceneLoaders(std::span(data, size));
    if (!violated.empty()) {
        std::fprintf(stderr, "scene loader property violated: %s\n", violated.c_str());
        std::abort();
    }
    return 0;
}
