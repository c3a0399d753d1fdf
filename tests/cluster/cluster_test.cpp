// rtpm-server + N rtpm-client processes on loopback: the image equals rtpm-render's, a killed
// client does not stop the run, hostile peers are closed, a client outlives no server.
#include <gtest/gtest.h>

#include <signal.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <map>

#include "client/worker.h"
#include "tests/support/cluster_util.h"
#include "common/image/image_io.h"
#include "common/core/interleave.h"

namespace rtpm::test {
namespace {

using namespace std::chrono_literals;

const std::string kToken = "cluster-test-token";

/// Settings shared by the cluster and the reference: small so a run takes about a second.
struct RunSettings {
    int width = 96, height = 72, m = 3, frames = 3, photons = 2000;
    std::vector<std::string> extra;  ///< more shared flags

    /// Flags that rtpm-render and rtpm-server share (README: "The main ones, shared by rtpm-server").
    std::vector<std::string> flags() const {
        std::vector<std::string> f{"--scene", "RING", "--width", std::to_string(width), "--height",
                                   std::to_string(height), "-M", std::to_string(m), "--frames",
                                   std::to_string(frames), "-P", std::to_string(photons)};
        f.insert(f.end(), extra.begin(), extra.end());
        return f;
    }
    std::string key() const {
        std::string k;
        for (const std::string& f : flags()) k += f + " ";
        return k;
    }
};

/// Where rtpm-render's image for `rs` is (or will be) written: one file per settings.
std::filesystem::path referencePath(const RunSettings& rs) {
    static TempDir dir;
    static std::map<std::string, std::string> names;
    auto it = names.find(rs.key());
    if (it == names.end()) it = names.emplace(rs.key(), dir.file("ref" + std::to_string(names.size()) + ".exr")).first;
    return it->second;
}

/// rtpm-render's image for `rs`, rendered once per settings and kept for the whole binary.
const ExrImage& reference(const RunSettings& rs) {
    static std::map<std::string, ExrImage> cache;
    auto it = cache.find(rs.key());
    if (it != cache.end()) return it->second;
    const std::string out = referencePath(rs).string();
    const std::string name = referencePath(rs).stem().string();
    const std::string dirPath = referencePath(rs).parent_path().string();
    std::vector<std::string> argv{binaryPath("common/cmd/rtpm-render")};
    for (const std::string& f : rs.flags()) argv.push_back(f);
    argv.insert(argv.end(), {"--out", out});
    Child render(argv, dirPath + "/" + name);
    auto st = render.wait(60s);
    if (!st || !st->exited || st->code != 0) throw std::runtime_error("rtpm-render failed\n" + render.logs());
    return cache.emplace(rs.key(), readExr(out)).first->second;
}

/// A server and its clients in a temp dir; every process is killed and reaped on destruction.
struct Cluster {
    TempDir dir;
    std::unique_ptr<Child> server;
    uint16_t port = 0;
    std::vector<std::unique_ptr<Child>> clients;

    std::string outPath() const { return dir.file("cluster.exr"); }

    void startServer(const RunSettings& rs, int minClients, const std::string& encoding,
                     std::vector<std::string> extra = {}) {
        std::vector<std::string> argv{binaryPath("server/rtpm-server"), "--port", "0", "--port-file",
                                      dir.file("port"), "--min-clients", std::to_string(minClients),
                                      "--encoding", encoding, "--out", outPath()};
        for (const std::string& f : rs.flags()) argv.push_back(f);
        for (const std::string& f : extra) argv.push_back(f);
        server = std::make_unique<Child>(argv, dir.file("server"), std::vector<std::string>{"RTPM_TOKEN=" + kToken});
        port = waitForPortFile(dir.file("port"), *server, 30s);
        ASSERT_NE(port, 0) << "server never wrote its port\n" << server->logs();
    }

    Child& startClient(std::vector<std::string> extra = {}) {
        std::vector<std::string> argv{binaryPath("client/rtpm-client"), "--server",
                                      "127.0.0.1:" + std::to_string(port), "--token", kToken, "--threads", "1",
                                      "--connect-timeout", "20", "--verbose"};
        for (const std::string& f : extra) argv.push_back(f);
        clients.push_back(
            std::make_unique<Child>(argv, dir.file("client" + std::to_string(clients.size()))));
        return *clients.back();
    }

    std::string logs() const {
        std::string s = "=== server\n" + (server ? server->logs() : std::string());
        for (size_t i = 0; i < clients.size(); ++i) s += "=== client " + std::to_string(i) + "\n" + clients[i]->logs();
        return s;
    }

    /// Waits for the server to finish; expects exit 0.
    void expectServerFinishes(std::chrono::milliseconds timeout = 60s) {
        auto st = server->wait(timeout);
        ASSERT_TRUE(st) << "server did not finish\n" << logs();
        ASSERT_TRUE(st->exited && st->code == 0) << "server exit " << st->code << " signal " << st->signal << "\n"
                                                 << logs();
    }
    void expectClientExits(Child& c, int code) {
        auto st = c.wait(20s);
        ASSERT_TRUE(st) << "client did not exit\n" << logs();
        EXPECT_TRUE(st->exited && st->code == code)
            << "client exit " << st->code << " signal " << st->signal << "\n" << logs();
    }
};

/// Layers of the DESIGN §6 EXR, "" = final.
const char* const kLayers[] = {"direct", "caustic", "caustic_filtered", ""};

void expectBitIdentical(const ExrImage& got, const ExrImage& want, const std::string& layer) {
    ASSERT_EQ(got.width, want.width);
    ASSERT_EQ(got.height, want.height);
    const std::vector<float> a = got.layerRgb(layer), b = want.layerRgb(layer);
    ASSERT_EQ(a.size(), b.size());
    size_t differing = 0, first = a.size();
    for (size_t i = 0; i < a.size(); ++i)
        if (std::memcmp(&a[i], &b[i], sizeof(float)) != 0) {
            if (!differing) first = i;
            ++differing;
        }
    EXPECT_EQ(differing, 0u) << "layer '" << layer << "': " << differing << " of " << a.size()
                             << " values differ; first at pixel " << first / 3 << ": "
                             << (first < a.size() ? a[first] : 0.0f) << " vs " << (first < b.size() ? b[first] : 0.0f);
}

/// Pixel values must be non-trivial somewhere, or an all-black image would equal a black one.
void expectNonTrivial(const ExrImage& img) {
    for (const char* layer : {"direct", "caustic"}) {
        const std::vector<float> v = img.layerRgb(layer);
        size_t positive = 0;
        for (float x : v) positive += x > 0.0f;
        EXPECT_GT(positive, v.size() / 100) << "layer " << layer << " is almost black: the test would prove nothing";
    }
}

class ClusterImage : public ::testing::TestWithParam<int> {};

TEST_P(ClusterImage, EqualsSingleProcessBitForBitWithFloat32Pixels) {
    const int n = GetParam();
    RunSettings rs;
    const ExrImage& ref = reference(rs);
    expectNonTrivial(ref);
    Cluster c;
    c.startServer(rs, n, "float32");
    for (int i = 0; i < n; ++i) c.startClient();
    c.expectServerFinishes();
    for (auto& cl : c.clients) c.expectClientExits(*cl, client::kExitOk);
    const ExrImage got = readExr(c.outPath());
    for (const char* layer : kLayers) expectBitIdentical(got, ref, layer);
}

INSTANTIATE_TEST_SUITE_P(Clients, ClusterImage, ::testing::Values(1, 2, 3),
                         [](const ::testing::TestParamInfo<int>& i) { return std::to_string(i.param) + "Clients"; });

// The progressive estimator (the default) keeps per-pixel state on the clients and fades the box
// filter by each set's pass count: the cluster must equal rtpm-render at every frame, not only
// at the last (frames 1 … 4 written by --save-every on both sides, and the final image), with
// the knn estimator too.
class ClusterEveryFrame : public ::testing::TestWithParam<const char*> {};

TEST_P(ClusterEveryFrame, EqualsSingleProcessBitForBitAtEveryFrame) {
    RunSettings rs;
    rs.frames = 5;
    rs.extra = {"--estimator", GetParam(), "--save-every", "1"};
    const ExrImage& ref = reference(rs);  // the renders' numbered frames sit beside the reference
    expectNonTrivial(ref);
    Cluster c;
    c.startServer(rs, 2, "float32");
    c.startClient();
    c.startClient();
    c.expectServerFinishes();
    for (auto& cl : c.clients) c.expectClientExits(*cl, client::kExitOk);
    for (const char* layer : kLayers) expectBitIdentical(readExr(c.outPath()), ref, layer);
    const std::filesystem::path refDir = referencePath(rs).parent_path();
    const std::string refStem = referencePath(rs).stem().string();
    for (int f = 1; f < rs.frames; ++f) {
        char suffix[16];
        std::snprintf(suffix, sizeof suffix, "_%05d.exr", f);
        const ExrImage want = readExr((refDir / (refStem + suffix)).string());
        const ExrImage got = readExr(c.dir.file(std::string("cluster") + suffix));
        SCOPED_TRACE("frame " + std::to_string(f));
        for (const char* layer : kLayers) expectBitIdentical(got, want, layer);
    }
}

INSTANTIATE_TEST_SUITE_P(Estimators, ClusterEveryFrame, ::testing::Values("progressive", "knn"));

// Every setting that reaches the clients through Settings, away from its default, must reach
// them intact (seed, both depth limits, area-light samples, k, r_max, filter, diffuse bounces).
TEST(ClusterImageSettings, NonDefaultSettingsStillGiveTheSingleProcessImage) {
    RunSettings rs;
    rs.m = 2;
    rs.extra = {"--seed", "987654321", "--depth", "6", "--photon-depth", "9", "--area-samples", "2",
                "--k", "24", "--rmax", "0.3", "-F", "3", "--diffuse-bounces", "0", "--no-spt"};
    const ExrImage& ref = reference(rs);
    expectNonTrivial(ref);
    Cluster c;
    c.startServer(rs, 2, "float32");
    c.startClient();
    c.startClient();
    c.expectServerFinishes();
    for (auto& cl : c.clients) c.expectClientExits(*cl, client::kExitOk);
    const ExrImage got = readExr(c.outPath());
    for (const char* layer : kLayers) expectBitIdentical(got, ref, layer);
}

// RGB9E5 keeps 9 mantissa bits under a shared exponent: each channel is off by at most half a
// unit of the largest channel's mantissa (≤ 2^-9 of it), values under 2^-24 flush to 0.
TEST(ClusterImageRgb9e5, EqualsSingleProcessWithinTheEncodingsPrecision) {
    RunSettings rs;
    const ExrImage& ref = reference(rs);
    Cluster c;
    c.startServer(rs, 2, "rgb9e5");
    c.startClient();
    c.startClient();
    c.expectServerFinishes();
    for (auto& cl : c.clients) c.expectClientExits(*cl, client::kExitOk);
    const ExrImage got = readExr(c.outPath());
    const int w = ref.width, h = ref.height, f = rs.m;  // F = 0 → F = M
    const float rel = std::ldexp(1.0f, -9), floor = std::ldexp(1.0f, -24);
    auto maxChannel = [](const std::vector<float>& v, size_t px) {
        return std::max({v[px * 3], v[px * 3 + 1], v[px * 3 + 2]});
    };
    const std::vector<float> rd = ref.layerRgb("direct"), rc = ref.layerRgb("caustic");
    std::vector<float> boundDirect(size_t(w * h)), boundCaustic(size_t(w * h)), boundFiltered(size_t(w * h));
    for (size_t px = 0; px < size_t(w * h); ++px) {
        boundDirect[px] = rel * maxChannel(rd, px) * 1.0001f + floor;
        boundCaustic[px] = rel * maxChannel(rc, px) * 1.0001f + floor;
    }
    // A filtered pixel averages caustic pixels of its window: its error is at most the largest
    // bound in the window (whatever the border rule, the clipped window lies inside this one).
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float b = 0.0f;
            for (int dy = -f; dy <= f; ++dy)
                for (int dx = -f; dx <= f; ++dx) {
                    const int xx = x + dx, yy = y + dy;
                    if (xx >= 0 && yy >= 0 && xx < w && yy < h) b = std::max(b, boundCaustic[size_t(yy * w + xx)]);
                }
            boundFiltered[size_t(y * w + x)] = b;
        }
    struct Check {
        const char* layer;
        std::function<float(size_t)> bound;
    };
    const Check checks[] = {
        {"direct", [&](size_t px) { return boundDirect[px]; }},
        {"caustic", [&](size_t px) { return boundCaustic[px]; }},
        {"caustic_filtered", [&](size_t px) { return boundFiltered[px]; }},
        {"", [&](size_t px) { return boundDirect[px] + boundFiltered[px] + floor; }},
    };
    for (const Check& ch : checks) {
        const std::vector<float> a = got.layerRgb(ch.layer), b = ref.layerRgb(ch.layer);
        ASSERT_EQ(a.size(), b.size());
        size_t over = 0, exact = 0;
        for (size_t i = 0; i < a.size(); ++i) {
            over += !(std::fabs(a[i] - b[i]) <= ch.bound(i / 3));
            exact += a[i] == b[i];
        }
        EXPECT_EQ(over, 0u) << "layer '" << ch.layer << "': " << over << " values beyond RGB9E5 precision";
        // Quantisation must actually have happened, or this test checks the Float32 path.
        if (std::string(ch.layer) == "direct") {
            EXPECT_LT(exact, a.size()) << "no value changed by RGB9E5?";
        }
    }
}

/// Sets a client rendered in frame 0 (its --verbose line "frame 0: sets 0,2,4, …").
std::vector<uint32_t> frameZeroSets(const std::string& out) {
    std::vector<uint32_t> sets;
    const std::string tag = "frame 0: sets ";
    const size_t at = out.find(tag);
    if (at == std::string::npos) return sets;
    std::string list = out.substr(at + tag.size());
    list = list.substr(0, list.find_first_of(" \n"));
    if (!list.empty() && list.back() == ',') list.pop_back();
    std::stringstream ls(list);
    std::string token;
    while (std::getline(ls, token, ','))
        if (!token.empty() && token != "none") sets.push_back(uint32_t(std::stoul(token)));
    return sets;
}

// With the knn estimator direct light does not depend on photons or on history; with the
// progressive one (the default) a set's direct light averages the area-light samples of its
// progression, so only the sets that never moved must equal the reference bit for bit (their
// progression was never restarted), while the moved sets restarted on the survivor.
class ClusterResilienceKill : public ::testing::TestWithParam<const char*> {};

TEST_P(ClusterResilienceKill, KilledClientDoesNotStopTheRunAndTheImageIsComplete) {
    const bool knn = std::string(GetParam()) == "knn";
    RunSettings rs;
    rs.frames = 40;
    rs.extra = {"--estimator", GetParam()};
    const ExrImage& ref = reference(rs);
    Cluster c;
    c.startServer(rs, 2, "float32");
    Child& survivor = c.startClient();
    Child& victim = c.startClient();
    // Kill once the victim has rendered two frames: the run is then under way.
    ASSERT_TRUE(waitUntil([&] { return victim.out().find("frame 1:") != std::string::npos || victim.poll(); }, 30s))
        << c.logs();
    victim.signal(SIGKILL);
    auto vst = victim.wait(5s);
    ASSERT_TRUE(vst);
    ASSERT_FALSE(vst->exited) << "the victim finished before it could be killed: the run was too short\n" << c.logs();
    c.expectServerFinishes();
    c.expectClientExits(survivor, client::kExitOk);

    const ExrImage got = readExr(c.outPath());
    // knn: direct light does not depend on photons: every set, moved or not, must equal the
    // reference. A set missing at the end would be black (or stale, which direct light cannot
    // show, hence the caustic checks below).
    if (knn) expectBitIdentical(got, ref, "direct");
    // The survivor's own sets kept their photon maps (only the victim's moved): their caustics
    // equal the reference's after the same number of batches; the moved sets restarted on the
    // survivor and must hold some caustic light of their own.
    const std::vector<uint32_t> kept = frameZeroSets(survivor.out());
    ASSERT_FALSE(kept.empty()) << c.logs();
    const Interleave pattern{rs.width, rs.height, rs.m};
    const std::vector<float> a = got.layerRgb("caustic"), b = ref.layerRgb("caustic");
    const std::vector<float> da = got.layerRgb("direct"), db = ref.layerRgb("direct");
    double movedDirect = 0.0, movedDirectRef = 0.0;
    std::vector<bool> isKept(size_t(pattern.setCount()), false);
    for (uint32_t s : kept) isKept[s] = true;
    std::vector<double> movedSum(size_t(pattern.setCount()), 0.0);
    size_t keptDiffering = 0;
    for (int y = 0; y < rs.height; ++y)
        for (int x = 0; x < rs.width; ++x) {
            const int set = pattern.setOf(x, y);
            const size_t px = size_t(y * rs.width + x) * 3;
            for (int ch = 0; ch < 3; ++ch) {
                if (isKept[size_t(set)]) {
                    keptDiffering += std::memcmp(&a[px + ch], &b[px + ch], sizeof(float)) != 0;
                    keptDiffering += std::memcmp(&da[px + ch], &db[px + ch], sizeof(float)) != 0;
                } else {
                    movedSum[size_t(set)] += a[px + ch];
                    movedDirect += da[px + ch];
                    movedDirectRef += db[px + ch];
                }
            }
        }
    EXPECT_EQ(keptDiffering, 0u) << "sets that never moved differ from the reference\n" << c.logs();
    // The moved sets' direct light is a restarted average of the same light: within 5 % of the
    // reference's in total (area-light sampling noise over a few hundred pixels is far smaller).
    EXPECT_NEAR(movedDirect, movedDirectRef, 0.05 * movedDirectRef);
    for (int s = 0; s < pattern.setCount(); ++s)
        if (!isKept[size_t(s)]) {
            EXPECT_GT(movedSum[size_t(s)], 0.0) << "moved set " << s << " has no caustic light";
        }
}

INSTANTIATE_TEST_SUITE_P(Estimators, ClusterResilienceKill, ::testing::Values("progressive", "knn"));

/// A 16-byte header as the protocol lays it out (PROTOCOL.md), with any field value.
std::vector<uint8_t> rawHeader(uint16_t version, uint16_t type, uint32_t payloadBytes) {
    proto::Writer w;
    w.u32(proto::kMagic);
    w.u16(version);
    w.u16(type);
    w.u32(0);
    w.u32(payloadBytes);
    return w.take();
}

/// Connects a hostile peer, sends `bytes`, and expects the server to close the connection
/// (after an optional Reject, whose reason is returned).
std::optional<proto::RejectReason> expectClosedAfter(uint16_t port, const std::vector<uint8_t>& bytes,
                                                     const std::string& what, const Cluster& c) {
    Socket s = Socket::connectLocal(port);
    EXPECT_TRUE(s.valid()) << what;
    if (!s.valid()) return std::nullopt;
    s.sendAll(bytes);  // the server may close before reading it all
    std::optional<proto::RejectReason> reason;
    proto::Message m;
    Socket::Got g = s.receive(m, 10s);
    if (g == Socket::Got::Message && std::holds_alternative<proto::Reject>(m)) {
        reason = std::get<proto::Reject>(m).reason;
        EXPECT_TRUE(s.waitClosed(10s)) << what << ": not closed after Reject\n" << c.logs();
    } else {
        EXPECT_TRUE(g == Socket::Got::Closed || s.waitClosed(10s)) << what << ": not closed\n" << c.logs();
    }
    return reason;
}

TEST(ClusterResilience, HostilePeersAreClosedWhileARealClientFinishes) {
    RunSettings rs;
    rs.frames = 20;
    const ExrImage& ref = reference(rs);
    Cluster c;
    c.startServer(rs, 1, "float32");

    std::vector<uint8_t> garbage(256);
    for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = uint8_t(i * 131 + 7);
    expectClosedAfter(c.port, garbage, "garbage", c);

    // A header announcing 4 GiB - 16 bytes: must be refused from the header alone.
    expectClosedAfter(c.port, rawHeader(proto::kProtocolVersion, uint16_t(proto::MessageType::Hello), 0xFFFFFFF0u),
                      "oversized header", c);

    proto::Hello hello;
    hello.authToken = kToken;
    hello.clientName = "hostile";
    std::vector<uint8_t> good = proto::encode(hello);
    // Same Hello under another header version.
    std::vector<uint8_t> wrongHeader = good;
    wrongHeader[4] = uint8_t(proto::kProtocolVersion + 1);
    auto r = expectClosedAfter(c.port, wrongHeader, "wrong header version", c);
    if (r) {
        EXPECT_EQ(*r, proto::RejectReason::VersionMismatch);
    }
    // A well-formed Hello announcing another protocol version.
    proto::Hello future = hello;
    future.protocolVersion = proto::kProtocolVersion + 1;
    r = expectClosedAfter(c.port, proto::encode(future), "wrong Hello version", c);
    ASSERT_TRUE(r) << "no Reject for a wrong Hello.protocolVersion\n" << c.logs();
    EXPECT_EQ(*r, proto::RejectReason::VersionMismatch);
    // The right version with a wrong token.
    proto::Hello bad = hello;
    bad.authToken = "not-the-token";
    r = expectClosedAfter(c.port, proto::encode(bad), "bad token", c);
    ASSERT_TRUE(r) << "no Reject for a bad token\n" << c.logs();
    EXPECT_EQ(*r, proto::RejectReason::BadToken);

    // None of them counted as a client: the real one now joins and renders the whole run, while
    // one more garbage peer arrives mid-run.
    Child& real = c.startClient();
    ASSERT_TRUE(waitUntil([&] { return real.out().find("frame 0:") != std::string::npos || real.poll(); }, 30s))
        << c.logs();
    if (!c.server->poll()) {
        Socket late = Socket::connectLocal(c.port);
        if (late.valid()) {
            late.sendAll(garbage);
            EXPECT_TRUE(late.waitClosed(10s)) << "mid-run garbage peer not closed\n" << c.logs();
        }
    }
    c.expectServerFinishes();
    c.expectClientExits(real, client::kExitOk);
    const ExrImage got = readExr(c.outPath());
    for (const char* layer : kLayers) expectBitIdentical(got, ref, layer);
}

TEST(ClusterResilience, ClientWhoseServerDiesExitsThreeWithAClearMessage) {
    RunSettings rs;
    rs.frames = 100000;  // never finishes on its own
    Cluster c;
    c.startServer(rs, 1, "float32");
    Child& cl = c.startClient();
    ASSERT_TRUE(waitUntil([&] { return cl.out().find("frame 0:") != std::string::npos || cl.poll(); }, 30s))
        << c.logs();
    c.server->signal(SIGKILL);
    ASSERT_TRUE(c.server->wait(5s));
    c.expectClientExits(cl, client::kExitServerGone);
    EXPECT_NE(cl.err().find("rtpm-client: server 127.0.0.1:" + std::to_string(c.port) + " closed the connection"),
              std::string::npos)
        << c.logs();
}

}  // namespace
}  // namespace rtpm::test
