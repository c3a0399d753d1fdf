// The viewer's lag and cost figures, gathered under one mutex.
#include "server/viewer/viewer_stats.h"

#include <algorithm>
#include <ctime>

namespace rtpm::server {

double threadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

void ViewerStats::composed(uint64_t frame, Clock::time_point now) {
    std::lock_guard lock(mu_);
    newestFrame_ = frame;
    composedAt_.emplace_back(frame, now);
    if (composedAt_.size() > 16) composedAt_.pop_front();
}

void ViewerStats::published(double toneMapCpuSeconds) {
    std::lock_guard lock(mu_);
    ++r_.framesPublished;
    r_.toneMapCpuSeconds += toneMapCpuSeconds;
}

void ViewerStats::encoded() {
    std::lock_guard lock(mu_);
    ++r_.framesEncoded;
}

void ViewerStats::shown(uint64_t frame, Clock::time_point now) {
    std::lock_guard lock(mu_);
    const uint64_t lag = newestFrame_ > frame ? newestFrame_ - frame : 0;
    ++r_.framesShown;
    lagSum_ += double(lag);
    r_.maxLagFrames = std::max(r_.maxLagFrames, lag);
    for (const auto& [f, t] : composedAt_)
        if (f == frame) {
            const double ms = std::chrono::duration<double, std::milli>(now - t).count();
            latencySum_ += ms;
            r_.maxLatencyMs = std::max(r_.maxLatencyMs, ms);
        }
}

void ViewerStats::chargeStatus(double seconds) {
    std::lock_guard lock(mu_);
    r_.statusCpuSeconds += seconds;
}

void ViewerStats::threadEnded(double cpuSeconds) {
    std::lock_guard lock(mu_);
    r_.threadCpuSeconds = cpuSeconds;
}

ViewerReport ViewerStats::report() const {
    std::lock_guard lock(mu_);
    ViewerReport r = r_;
    if (r.framesShown) {
        r.meanLagFrames = lagSum_ / double(r.framesShown);
        r.meanLatencyMs = latencySum_ / double(r.framesShown);
    }
    r.cpuSeconds = r.toneMapCpuSeconds + r.threadCpuSeconds + r.statusCpuSeconds;
    return r;
}

}  // namespace rtpm::server
