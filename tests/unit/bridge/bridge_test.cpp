// Round trips of every proto ↔ common conversion (the Settings message carries RenderSettings
// itself, row by row: tests/unit/proto/messages_test.cpp).
#include "proto/bridge/bridge.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/scene/scene_loader.h"

namespace rtpm {
namespace {

TEST(Bridge, FrameModesRoundTripWithTheWiresIds) {
    const FrameMode modes[] = {FrameMode::Interaction, FrameMode::Accumulate, FrameMode::Walkthrough,
                               FrameMode::Converging, FrameMode::Edit};
    const proto::FrameMode wire[] = {proto::FrameMode::Interaction, proto::FrameMode::Accumulate,
                                     proto::FrameMode::Walkthrough, proto::FrameMode::Converging,
                                     proto::FrameMode::Edit};
    for (size_t i = 0; i < 5; ++i) {
        EXPECT_EQ(bridge::toWire(modes[i]), wire[i]);
        EXPECT_EQ(bridge::fromWire(wire[i]), modes[i]);
    }
}

TEST(Bridge, CameraRoundTripIsBitExactAndDegenerateCamerasAreRefused) {
    Camera c;
    c.position = Vec3(0.1f, -2.5f, 3.25f);
    c.forward = glm::normalize(Vec3(0.3f, -0.2f, -1.0f));
    c.up = Vec3(0.0f, 1.0f, 0.0f);
    c.yfov = 0.7f;
    const Camera back = bridge::fromWire(bridge::toWire(c));
    EXPECT_EQ(back.position, c.position);
    EXPECT_EQ(back.forward, c.forward);
    EXPECT_EQ(back.up, c.up);
    EXPECT_EQ(back.yfov, c.yfov);
    proto::CameraState bad = bridge::toWire(c);
    bad.up = bad.forward;
    EXPECT_THROW(bridge::fromWire(bad), std::invalid_argument);
    bad = bridge::toWire(c);
    bad.yfov = 3.5f;
    EXPECT_THROW(bridge::fromWire(bad), std::invalid_argument);
}

TEST(Bridge, EditsRoundTripThroughTheScene) {
    const Scene ring = loadScene("RING");
    ASSERT_FALSE(ring.materials.empty());
    ASSERT_FALSE(ring.instances.empty());
    Scene edited = ring;
    edited.materials[0].baseColor = Vec3(0.25f, 0.5f, 0.75f);
    edited.instances[0].transform[3] = glm::vec4(0.5f, 0.0f, 0.25f, 1.0f);
    // Wire edits taken from the edited scene, read back against the original: the same values.
    auto m = bridge::fromWire(ring, bridge::materialToWire(edited, 0));
    ASSERT_TRUE(m);
    EXPECT_EQ(m->kind, SceneEdit::Kind::Material);
    EXPECT_EQ(m->material.baseColor, edited.materials[0].baseColor);
    EXPECT_EQ(m->material.type, edited.materials[0].type);
    // Every material type crosses as itself (a plastic was sent as a Lambertian before kind 3).
    for (MaterialType type : {MaterialType::Diffuse, MaterialType::Mirror, MaterialType::Dielectric,
                              MaterialType::Plastic}) {
        edited.materials[0].type = type;
        auto k = bridge::fromWire(ring, bridge::materialToWire(edited, 0));
        ASSERT_TRUE(k);
        EXPECT_EQ(k->material.type, type) << materialTypeName(type);
    }
    auto t = bridge::fromWire(ring, bridge::transformToWire(edited, 0));
    ASSERT_TRUE(t);
    EXPECT_EQ(t->transform, edited.instances[0].transform);
    if (!ring.lights.empty()) {
        edited.lights[0].position += Vec3(0.1f);
        auto l = bridge::fromWire(ring, bridge::lightToWire(edited, 0));
        ASSERT_TRUE(l);
        EXPECT_EQ(l->light.position, edited.lights[0].position);
        EXPECT_EQ(l->light.type, ring.lights[0].type);  // not on the wire: kept from the scene
    }
    EXPECT_FALSE(bridge::fromWire(ring, proto::CameraEdit{}));
    proto::MaterialEdit missing;
    missing.index = uint32_t(ring.materials.size());
    EXPECT_THROW(bridge::fromWire(ring, missing), std::invalid_argument);
}

TEST(Bridge, PixelsEncodeFromAndDecodeIntoRadianceBuffersWithoutACopy) {
    std::vector<PixelRadiance> px(37);
    for (size_t i = 0; i < px.size(); ++i) {
        px[i].direct = Vec3(float(i), 0.5f * float(i), 0.25f);
        px[i].caustic = Vec3(i % 3 ? 0.0f : 2.0f, 1e-3f * float(i), 0.0f);
    }
    const proto::EncodedPixels enc =
        proto::encodePixels(bridge::pixelView(std::span<const PixelRadiance>(px)), proto::PixelEncoding::Float32);
    std::vector<PixelRadiance> back(px.size());
    ASSERT_TRUE(proto::decodePixels(enc.encoding, enc.bytes, bridge::pixelView(std::span(back))).ok());
    for (size_t i = 0; i < px.size(); ++i) {
        EXPECT_EQ(back[i].direct, px[i].direct) << i;
        EXPECT_EQ(back[i].caustic, px[i].caustic) << i;
    }
    // The view addresses the caller's memory: the encoder read these very floats.
    EXPECT_EQ(bridge::pixelView(std::span(back)).base, &back[0].direct.x);
}

// The world light crosses the wire as the master loaded it: the same floats, so the client builds
// the same sampling tables and draws the same directions; a bad map is refused as a scene error.
TEST(Bridge, WorldLightRoundTripsBitForBit) {
    proto::Scene m;
    m.builtinName = "ring";
    bridge::environmentToWire(Environment{}, m);
    EXPECT_EQ(m.environment, proto::Scene::Environment::None);
    EXPECT_TRUE(bridge::environmentFromWire(m).empty());

    bridge::environmentToWire(Environment::uniform(Vec3(0.1f, 0.2f, 0.3f)), m);
    EXPECT_EQ(m.environment, proto::Scene::Environment::Uniform);
    EXPECT_EQ(bridge::environmentFromWire(m).uniformRadiance(), Vec3(0.1f, 0.2f, 0.3f));

    Texture map;
    map.width = 8;
    map.height = 4;
    for (int i = 0; i < 96; ++i) map.rgb.push_back(std::exp(0.1f * float(i)) * 1e-3f);
    const Environment sent = Environment::fromMap(map);
    bridge::environmentToWire(sent, m);
    const std::vector<uint8_t> bytes = proto::encode(m);
    const auto decoded = proto::decodeMessage(bytes);
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    const Environment got = bridge::environmentFromWire(std::get<proto::Scene>(decoded.value()));
    ASSERT_EQ(got.texels(), sent.texels());
    for (float u : {0.01f, 0.3f, 0.77f}) {
        const EnvironmentSample a = sent.sample(Vec2(u, 1.0f - u)), b = got.sample(Vec2(u, 1.0f - u));
        EXPECT_EQ(a.direction, b.direction);
        EXPECT_EQ(a.pdf, b.pdf);
    }
    m.environmentHeight = 8;  // not 2:1 (the decoder refuses it first; the bridge still checks)
    EXPECT_THROW(bridge::environmentFromWire(m), SceneError);
}

}  // namespace
}  // namespace rtpm
