// Soak (label `soak`, issues 13 and 26): a service cluster on loopback under a bounded flood of
// hostile peers on the cluster port (garbage bytes, tokenless Hellos, Hello then garbage,
// oversized and stalled announcements, idle sockets) and on the viewer's HTTP port (idle and slow
// requests, forged Origins, wrong tokens, WebSockets that never say hello) while one client is
// killed and restarted periodically. Frames must keep flowing in every period, the master's
// resident memory, open descriptors and log must stay flat (sampled from /proc), a viewer with
// the token must still get frames, and the image written at SIGTERM must be complete and finite.
// Duration: RTPM_SOAK_SECONDS (default 150); every loop is bounded by it.
#include <gtest/gtest.h>

#include <dirent.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "client/worker.h"
#include "common/core/interleave.h"
#include "common/image/image_io.h"
#include "proto/messages.h"
#include "tests/support/cluster_util.h"
#include "tests/support/ws_client.h"

namespace rtpm::test {
namespace {

using namespace std::chrono_literals;

const std::string kToken = "3e8a1f5c90d27b64e1c8a3f05d9b27e6";  // `openssl rand -hex 16`

/// RTPM_SOAK_SECONDS, or 150 when unset. A value that is not a whole number of seconds in
/// [30, 3600] fails the test by name rather than running some other length.
int soakSeconds() {
    const char* env = std::getenv("RTPM_SOAK_SECONDS");
    if (!env) return 150;
    char* end = nullptr;
    const long s = std::strtol(env, &end, 10);
    if (end == env || *end != '\0' || s < 30 || s > 3600)
        throw std::invalid_argument(std::string("RTPM_SOAK_SECONDS=") + env + ": need whole seconds in [30, 3600]");
    return int(s);
}

/// Resident set size of `pid` in KiB (VmRSS), 0 if unreadable.
long rssKiB(pid_t pid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string key;
    long value = 0;
    while (in >> key) {
        if (key == "VmRSS:") {
            in >> value;
            return value;
        }
        in.ignore(1 << 12, '\n');
    }
    return 0;
}

/// Open file descriptors of `pid`, -1 if unreadable.
int openFds(pid_t pid) {
    DIR* d = opendir(("/proc/" + std::to_string(pid) + "/fd").c_str());
    if (!d) return -1;
    int n = 0;
    while (dirent* e = readdir(d))
        if (e->d_name[0] != '.') ++n;
    closedir(d);
    return n;
}

size_t framesShown(const std::string& out) {
    size_t n = 0;
    for (size_t at = out.find("\nframe "); at != std::string::npos; at = out.find("\nframe ", at + 1)) ++n;
    return n;
}

std::vector<uint8_t> rawHeader(uint16_t type, uint32_t payloadBytes) {
    proto::Writer w;
    w.u32(proto::kMagic);
    w.u16(proto::kProtocolVersion);
    w.u16(type);
    w.u32(0);
    w.u32(payloadBytes);
    return w.take();
}

/// Hostile peers, one kind after another, until `stop`: each is bounded (short receive timeouts),
/// at most kIdle idle sockets are held open at once, and the rate is capped.
class Flood {
public:
    static constexpr size_t kIdle = 16;
    explicit Flood(uint16_t port) : port_(port), thread_([this] { run(); }) {}
    ~Flood() {
        stop_ = true;
        thread_.join();
    }
    uint64_t peers() const { return peers_; }

private:
    void run() {
        std::deque<Socket> idle;
        std::vector<uint8_t> garbage(512);
        for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = uint8_t(i * 131 + 7);
        proto::Hello tokenless;  // never proves the token
        tokenless.clientName = "tokenless";
        for (uint64_t i = 0; !stop_; ++i) {
            Socket s = Socket::connectLocal(port_);
            ++peers_;
            if (s.valid()) {
                proto::Message m;
                switch (i % 6) {
                    case 0: s.sendAll(garbage); break;
                    case 1: s.send(tokenless); s.receive(m, 2s); break;
                    case 2: s.send(tokenless); s.sendAll(garbage); s.receive(m, 2s); break;
                    case 3:  // beyond any type's limit: refused from the header alone
                        s.sendAll(rawHeader(uint16_t(proto::MessageType::FrameData), 0xFFFFFFF0u));
                        break;
                    case 4: {  // at the limit, a few KiB of it, then stalled (the handshake timeout)
                        std::vector<uint8_t> b = rawHeader(uint16_t(proto::MessageType::Scene), 256u << 20);
                        b.resize(b.size() + 4096, 0xAB);
                        s.sendAll(b);
                        break;
                    }
                    case 5: break;  // connects and says nothing
                }
                if (i % 6 == 4 || i % 6 == 5) {
                    idle.push_back(std::move(s));
                    if (idle.size() > kIdle) idle.pop_front();
                }
            }
            std::this_thread::sleep_for(20ms);  // ≤ 50 peers/s
        }
    }
    uint16_t port_;
    std::atomic<bool> stop_{false};
    std::atomic<uint64_t> peers_{0};
    std::thread thread_;
};

/// Hostile peers of the viewer's HTTP port, one kind after another from two addresses, until
/// `stop`: at most kIdle sockets held open at once, ≤ 50 peers a second (about 8: each wrong
/// token is answered after 0.5 s).
class ViewerFlood {
public:
    static constexpr size_t kIdle = 16;
    explicit ViewerFlood(uint16_t port) : port_(port), thread_([this] { run(); }) {}
    ~ViewerFlood() {
        stop_ = true;
        thread_.join();
    }
    uint64_t peers() const { return peers_; }

private:
    void run() {
        std::deque<RawHttp> idle;
        const std::string forged = "Origin: http://x\nrtpm-server: client 1 (forged) joined\x1b[2J" + std::string(8000, 'A') + "\r\n";
        for (uint64_t i = 0; !stop_; ++i) {
            RawHttp c(port_, i % 2 ? "127.0.0.7" : "127.0.0.8");
            ++peers_;
            if (c.valid()) {
                switch (i % 5) {
                    case 0: break;                                    // connects and says nothing
                    case 1: c.sendRaw("GET / HTTP/1.1\r\nHost: x\r\nX-Slow: "); break;  // never ends
                    case 2: c.request("/ws", true, forged, 1s); break;  // refused for its Origin
                    case 3:                                          // a wrong token
                        if (c.request("/ws", true, "", 1s) == 101) {
                            c.sendText(R"({"type":"hello","token":"0f9e8d7c6b5a4f3e2d1c0b9a8f7e6d5c"})");
                            c.readText(1s);
                        }
                        break;
                    case 4: c.request("/ws", true, "", 1s); break;   // a WebSocket that never says hello
                }
                if (i % 5 != 2 && i % 5 != 3) {
                    idle.push_back(std::move(c));
                    if (idle.size() > kIdle) idle.pop_front();
                }
            }
            std::this_thread::sleep_for(20ms);
        }
    }
    uint16_t port_;
    std::atomic<bool> stop_{false};
    std::atomic<uint64_t> peers_{0};
    std::thread thread_;
};

/// A viewer with the token: hello answered with controls, then a frame (binary) within `timeout`.
bool viewerGetsAFrame(uint16_t port, std::chrono::milliseconds timeout) {
    RawHttp v(port, "127.0.0.9");
    if (v.request("/ws", true, "") != 101) return false;
    v.sendText(R"({"type":"hello","token":")" + kToken + R"("})");
    auto hello = v.readText(5s);
    if (!hello || hello->find(R"("control":true)") == std::string::npos) return false;
    return v.readBinary(timeout);
}

TEST(Soak, ClusterUnderHostileFloodWithAClientRestartedPeriodically) {
    const int seconds = soakSeconds();
    const auto period = 15s;
    TempDir dir;
    const std::string out = dir.file("soak.exr");
    Child server({binaryPath("server/rtpm-server"), "--port", "0", "--port-file", dir.file("port"), "--min-clients",
                  "1", "--encoding", "float32", "--scene", "RING", "--width", "96", "--height", "72", "-M", "3",
                  "-P", "2000", "--frames", "0", "--http", "127.0.0.1:0", "--out", out},
                 dir.file("server"), {"RTPM_TOKEN=" + kToken});
    const uint16_t port = waitForPortFile(dir.file("port"), server, 30s);
    ASSERT_NE(port, 0) << server.logs();
    uint16_t http = 0;
    ASSERT_TRUE(waitUntil([&] {
        const std::string o = server.out();
        const size_t at = o.find("viewer: http://127.0.0.1:");
        if (at != std::string::npos) http = uint16_t(std::atoi(o.c_str() + at + 25));
        return http != 0;
    }, 30s)) << server.logs();
    auto client = [&](const std::string& name, int generation) {
        return std::make_unique<Child>(
            std::vector<std::string>{binaryPath("client/rtpm-client"), "--server", "127.0.0.1:" + std::to_string(port),
                                     "--token", kToken, "--threads", "1", "--name", name, "--connect-timeout", "30"},
            dir.file(name + "-" + std::to_string(generation)));
    };
    auto stable = client("stable", 0);
    int generation = 0;
    auto restarted = client("restarted", generation);
    ASSERT_TRUE(waitUntil([&] { return framesShown(server.out()) >= 5 || server.poll(); }, 60s)) << server.logs();

    struct Sample {
        double t;
        long rss;
        int fds;
    };
    std::vector<Sample> samples;
    std::vector<size_t> framesPerPeriod;
    const auto start = Clock::now();
    uint64_t floodPeers = 0, viewerFloodPeers = 0;
    const int fdBefore = openFds(server.pid());
    {
        Flood flood(port);
        ViewerFlood viewerFlood(http);
        auto nextRestart = start + period;
        size_t framesAtPeriodStart = framesShown(server.out());
        while (Clock::now() - start < std::chrono::seconds(seconds) && !server.poll()) {
            std::this_thread::sleep_for(1s);
            samples.push_back({std::chrono::duration<double>(Clock::now() - start).count(), rssKiB(server.pid()),
                               openFds(server.pid())});
            if (Clock::now() >= nextRestart) {
                const size_t now = framesShown(server.out());
                framesPerPeriod.push_back(now - framesAtPeriodStart);
                framesAtPeriodStart = now;
                restarted->signal(SIGKILL);
                restarted->wait(10s);
                restarted = client("restarted", ++generation);
                nextRestart += period;
            }
        }
        floodPeers = flood.peers();
        viewerFloodPeers = viewerFlood.peers();
        // A viewer with the token gets in and gets frames while the flood runs.
        EXPECT_TRUE(viewerGetsAFrame(http, 10s)) << server.logs();
    }
    ASSERT_FALSE(server.poll()) << "the master ended during the soak\n" << server.logs();
    ASSERT_GE(samples.size(), 20u);

    // Memory and descriptors: the later part of the run holds no more than the early part.
    auto window = [&](double from, double to, auto field) {
        long m = 0;
        for (const Sample& s : samples)
            if (s.t >= from * seconds && s.t < to * seconds) m = std::max<long>(m, field(s));
        return m;
    };
    const long rssEarly = window(0.15, 0.4, [](const Sample& s) { return s.rss; });
    const long rssLate = window(0.7, 1.01, [](const Sample& s) { return s.rss; });
    const long fdEarly = window(0.15, 0.4, [](const Sample& s) { return long(s.fds); });
    const long fdLate = window(0.7, 1.01, [](const Sample& s) { return long(s.fds); });
    std::printf("soak: %d s, %llu hostile peers on the cluster port and %llu on the viewer's, %d client restarts, "
                "frames per %lld s period:", seconds, (unsigned long long)floodPeers,
                (unsigned long long)viewerFloodPeers, generation, (long long)period.count());
    for (size_t f : framesPerPeriod) std::printf(" %zu", f);
    std::printf("\nsoak: master RSS max %ld KiB early, %ld KiB late; open fds max %ld early, %ld late\n", rssEarly,
                rssLate, fdEarly, fdLate);
    EXPECT_GT(floodPeers, uint64_t(seconds) * 10) << "the flood did not run";
    EXPECT_GT(viewerFloodPeers, uint64_t(seconds) * 4) << "the viewer flood did not run";  // a wrong token waits 0.5 s
    // The log: summary lines (one per 10 s and port at most), never a line per hostile peer.
    const std::string err = server.err();
    const size_t errLines = size_t(std::count(err.begin(), err.end(), '\n'));
    EXPECT_LE(errLines, size_t(seconds) / 5 + 4 * size_t(generation) + 20) << err.substr(0, 4000);
    for (char ch : err) ASSERT_TRUE(ch == '\n' || (uint8_t(ch) >= 0x20 && ch != 0x7f)) << "control byte in the log";
    EXPECT_LE(rssLate, rssEarly + rssEarly / 4 + 16 * 1024) << "master memory grows under the flood";
    EXPECT_LE(fdLate, fdEarly + 4) << "master descriptors grow under the flood";
    ASSERT_FALSE(framesPerPeriod.empty());
    for (size_t i = 0; i < framesPerPeriod.size(); ++i)
        EXPECT_GE(framesPerPeriod[i], 5u) << "period " << i << ": frames stopped flowing\n" << server.err();

    // Once the flood stopped, every hostile socket is closed by the master (handshake timeout):
    // back to the descriptors it held before the flood (+2: a restarted client's old and new
    // connection may overlap for a moment).
    EXPECT_TRUE(waitUntil([&] { return openFds(server.pid()) <= fdBefore + 2; }, 30s))
        << "open fds " << openFds(server.pid()) << ", " << fdBefore << " before the flood";

    // The final image: both clients in, SIGTERM, complete and finite.
    const size_t before = framesShown(server.out());
    ASSERT_TRUE(waitUntil([&] { return framesShown(server.out()) >= before + 5; }, 60s)) << server.logs();
    server.signal(SIGTERM);
    auto st = server.wait(60s);
    ASSERT_TRUE(st && st->exited && st->code == 0) << server.logs();
    const std::string o = server.out();
    const size_t last = o.rfind("\nframe ");
    ASSERT_NE(last, std::string::npos);
    EXPECT_NE(o.substr(last, o.find('\n', last + 1) - last).find("sets   9/9"), std::string::npos)
        << "last frame incomplete: " << o.substr(last);
    const ExrImage img = readExr(out);
    const Interleave pattern{96, 72, 3};
    std::vector<double> setDirect(size_t(pattern.setCount()), 0.0);
    const std::vector<float> direct = img.layerRgb("direct");
    size_t nonFinite = 0;
    for (const char* layer : {"", "direct", "caustic", "caustic_filtered"})
        for (float v : img.layerRgb(layer)) nonFinite += !std::isfinite(v);
    for (int y = 0; y < 72; ++y)
        for (int x = 0; x < 96; ++x)
            for (int c = 0; c < 3; ++c) setDirect[size_t(pattern.setOf(x, y))] += direct[size_t(y * 96 + x) * 3 + c];
    EXPECT_EQ(nonFinite, 0u);
    for (int s = 0; s < pattern.setCount(); ++s) EXPECT_GT(setDirect[size_t(s)], 0.0) << "set " << s << " is empty";
    auto a = stable->wait(20s);
    auto b = restarted->wait(20s);
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->code, client::kExitServerGone);
    EXPECT_EQ(b->code, client::kExitServerGone);
}

}  // namespace
}  // namespace rtpm::test
