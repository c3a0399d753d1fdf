// Tests of the OBJ/MTL importer: the MTL material mapping, normals, overrides and malformed files.
#include "common/scene/obj_loader.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "common/scene/scene_loader.h"

namespace rtpm {
namespace {

const std::string kObjDir = std::string(RTPM_TEST_DATA_DIR) + "/obj";

const Material& materialNamed(const Scene& s, const std::string& name) {
    for (const Material& m : s.materials)
        if (m.name == name) return m;
    throw std::runtime_error("no material " + name);
}

TEST(ObjLoader, MtlMapsToMirrorGlassDiffuseAndEmitter) {
    Scene s = loadScene(kObjDir + "/materials.obj");
    EXPECT_EQ(s.triangleCount(), 8u);
    const Material& chrome = materialNamed(s, "chrome");
    EXPECT_EQ(chrome.type, MaterialType::Mirror);
    EXPECT_NEAR(chrome.baseColor.y, 0.85f, 1e-6f);
    const Material& glass = materialNamed(s, "glass");
    EXPECT_EQ(glass.type, MaterialType::Dielectric);
    EXPECT_NEAR(glass.ior, 1.45f, 1e-6f);
    // Tf = transmittance through 1 m: σ = −ln(0.5) in red and green, none in blue.
    EXPECT_NEAR(glass.absorption.x, -std::log(0.5f), 1e-5f);
    EXPECT_NEAR(glass.absorption.z, 0.0f, 1e-6f);
    const Material& clay = materialNamed(s, "clay");
    EXPECT_EQ(clay.type, MaterialType::Diffuse);
    EXPECT_NEAR(clay.baseColor.z, 0.6f, 1e-6f);
    const Material& lamp = materialNamed(s, "lamp");
    EXPECT_NEAR(lamp.emission.x, 10.0f, 1e-6f);
    // No camera in OBJ: loadScene supplies one looking at the scene.
    ASSERT_TRUE(s.camera);
    EXPECT_GT(glm::dot(s.bounds().centre() - s.camera->position, s.camera->forward), 0.0f);
    // Each face is one mesh (one per object and material) with unit normals along its winding.
    for (const Mesh& m : s.meshes) {
        ASSERT_EQ(m.normals.size(), m.positions.size());
        Vec3 g = glm::cross(m.positions[m.indices[1]] - m.positions[m.indices[0]],
                            m.positions[m.indices[2]] - m.positions[m.indices[0]]);
        for (Vec3 n : m.normals) {
            EXPECT_NEAR(glm::length(n), 1.0f, 1e-5f);
            EXPECT_GT(glm::dot(n, g), 0.0f) << m.name;
        }
    }
}

TEST(ObjLoader, FaceReferencingMissingVertexNamesTheLine) {
    const std::string path = kObjDir + "/bad_index.obj";
    try {
        loadObj(path);
        ADD_FAILURE() << "bad_index.obj loaded";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.file, path);
        EXPECT_EQ(e.element, "line 6");
        EXPECT_NE(std::string(e.what()).find("99"), std::string::npos) << e.what();
    }
}

TEST(ObjLoader, SceneWithoutLightGetsTheDefaultLightOrAnOverride) {
    const std::string path = kObjDir + "/no_light.obj";
    SceneOverrides strict;
    strict.defaultLight = false;  // --no-default-light
    try {
        loadScene(path, strict);
        ADD_FAILURE() << "no_light.obj loaded without a light";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.file, path);
        EXPECT_EQ(e.element, "lights");
    }
    // By default: the default spot light and the key light, and a warning naming the file.
    Scene d = loadScene(path);
    ASSERT_EQ(d.lights.size(), 2u);
    EXPECT_EQ(d.lights[0].type, LightType::Spot);
    EXPECT_EQ(d.lights[1].type, LightType::Spot);
    ASSERT_FALSE(d.warnings.empty());
    EXPECT_NE(d.warnings.back().find(path), std::string::npos) << d.warnings.back();
    SceneOverrides o;
    o.light = PointLightOverride{Vec3(0, 2, 1), Vec3(3.0f)};
    o.camera = CameraOverride{Vec3(0, 0, 4), Vec3(0), Vec3(0, 1, 0), 0.5f};
    Scene s = loadScene(path, o);
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].position, Vec3(0, 2, 1));
    EXPECT_EQ(s.camera->position, Vec3(0, 0, 4));
    EXPECT_NEAR(s.camera->yfov, 0.5f, 1e-6f);
}

TEST(ObjLoader, MalformedLinesAreErrorsWithTheirLine) {
    const auto dir = std::filesystem::temp_directory_path() / ("rtpm_obj_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    struct Case {
        const char* text;
        const char* element;
    } cases[] = {
        {"v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n", "line 3"},
        {"v 0 0 0\nv 1 0 zero\nv 0 1 0\nf 1 2 3\n", "line 2"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", "line 4"},  // no vt defined
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "line 4"},
        // Beyond a long (strtol saturates; negating LONG_MIN was undefined): a bad index.
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -27777777777777777777777777 -3\n", "line 4"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n", "line 4"},
        {"", "file"},
        {"# only a comment\n", "faces"},
        {"\x01\x02garbage\0bytes", "file"},
    };
    for (const Case& c : cases) {
        const std::string path = (dir / "case.obj").string();
        std::ofstream(path, std::ios::binary) << std::string(c.text, c.text + std::strlen(c.text) +
                                                                  (c.text[0] == '\x01' ? 7 : 0));
        try {
            loadObj(path);
            ADD_FAILURE() << "loaded: " << c.text;
        } catch (const SceneError& e) {
            EXPECT_EQ(e.element, c.element) << e.what();
        }
    }
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rtpm
