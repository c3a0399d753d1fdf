// Tests of the built-in scenes: sizes in the paper's range, lights, cameras, winding, watertightness.
#include "common/scene/builtin_scenes.h"

#include <gtest/gtest.h>

#include <map>
#include <tuple>

#include "common/scene/scene_loader.h"

namespace rtpm {
namespace {

struct Range {
    size_t lo, hi;
};

const std::map<std::string, Range> kTriangleRanges = {
    {"RING", {800, 1500}},        // paper: ≈1k
    {"GLASS", {15000, 30000}},    // paper: ≈20k
    {"EGG", {3000, 6000}},        // paper: ≈4k
    {"HEADLIGHT", {120000, 200000}},  // paper: ≈150k
    {"CORNELL", {1000, 100000}},
};

bool emits(const Scene& s) {
    for (const Instance& i : s.instances)
        if (s.materials[s.meshes[i.mesh].material].isEmissive()) return true;
    return false;
}

TEST(BuiltinScenes, EveryNameLoadsValidatesAndShowsACaustic) {
    for (const std::string& name : builtinSceneNames()) {
        SCOPED_TRACE(name);
        Scene s = loadScene(name);
        s.validate(name);
        const Range r = kTriangleRanges.at(name);
        EXPECT_GE(s.triangleCount(), r.lo);
        EXPECT_LE(s.triangleCount(), r.hi);
        EXPECT_TRUE(s.camera.has_value());
        EXPECT_TRUE(!s.lights.empty() || emits(s));
        bool specular = false;
        for (const Instance& i : s.instances) specular |= s.materials[s.meshes[i.mesh].material].isSpecular();
        EXPECT_TRUE(specular);
        EXPECT_EQ(s.instances.size(), s.meshes.size());
        for (const Mesh& m : s.meshes) EXPECT_EQ(m.normals.size(), m.positions.size()) << m.name;
        // The camera looks at the scene: the bounds' centre is in front of it.
        Vec3 toCentre = s.bounds().centre() - s.camera->position;
        EXPECT_GT(glm::dot(toCentre, s.camera->forward), 0.0f);
    }
}

TEST(BuiltinScenes, NamesAreCaseInsensitive) {
    EXPECT_EQ(loadScene("ring").triangleCount(), loadScene("RING").triangleCount());
    EXPECT_EQ(loadScene("Cornell").triangleCount(), loadScene("CORNELL").triangleCount());
    EXPECT_THROW(loadScene("NOSUCHSCENE"), SceneError);
}

// Edges keyed by vertex positions (bands of a lathe duplicate the positions where they meet).
using Key = std::tuple<float, float, float>;
Key key(Vec3 p) { return {p.x, p.y, p.z}; }

// Closed and consistently wound: every directed edge appears once and its reverse once.
void expectWatertight(const Mesh& m) {
    std::map<std::pair<Key, Key>, int> directed;
    for (size_t t = 0; t < m.indices.size(); t += 3)
        for (int e = 0; e < 3; ++e) {
            Vec3 a = m.positions[m.indices[t + e]], b = m.positions[m.indices[t + (e + 1) % 3]];
            if (key(a) == key(b)) continue;  // degenerate edge at a pole
            directed[{key(a), key(b)}]++;
        }
    size_t bad = 0;
    for (const auto& [edge, n] : directed) {
        auto rev = directed.find({edge.second, edge.first});
        if (n != 1 || rev == directed.end() || rev->second != 1) ++bad;
    }
    EXPECT_EQ(bad, 0u) << m.name;
}

// Signed volume of a closed mesh: positive when the geometric normals point outwards.
double signedVolume(const Mesh& m) {
    double v = 0.0;
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        glm::dvec3 a(m.positions[m.indices[t]]), b(m.positions[m.indices[t + 1]]), c(m.positions[m.indices[t + 2]]);
        v += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    return v;
}

// Shading normals agree with the geometric normal of every non-degenerate triangle.
void expectNormalsMatchWinding(const Mesh& m) {
    size_t bad = 0;
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        Vec3 a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]], c = m.positions[m.indices[t + 2]];
        Vec3 g = glm::cross(b - a, c - a);
        if (glm::length(g) < 1e-14f) continue;
        for (int k = 0; k < 3; ++k)
            if (glm::dot(g, m.normals[m.indices[t + k]]) <= 0.0f) ++bad;
    }
    EXPECT_EQ(bad, 0u) << m.name;
}

TEST(BuiltinScenes, ClosedSpecularSolidsAreWatertightAndWoundOutwards) {
    for (const std::string& name : builtinSceneNames()) {
        Scene s = buildBuiltinScene(name);
        for (const Mesh& m : s.meshes) {
            SCOPED_TRACE(name + " / " + m.name);
            expectNormalsMatchWinding(m);
            const Material& mat = s.materials[m.material];
            if (mat.type == MaterialType::Dielectric || m.name == "ring" || m.name == "mirror sphere") {
                expectWatertight(m);
                // The bulb is a shell (outer minus inner): still positive.
                EXPECT_GT(signedVolume(m), 0.0);
            }
        }
    }
}

TEST(BuiltinScenes, HeadlightReflectorFacesItsFocusAndFilamentSitsThere) {
    Scene s = buildHeadlightScene();
    const Mesh* reflector = nullptr;
    const Mesh* filament = nullptr;
    for (const Mesh& m : s.meshes) {
        if (m.name == "reflector") reflector = &m;
        if (m.name == "filament") filament = &m;
    }
    ASSERT_TRUE(reflector && filament);
    EXPECT_EQ(s.materials[reflector->material].type, MaterialType::Mirror);
    EXPECT_TRUE(s.materials[filament->material].isEmissive());
    for (size_t t = 0; t < reflector->indices.size(); t += 3) {
        Vec3 a = reflector->positions[reflector->indices[t]], b = reflector->positions[reflector->indices[t + 1]],
             c = reflector->positions[reflector->indices[t + 2]];
        Vec3 g = glm::cross(b - a, c - a);
        ASSERT_GT(glm::dot(g, Vec3(0.0f) - (a + b + c) / 3.0f), 0.0f);
        // Paraboloid about +Z with focus at the origin: distance to focus = z + 2f.
        EXPECT_NEAR(glm::length(a), a.z + 0.05f, 1e-5f);
    }
    Bounds fb;
    for (Vec3 p : filament->positions) fb.extend(p);
    EXPECT_LT(glm::length(fb.centre()), 1e-6f);
}

TEST(BuiltinScenes, RingLightIsLowBesideTheRing) {
    Scene s = buildRingScene();
    // The nephroid needs light grazing into the ring: an emitter below 30° elevation.
    for (const Instance& i : s.instances) {
        const Mesh& m = s.meshes[i.mesh];
        if (!s.materials[m.material].isEmissive()) continue;
        Vec3 c(0.0f);
        for (Vec3 p : m.positions) c += p / float(m.positions.size());
        float elevation = std::atan2(c.y, glm::length(Vec2(c.x, c.z)));
        EXPECT_LT(elevation, 0.5f);
        EXPECT_GT(elevation, 0.05f);
    }
}

}  // namespace
}  // namespace rtpm
