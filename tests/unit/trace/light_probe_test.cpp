// directlyLitShare counts the share of the camera's view a punctual light reaches, and a file
// whose lights leave most of its view dark gets the default sky as its world.
#include <gtest/gtest.h>

#include <cmath>

#include "common/scene/environment_loader.h"
#include "common/trace/light_probe.h"
#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

using testscenes::addMaterial;
using testscenes::addMesh;
using testscenes::quad;

/// A 20 m white floor at y = 0 filling the view of a camera 2 m above it looking straight down,
/// lit by a sun travelling along `sunDirection` (none when zero).
Scene floorSeenFromAbove(Vec3 sunDirection) {
    Scene s;
    const uint32_t white = addMaterial(s, MaterialType::Diffuse, Vec3(0.8f));
    addMesh(s, quad(Vec3(0.0f), Vec3(10, 0, 0), Vec3(0, 0, -10), white));
    if (glm::length(sunDirection) > 0.0f) {
        Light sun;
        sun.type = LightType::Directional;
        sun.direction = glm::normalize(sunDirection);
        sun.intensity = Vec3(3.0f);
        s.lights.push_back(sun);
    }
    s.camera = Camera::lookAt(Vec3(0, 2, 0), Vec3(0.0f), Vec3(0, 0, -1), 0.8f);
    return s;
}

TEST(LightProbe, ASunFromAboveLightsTheWholeViewAndAGrazingOneNone) {
    EXPECT_FLOAT_EQ(directlyLitShare(floorSeenFromAbove(Vec3(0.3f, -1.0f, 0.2f))), 1.0f);
    EXPECT_FLOAT_EQ(directlyLitShare(floorSeenFromAbove(Vec3(0.0f, 0.0f, 1.0f))), 0.0f);   // in the floor's plane
    EXPECT_FLOAT_EQ(directlyLitShare(floorSeenFromAbove(Vec3(0.0f, -0.02f, 1.0f))), 0.0f); // 1.1°: grazing
    EXPECT_FLOAT_EQ(directlyLitShare(floorSeenFromAbove(Vec3(0.0f, 1.0f, 0.0f))), 0.0f);   // from below
}

TEST(LightProbe, ASpotLightsItsConeAndABlockerShadowsIt) {
    Scene s = floorSeenFromAbove(Vec3(0.0f));
    Light spot;
    spot.type = LightType::Spot;
    spot.position = Vec3(0, 1, 0);
    spot.direction = Vec3(0, -1, 0);
    spot.innerConeAngle = 0.1f;
    spot.outerConeAngle = 0.2f;  // a disc of radius tan(0.2) ≈ 0.2 m on the floor
    spot.intensity = Vec3(10.0f);
    s.lights.push_back(spot);
    // The view spans 2·2·tan(0.4) ≈ 1.69 m square: the disc is π 0.2² / 1.69² ≈ 4.4 % of it.
    const float share = directlyLitShare(s, 256, 256);
    EXPECT_NEAR(share, kPi * std::pow(std::tan(0.2f), 2.0f) / std::pow(4.0f * std::tan(0.4f), 2.0f), 0.005f);
    // A plate 0.5 m below the spot, wider than the cone there (radius 0.5·tan 0.2 ≈ 0.1 m): the
    // floor's disc is all in its shadow, and the plate is lit on a disc of half the radius, which
    // the camera, 1.5 m above it instead of 2, sees (2 / 1.5)² larger: 0.25 · 1.78 of the share.
    const uint32_t grey = addMaterial(s, MaterialType::Diffuse, Vec3(0.5f));
    addMesh(s, quad(Vec3(0, 0.5f, 0), Vec3(0.15f, 0, 0), Vec3(0, 0, -0.15f), grey));
    EXPECT_NEAR(directlyLitShare(s, 256, 256), 0.25f * (16.0f / 9.0f) * share, 0.1f * share);
}

TEST(LightProbe, AnEmissiveSurfaceInViewShowsItselfAndWhatNoRayHitsIsDark) {
    Scene s = floorSeenFromAbove(Vec3(0.0f));
    s.materials[0].emission = Vec3(1.0f);
    EXPECT_FLOAT_EQ(directlyLitShare(s), 1.0f);
    Scene empty = floorSeenFromAbove(Vec3(0.0f, 0.0f, 1.0f));
    empty.camera = Camera::lookAt(Vec3(0, 2, 0), Vec3(0, 4, 0), Vec3(0, 0, -1), 0.8f);  // looking away
    EXPECT_FLOAT_EQ(directlyLitShare(empty), 0.0f);
    // Raised until the 20 m floor spans half the view's height (and 3/8 of its 4:3 width): the
    // rest is background, dark without a world light, though the sun lights all of the floor.
    Scene far = floorSeenFromAbove(Vec3(0.0f, -1.0f, 0.0f));
    far.camera = Camera::lookAt(Vec3(0, 20.0f / std::tan(0.4f), 0), Vec3(0.0f), Vec3(0, 0, -1), 0.8f);
    EXPECT_NEAR(directlyLitShare(far, 256, 192), 0.5f * (0.5f * 192.0f / 256.0f), 0.01f);
}

TEST(LightProbe, AFileWhoseLightsMissTheViewGetsTheDefaultSkyUnlessItSaysOtherwise) {
    const Vec3 grazing(0.0f, 0.0f, 1.0f);
    Scene file = floorSeenFromAbove(grazing);
    ASSERT_TRUE(addSkyWhereLightsMissTheView(file, "board.gltf", {}));
    EXPECT_FALSE(file.environment.empty());
    EXPECT_EQ(file.environment.uniformRadiance(), defaultSky().uniformRadiance());
    ASSERT_FALSE(file.warnings.empty());
    EXPECT_NE(file.warnings.back().find("reach only 0.0 % of what the camera sees"), std::string::npos)
        << file.warnings.back();

    Scene lit = floorSeenFromAbove(Vec3(0.0f, -1.0f, 0.0f));
    EXPECT_FALSE(addSkyWhereLightsMissTheView(lit, "board.gltf", {}));
    EXPECT_TRUE(lit.environment.empty());

    Scene refused = floorSeenFromAbove(grazing);
    SceneOverrides noDefault;
    noDefault.defaultLight = false;  // --no-default-light
    EXPECT_FALSE(addSkyWhereLightsMissTheView(refused, "board.gltf", noDefault));
    Scene black = floorSeenFromAbove(grazing);
    SceneOverrides blackWorld;
    blackWorld.environment = EnvironmentOverride{};  // --env-color 0: a world of the user's own
    EXPECT_FALSE(addSkyWhereLightsMissTheView(black, "board.gltf", blackWorld));
    Scene builtin = floorSeenFromAbove(grazing);
    EXPECT_FALSE(addSkyWhereLightsMissTheView(builtin, "ring", {}));
    Scene exported = floorSeenFromAbove(grazing);
    exported.worldless = true;  // our own export of a scene without a world
    EXPECT_FALSE(addSkyWhereLightsMissTheView(exported, "board.glb", {}));
    for (const Scene* s : {&refused, &black, &builtin, &exported}) EXPECT_TRUE(s->environment.empty());
}

}  // namespace
}  // namespace rtpm
