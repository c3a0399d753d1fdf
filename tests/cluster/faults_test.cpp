// Faults degrade, never stall (issue 13): a client killed in a walkthrough, a frozen client, a
// frozen master, SIGTERM to the master, a run without a complete frame — real processes on
// loopback, every wait bounded, every process stopped by PID.
#include <gtest/gtest.h>

#include <signal.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <regex>

#include "client/worker.h"
#include "common/core/interleave.h"
#include "common/image/image_io.h"
#include "server/master.h"
#include "tests/support/cluster_util.h"

namespace rtpm::test {
namespace {

using namespace std::chrono_literals;

const std::string kToken = "9c41e07b2d5a8f36c1b4e9d07a52f8c3";  // `openssl rand -hex 16`

/// Flags shared by rtpm-server and rtpm-render: a small RING so a frame takes tens of ms.
std::vector<std::string> sceneFlags(int frames, std::vector<std::string> extra = {}, int photons = 2000) {
    std::vector<std::string> f{"--scene", "RING", "--width", "96", "--height", "72", "-M", "3",
                               "--frames", std::to_string(frames), "-P", std::to_string(photons),
                               "--frame-budget-ms", "0"};  // one batch per pass: the same in every process
    f.insert(f.end(), extra.begin(), extra.end());
    return f;
}

/// A master and its clients in a temp dir; the Child destructors kill and reap what still runs.
struct FaultRun {
    TempDir dir;
    std::unique_ptr<Child> server;
    uint16_t port = 0;
    std::vector<std::unique_ptr<Child>> clients;

    std::string out() const { return dir.file("out.exr"); }

    void startServer(const std::vector<std::string>& flags, int minClients) {
        std::vector<std::string> argv{binaryPath("server/rtpm-server"), "--port", "0", "--port-file",
                                      dir.file("port"), "--min-clients", std::to_string(minClients),
                                      "--encoding", "float32", "--out", out()};
        argv.insert(argv.end(), flags.begin(), flags.end());
        server = std::make_unique<Child>(argv, dir.file("server"), std::vector<std::string>{"RTPM_TOKEN=" + kToken});
        port = waitForPortFile(dir.file("port"), *server, 30s);
        ASSERT_NE(port, 0) << "server never wrote its port\n" << server->logs();
    }
    Child& startClient(std::vector<std::string> extra = {}) {
        std::vector<std::string> argv{binaryPath("client/rtpm-client"), "--server",
                                      "127.0.0.1:" + std::to_string(port), "--token", kToken, "--threads", "1",
                                      "--connect-timeout", "20", "--verbose"};
        argv.insert(argv.end(), extra.begin(), extra.end());
        clients.push_back(std::make_unique<Child>(argv, dir.file("client" + std::to_string(clients.size()))));
        return *clients.back();
    }
    std::string logs() const {
        std::string s = "=== server\n" + (server ? server->logs() : std::string());
        for (size_t i = 0; i < clients.size(); ++i) s += "=== client " + std::to_string(i) + "\n" + clients[i]->logs();
        return s;
    }
    /// Frames the server has shown so far (its per-frame stdout lines).
    size_t framesShown() const {
        const std::string o = server->out();
        size_t n = 0;
        for (size_t at = o.find("\nframe "); at != std::string::npos; at = o.find("\nframe ", at + 1)) ++n;
        return n;
    }
    ExitStatus waitFor(Child& c, std::chrono::milliseconds timeout) const {
        auto st = c.wait(timeout);
        EXPECT_TRUE(st) << "process still running\n" << logs();
        return st ? *st : ExitStatus{};
    }
};

bool rendered(Child& c, int frame) { return c.out().find("frame " + std::to_string(frame) + ":") != std::string::npos; }

/// Sum of a layer's values and whether all are finite.
std::pair<double, bool> layerSum(const ExrImage& img, const std::string& layer) {
    double sum = 0.0;
    bool finite = true;
    for (float v : img.layerRgb(layer)) {
        finite = finite && std::isfinite(v);
        sum += v;
    }
    return {sum, finite};
}

// Issue 13: with --walkthrough and two clients, killing one after frame 5 left its sets with
// zero caustic for the rest of the run (the survivor never shot for them): the filtered caustic
// lost about half its energy (measured 0.56 of the undisturbed run). A moved set now shoots its
// first batch on its new owner, so the final image equals the undisturbed walkthrough's — which is
// rtpm-render's first frame (one batch per set, the same camera) — bit for bit.
TEST(Faults, ClientKilledInAWalkthroughLosesNoCausticEnergy) {
    const int frames = 40;
    TempDir refDir;
    {
        std::vector<std::string> argv{binaryPath("common/cmd/rtpm-render")};
        for (const std::string& f : sceneFlags(1)) argv.push_back(f);
        argv.insert(argv.end(), {"--out", refDir.file("ref.exr")});
        Child render(argv, refDir.file("render"));
        auto st = render.wait(60s);
        ASSERT_TRUE(st && st->exited && st->code == 0) << render.logs();
    }
    const ExrImage ref = readExr(refDir.file("ref.exr"));

    FaultRun r;
    r.startServer(sceneFlags(frames, {"--walkthrough"}), 2);
    Child& survivor = r.startClient();
    Child& victim = r.startClient();
    ASSERT_TRUE(waitUntil([&] { return rendered(victim, 5) || victim.poll(); }, 60s)) << r.logs();
    victim.signal(SIGKILL);
    auto vst = r.waitFor(victim, 10s);
    ASSERT_FALSE(vst.exited) << "the victim finished before it was killed: the run was too short\n" << r.logs();
    auto st = r.waitFor(*r.server, 120s);
    ASSERT_TRUE(st.exited && st.code == 0) << r.logs();
    EXPECT_EQ(r.waitFor(survivor, 20s).code, client::kExitOk) << r.logs();

    const ExrImage got = readExr(r.out());
    for (const char* layer : {"caustic", "caustic_filtered"}) {
        const auto [sum, finite] = layerSum(got, layer);
        const double refSum = layerSum(ref, layer).first;
        ASSERT_GT(refSum, 0.0);
        EXPECT_TRUE(finite) << layer;
        EXPECT_NEAR(sum / refSum, 1.0, 1e-6) << layer << ": caustic energy of the killed run / undisturbed";
        const std::vector<float> a = got.layerRgb(layer), b = ref.layerRgb(layer);
        ASSERT_EQ(a.size(), b.size());
        EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << layer << " differs\n" << r.logs();
    }
}

/// Frame number of the first "frame N shown at its deadline" line and of the eviction of a
/// client ("(before frame N)"), -1 when absent.
long firstMatch(const std::string& text, const std::string& pattern) {
    std::smatch m;
    if (!std::regex_search(text, m, std::regex(pattern))) return -1;
    return std::stol(m[1]);
}

// Issue 13: a client frozen with SIGSTOP (defaults: 10 s deadline, evict after 10) held the whole
// cluster to 2 frames in 20 s, and after SIGCONT it exited with code 4 and never came back.
// Now the deadline adapts to the measured frame time, the client is evicted within a few frames,
// is told why, and rejoins by itself after SIGCONT.
TEST(Faults, FrozenClientIsEvictedWithinAFewFramesAndRejoinsAfterSigcont) {
    FaultRun r;
    r.startServer(sceneFlags(0), 2);  // a service: until SIGTERM, default deadline and eviction
    Child& survivor = r.startClient();
    Child& frozen = r.startClient();
    ASSERT_TRUE(waitUntil([&] { return rendered(frozen, 3) || frozen.poll(); }, 60s)) << r.logs();
    frozen.signal(SIGSTOP);
    // Bounded: with the old defaults this takes > 100 s.
    const bool evicted =
        waitUntil([&] { return r.server->err().find(") evicted: ") != std::string::npos; }, 60s);
    if (!evicted) frozen.signal(SIGCONT);
    ASSERT_TRUE(evicted) << "the frozen client was not evicted\n" << r.logs();
    const std::string err = r.server->err();
    const long firstLate = firstMatch(err, "frame (\\d+) shown at its deadline");
    const long evictedBefore = firstMatch(err, "evicted: .*\\(before frame (\\d+)\\)");
    ASSERT_GE(firstLate, 0) << r.logs();
    ASSERT_GE(evictedBefore, 0) << r.logs();
    // Frames in flight when it froze (kPipeline = 2) retire at their deadline, then it is skipped
    // until --evict-after (3) frames in a row: evicted within 3 + 2 (+1 for where the stop lands).
    EXPECT_LE(evictedBefore - firstLate, 6) << r.logs();
    // Frames keep flowing without it.
    const size_t atEviction = r.framesShown();
    EXPECT_TRUE(waitUntil([&] { return r.framesShown() >= atEviction + 10; }, 60s)) << r.logs();
    frozen.signal(SIGCONT);
    ASSERT_TRUE(waitUntil([&] { return frozen.err().find("rtpm-client: rejoined") != std::string::npos || frozen.poll(); },
                          60s))
        << "the evicted client did not rejoin\n" << r.logs();
    EXPECT_NE(frozen.err().find("said bye (timeout"), std::string::npos) << "not told why\n" << r.logs();
    // It renders again: a frame of the new session. The old session's render thread may still
    // print the frame it was on when the client froze, numbered below every frame shown since, so
    // only a line of a frame issued after the rejoin counts.
    const size_t shownAtRejoin = r.framesShown();
    auto lastFrameLine = [&] {
        long last = -1;
        const std::string out = frozen.out();
        static const std::regex line("(^|\n)frame (\\d+):");
        for (auto it = std::sregex_iterator(out.begin(), out.end(), line); it != std::sregex_iterator(); ++it)
            last = std::max(last, std::stol((*it)[2]));
        return last;
    };
    EXPECT_TRUE(waitUntil([&] { return lastFrameLine() >= long(shownAtRejoin); }, 60s)) << r.logs();
    r.server->signal(SIGTERM);
    auto st = r.waitFor(*r.server, 60s);
    EXPECT_TRUE(st.exited && st.code == 0) << r.logs();
    EXPECT_TRUE(std::filesystem::exists(r.out())) << r.logs();
    EXPECT_EQ(r.waitFor(survivor, 20s).code, client::kExitServerGone) << r.logs();
    EXPECT_EQ(r.waitFor(frozen, 20s).code, client::kExitServerGone) << r.logs();
}

// Issue 13: a frozen master left its clients waiting forever. They now notice the silence after
// --idle-timeout (the master sends a heartbeat every second), say Bye{Timeout}, keep trying to
// rejoin, and get back in once the master runs again.
TEST(Faults, FrozenMasterIsNoticedByItsClientsWhichRejoinWhenItRunsAgain) {
    FaultRun r;
    r.startServer(sceneFlags(0), 1);
    Child& cl = r.startClient({"--idle-timeout", "3"});
    ASSERT_TRUE(waitUntil([&] { return rendered(cl, 2) || cl.poll(); }, 60s)) << r.logs();
    r.server->signal(SIGSTOP);
    // The client writes two lines when it notices (the silence, then that it rejoins): wait for
    // the second, or a read between the two fails the test.
    const bool noticed = waitUntil(
        [&] { return cl.err().find("the server fell silent; rejoining") != std::string::npos || cl.poll(); }, 30s);
    r.server->signal(SIGCONT);
    ASSERT_TRUE(noticed) << "the client did not notice the frozen master, or did not say it rejoins\n" << r.logs();
    EXPECT_FALSE(cl.poll()) << "the client should keep trying to rejoin\n" << r.logs();
    EXPECT_NE(cl.err().find("idle timeout 3.0 s"), std::string::npos) << r.logs();
    ASSERT_TRUE(waitUntil([&] { return cl.err().find("rtpm-client: rejoined") != std::string::npos || cl.poll(); }, 60s))
        << r.logs();
    r.server->signal(SIGTERM);
    auto st = r.waitFor(*r.server, 60s);
    EXPECT_TRUE(st.exited && st.code == 0) << r.logs();
    EXPECT_EQ(r.waitFor(cl, 20s).code, client::kExitServerGone) << r.logs();
}

// Issue 13: SIGTERM to the master wrote no image and its clients exited 0 where MULTI-HOST.md
// says 3. Now the last frame is written, and clients exit with the documented code.
TEST(Faults, SigtermToTheMasterWritesTheImageAndClientsExitThree) {
    FaultRun r;
    r.startServer(sceneFlags(0), 2);
    Child& a = r.startClient();
    Child& b = r.startClient();
    ASSERT_TRUE(waitUntil([&] { return (rendered(a, 3) && rendered(b, 3)) || a.poll() || b.poll(); }, 60s)) << r.logs();
    r.server->signal(SIGTERM);
    auto st = r.waitFor(*r.server, 60s);
    EXPECT_TRUE(st.exited && st.code == 0) << r.logs();
    ASSERT_TRUE(std::filesystem::exists(r.out())) << r.logs();
    const auto [sum, finite] = layerSum(readExr(r.out()), "");
    EXPECT_TRUE(finite);
    EXPECT_GT(sum, 0.0);
    EXPECT_EQ(r.waitFor(a, 20s).code, client::kExitServerGone) << r.logs();
    EXPECT_EQ(r.waitFor(b, 20s).code, client::kExitServerGone) << r.logs();
    EXPECT_NE(a.err().find("said bye (shutdown)"), std::string::npos) << r.logs();
}

// Issue 13: "4 frames shown (4 incomplete)" exited 0. With a 1 ms deadline no frame's data can
// arrive in time (the client loads the scene and shoots 20 000 photons per set first): every
// frame is incomplete, and the run ends with kExitNoCompleteFrame and says so.
TEST(Faults, RunWithoutACompleteFrameExitsWithItsOwnCode) {
    FaultRun r;
    r.startServer(sceneFlags(3, {"--deadline-ms", "1"}, 20000), 1);
    r.startClient({"--rejoin-timeout", "0"});
    auto st = r.waitFor(*r.server, 60s);
    EXPECT_TRUE(st.exited) << r.logs();
    EXPECT_EQ(st.code, server::kExitNoCompleteFrame) << r.logs();
    EXPECT_NE(r.server->err().find("no frame was complete"), std::string::npos) << r.logs();
    EXPECT_NE(r.server->out().find("3 frames shown (3 incomplete)"), std::string::npos) << r.logs();
}

}  // namespace
}  // namespace rtpm::test
