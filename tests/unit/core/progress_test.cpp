// The progress line: frame i/N, elapsed time, ETA and rate, in place on a terminal and as plain
// lines (at most one a second, the last always) otherwise (issue 24, item 2).
#include "common/core/progress.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <regex>
#include <string>

namespace rtpm {
namespace {

TEST(Progress, DurationsReadAsSecondsMinutesOrHours) {
    EXPECT_EQ(formatDuration(0.0), "0.0 s");
    EXPECT_EQ(formatDuration(42.04), "42.0 s");
    EXPECT_EQ(formatDuration(185.0), "3 min 05 s");
    EXPECT_EQ(formatDuration(7380.0), "2 h 03 min");
    EXPECT_EQ(formatDuration(-1.0), "?");
}

TEST(Progress, LineShowsFrameOfTotalElapsedEtaAndFps) {
    EXPECT_EQ(formatProgress(3, 10, 1.5), "frame 3/10  elapsed 1.5 s  ETA 3.5 s  2.00 fps");
    EXPECT_EQ(formatProgress(10, 10, 5.0), "frame 10/10  elapsed 5.0 s  ETA 0.0 s  2.00 fps");
    // Before the first frame nothing is measured; a run without an end has no ETA.
    EXPECT_EQ(formatProgress(0, 10, 0.0), "frame 0/10  elapsed 0.0 s  ETA ?  ? fps");
    EXPECT_EQ(formatProgress(120, 0, 60.0), "frame 120  elapsed 1 min 00 s  2.00 fps");
}

std::string drawn(bool terminal, const std::function<void(ProgressLine&)>& draw) {
    std::FILE* f = std::tmpfile();
    {
        ProgressLine line(f, terminal);
        draw(line);
    }
    std::rewind(f);
    std::string s;
    char buf[512];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
    std::fclose(f);
    return s;
}

TEST(Progress, TerminalRedrawsOneLineInPlace) {
    const std::string s = drawn(true, [](ProgressLine& p) {
        p.update(1, 3, 0.5);
        p.update(2, 3, 1.0);
        p.clear();
        p.update(3, 3, 1.5);
        p.finish();
    });
    EXPECT_EQ(s, "\rframe 1/3  elapsed 0.5 s  ETA 1.0 s  2.00 fps\033[K"
                 "\rframe 2/3  elapsed 1.0 s  ETA 0.5 s  2.00 fps\033[K"
                 "\r\033[K"
                 "\rframe 3/3  elapsed 1.5 s  ETA 0.0 s  2.00 fps\033[K\n");
}

TEST(Progress, PlainOutputPrintsAtMostALineASecondAndTheLast) {
    const std::string s = drawn(false, [](ProgressLine& p) {
        for (int i = 1; i <= 10; ++i) p.update(uint64_t(i), 10, 0.25 * i);  // 4 frames a second
    });
    EXPECT_EQ(s, "frame 1/10  elapsed 0.2 s  ETA 2.2 s  4.00 fps\n"
                 "frame 5/10  elapsed 1.2 s  ETA 1.2 s  4.00 fps\n"
                 "frame 9/10  elapsed 2.2 s  ETA 0.2 s  4.00 fps\n"
                 "frame 10/10  elapsed 2.5 s  ETA 0.0 s  4.00 fps\n");
    const std::regex format(R"(frame \d+/\d+  elapsed [0-9.]+ s  ETA [0-9.]+ s  [0-9.]+ fps)");
    EXPECT_TRUE(std::regex_search(s, format));
}

}  // namespace
}  // namespace rtpm
