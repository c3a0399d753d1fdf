// rtpm-client as a real process against a scripted fake server: handshake, pipelined frames
// equal to a local RenderJob, edits at epochs, validation of bad server data, exit codes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <numeric>

#include "client/frame_renderer.h"
#include "client/worker.h"
#include "proto/auth.h"
#include "tests/support/cluster_util.h"
#include "common/render/render_job.h"
#include "common/scene/scene_loader.h"

namespace rtpm::test {
namespace {

using namespace std::chrono_literals;
using client::kExitEvicted;
using client::kExitOk;
using client::kExitProtocolError;
using client::kExitRejected;
using client::kExitServerGone;
using client::kExitStartup;

proto::Settings smallSettings() {
    proto::Settings s;
    s.render.width = 40;
    s.render.height = 30;
    s.render.interleave = 2;
    s.render.filter = 2;
    s.render.photons.photonsPerBatch = 400;
    s.render.photons.k = 20;
    s.encoding = proto::PixelEncoding::Float32;
    return s;
}

proto::CameraState ringCamera() {
    const Camera c = *loadScene("RING").camera;
    proto::CameraState w;
    w.position = {c.position.x, c.position.y, c.position.z};
    w.forward = {c.forward.x, c.forward.y, c.forward.z};
    w.up = {c.up.x, c.up.y, c.up.z};
    w.yfov = c.yfov;
    return w;
}

proto::Scene ringScene() {
    proto::Scene s;
    s.sceneVersion = 1;
    s.builtinName = "ring";
    return s;
}

proto::FrameBegin frameBegin(uint64_t frame, uint32_t epoch, uint32_t version, std::vector<uint32_t> sets,
                             proto::FrameMode mode) {
    proto::FrameBegin fb;
    fb.frame = frame;
    fb.epoch = epoch;
    fb.sceneVersion = version;
    fb.camera = ringCamera();
    fb.mode = mode;
    fb.sets = std::move(sets);
    return fb;
}

/// A fake master: listens, starts rtpm-client against itself, accepts its connection.
struct FakeServer {
    TempDir dir;
    Listener listener;
    std::unique_ptr<Child> client;
    Socket peer;

    /// `extra` flags are added; without a --rejoin-timeout among them it is 0 (most tests check
    /// how one session ends).
    void start(const std::string& token = "s3cret", const std::vector<std::string>& extra = {}) {
        std::vector<std::string> argv{binaryPath("client/rtpm-client"), "--server",
                                      "127.0.0.1:" + std::to_string(listener.port()), "--token", token, "--threads",
                                      "2", "--connect-timeout", "20", "--name", "fake-test"};
        if (std::find(extra.begin(), extra.end(), "--rejoin-timeout") == extra.end())
            argv.insert(argv.end(), {"--rejoin-timeout", "0"});
        argv.insert(argv.end(), extra.begin(), extra.end());
        client = std::make_unique<Child>(argv, dir.file("client"));
        peer = listener.accept(20s);
        ASSERT_TRUE(peer.valid()) << client->logs();
    }

    template <class T>
    T expect(std::chrono::milliseconds timeout = 30s) {
        proto::Message m;
        Socket::Got g = peer.receive(m, timeout);
        if (g != Socket::Got::Message) {
            ADD_FAILURE() << "expected a message, got " << int(g) << "\n" << client->logs();
            return T{};
        }
        if (!std::holds_alternative<T>(m)) {
            ADD_FAILURE() << "unexpected message type " << int(proto::typeOf(m)) << "\n" << client->logs();
            return T{};
        }
        return std::get<T>(std::move(m));
    }

    /// Hello checked, Welcome sent.
    void handshake(std::vector<uint32_t> sets) { handshakeOn(peer, std::move(sets)); }
    /// The same on another connection of the client (a rejoin).
    void handshakeOn(Socket& s, std::vector<uint32_t> sets) {
        proto::Message m;
        ASSERT_EQ(s.receive(m, 30s), Socket::Got::Message) << client->logs();
        ASSERT_TRUE(std::holds_alternative<proto::Hello>(m)) << client->logs();
        const proto::Hello hello = std::get<proto::Hello>(m);
        EXPECT_EQ(hello.protocolVersion, proto::kProtocolVersion);
        EXPECT_EQ(hello.cores, 2u);
        EXPECT_EQ(hello.clientName, "fake-test");
        const proto::Nonce nonce = proto::makeNonce();
        ASSERT_TRUE(s.send(proto::Challenge{nonce}));
        ASSERT_EQ(s.receive(m, 30s), Socket::Got::Message) << client->logs();
        ASSERT_TRUE(std::holds_alternative<proto::Auth>(m)) << client->logs();
        EXPECT_TRUE(proto::macEquals(std::get<proto::Auth>(m).mac, proto::authMac("s3cret", nonce, hello)));
        ASSERT_TRUE(s.send(proto::Welcome{3, std::move(sets)}));
    }

    ExitStatus exitStatus(std::chrono::milliseconds timeout = 20s) {
        auto st = client->wait(timeout);
        if (!st) {
            ADD_FAILURE() << "client still running\n" << client->logs();
            return {};
        }
        return *st;
    }
};

std::vector<proto::PixelPair> decode(const proto::FrameData& d) {
    std::vector<proto::PixelPair> px(d.pixelCount);
    EXPECT_TRUE(proto::decodePixels(d.encoding, d.pixels, px).ok());
    return px;
}

/// Bitwise equality of a FrameData payload with a RenderJob's pixels of that set.
void expectSamePixels(const proto::FrameData& d, const std::vector<SetPixels>& ref) {
    const SetPixels* sp = nullptr;
    for (const SetPixels& s : ref)
        if (uint32_t(s.set) == d.set) sp = &s;
    ASSERT_NE(sp, nullptr);
    std::vector<proto::PixelPair> px = decode(d);
    ASSERT_EQ(px.size(), sp->pixels.size());
    size_t differing = 0;
    for (size_t i = 0; i < px.size(); ++i) {
        const PixelRadiance& r = sp->pixels[i];
        const float want[6] = {r.direct.x, r.direct.y, r.direct.z, r.caustic.x, r.caustic.y, r.caustic.z};
        if (std::memcmp(want, px[i].direct, sizeof want) != 0) ++differing;
    }
    EXPECT_EQ(differing, 0u) << "set " << d.set << " frame " << d.frame;
}

TEST(ClientSession, PipelinedFramesAreBitIdenticalToRenderJobAndByeExitsZero) {
    FakeServer fs;
    fs.start();
    fs.handshake({0, 1, 2, 3});
    const proto::Settings settings = smallSettings();
    ASSERT_TRUE(fs.peer.send(settings));
    ASSERT_TRUE(fs.peer.send(ringScene()));
    // Both frames go out before any reply: the client must queue the second while rendering.
    ASSERT_TRUE(fs.peer.send(frameBegin(0, 0, 1, {3, 0, 2, 1}, proto::FrameMode::Interaction)));
    ASSERT_TRUE(fs.peer.send(frameBegin(1, 0, 1, {3, 0, 2, 1}, proto::FrameMode::Converging)));

    RenderJob ref(loadScene("RING"), client::toRenderSettings(settings), {0, 1, 2, 3});
    std::vector<SetPixels> refPixels;
    const Camera cam = client::toCamera(ringCamera());
    for (uint64_t f = 0; f < 2; ++f) {
        ref.renderFrame(cam, refPixels);
        for (uint32_t set : {3u, 0u, 2u, 1u}) {
            proto::FrameData d = fs.expect<proto::FrameData>();
            EXPECT_EQ(d.frame, f);
            EXPECT_EQ(d.set, set);
            expectSamePixels(d, refPixels);
        }
        proto::Stats st = fs.expect<proto::Stats>();
        EXPECT_EQ(st.frame, f);
        EXPECT_GT(st.photonsShot, 0u);
        EXPECT_EQ(st.threads, 2u);
    }
    ASSERT_TRUE(fs.peer.send(proto::Bye{proto::ByeReason::Normal, "done"}));
    ExitStatus st = fs.exitStatus();
    EXPECT_TRUE(st.exited);
    EXPECT_EQ(st.code, kExitOk) << fs.client->logs();
}

TEST(ClientSession, EditBeforeNewEpochIsAppliedAndResetsPhotons) {
    FakeServer fs;
    fs.start();
    fs.handshake({0, 1, 2, 3});
    const proto::Settings settings = smallSettings();
    ASSERT_TRUE(fs.peer.send(settings));
    ASSERT_TRUE(fs.peer.send(ringScene()));
    Scene scene = loadScene("RING");
    ASSERT_FALSE(scene.instances.empty());
    // Move instance 0 (RING's light is an emissive mesh, so move geometry) 5 cm along x.
    Mat4 moved = scene.instances[0].transform;
    moved[3][0] += 0.05f;
    proto::TransformEdit te;
    te.instance = 0;
    std::memcpy(te.matrix.data(), &moved[0][0], sizeof(float) * 16);
    ASSERT_TRUE(fs.peer.send(frameBegin(0, 0, 1, {1, 2}, proto::FrameMode::Interaction)));
    ASSERT_TRUE(fs.peer.send(frameBegin(1, 0, 1, {1, 2}, proto::FrameMode::Converging)));
    ASSERT_TRUE(fs.peer.send(proto::Edit{2, te}));
    ASSERT_TRUE(fs.peer.send(frameBegin(2, 1, 2, {1, 2}, proto::FrameMode::Edit)));

    RenderJob ref(std::move(scene), client::toRenderSettings(settings), {1, 2});
    std::vector<SetPixels> refPixels;
    const Camera cam = client::toCamera(ringCamera());
    for (uint64_t f = 0; f < 3; ++f) {
        if (f == 2) {
            SceneEdit e;
            e.kind = SceneEdit::Kind::Transform;
            e.index = 0;
            e.transform = moved;
            ref.applyEdit(e);
        }
        ref.renderFrame(cam, refPixels);
        for (int i = 0; i < 2; ++i) expectSamePixels(fs.expect<proto::FrameData>(), refPixels);
        fs.expect<proto::Stats>();
    }
    EXPECT_EQ(ref.photons().stats(1).batches, 1u);  // the reference restarted too
    ASSERT_TRUE(fs.peer.send(proto::Bye{proto::ByeReason::Normal, ""}));
    EXPECT_EQ(fs.exitStatus().code, kExitOk);
}

/// Runs a session that sends `bad` after the handshake and settings; expects Bye{ProtocolError}
/// whose text contains `why`, then exit code 4.
void expectProtocolError(const std::vector<proto::Message>& bad, const std::string& why,
                         const proto::Settings& settings = smallSettings()) {
    FakeServer fs;
    fs.start();
    fs.handshake({0, 1, 2, 3});
    ASSERT_TRUE(fs.peer.send(settings));
    for (const proto::Message& m : bad) ASSERT_TRUE(fs.peer.send(m));
    proto::Message m;
    // Frames rendered before the bad message may arrive first.
    for (;;) {
        ASSERT_EQ(fs.peer.receive(m, 30s), Socket::Got::Message) << fs.client->logs();
        if (std::holds_alternative<proto::Bye>(m)) break;
    }
    const proto::Bye& bye = std::get<proto::Bye>(m);
    EXPECT_EQ(bye.reason, proto::ByeReason::ProtocolError);
    EXPECT_NE(bye.text.find(why), std::string::npos) << bye.text;
    ExitStatus st = fs.exitStatus();
    EXPECT_TRUE(st.exited);
    EXPECT_EQ(st.code, kExitProtocolError) << fs.client->logs();
    EXPECT_NE(fs.client->err().find(why), std::string::npos) << fs.client->logs();
}

TEST(ClientSession, SceneNameThatIsNotBuiltinIsRefusedNotOpened) {
    proto::Scene s = ringScene();
    s.builtinName = "/etc/passwd.obj";
    expectProtocolError({s}, "not a built-in scene");
}

TEST(ClientSession, CorruptGlbIsRefusedWithTheLoadersReason) {
    proto::Scene s;
    s.sceneVersion = 1;
    s.source = proto::Scene::Source::Gltf;
    s.gltf = {'g', 'l', 'T', 'F', 2, 0, 0, 0, 200, 0, 0, 0, 1, 2, 3};
    expectProtocolError({s}, "scene");
}

TEST(ClientSession, EditOfMissingLightIsRefused) {
    proto::LightEdit le;
    le.index = 99;
    le.intensity = {1, 1, 1};
    le.direction = {0, -1, 0};
    expectProtocolError({ringScene(), proto::Edit{2, le}, frameBegin(0, 1, 2, {0}, proto::FrameMode::Interaction)},
                        "light 99");
}

TEST(ClientSession, FrameBeginForUnknownSceneVersionIsRefused) {
    expectProtocolError({ringScene(), frameBegin(0, 0, 5, {0}, proto::FrameMode::Interaction)}, "scene version 5");
}

TEST(ClientSession, SetOutsideTheInterleavingIsRefused) {
    expectProtocolError({ringScene(), frameBegin(0, 0, 1, {4}, proto::FrameMode::Interaction)}, "set 4 out of range");
}

TEST(ClientSession, FrameBeforeSceneIsRefused) {
    expectProtocolError({frameBegin(0, 0, 1, {0}, proto::FrameMode::Interaction)}, "before any Scene");
}

TEST(ClientSession, DegenerateCameraIsRefused) {
    proto::FrameBegin fb = frameBegin(0, 0, 1, {0}, proto::FrameMode::Interaction);
    fb.camera.up = fb.camera.forward;
    expectProtocolError({ringScene(), fb}, "parallel");
}

TEST(ClientSession, SettingsTheRendererRefusesAreAProtocolError) {
    proto::Settings s = smallSettings();
    s.render.width = 3;
    s.render.height = 3;
    s.render.interleave = 8;  // more sets per row than pixels
    // Refused by the Settings decoder itself (the rule between rows), before the renderer sees it.
    expectProtocolError({}, "settings: invalid setting: interleave M = 8 exceeds the image size", s);
}

TEST(ClientSession, GarbageFromServerIsAnsweredWithByeAndExitFour) {
    FakeServer fs;
    fs.start();
    fs.handshake({0});
    std::vector<uint8_t> junk(64);
    for (size_t i = 0; i < junk.size(); ++i) junk[i] = uint8_t(i * 37 + 11);
    ASSERT_TRUE(fs.peer.sendAll(junk));
    proto::Bye bye = fs.expect<proto::Bye>();
    EXPECT_EQ(bye.reason, proto::ByeReason::ProtocolError);
    EXPECT_EQ(fs.exitStatus().code, kExitProtocolError);
}

TEST(ClientSession, ClientOnlyMessageFromServerIsAProtocolError) {
    FakeServer fs;
    fs.start();
    fs.handshake({0});
    ASSERT_TRUE(fs.peer.send(proto::Hello{}));
    proto::Bye bye = fs.expect<proto::Bye>();
    EXPECT_EQ(bye.reason, proto::ByeReason::ProtocolError);
    EXPECT_NE(bye.text.find("Hello"), std::string::npos) << bye.text;
    EXPECT_EQ(fs.exitStatus().code, kExitProtocolError);
}

TEST(ClientSession, RejectExitsTwoNamingTheReason) {
    FakeServer fs;
    fs.start();
    fs.expect<proto::Hello>();
    ASSERT_TRUE(fs.peer.send(proto::Reject{proto::RejectReason::BadToken, "token mismatch"}));
    ExitStatus st = fs.exitStatus();
    EXPECT_EQ(st.code, kExitRejected);
    EXPECT_NE(fs.client->err().find("bad token"), std::string::npos) << fs.client->logs();
}

TEST(ClientSession, ServerVanishingWhileRenderingExitsThreeWithClearMessage) {
    FakeServer fs;
    fs.start();
    fs.handshake({0, 1, 2, 3});
    ASSERT_TRUE(fs.peer.send(smallSettings()));
    ASSERT_TRUE(fs.peer.send(ringScene()));
    ASSERT_TRUE(fs.peer.send(frameBegin(0, 0, 1, {0, 1, 2, 3}, proto::FrameMode::Interaction)));
    fs.peer.close();
    ExitStatus st = fs.exitStatus();
    EXPECT_TRUE(st.exited);
    EXPECT_EQ(st.code, kExitServerGone) << fs.client->logs();
    EXPECT_NE(fs.client->err().find("rtpm-client: server 127.0.0.1:" + std::to_string(fs.listener.port()) +
                                    " closed the connection"),
              std::string::npos)
        << fs.client->logs();
}

TEST(ClientSession, ByeShutdownMeansTheMasterStoppedExitThreeWithoutRejoining) {
    FakeServer fs;
    fs.start("s3cret", {"--rejoin-timeout", "30"});
    fs.handshake({0});
    ASSERT_TRUE(fs.peer.send(proto::Bye{proto::ByeReason::Shutdown, "server stopped"}));
    EXPECT_EQ(fs.exitStatus().code, kExitServerGone) << fs.client->logs();
    EXPECT_FALSE(fs.listener.accept(500ms).valid()) << "no rejoin after a Shutdown";
}

// Issue 13: an evicted client exited with code 4 ("master sent something unusable") and never
// came back. Now Bye{Timeout} is an eviction: it rejoins with a fresh Hello, or exits 7.
TEST(ClientSession, EvictedClientRejoinsWithAFreshHello) {
    FakeServer fs;
    fs.start("s3cret", {"--rejoin-timeout", "30"});
    fs.handshake({0});
    ASSERT_TRUE(fs.peer.send(proto::Bye{proto::ByeReason::Timeout, "evicted: late 3 frames in a row"}));
    fs.peer.close();
    Socket again = fs.listener.accept(20s);
    ASSERT_TRUE(again.valid()) << "no rejoin\n" << fs.client->logs();
    fs.handshakeOn(again, {1});
    proto::Message m;
    ASSERT_TRUE(again.send(smallSettings()));
    ASSERT_TRUE(again.send(ringScene()));
    ASSERT_TRUE(again.send(frameBegin(0, 0, 1, {1}, proto::FrameMode::Interaction)));
    ASSERT_EQ(again.receive(m, 30s), Socket::Got::Message) << fs.client->logs();
    ASSERT_TRUE(std::holds_alternative<proto::FrameData>(m));
    EXPECT_EQ(std::get<proto::FrameData>(m).set, 1u);
    ASSERT_TRUE(again.send(proto::Bye{proto::ByeReason::Normal, ""}));
    EXPECT_EQ(fs.exitStatus().code, kExitOk) << fs.client->logs();
    const std::string err = fs.client->err();
    EXPECT_NE(err.find("evicted; rejoining"), std::string::npos) << err;
    EXPECT_NE(err.find("rejoined 127.0.0.1"), std::string::npos) << err;
}

TEST(ClientSession, EvictedClientWithoutRejoinExitsSeven) {
    FakeServer fs;
    fs.start();  // --rejoin-timeout 0
    fs.handshake({0});
    ASSERT_TRUE(fs.peer.send(proto::Bye{proto::ByeReason::Timeout, "evicted"}));
    EXPECT_EQ(fs.exitStatus().code, kExitEvicted) << fs.client->logs();
}

// A capacity refusal is transient: the client retries (issue 13: 0 of 7 joins under a flood).
TEST(ClientSession, CapacityRefusalIsRetriedOtherRefusalsAreFinal) {
    FakeServer fs;
    fs.start();
    fs.expect<proto::Hello>();
    ASSERT_TRUE(fs.peer.send(proto::Reject{proto::RejectReason::Capacity, "at the connection limit"}));
    fs.peer.close();
    Socket again = fs.listener.accept(20s);
    ASSERT_TRUE(again.valid()) << "no retry after Capacity\n" << fs.client->logs();
    proto::Message m;
    ASSERT_EQ(again.receive(m, 10s), Socket::Got::Message);
    ASSERT_TRUE(std::holds_alternative<proto::Hello>(m));
    ASSERT_TRUE(again.send(proto::Reject{proto::RejectReason::BadToken, "no"}));
    EXPECT_EQ(fs.exitStatus().code, kExitRejected) << fs.client->logs();
}

// A frozen master (issue 13: clients waited forever). Heartbeats keep an idle session alive;
// silence past --idle-timeout makes the client say Bye{Timeout} and, with no rejoin, exit 3.
TEST(ClientSession, HeartbeatsKeepAnIdleSessionSilenceEndsIt) {
    FakeServer fs;
    fs.start("s3cret", {"--idle-timeout", "2"});
    fs.handshake({0});
    proto::Message m;
    for (int i = 0; i < 10; ++i) {  // 5 s of heartbeats, 2.5 idle timeouts
        ASSERT_TRUE(fs.peer.send(proto::Heartbeat{})) << fs.client->logs();
        ASSERT_EQ(fs.peer.receive(m, 500ms), Socket::Got::Timeout)
            << "the client left although the master kept sending heartbeats\n" << fs.client->logs();
    }
    ASSERT_EQ(fs.peer.receive(m, 30s), Socket::Got::Message) << fs.client->logs();
    ASSERT_TRUE(std::holds_alternative<proto::Bye>(m));
    EXPECT_EQ(std::get<proto::Bye>(m).reason, proto::ByeReason::Timeout);
    EXPECT_EQ(fs.exitStatus().code, kExitServerGone) << fs.client->logs();
    EXPECT_NE(fs.client->err().find("idle timeout"), std::string::npos) << fs.client->logs();
}

TEST(ClientSession, SigtermLeavesWithByeShutdown) {
    FakeServer fs;
    fs.start();
    fs.handshake({0});
    fs.client->signal(SIGTERM);
    proto::Bye bye = fs.expect<proto::Bye>();
    EXPECT_EQ(bye.reason, proto::ByeReason::Shutdown);
    ExitStatus st = fs.exitStatus();
    EXPECT_TRUE(st.exited);
    EXPECT_EQ(st.code, 128 + SIGTERM);
}

TEST(ClientSession, RetriesUntilThePortFileAppears) {
    TempDir dir;
    const std::string portFile = dir.file("port");
    Child client({binaryPath("client/rtpm-client"), "--port-file", portFile, "--token", "t", "--connect-timeout", "5",
                  "--idle-timeout", "2"},
                 dir.file("client"));
    // Let the client fail a few attempts first: it must keep retrying, not exit.
    EXPECT_FALSE(client.wait(400ms)) << client.logs();
    Listener listener;
    {
        std::ofstream(portFile + ".tmp") << listener.port() << "\n";
    }
    std::filesystem::rename(portFile + ".tmp", portFile);
    Socket peer = listener.accept(10s);
    ASSERT_TRUE(peer.valid()) << client.logs();
    proto::Message m;
    ASSERT_EQ(peer.receive(m, 10s), Socket::Got::Message);
    EXPECT_TRUE(std::holds_alternative<proto::Hello>(m));
    // Closed before Welcome (a master starting up, full, or refusing a flood): a failed attempt,
    // retried within the connect window (issue 13: such clients exited at once with code 3).
    peer.close();
    Socket again = listener.accept(10s);
    ASSERT_TRUE(again.valid()) << "no second attempt\n" << client.logs();
    ASSERT_EQ(again.receive(m, 10s), Socket::Got::Message);
    EXPECT_TRUE(std::holds_alternative<proto::Hello>(m));
    again.close();
    // Once the connect window has run out, the client says why it stopped: a master was
    // reached but never took it (code 3).
    auto st = client.wait(30s);
    ASSERT_TRUE(st) << client.logs();
    EXPECT_EQ(st->code, kExitServerGone) << client.logs();
}

TEST(ClientSession, GivesUpAfterTheConnectTimeout) {
    TempDir dir;
    Child client({binaryPath("client/rtpm-client"), "--port-file", dir.file("never"), "--token", "t",
                  "--connect-timeout", "0.5"},
                 dir.file("client"));
    auto st = client.wait(15s);
    ASSERT_TRUE(st);
    EXPECT_EQ(st->code, kExitStartup);
    EXPECT_NE(client.err().find("could not connect"), std::string::npos) << client.logs();
}

TEST(FrameRenderer, SetsThatStayKeepAccumulatingWhenOthersMove) {
    client::FrameRenderer r(1);
    r.setSettings(smallSettings());
    r.setScene(ringScene());
    const auto now = std::chrono::steady_clock::now();
    r.render(frameBegin(0, 0, 1, {0, 1}, proto::FrameMode::Interaction), now);
    r.render(frameBegin(1, 0, 1, {0, 1, 2}, proto::FrameMode::Accumulate), now);
    EXPECT_EQ(r.batches(0), 2u);
    EXPECT_EQ(r.batches(2), 1u);  // new here: starts from batch 0
    client::RenderedFrame f = r.render(frameBegin(2, 0, 1, {2, 1}, proto::FrameMode::Accumulate), now);
    ASSERT_EQ(f.data.size(), 2u);
    EXPECT_EQ(f.data[0].set, 2u);
    EXPECT_EQ(f.data[1].set, 1u);
    EXPECT_EQ(r.batches(2), 2u);  // its group held only wanted sets: kept
    EXPECT_EQ(r.batches(1), 1u);  // its group also held set 0, which left: restarted
    EXPECT_EQ(r.batches(0), 0u);
    // A new epoch resets every kept set.
    r.render(frameBegin(3, 1, 1, {2, 1}, proto::FrameMode::Interaction), now);
    EXPECT_EQ(r.batches(2), 1u);
    EXPECT_EQ(r.batches(1), 1u);
    // Walkthrough shoots nothing.
    f = r.render(frameBegin(4, 1, 1, {2, 1}, proto::FrameMode::Walkthrough), now);
    EXPECT_EQ(f.stats.photonsShot, 0u);
    EXPECT_EQ(r.batches(2), 1u);
}

// Issue 13: with --walkthrough, sets that moved to a client after the epoch's first frame were
// never shot there (zero caustic for the rest of the run). A map with no batch shoots one even in
// a Walkthrough frame; maps that have photons still shoot nothing.
TEST(FrameRenderer, SetsMovedHereShootTheirFirstBatchEvenInAWalkthroughFrame) {
    client::FrameRenderer r(1);
    r.setSettings(smallSettings());
    r.setScene(ringScene());
    const auto now = std::chrono::steady_clock::now();
    r.render(frameBegin(0, 0, 1, {0, 1}, proto::FrameMode::Interaction), now);
    client::RenderedFrame f = r.render(frameBegin(1, 0, 1, {0, 1, 2, 3}, proto::FrameMode::Walkthrough), now);
    EXPECT_GT(f.stats.photonsShot, 0u);
    EXPECT_EQ(r.batches(0), 1u);  // had photons: walkthrough, nothing shot
    EXPECT_EQ(r.batches(1), 1u);
    EXPECT_EQ(r.batches(2), 1u);  // moved here: its first batch
    EXPECT_EQ(r.batches(3), 1u);
    f = r.render(frameBegin(2, 0, 1, {0, 1, 2, 3}, proto::FrameMode::Walkthrough), now);
    EXPECT_EQ(f.stats.photonsShot, 0u);
    EXPECT_EQ(r.batches(2), 1u);
    // The moved sets' maps equal what their first owner built from the same batch: bit for bit.
    client::FrameRenderer first(1);
    first.setSettings(smallSettings());
    first.setScene(ringScene());
    client::RenderedFrame ref = first.render(frameBegin(0, 0, 1, {0, 1, 2, 3}, proto::FrameMode::Interaction), now);
    ref = first.render(frameBegin(1, 0, 1, {0, 1, 2, 3}, proto::FrameMode::Walkthrough), now);
    ASSERT_EQ(ref.data.size(), f.data.size());
    for (size_t i = 0; i < f.data.size(); ++i) {
        EXPECT_EQ(f.data[i].set, ref.data[i].set);
        EXPECT_EQ(f.data[i].pixels, ref.data[i].pixels) << "set " << f.data[i].set;
    }
}

TEST(FrameRenderer, OnlyFilterOrEncodingChangesKeepPhotons) {
    client::FrameRenderer r(1);
    proto::Settings s = smallSettings();
    r.setSettings(s);
    r.setScene(ringScene());
    const auto now = std::chrono::steady_clock::now();
    r.render(frameBegin(0, 0, 1, {0}, proto::FrameMode::Interaction), now);
    s.render.filter = 5;
    s.encoding = proto::PixelEncoding::Rgb9e5;
    r.setSettings(s);
    r.render(frameBegin(1, 0, 1, {0}, proto::FrameMode::Accumulate), now);
    EXPECT_EQ(r.batches(0), 2u);
    s.render.photons.k = 30;
    r.setSettings(s);
    r.render(frameBegin(2, 0, 1, {0}, proto::FrameMode::Accumulate), now);
    EXPECT_EQ(r.batches(0), 1u);
}

// The viewer and edit scripts switch the estimator live: new Settings, then a new epoch. The
// client restarts its sets with the new estimator and renders what a client that started with it
// renders, bit for bit.
TEST(FrameRenderer, AnEstimatorChangeRestartsTheSetsWithTheNewEstimator) {
    proto::Settings s = smallSettings();
    ASSERT_EQ(s.render.photons.estimator, CausticEstimatorKind::Progressive);
    client::FrameRenderer r(1);
    r.setSettings(s);
    r.setScene(ringScene());
    const auto now = std::chrono::steady_clock::now();
    r.render(frameBegin(0, 0, 1, {0, 1}, proto::FrameMode::Interaction), now);
    client::RenderedFrame still = r.render(frameBegin(1, 0, 1, {0, 1}, proto::FrameMode::Converging), now);
    ASSERT_EQ(still.data.size(), 2u);
    EXPECT_GT(still.data[0].passes, 0u) << "a converging frame of the progressive estimator";
    s.render.photons.estimator = CausticEstimatorKind::Knn;
    r.setSettings(s);
    r.render(frameBegin(2, 1, 1, {0, 1}, proto::FrameMode::Interaction), now);
    client::RenderedFrame knn = r.render(frameBegin(3, 1, 1, {0, 1}, proto::FrameMode::Accumulate), now);
    client::FrameRenderer fresh(1);
    fresh.setSettings(s);
    fresh.setScene(ringScene());
    fresh.render(frameBegin(2, 1, 1, {0, 1}, proto::FrameMode::Interaction), now);
    client::RenderedFrame ref = fresh.render(frameBegin(3, 1, 1, {0, 1}, proto::FrameMode::Accumulate), now);
    ASSERT_EQ(knn.data.size(), ref.data.size());
    for (size_t i = 0; i < knn.data.size(); ++i) {
        EXPECT_EQ(knn.data[i].passes, 0u);
        EXPECT_EQ(knn.data[i].pixels, ref.data[i].pixels) << "set " << knn.data[i].set;
    }
    EXPECT_EQ(r.batches(0), 2u);
}

// The frame mode is the master's decision: a still camera converges only in a Converging frame,
// and a Converging frame whose camera differs from the one a set's progression was traced with
// restarts that set (its client missed the frame the camera moved in).
TEST(FrameRenderer, RendersByTheFrameModeTheMasterSends) {
    proto::Settings s = smallSettings();
    ASSERT_EQ(s.render.photons.estimator, CausticEstimatorKind::Progressive);
    client::FrameRenderer r(1);
    r.setSettings(s);
    r.setScene(ringScene());
    const auto now = std::chrono::steady_clock::now();
    r.render(frameBegin(0, 0, 1, {0, 1}, proto::FrameMode::Interaction), now);
    client::RenderedFrame f = r.render(frameBegin(1, 0, 1, {0, 1}, proto::FrameMode::Accumulate), now);
    EXPECT_EQ(f.data[0].passes, 0u) << "an Accumulate frame restarts, even with the camera still";
    f = r.render(frameBegin(2, 0, 1, {0, 1}, proto::FrameMode::Converging), now);
    EXPECT_EQ(f.data[0].passes, 1u) << "a Converging frame runs a pass";
    f = r.render(frameBegin(3, 0, 1, {0, 1}, proto::FrameMode::Converging), now);
    EXPECT_EQ(f.data[1].passes, 2u);
    proto::FrameBegin moved = frameBegin(4, 0, 1, {0, 1}, proto::FrameMode::Converging);
    moved.camera.position.x += 0.01f;
    f = r.render(moved, now);
    EXPECT_EQ(f.data[0].passes, 0u) << "no records of this camera: a restart";
    f = r.render(frameBegin(5, 0, 1, {0, 1}, proto::FrameMode::Walkthrough), now);
    EXPECT_EQ(f.data[0].passes, 0u);
    EXPECT_EQ(f.stats.photonsShot, 0u);

    // What a client renders by the master's modes equals what rtpm-render's own decisions give.
    RenderJob ref(loadScene("RING"), client::toRenderSettings(s), {0, 1});
    std::vector<SetPixels> refPixels;
    const Camera cam = client::toCamera(ringCamera());
    client::FrameRenderer obeying(1);
    obeying.setSettings(s);
    obeying.setScene(ringScene());
    // With its Converging frames the master forwards every set's shot of kSharedPhotonLag frames
    // ago (server/photon_relay.h), as rtpm-render's job bins its own record of them.
    std::vector<std::vector<proto::SetShot>> shots;
    for (uint64_t frame = 0; frame < 4; ++frame) {
        ref.renderFrame(cam, refPixels);
        proto::FrameBegin fb = frameBegin(frame, 0, 1, {0, 1},
                                          frame == 0 ? proto::FrameMode::Interaction : proto::FrameMode::Converging);
        if (frame >= kSharedPhotonLag) fb.shared = shots[frame - kSharedPhotonLag];
        f = obeying.render(fb, now);
        for (const proto::FrameData& d : f.data) expectSamePixels(d, refPixels);
        std::vector<proto::SetShot>& sent = shots.emplace_back();
        for (const proto::FrameData& d : f.data)
            if (d.shotBatches > 0) sent.push_back({d.set, d.shotBatches, d.shot});
    }
    EXPECT_FALSE(shots[0].empty()) << "frame 2's passes were handed no photons";
}

// A set off its turn sends no pixels (not re-encoded) and names the frame that last sent them;
// the pixels that frame sent equal rtpm-render's of this frame, so the master shows rtpm-render's
// image at every frame.
TEST(FrameRenderer, ASetOffItsTurnNamesTheFrameThatSentItsPixels) {
    const proto::Settings s = smallSettings();
    RenderJob ref(loadScene("RING"), client::toRenderSettings(s), {0, 1, 2, 3});
    std::vector<SetPixels> refPixels;
    const Camera cam = client::toCamera(ringCamera());
    client::FrameRenderer r(1);
    r.setSettings(s);
    r.setScene(ringScene());
    const auto now = std::chrono::steady_clock::now();
    constexpr uint32_t kPeriod = 2;
    std::vector<std::vector<proto::SetShot>> shots;
    std::map<uint32_t, proto::FrameData> last;  // per set, the last FrameData carrying pixels
    int repeats = 0;
    for (uint64_t frame = 0; frame < 6; ++frame) {
        ref.renderFrame(cam, refPixels, 1, frame == 0 ? 1 : kPeriod);
        proto::FrameBegin fb = frameBegin(frame, 0, 1, {0, 1, 2, 3},
                                          frame == 0 ? proto::FrameMode::Interaction : proto::FrameMode::Converging);
        if (frame > 0) fb.passPeriod = kPeriod;
        if (frame >= kSharedPhotonLag) fb.shared = shots[frame - kSharedPhotonLag];
        const client::RenderedFrame f = r.render(fb, now);
        for (const proto::FrameData& d : f.data) {
            if (frame > 0 && d.shotBatches == 0) {
                EXPECT_TRUE(d.unchanged) << "set " << d.set << " off its turn, frame " << frame;
                EXPECT_TRUE(d.pixels.empty() && d.ownWeights.empty());
                ASSERT_TRUE(last.count(d.set));
                EXPECT_EQ(d.sameAs, last[d.set].frame);
                expectSamePixels(last[d.set], refPixels);
                ++repeats;
                continue;
            }
            EXPECT_FALSE(d.unchanged);
            expectSamePixels(d, refPixels);
            last[d.set] = d;
        }
        std::vector<proto::SetShot>& sent = shots.emplace_back();
        for (const proto::FrameData& d : f.data)
            if (d.shotBatches > 0) sent.push_back({d.set, d.shotBatches, d.shot});
    }
    EXPECT_GE(repeats, 8) << "half the sets wait in each of frames 1-5";
}

// A client holds one scene and one BVH for all its set groups; an edit applied once to it reaches
// every group, which then renders what a job over the edited scene renders, bit for bit.
TEST(FrameRenderer, SetGroupsShareOneSceneThatAnEditChangesOnce) {
    const proto::Settings s = smallSettings();
    client::FrameRenderer r(1);
    r.setSettings(s);
    r.setScene(ringScene());
    const auto now = std::chrono::steady_clock::now();
    r.render(frameBegin(0, 0, 1, {0, 1}, proto::FrameMode::Interaction), now);
    r.render(frameBegin(1, 0, 1, {0, 1, 2, 3}, proto::FrameMode::Accumulate), now);
    ASSERT_EQ(r.groupCount(), 2u);
    Scene scene = loadScene("RING");
    Mat4 moved = scene.instances[0].transform;
    moved[3][0] += 0.05f;
    proto::TransformEdit te;
    te.instance = 0;
    std::memcpy(te.matrix.data(), &moved[0][0], sizeof(float) * 16);
    r.queueEdit(proto::Edit{2, te});
    client::RenderedFrame f = r.render(frameBegin(2, 1, 2, {0, 1, 2, 3}, proto::FrameMode::Edit), now);
    EXPECT_EQ(r.groupCount(), 2u) << "the groups survive the edit";

    RenderJob ref(std::move(scene), client::toRenderSettings(s), {0, 1, 2, 3});
    SceneEdit e;
    e.kind = SceneEdit::Kind::Transform;
    e.index = 0;
    e.transform = moved;
    ref.applyEdit(e);
    std::vector<SetPixels> refPixels;
    ref.renderFrame(client::toCamera(ringCamera()), refPixels);
    ASSERT_EQ(f.data.size(), 4u);
    for (const proto::FrameData& d : f.data) expectSamePixels(d, refPixels);
}

// The client validates the settings it is given again (a message built in memory was never
// decoded): a value outside its row is refused.
TEST(FrameRenderer, SettingsOutsideTheirRowsAreRefused) {
    proto::Settings s = smallSettings();
    EXPECT_EQ(client::toRenderSettings(s).photons.tree, PhotonTree::MiddleSplit);
    s.render.photons.tree = static_cast<PhotonTree>(7);  // only a corrupt in-memory value; the decoder refuses it
    EXPECT_THROW(client::toRenderSettings(s), client::ProtocolViolation);
    s = smallSettings();
    s.render.photons.k = 0;
    EXPECT_THROW(client::toRenderSettings(s), client::ProtocolViolation);
}

TEST(ParseHostPort, AcceptsHostsAndBracketedV6WithTheDefaultPortRejectsBadPorts) {
    std::string h;
    uint16_t p = 0;
    EXPECT_TRUE(client::parseHostPort("example.org:7000", h, p));
    EXPECT_EQ(h, "example.org");
    EXPECT_EQ(p, 7000);
    EXPECT_TRUE(client::parseHostPort("[::1]:80", h, p));
    EXPECT_EQ(h, "::1");
    EXPECT_EQ(p, 80);
    EXPECT_TRUE(client::parseHostPort("[::1]", h, p));
    EXPECT_EQ(p, proto::kDefaultPort);
    EXPECT_TRUE(client::parseHostPort("localhost", h, p));  // the default port, 7411
    EXPECT_EQ(h, "localhost");
    EXPECT_EQ(p, 7411);
    EXPECT_FALSE(client::parseHostPort("", h, p));
    EXPECT_FALSE(client::parseHostPort("[::1]x", h, p));
    EXPECT_FALSE(client::parseHostPort("host:0", h, p));
    EXPECT_FALSE(client::parseHostPort("host:65536", h, p));
    EXPECT_FALSE(client::parseHostPort("host:12ab", h, p));
    EXPECT_FALSE(client::parseHostPort(":80", h, p));
}

}  // namespace
}  // namespace rtpm::test
