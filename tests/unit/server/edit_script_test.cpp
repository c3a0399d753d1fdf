// Edit scripts: grammar, errors naming the line, application to the live scene, animate presets.
#include "server/animation.h"
#include "server/live_scene.h"
#include "server/script/script_edit.h"
#include "tests/support/test_scenes.h"

#include <gtest/gtest.h>

#include "common/scene/scene_loader.h"

namespace rtpm::server {
namespace {


std::string errorOf(const std::string& text) {
    try {
        parseEditScript(text, "edits.txt");
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

TEST(EditScript, ParsesEveryKindAndSortsByFrame) {
    auto edits = parseEditScript(
        "# a comment\n"
        "frame 5 light 0 position 1 2 3 intensity 4 4 4\n"
        "\n"
        "frame 2 camera eye 0 1 2 target 0 0 0 yfov 0.5  # trailing comment\n"
        "frame 5 material 1 type mirror color 0.5 0.5 0.5 ior 1.3\n"
        "frame 7 transform 1 translate 0 1 0 rotate 0 1 0 90 scale 2\n",
        "edits.txt");
    ASSERT_EQ(edits.size(), 4u);
    EXPECT_EQ(edits[0].frame, 2u);
    EXPECT_EQ(edits[0].kind, ScriptEdit::Kind::Camera);
    EXPECT_EQ(edits[0].line, 4);
    EXPECT_FLOAT_EQ(*edits[0].camera.yfov, 0.5f);
    EXPECT_EQ(edits[1].kind, ScriptEdit::Kind::Light);
    EXPECT_EQ(*edits[1].light.position, Vec3(1, 2, 3));
    EXPECT_FALSE(edits[1].light.direction.has_value());
    EXPECT_EQ(edits[2].kind, ScriptEdit::Kind::Material);
    EXPECT_EQ(*edits[2].material.type, MaterialType::Mirror);
    EXPECT_EQ(edits[3].kind, ScriptEdit::Kind::Transform);
    EXPECT_FLOAT_EQ(edits[3].transform.rotate->w, 90.0f);
}

TEST(EditScript, SettingsLinesParseAndValidate) {
    auto e = parseEditScript("frame 4 settings M 2 F 5 k 32 P 1000 tree grid\n", "s.txt");
    ASSERT_EQ(e.size(), 1u);
    EXPECT_EQ(e[0].kind, ScriptEdit::Kind::Settings);
    EXPECT_EQ(*e[0].knob(Knob::Interleave), 2);
    EXPECT_EQ(*e[0].knob(Knob::Filter), 5);
    EXPECT_EQ(*e[0].knob(Knob::K), 32);
    EXPECT_EQ(*e[0].knob(Knob::Photons), 1000);
    EXPECT_EQ(*e[0].knob(Knob::Tree), double(PhotonTree::UniformGrid));
    RenderSettings rs;
    applySettingsEdit(e[0], "s.txt", rs);
    EXPECT_EQ(rs.interleave, 2);
    EXPECT_EQ(rs.photons.k, 32u);
    // k = 0 is refused and leaves the settings as they were.
    auto bad = parseEditScript("frame 1 settings k 0\n", "s.txt");
    EXPECT_THROW(applySettingsEdit(bad[0], "s.txt", rs), SceneError);
    EXPECT_EQ(rs.photons.k, 32u);
    EXPECT_THROW(parseEditScript("frame 1 settings tree oak\n", "s.txt"), SceneError);
    // P has one ceiling (its knob row): 5e7 passes, one more is refused without wrapping.
    auto most = parseEditScript("frame 1 settings P 50000000\n", "s.txt");
    applySettingsEdit(most[0], "s.txt", rs);
    EXPECT_EQ(rs.photons.photonsPerBatch, 50'000'000u);
    auto over = parseEditScript("frame 1 settings P 4294967297 k 2.5\n", "s.txt");
    EXPECT_THROW(applySettingsEdit(over[0], "s.txt", rs), SceneError);
    EXPECT_EQ(rs.photons.photonsPerBatch, 50'000'000u);
    // The gather radius is a live knob too.
    auto radius = parseEditScript("frame 2 settings rmax 0.25\n", "s.txt");
    applySettingsEdit(radius[0], "s.txt", rs);
    EXPECT_FLOAT_EQ(rs.photons.rMax, 0.25f);
    EXPECT_EQ(formatScriptEdit(radius[0]), "frame 2 settings rmax 0.25");
    // So is the progressive estimator's confidence width, and P's floor is the flag's.
    auto gamma = parseEditScript("frame 3 settings confidence 0.75\n", "s.txt");
    applySettingsEdit(gamma[0], "s.txt", rs);
    EXPECT_FLOAT_EQ(rs.photons.progressiveGamma, 0.75f);
    auto none = parseEditScript("frame 4 settings P 0\n", "s.txt");
    EXPECT_THROW(applySettingsEdit(none[0], "s.txt", rs), SceneError);
}

TEST(EditScript, TheEstimatorIsASetting) {
    auto e = parseEditScript("frame 9 settings estimator knn\n", "s.txt");
    ASSERT_EQ(e.size(), 1u);
    ASSERT_TRUE(e[0].knob(Knob::Estimator));
    EXPECT_EQ(*e[0].knob(Knob::Estimator), double(CausticEstimatorKind::Knn));
    RenderSettings rs;
    ASSERT_EQ(rs.photons.estimator, CausticEstimatorKind::Progressive);
    applySettingsEdit(e[0], "s.txt", rs);
    EXPECT_EQ(rs.photons.estimator, CausticEstimatorKind::Knn);
    EXPECT_EQ(formatScriptEdit(e[0]), "frame 9 settings estimator knn");
    EXPECT_NE(errorOf("frame 1 settings estimator sppm").find("unknown estimator 'sppm' (expected progressive|knn)"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 settings estimator knn estimator knn").find("estimator"), std::string::npos);
}

TEST(EditScript, FormattedEditsParseBackToTheSameEdit) {
    const std::string text =
        "frame 3 camera eye 0.1 0.2 0.3 target 1 2 3 yfov 0.7\n"
        "frame 4 light 0 position 1.25 -2 3.0000001 intensity 10 20 30\n"
        "frame 5 material 1 type dielectric color 0.5 0.25 1 ior 1.33333 absorption 0.1 0 0 emission 0 0 0\n"
        "frame 6 transform 0 translate 0.1 0 -0.2 rotate 0 1 0 45 scale 2\n"
        "frame 7 settings M 4 F 0 k 16 P 12345 rmax 0.0375 tree median estimator knn\n"
        "frame 8 material 0 type plastic color 0.8 0.1 0.1\n";
    const auto edits = parseEditScript(text, "a.txt");
    std::string formatted;
    for (const ScriptEdit& e : edits) formatted += formatScriptEdit(e) + "\n";
    const auto again = parseEditScript(formatted, "b.txt");
    ASSERT_EQ(again.size(), edits.size());
    for (size_t i = 0; i < edits.size(); ++i) {
        EXPECT_EQ(formatScriptEdit(again[i]), formatScriptEdit(edits[i]));
        EXPECT_EQ(again[i].camera.eye, edits[i].camera.eye);
        EXPECT_EQ(again[i].light.position, edits[i].light.position);
        EXPECT_EQ(again[i].material.ior, edits[i].material.ior);
        EXPECT_EQ(again[i].transform.rotate, edits[i].transform.rotate);
        EXPECT_EQ(again[i].settings, edits[i].settings);
    }
}

TEST(EditScript, MalformedLinesNameTheLine) {
    EXPECT_NE(errorOf("frame 1 camera yfov 0.5\nframe x camera yfov 1\n").find("line 2"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 lamp 0 position 1 2 3").find("unknown edit 'lamp'"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 light 0 position 1 2").find("line 1"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 light 0 position 1 2 nan").find("finite"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 light 0").find("at least one keyword"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 light 0 colour 1 1 1").find("unknown keyword 'colour'"), std::string::npos);
    EXPECT_NE(errorOf("frame -1 camera yfov 1").find("non-negative integer"), std::string::npos);
    EXPECT_NE(errorOf("camera yfov 1").find("must start with 'frame"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 camera yfov 1 yfov 2").find("given twice"), std::string::npos);
    EXPECT_NE(errorOf("frame 1 transform 0 matrix 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 scale 2").find("cannot be combined"),
              std::string::npos);
    EXPECT_NE(errorOf("frame 1 material 0 type glass").find("unknown material type"), std::string::npos);
}

TEST(EditScript, AppliedEditsChangeOnlyWhatTheyMentionAndEmitProtocolEdits) {
    LiveScene live(testscenes::floorAndGlassBox());
    std::vector<proto::SceneEdit> out;
    for (const ScriptEdit& e : parseEditScript("frame 1 light 0 intensity 2 3 4\n"
                                               "frame 1 material 1 ior 1.33\n"
                                               "frame 1 transform 1 translate 0 1 0\n",
                                               "s"))
        live.apply(e, "s", out);
    ASSERT_EQ(out.size(), 3u);
    auto& l = std::get<proto::LightEdit>(out[0]);
    EXPECT_EQ(l.position, (proto::Vec3f{0, 2, 0}));
    EXPECT_EQ(l.intensity, (proto::Vec3f{2, 3, 4}));
    auto& m = std::get<proto::MaterialEdit>(out[1]);
    EXPECT_EQ(m.kind, proto::MaterialKind::Dielectric);
    EXPECT_FLOAT_EQ(m.ior, 1.33f);
    auto& t = std::get<proto::TransformEdit>(out[2]);
    EXPECT_FLOAT_EQ(t.matrix[13], 1.0f);  // column 3, row 1: y translation
    EXPECT_FLOAT_EQ(live.scene().instances[1].transform[3][1], 1.0f);
    // Transforms are absolute w.r.t. the loaded pose: applying it twice does not stack.
    live.apply(parseEditScript("frame 2 transform 1 translate 0 1 0", "s")[0], "s", out);
    EXPECT_FLOAT_EQ(live.scene().instances[1].transform[3][1], 1.0f);
}

TEST(EditScript, EditsThatDoNotFitTheSceneNameTheLineAndChangeNothing) {
    LiveScene live(testscenes::floorAndGlassBox());
    std::vector<proto::SceneEdit> out;
    auto bad = [&](const std::string& text, const std::string& needle) {
        try {
            live.apply(parseEditScript(text, "s")[0], "s", out);
            ADD_FAILURE() << text << " was accepted";
        } catch (const SceneError& e) {
            EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("line 1"), std::string::npos) << e.what();
        }
    };
    bad("frame 1 light 3 position 0 0 0", "light 3 does not exist");
    bad("frame 1 material 9 ior 1.2", "material 9 does not exist");
    bad("frame 1 transform 5 scale 2", "instance 5 does not exist");
    bad("frame 1 material 0 color 2 0 0", "[0, 1]");
    bad("frame 1 material 0 ior 0", "ior must be > 0");
    bad("frame 1 light 0 direction 0 0 0", "direction is zero");
    bad("frame 1 light 0 intensity -1 0 0", ">= 0");
    EXPECT_TRUE(out.empty());
    EXPECT_EQ(live.scene().materials[0].baseColor, testscenes::floorAndGlassBox().materials[0].baseColor);
}

TEST(EditScript, CameraEditsNeverProduceSceneEdits) {
    LiveScene live(testscenes::floorAndGlassBox());
    std::vector<proto::SceneEdit> out;
    live.apply(parseEditScript("frame 1 camera eye 0 2 4 target 0 0 0", "s")[0], "s", out);
    EXPECT_TRUE(out.empty());
    EXPECT_EQ(live.camera().position, Vec3(0, 2, 4));
    EXPECT_NEAR(glm::length(live.camera().forward), 1.0f, 1e-6f);
}

TEST(EditScript, CompactedEditsKeepTheLatestPerTarget) {
    LiveScene live(testscenes::floorAndGlassBox());
    std::vector<proto::SceneEdit> out;
    for (const char* line : {"frame 1 light 0 position 1 1 1", "frame 2 material 1 ior 1.2",
                             "frame 3 light 0 position 2 2 2"})
        live.apply(parseEditScript(line, "s")[0], "s", out);
    EXPECT_EQ(live.version(), 1u);  // applied, not yet sent
    for (const auto& e : out) live.record(e);
    EXPECT_EQ(live.version(), 4u);  // every edit sent counts, compacted or not
    ASSERT_EQ(live.compactedEdits().size(), 2u);
    EXPECT_EQ(std::get<proto::LightEdit>(live.compactedEdits()[0]).position, (proto::Vec3f{2, 2, 2}));
}

TEST(Animate, PresetsEditWhatTheyPromise) {
    Scene s = testscenes::floorAndGlassBox();
    for (Animation a : {Animation::Orbit, Animation::Light, Animation::Ior, Animation::Object})
        EXPECT_NO_THROW(checkAnimation(a, s));
    LiveScene live(s);
    std::vector<proto::SceneEdit> out;
    animate(Animation::Orbit, 0, live, out);
    EXPECT_EQ(live.camera().position, s.camera->position) << "frame 0 is the loaded scene";
    animate(Animation::Orbit, 30, live, out);
    EXPECT_TRUE(out.empty()) << "orbit moves the camera only";
    EXPECT_GT(glm::length(live.camera().position - s.camera->position), 0.1f);
    animate(Animation::Light, 10, live, out);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_TRUE(std::holds_alternative<proto::LightEdit>(out[0]));
    animate(Animation::Ior, 15, live, out);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_NEAR(std::get<proto::MaterialEdit>(out[1]).ior, 1.7f, 1e-4f);
    animate(Animation::Object, 30, live, out);
    ASSERT_EQ(out.size(), 3u);
    EXPECT_EQ(std::get<proto::TransformEdit>(out[2]).instance, 1u);
}

TEST(Animate, ScenesWithoutTheAnimatedThingAreRefusedClearly) {
    Scene s = testscenes::floorAndGlassBox();
    s.materials[1].type = MaterialType::Diffuse;
    s.lights.clear();
    EXPECT_THROW(checkAnimation(Animation::Ior, s), std::invalid_argument);
    EXPECT_THROW(checkAnimation(Animation::Object, s), std::invalid_argument);
    EXPECT_THROW(checkAnimation(Animation::Light, s), std::invalid_argument);
    EXPECT_FALSE(parseAnimation("spin").has_value());
    EXPECT_EQ(parseAnimation("orbit"), Animation::Orbit);
}

TEST(Animate, WorksOnEveryBuiltinSceneThatHasTheThing) {
    for (const std::string& name : builtinSceneNames()) {
        Scene s = loadScene(name);
        LiveScene live(s);
        std::vector<proto::SceneEdit> out;
        for (Animation a : {Animation::Orbit, Animation::Light, Animation::Ior, Animation::Object}) {
            try {
                checkAnimation(a, s);
            } catch (const std::invalid_argument&) {
                continue;
            }
            animate(a, 7, live, out);
        }
        // Every emitted edit survives the protocol's own validation.
        for (const auto& e : out) {
            auto bytes = proto::encode(proto::Edit{1, e});
            EXPECT_TRUE(proto::decodeMessage(bytes).ok()) << name;
        }
    }
}

}  // namespace
}  // namespace rtpm::server
