// Programs write their lines as they happen, also into a pipe (CI, containers, `| tee`): the
// first frame line of rtpm-render reaches a reader while it is still rendering, long before its
// last line.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <regex>
#include <string>
#include <vector>

#include "tests/support/cluster_util.h"

namespace rtpm::test {
namespace {

TEST(ConsoleOutput, RenderFrameLinesArriveThroughAPipeWhileItRenders) {
    TempDir dir;
    int fds[2];
    ASSERT_EQ(pipe2(fds, O_CLOEXEC), 0);
    // 20 frames of a small RING on one thread: about a second of rendering after frame 0 is
    // printed. The whole output (≈ 2 KiB) stays below one stdio block, so a fully buffered stdout
    // hands it to the pipe in one write at exit, frame 0's line together with the last one.
    std::vector<std::string> argv{binaryPath("common/cmd/rtpm-render"), "--scene", "RING", "--width", "64",
                                  "--height", "48", "--frames", "20", "--threads", "1",
                                  "--out", dir.file("ring.exr")};
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    const std::string errPath = dir.file("render.err");
    posix_spawn_file_actions_addopen(&fa, 2, errPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<char*> args;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    pid_t pid = -1;
    const int rc = posix_spawn(&pid, args[0], &fa, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    close(fds[1]);
    ASSERT_EQ(rc, 0) << "cannot start " << argv[0];

    // Read until the line of frame 0 ("    0 interaction …") arrives, or EOF, or 120 s.
    const std::regex frameZero(R"((^|\n) +0 [a-z]+ )");
    std::string text;
    bool eof = false;
    bool lastLineWithFirstFrame = false;
    const auto end = Clock::now() + std::chrono::seconds(120);
    while (!eof && Clock::now() < end) {
        pollfd p{fds[0], POLLIN, 0};
        if (::poll(&p, 1, 100) <= 0) continue;
        char buf[4096];
        const ssize_t n = read(fds[0], buf, sizeof buf);
        if (n <= 0) {
            eof = true;
            break;
        }
        text.append(buf, size_t(n));
        if (std::regex_search(text, frameZero)) {
            lastLineWithFirstFrame = text.find("wrote ") != std::string::npos;
            break;
        }
    }
    // Drain the rest, then reap.
    while (!eof) {
        char buf[4096];
        const ssize_t n = read(fds[0], buf, sizeof buf);
        if (n <= 0) break;
        text.append(buf, size_t(n));
    }
    close(fds[0]);
    int st = 0;
    ASSERT_EQ(waitpid(pid, &st, 0), pid);
    EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << text << readFile(errPath);

    EXPECT_TRUE(std::regex_search(text, frameZero)) << "no frame line on stdout:\n" << text << readFile(errPath);
    EXPECT_FALSE(lastLineWithFirstFrame) << "frame 0's line arrived together with the last line, "
                                            "when rtpm-render exited:\n" << text;
    EXPECT_NE(text.find("wrote "), std::string::npos) << text;
    EXPECT_LT(text.size(), 4096u) << "the output outgrew one stdio block: the check above no longer "
                                      "tells line buffering from full buffering";
}

}  // namespace
}  // namespace rtpm::test
