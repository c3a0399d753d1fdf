// Every program's command line as a user meets it (issue 24): --version, the exit codes in
// --help, usage errors that exit 2 with the program's name and the flag meant, rtpm-render's
// progress line and summary, and SIGINT/SIGTERM writing the image rendered so far.
#include <gtest/gtest.h>

#include <signal.h>

#include <cstdlib>
#include <regex>
#include <string>
#include <vector>

#include "common/image/image_io.h"
#include "tests/support/cluster_util.h"

namespace rtpm::test {
namespace {

using namespace std::chrono_literals;

const char* const kPrograms[] = {"common/cmd/rtpm-render", "server/rtpm-server", "client/rtpm-client",
                                 "common/cmd/rtpm-compare"};

std::string programName(const std::string& rel) { return rel.substr(rel.rfind('/') + 1); }

/// Runs `rel` with `args` to its end (at most 60 s); returns the exit code.
int run(TempDir& dir, const std::string& rel, std::vector<std::string> args, std::string& out, std::string& err) {
    args.insert(args.begin(), binaryPath(rel));
    Child c(args, dir.file(programName(rel)));
    const auto st = c.wait(60s);
    out = c.out();
    err = c.err();
    if (!st) return -1;
    return st->exited ? st->code : 128 + st->signal;
}

TEST(Programs, VersionNamesTheVersionCommitAndProtocol) {
    TempDir dir;
    for (const std::string rel : kPrograms) {
        std::string out, err;
        EXPECT_EQ(run(dir, rel, {"--version"}, out, err), 0) << rel << "\n" << err;
        const std::regex format(programName(rel) + R"( \d+\.\d+\.\d+\ncommit ([0-9a-f]{12}(-dirty)?|unknown)\n)"
                                                   R"(protocol version \d+\n)");
        EXPECT_TRUE(std::regex_match(out, format)) << out;
    }
}

// --help ends with the exit codes and example command lines, shows ranges in words (before:
// "--max-scene-bytes UINT:UINT in [1 - 1099511627776]=536870912") and no default that is the help
// process's own (before: the client's --name default was the --help process's pid).
TEST(Programs, HelpListsTheExitCodesExamplesAndRangesInWords) {
    TempDir dir;
    for (const std::string rel : kPrograms) {
        std::string out, err;
        EXPECT_EQ(run(dir, rel, {"--help"}, out, err), 0) << rel << "\n" << err;
        EXPECT_NE(out.find("Exit codes:\n  0  "), std::string::npos) << out;
        EXPECT_NE(out.find("\n  2  usage error"), std::string::npos) << out;
        const size_t examples = out.find("\n\nExamples:\n  ");
        ASSERT_NE(examples, std::string::npos) << out;
        EXPECT_NE(out.find(programName(rel) + " --", examples), std::string::npos) << out;
        EXPECT_EQ(out.find(" in ["), std::string::npos) << out;
        EXPECT_EQ(out.find("NONNEGATIVE"), std::string::npos) << out;
    }
    std::string out, err;
    ASSERT_EQ(run(dir, "server/rtpm-server", {"--help"}, out, err), 0) << err;
    EXPECT_NE(out.find("--max-scene-bytes UINT=536870912"), std::string::npos) << out;
    EXPECT_NE(out.find(", [1, 1099511627776]"), std::string::npos) << out;
    ASSERT_EQ(run(dir, "client/rtpm-client", {"--help"}, out, err), 0) << err;
    EXPECT_NE(out.find("--name TEXT "), std::string::npos) << out;  // no "=HOST/<pid of --help>"
    EXPECT_NE(out.find("(default: HOST/PID)"), std::string::npos) << out;
}

// The renderers' --help lists its flags in groups, in this order (before: rtpm-render's own flags,
// --frames, --out, --csv, the camera and the light among them, stood in one flat list).
TEST(Programs, HelpGroupsTheFlags) {
    TempDir dir;
    const std::pair<const char*, std::vector<std::string>> programs[] = {
        {"server/rtpm-server", {"scene", "image", "photons", "estimator", "cluster", "viewer", "security", "output"}},
        {"common/cmd/rtpm-render", {"scene", "image", "photons", "estimator", "output"}}};
    for (const auto& [rel, groups] : programs) {
        std::string out, err;
        ASSERT_EQ(run(dir, rel, {"--help"}, out, err), 0) << err;
        size_t at = 0;
        for (const std::string& group : groups) {
            const size_t found = out.find("\n" + group + ":\n", at);
            ASSERT_NE(found, std::string::npos) << rel << ": no group '" << group << "' after offset " << at << "\n" << out;
            at = found + 1;
        }
        // Only --help, --version and flags of no group stand before the first group.
        const std::string head = out.substr(0, out.find("\n" + groups.front() + ":\n"));
        for (const char* flag : {"--frames", "--out ", "--csv", "--camera-eye", "--light "})
            EXPECT_EQ(head.find(flag), std::string::npos) << rel << ": " << flag << " outside its group\n" << head;
    }
}

TEST(Programs, AMistypedFlagExitsTwoWithTheFlagMeant) {
    TempDir dir;
    struct Case {
        const char* program;
        std::vector<std::string> args;
        const char* expected;
    };
    const Case cases[] = {
        {"common/cmd/rtpm-render", {"--frmaes", "3"}, "unknown flag --frmaes: did you mean --frames?"},
        {"server/rtpm-server", {"--insecure-no-token", "--frmaes", "3"}, "unknown flag --frmaes: did you mean --frames?"},
        {"client/rtpm-client", {"--server", "localhost", "--treads", "3"}, "unknown flag --treads: did you mean --threads?"},
        {"common/cmd/rtpm-compare", {"a.exr", "b.exr", "--lyer", "direct"}, "unknown flag --lyer: did you mean --layer?"},
        {"common/cmd/rtpm-render", {"--bogus-flag"}, "unknown flag --bogus-flag\n"},  // nothing near: no guess
    };
    for (const Case& c : cases) {
        std::string out, err;
        EXPECT_EQ(run(dir, c.program, c.args, out, err), 2) << c.program << "\n" << err;
        const std::string name = programName(c.program);
        EXPECT_NE(err.find(name + ": " + c.expected), std::string::npos) << err;
        EXPECT_NE(err.find("run '" + name + " --help'"), std::string::npos) << err;
    }
}

TEST(Programs, OutOfRangeValuesAreRefusedWithTheRange) {
    TempDir dir;
    std::string out, err;
    EXPECT_EQ(run(dir, "common/cmd/rtpm-render", {"--threads", "-1"}, out, err), 2) << err;
    EXPECT_NE(err.find("rtpm-render: --threads: Value -1 not in range 0 to 4096"), std::string::npos) << err;
    EXPECT_EQ(run(dir, "common/cmd/rtpm-render", {"-P", "0"}, out, err), 2) << err;
    EXPECT_NE(err.find("rtpm-render: --photons: Value 0 not in range 1 to 50000000"), std::string::npos) << err;
    EXPECT_EQ(run(dir, "server/rtpm-server", {"--insecure-no-token", "-P", "0"}, out, err), 2) << err;
    EXPECT_NE(err.find("rtpm-server: --photons: Value 0 not in range"), std::string::npos) << err;
    EXPECT_EQ(run(dir, "server/rtpm-server", {"--insecure-no-token", "--width", "0"}, out, err), 2) << err;
    // The image size is a row of the fixed settings' table: refused by the parser, as a knob is.
    EXPECT_NE(err.find("rtpm-server: --width: Value 0 not in range 1 to 16384"), std::string::npos) << err;
    EXPECT_EQ(run(dir, "client/rtpm-client", {"--server", "localhost", "--threads", "-1"}, out, err), 2) << err;
    EXPECT_NE(err.find("rtpm-client: --threads: Value -1 not in range 0 to 4096"), std::string::npos) << err;
    EXPECT_EQ(run(dir, "client/rtpm-client", {"--server", "host:99999"}, out, err), 2) << err;
    EXPECT_NE(err.find("is not HOST[:PORT]"), std::string::npos) << err;
}

TEST(Programs, RenderShowsProgressAndASummary) {
    TempDir dir;
    std::string out, err;
    ASSERT_EQ(run(dir, "common/cmd/rtpm-render",
                  {"--scene", "RING", "--width", "32", "--height", "24", "-P", "500", "--frames", "3", "--out",
                   dir.file("ring.exr")},
                  out, err),
              0)
        << err;
    // Not a terminal: plain lines, the last frame's always.
    EXPECT_TRUE(std::regex_search(err, std::regex(R"((^|\n)frame 3/3  elapsed [0-9.]+ s  ETA 0\.0 s  [0-9.]+ fps\n)")))
        << err;
    EXPECT_TRUE(std::regex_search(
        out, std::regex(R"(summary: 3 of 3 frames in [0-9.]+ s = [0-9.]+ fps, \d+ photons stored, \d+ photon paths)")))
        << out;
}

// rtpm-render's still view starts with every set passing, however far its first frame ran over
// the budget: the frame count a user compares with knn's holds as many photons (before: a period
// predicted from the first frame's shooting halved frame 2's photons on the curved mirror, which
// then showed more error than knn's frame 2).
TEST(Programs, RenderStillViewStartsWithEverySetPassing) {
    TempDir dir;
    std::string out, err;
    ASSERT_EQ(run(dir, "common/cmd/rtpm-render",
                  {"--scene", "RING", "--width", "32", "--height", "24", "-P", "500", "--frames", "2",
                   "--frame-budget-ms", "0.001", "--out", dir.file("ring.exr")},
                  out, err),
              0)
        << err;
    // Frame 1's pass work: one batch per set ("1/p" while the sets take turns).
    EXPECT_TRUE(std::regex_search(out, std::regex(R"((^|\n) +1 converging( +[0-9.]+){7}% +1 +)"))) << out;
}

// Before: Ctrl-C after minutes of rendering wrote nothing.
void expectStopWritesTheImageSoFar(int sig, int code, const char* name) {
    TempDir dir;
    Child render({binaryPath("common/cmd/rtpm-render"), "--scene", "RING", "--width", "32", "--height", "24", "-P",
                  "500", "--frames", "1000000", "--out", dir.file("ring.exr")},
                 dir.file("render"));
    ASSERT_TRUE(waitUntil([&] { return render.out().find("    2 converging") != std::string::npos || render.poll(); },
                          60s))
        << render.logs();
    render.signal(sig);
    const auto st = render.wait(60s);
    ASSERT_TRUE(st && st->exited) << render.logs();
    EXPECT_EQ(st->code, code) << render.logs();
    EXPECT_NE(render.err().find(std::string("rtpm-render: ") + name + " after frame "), std::string::npos)
        << render.logs();
    EXPECT_NE(render.out().find("(stopped by a signal)"), std::string::npos) << render.logs();
    const ExrImage img = readExr(dir.file("ring.exr"));
    EXPECT_TRUE(std::filesystem::is_regular_file(dir.file("ring.png")));
    const uint64_t frames = std::stoull(img.attributes.at("rtpm:frames"));
    EXPECT_GE(frames, 3u);
    EXPECT_LT(frames, 1000000u);
    EXPECT_EQ(img.attributes.at("rtpm:scene"), "RING");
}

TEST(Programs, RenderStoppedBySigintWritesTheImageSoFarAndExits130) { expectStopWritesTheImageSoFar(SIGINT, 130, "SIGINT"); }

TEST(Programs, RenderStoppedBySigtermWritesTheImageSoFarAndExits143) {
    expectStopWritesTheImageSoFar(SIGTERM, 143, "SIGTERM");
}

// Network start-up errors name the address and the fix (before: "Invalid argument", "bind:
// Address already in use", and --http 8080 taken as a host name).
TEST(Programs, ServerStartUpErrorsNameTheAddressAndTheFix) {
    TempDir dir;
    std::string out, err;
    EXPECT_EQ(run(dir, "server/rtpm-server", {"--insecure-no-token", "--http", "8080"}, out, err), 2) << err;
    EXPECT_NE(err.find("rtpm-server: --http 8080: expects HOST:PORT"), std::string::npos) << err;
    EXPECT_EQ(run(dir, "server/rtpm-server", {"--insecure-no-token", "--listen", "no-such-host.invalid"}, out, err), 1)
        << err;
    EXPECT_NE(err.find("--listen no-such-host.invalid: expects an IP address or a host name that resolves"),
              std::string::npos)
        << err;
    // A host name that resolves is accepted; the port file's missing folder is created, as every
    // output's is (before: "cannot write .../port.tmp" once listening, after the scene loaded).
    Child first({binaryPath("server/rtpm-server"), "--insecure-no-token", "--listen", "localhost", "--port", "0",
                 "--port-file", dir.file("missing/folder/port"), "--out", dir.file("a.exr")},
                dir.file("first"));
    const uint16_t port = waitForPortFile(dir.file("missing/folder/port"), first, 60s);
    ASSERT_NE(port, 0) << first.logs();
    // Its port is busy for a second server.
    const std::string p = std::to_string(port);
    EXPECT_EQ(run(dir, "server/rtpm-server", {"--insecure-no-token", "--port", p, "--out", dir.file("b.exr")}, out, err),
              1)
        << err;
    EXPECT_NE(err.find("rtpm-server: --port " + p + ": port " + p + " on 127.0.0.1 is already in use"),
              std::string::npos)
        << err;
    EXPECT_NE(err.find("or port 0 for any free one"), std::string::npos) << err;
    // No token: how to make one, and that the environment is the place for it (before: "pass --token
    // or set RTPM_TOKEN", the command line first, against the docs' advice).
    ::unsetenv("RTPM_TOKEN");
    EXPECT_EQ(run(dir, "server/rtpm-server", {"--port", "0", "--out", dir.file("c.exr")}, out, err), 2) << err;
    EXPECT_NE(err.find("rtpm-server: no token: set RTPM_TOKEN for the server and every client, e.g. export "
                       "RTPM_TOKEN=$(openssl rand -hex 16)"),
              std::string::npos)
        << err;
    first.signal(SIGTERM);
    EXPECT_TRUE(first.wait(30s)) << first.logs();
}

TEST(Programs, AClientSaysWhomItIsWaitingFor) {
    TempDir dir;
    std::string out, err;
    EXPECT_EQ(run(dir, "client/rtpm-client",
                  {"--port-file", dir.file("never"), "--host", "127.0.0.1", "--token", "t", "--connect-timeout", "1"},
                  out, err),
              1)
        << err;
    EXPECT_NE(err.find("rtpm-client: waiting for the server at 127.0.0.1, port from " + dir.file("never") +
                       " (port file " + dir.file("never") + " does not exist yet); retrying for "),
              std::string::npos)
        << err;
    EXPECT_NE(err.find("retrying for "), std::string::npos) << err;
    // The port file is read again every few milliseconds while it is missing; those reads are not
    // connection attempts, and the give-up line counts only the latter.
    EXPECT_NE(err.find("within 1.0 s (0 connection attempts): port file " + dir.file("never") + " does not exist yet"),
              std::string::npos)
        << err;
}

// The server's summary tells a wrong token from a broken protocol (before: both were "protocol errors").
TEST(Programs, ServerSummaryCountsFailedAuthenticationsApart) {
    TempDir dir;
    const std::string token = "5f2c8d0a9b7e4c1f3a6d8e2b0c9f7a14";  // `openssl rand -hex 16`
    Child server({binaryPath("server/rtpm-server"), "--port", "0", "--port-file", dir.file("port"), "--scene", "RING",
                  "--width", "32", "--height", "24", "-M", "2", "-P", "500", "--frames", "2", "--out",
                  dir.file("ring.exr")},
                 dir.file("server"), {"RTPM_TOKEN=" + token});
    const uint16_t port = waitForPortFile(dir.file("port"), server, 60s);
    ASSERT_NE(port, 0) << server.logs();
    const std::string address = "127.0.0.1:" + std::to_string(port);
    Child intruder({binaryPath("client/rtpm-client"), "--server", address, "--token", "wrong", "--threads", "1"},
                   dir.file("intruder"));
    const auto refused = intruder.wait(30s);
    ASSERT_TRUE(refused && refused->exited) << intruder.logs();
    EXPECT_EQ(refused->code, 5) << intruder.logs();
    Child client({binaryPath("client/rtpm-client"), "--server", address, "--token", token, "--threads", "1"},
                 dir.file("client"));
    const auto st = server.wait(60s);
    ASSERT_TRUE(st && st->exited && st->code == 0) << server.logs() << client.logs();
    EXPECT_NE(server.out().find("1 failed authentications, 0 protocol errors"), std::string::npos) << server.logs();
    // The image says what made it.
    const ExrImage img = readExr(dir.file("ring.exr"));
    EXPECT_EQ(img.attributes.at("rtpm:program"), "rtpm-server");
    EXPECT_EQ(img.attributes.at("rtpm:frames"), "2");
    EXPECT_EQ(img.attributes.at("rtpm:resolution"), "32x24");
    // Not a terminal: plain progress lines, the last frame's always.
    EXPECT_TRUE(std::regex_search(server.err(), std::regex(R"((^|\n)frame 2/2  elapsed [0-9.]+ s  ETA 0\.0 s  [0-9.]+ fps\n)")))
        << server.logs();
}

// Identity checks (the multihost and Docker tests) compare pixels, not files: the EXR header
// names the program that wrote it, so rtpm-server's and rtpm-render's files differ in bytes.
TEST(Programs, CompareIdenticalJudgesPixelsNotTheHeader) {
    TempDir dir;
    std::string out, err;
    const std::vector<std::string> settings = {"--scene", "RING", "--width", "32", "--height", "24", "-P", "500",
                                               "--frame-budget-ms", "0", "--frames"};
    auto render = [&](const std::string& frames, const std::string& name) {
        std::vector<std::string> args = settings;
        args.insert(args.end(), {frames, "--out", dir.file(name)});
        ASSERT_EQ(run(dir, "common/cmd/rtpm-render", args, out, err), 0) << err;
    };
    render("2", "a.exr");
    render("2", "b.exr");
    render("3", "c.exr");
    EXPECT_EQ(run(dir, "common/cmd/rtpm-compare", {"--identical", dir.file("a.exr"), dir.file("b.exr")}, out, err), 0)
        << err;
    // The frame count in the header differs, and so do the pixels: exit 3, naming a channel.
    EXPECT_EQ(run(dir, "common/cmd/rtpm-compare", {"--identical", dir.file("a.exr"), dir.file("c.exr")}, out, err), 3)
        << err;
    EXPECT_TRUE(std::regex_search(err, std::regex(R"(not identical: channel caustic\S*\.[RGB] differs at \d+ pixels)")))
        << err;
}

}  // namespace
}  // namespace rtpm::test
