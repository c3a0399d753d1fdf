// Frame progress lines (progress.h).
#include "common/core/progress.h"

#include <unistd.h>

#include <cmath>

namespace rtpm {

std::string formatDuration(double seconds) {
    if (!std::isfinite(seconds) || seconds < 0.0) return "?";
    char buf[48];
    if (seconds < 60.0) {
        std::snprintf(buf, sizeof buf, "%.1f s", seconds);
    } else if (seconds < 3600.0) {
        const long s = std::lround(seconds);
        std::snprintf(buf, sizeof buf, "%ld min %02ld s", s / 60, s % 60);
    } else {
        const long m = std::lround(seconds / 60.0);
        std::snprintf(buf, sizeof buf, "%ld h %02ld min", m / 60, m % 60);
    }
    return buf;
}

std::string formatProgress(uint64_t done, uint64_t total, double elapsedSeconds) {
    const bool measured = done > 0 && elapsedSeconds > 0.0;
    const double fps = measured ? double(done) / elapsedSeconds : 0.0;
    std::string line = "frame " + std::to_string(done);
    if (total > 0) line += "/" + std::to_string(total);
    line += "  elapsed " + formatDuration(elapsedSeconds);
    if (total > 0)
        line += "  ETA " + (measured ? formatDuration(double(total > done ? total - done : 0) / fps) : std::string("?"));
    char rate[32];
    if (measured) std::snprintf(rate, sizeof rate, "  %.2f fps", fps);
    else std::snprintf(rate, sizeof rate, "  ? fps");
    return line + rate;
}

void ProgressLine::update(uint64_t done, uint64_t total, double elapsedSeconds) {
    const std::string line = formatProgress(done, total, elapsedSeconds);
    if (terminal_) {
        std::fprintf(stream_, "\r%s\033[K", line.c_str());
        drawn_ = true;
    } else {
        if (elapsedSeconds - lastPlainSeconds_ < 1.0 && !(total > 0 && done >= total)) return;
        lastPlainSeconds_ = elapsedSeconds;
        std::fprintf(stream_, "%s\n", line.c_str());
    }
    std::fflush(stream_);
}

void ProgressLine::clear() {
    if (!terminal_ || !drawn_) return;
    std::fprintf(stream_, "\r\033[K");
    std::fflush(stream_);
    drawn_ = false;
}

void ProgressLine::finish() {
    if (!terminal_ || !drawn_) return;
    std::fprintf(stream_, "\n");
    std::fflush(stream_);
    drawn_ = false;
}

bool isTerminal(std::FILE* stream) { return ::isatty(::fileno(stream)) == 1; }

}  // namespace rtpm
