// Frame progress a user can watch: "frame 3/10  elapsed 1.2 s  ETA 2.8 s  2.50 fps", one line
// updated in place on a terminal, plain lines (at most one a second, and the last) otherwise.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace rtpm {

/// "0.4 s", "42.0 s", "3 min 05 s", "2 h 03 min". Negative or non-finite values give "?".
std::string formatDuration(double seconds);

/// The progress text of `done` frames out of `total` (0 = no end: no "/N" and no ETA) after
/// `elapsedSeconds`: "frame 3/10  elapsed 1.2 s  ETA 2.8 s  2.50 fps". The ETA and the rate are
/// the run's mean so far; before the first frame they read "?".
std::string formatProgress(uint64_t done, uint64_t total, double elapsedSeconds);

/// Draws formatProgress on `stream` (stderr for the programs, so stdout stays a clean log).
/// Terminal: one line redrawn with '\r'; clear() erases it before other output is printed and the
/// next update() draws it again. Otherwise: a plain line per update, at most one a second
/// (the last frame always). Not thread-safe.
class ProgressLine {
public:
    /// `terminal`: whether `stream` is a terminal (isatty), decided by the caller.
    ProgressLine(std::FILE* stream, bool terminal) : stream_(stream), terminal_(terminal) {}
    /// Draws the progress after `done` of `total` frames.
    void update(uint64_t done, uint64_t total, double elapsedSeconds);
    /// Terminal: erases the drawn line (before printing something else). Otherwise nothing.
    void clear();
    /// Terminal: ends the drawn line with a newline, so later output starts on its own line.
    void finish();
    /// Whether the line is drawn on a terminal.
    bool terminal() const { return terminal_; }

private:
    std::FILE* stream_;
    bool terminal_;
    bool drawn_ = false;
    double lastPlainSeconds_ = -1e300;
};

/// Whether `stream` is a terminal.
bool isTerminal(std::FILE* stream);

}  // namespace rtpm
