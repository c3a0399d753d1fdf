// Edits are validated once, where they enter (edit script, --animate), with the rules every client
// applies (common/scene/scene.h): what the server accepts, a client accepts; what would break a
// client or Embree never leaves the server. Failures found by hand in issue 13.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include <glm/gtc/matrix_transform.hpp>

#include "client/frame_renderer.h"
#include "common/render/render_job.h"
#include "proto/bridge/bridge.h"
#include "server/animation.h"
#include "server/live_scene.h"
#include "server/script/script_edit.h"
#include "tests/support/test_scenes.h"

namespace rtpm::server {
namespace {

namespace fs = std::filesystem;


// The server-side error for a one-line script applied to floorAndGlassBox(), or "" if accepted.
std::string serverError(const std::string& line) {
    LiveScene live(testscenes::floorAndGlassBox());
    std::vector<proto::SceneEdit> out;
    try {
        for (const ScriptEdit& e : parseEditScript(line, "edits.txt")) live.apply(e, "edits.txt", out);
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

TEST(EditValidation, EditsThatKilledEveryClientAreRefusedAtTheServer) {
    const char* hostile[] = {
        // all-zero and 1e30-scaled transforms passed the start-up check; every client exited 4
        "frame 1 transform 1 matrix 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0",
        "frame 1 transform 1 scale 1e30",
        "frame 1 transform 1 scale 1e-30",
        "frame 1 transform 1 matrix 1e30 0 0 0 0 1e30 0 0 0 0 1e30 0 0 0 0 1",
        "frame 1 transform 1 matrix 1 0 0 0 0 1 0 0 0 0 0 0 0 0 0 1",  // flattens the box
        "frame 1 transform 1 matrix 1 0 0 0.5 0 1 0 0 0 0 1 0 0 0 0 1",  // projective
        "frame 1 transform 1 translate 1e38 0 0",
        // camera eye 1e38 aborted every client inside Embree
        "frame 1 camera eye 1e38 0 0",
        "frame 1 camera eye 0 -3e38 0",
        "frame 1 light 0 position 1e38 1 1",
        "frame 1 light 0 intensity 3e38 0 0",
        "frame 1 material 0 emission 3e38 3e38 3e38",
        "frame 1 material 1 absorption 1e38 0 0",
        "frame 1 material 1 ior 0.5",  // dielectric below 1
        "frame 1 material 0 type dielectric ior 7",
    };
    for (const char* line : hostile) {
        const std::string err = serverError(line);
        EXPECT_FALSE(err.empty()) << line << " was accepted";
        EXPECT_NE(err.find("edits.txt: line 1:"), std::string::npos) << err;
    }
    // Large but sane values still pass: a 100 km scene, a far camera, a bright light.
    for (const char* line : {"frame 1 transform 1 scale 1e5", "frame 1 camera eye 0 0 1e8",
                             "frame 1 light 0 intensity 1e12 1e12 1e12", "frame 1 transform 0 scale 1e-5"})
        EXPECT_EQ(serverError(line), "") << line;
}

// Random edits across magnitudes: whatever the server accepts, a client applies without complaint
// (and its camera converts), so the server never sends what a client must refuse.
TEST(EditValidation, WhatTheServerAcceptsEveryClientAccepts) {
    std::mt19937 rng(1313);
    const float magnitudes[] = {0.0f, 1e-30f, 1e-7f, 1e-3f, 0.5f, 1.0f, 3.0f, 1e5f, 1e8f, 2e9f, 1e20f, 3e38f};
    auto value = [&] {
        float v = magnitudes[rng() % std::size(magnitudes)];
        return rng() % 3 == 0 ? -v : v;
    };
    auto vec = [&] { return std::to_string(value()) + " " + std::to_string(value()) + " " + std::to_string(value()); };
    int accepted = 0, refused = 0;
    for (int i = 0; i < 3000; ++i) {
        std::string line = "frame 1 ";
        switch (rng() % 5) {
            case 0: line += "camera eye " + vec() + (rng() % 2 ? " target " + vec() : ""); break;
            case 1: line += "light 0 position " + vec() + " intensity " + vec(); break;
            case 2: line += "material " + std::to_string(rng() % 2) + " emission " + vec() + " absorption " + vec(); break;
            case 3: line += "transform " + std::to_string(rng() % 2) + " scale " + std::to_string(value()) +
                            " translate " + vec(); break;
            case 4: {
                line += "transform 1 matrix";
                for (int k = 0; k < 16; ++k) line += " " + std::to_string(k % 5 == 0 ? 1.0f : value() * float(rng() % 2));
                break;
            }
        }
        Scene clientScene = testscenes::floorAndGlassBox();
        LiveScene live(testscenes::floorAndGlassBox());
        std::vector<proto::SceneEdit> out;
        try {
            for (const ScriptEdit& e : parseEditScript(line, "x")) live.apply(e, "x", out);
        } catch (const SceneError&) {
            ++refused;
            continue;
        }
        ++accepted;
        for (const proto::SceneEdit& wire : out)
            EXPECT_NO_THROW(client::applyWireEdit(clientScene, wire)) << line;
        EXPECT_NO_THROW(client::toCamera(bridge::toWire(live.camera()))) << line;
    }
    EXPECT_GT(accepted, 100);
    EXPECT_GT(refused, 100);
}

TEST(EditValidation, RenderJobRefusesWhatEmbreeMustNotSee) {
    RenderSettings rs;
    rs.width = 8;
    rs.height = 8;
    rs.interleave = 1;
    RenderJob job(testscenes::floorAndGlassBox(), rs, {0});
    SceneEdit zero;
    zero.kind = SceneEdit::Kind::Transform;
    zero.index = 1;
    zero.transform = Mat4(0.0f);
    EXPECT_THROW(job.applyEdit(zero), SceneError);
    SceneEdit huge = zero;
    huge.transform = glm::scale(Mat4(1.0f), Vec3(1e30f));
    EXPECT_THROW(job.applyEdit(huge), SceneError);
    SceneEdit light;
    light.kind = SceneEdit::Kind::Light;
    light.light = job.scene().lights[0];
    light.light.intensity = Vec3(3e38f);
    EXPECT_THROW(job.applyEdit(light), SceneError);
    EXPECT_EQ(job.scene().instances[1].transform, Mat4(1.0f));  // nothing changed
    // And the client's camera conversion refuses the eye that aborted Embree.
    proto::CameraState far = bridge::toWire(*testscenes::floorAndGlassBox().camera);
    far.position = {1e38f, 0.0f, 0.0f};
    EXPECT_THROW(client::toCamera(far), client::ProtocolViolation);
}

TEST(EditValidation, AnimationStatesBeyondTheRulesAreRefusedAtStartUp) {
    // A light near the edge of the world: --animate light circles it out of bounds.
    Scene s = testscenes::floorAndGlassBox();
    for (Mesh& m : s.meshes)
        for (Vec3& p : m.positions) p *= Vec3(9e8f, 1.0f, 9e8f);
    s.lights[0].position = Vec3(0.0f, 2.0f, 9.9e8f);
    s.camera = Camera::lookAt(Vec3(0, 1e3f, 0), Vec3(0), Vec3(0, 0, 1), 0.8f);
    s.validate("edge");
    EXPECT_THROW(checkAnimation(Animation::Light, s), SceneError);
    // An ordinary scene animates through every state of every preset.
    for (Animation a : {Animation::Orbit, Animation::Light, Animation::Ior, Animation::Object})
        EXPECT_NO_THROW(checkAnimation(a, testscenes::floorAndGlassBox()));
}

long maxRssKb() {
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss;
}

TEST(EditValidation, HugeOrEndlessScriptsAreRefusedBeforeReading) {
    const fs::path dir = fs::temp_directory_path() / ("rtpm_script_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const long before = maxRssKb();
    {
        // 50 MB of valid lines: before, the master took 1 GB for it.
        std::ofstream f(dir / "big.txt");
        const std::string line = "frame 1 camera yfov 0.7\n";
        for (size_t n = 0; n < (50u << 20) / line.size(); ++n) f << line;
    }
    try {
        loadEditScript((dir / "big.txt").string());
        ADD_FAILURE() << "a 50 MB script was read";
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("larger than"), std::string::npos) << e.what();
    }
    EXPECT_LT(maxRssKb() - before, 64 * 1024) << "kB of peak memory grew";
    // Too many edits in a script under the byte limit.
    std::string many;
    for (size_t n = 0; n <= kMaxScriptEdits; ++n) many += "frame 1 camera yfov 0.7\n";
    EXPECT_THROW(parseEditScript(many, "many.txt"), SceneError);
    // A FIFO and /dev/zero: refused at once, never read.
    ASSERT_EQ(::mkfifo((dir / "fifo.txt").c_str(), 0600), 0);
    EXPECT_THROW(loadEditScript((dir / "fifo.txt").string()), SceneError);
    EXPECT_THROW(loadEditScript("/dev/zero"), SceneError);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace rtpm::server
