// Adaptive frame deadline: a multiple of the running median frame time, within floor and ceiling.
#include "server/deadline.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace rtpm::server {

FrameDeadline::FrameDeadline(DeadlinePolicy policy) : policy_(policy) {
    if (policy_.fixed && policy_.fixed->count() < 1) throw std::invalid_argument("deadline must be >= 1 ms");
    if (!(policy_.multiple >= 1.0) || policy_.floor.count() < 1 || policy_.ceiling < policy_.floor ||
        policy_.window < 1)
        throw std::invalid_argument("adaptive deadline: need multiple >= 1, 1 ms <= floor <= ceiling, window >= 1");
}

void FrameDeadline::completed(std::chrono::nanoseconds took, FrameCost cost) {
    auto& s = samples_[size_t(cost)];
    s.push_back(std::max(took, std::chrono::nanoseconds(0)));
    while (s.size() > policy_.window) s.pop_front();
}

std::chrono::nanoseconds FrameDeadline::median(FrameCost cost) const {
    const auto& s = samples(cost);
    if (s.empty()) return std::chrono::nanoseconds(0);
    std::vector<std::chrono::nanoseconds> v(s.begin(), s.end());
    auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;  // the upper median: never under-estimates with an even count
}

std::chrono::milliseconds FrameDeadline::forFrame(bool costUnknown, FrameCost cost) const {
    if (policy_.fixed) return *policy_.fixed;
    if (costUnknown || samples(cost).size() < policy_.minSamples) return policy_.ceiling;
    const double ms = policy_.multiple * std::chrono::duration<double, std::milli>(median(cost)).count();
    const auto scaled = std::chrono::milliseconds(static_cast<long long>(std::min(ms, 1e12)) + 1);
    return std::clamp(scaled, policy_.floor, policy_.ceiling);
}

}  // namespace rtpm::server
