// A connection's read deadline for a message that has begun to arrive: no byte for `stall`, or
// not complete within `stall` plus its size at a minimum rate, and the connection is closed.
#pragma once

#include <asio.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <optional>

namespace rtpm::net {

/// Owns the deadline's timer; lives inside its connection on the I/O thread; not thread-safe.
class ReadDeadline {
public:
    using TimePoint = std::chrono::steady_clock::time_point;

    explicit ReadDeadline(const asio::any_io_executor& executor) : timer_(executor) {}

    /// Zero `stall`: no deadline (the default).
    void set(std::chrono::milliseconds stall, uint64_t minBytesPerSecond) {
        stall_ = stall;
        minBytesPerSecond_ = minBytesPerSecond;
    }
    bool enabled() const { return stall_.count() > 0; }

    /// Between messages: no deadline.
    void idle() {
        if (!partialSince_) return;
        partialSince_.reset();
        ++generation_;
        timer_.cancel();
    }
    /// A message of `messageBytes` (header and payload) is partly in: the stall deadline starts
    /// again from now, the message's own bound from when it began. `onExpiry(messageEnd)` runs if
    /// the deadline passes before the next arm(), idle() or cancel(); it must keep the
    /// connection (and so this) alive.
    template <class F>
    void arm(uint64_t messageBytes, F onExpiry) {
        const auto now = std::chrono::steady_clock::now();
        if (!partialSince_) partialSince_ = now;
        // Progress re-arms the stall deadline; the whole message is bounded by its size at the minimum rate.
        auto messageEnd = TimePoint::max();
        if (minBytesPerSecond_ > 0) {
            const auto allowance = std::chrono::milliseconds(messageBytes * 1000 / minBytesPerSecond_);
            messageEnd = *partialSince_ + stall_ + allowance;
        }
        const uint64_t generation = ++generation_;
        timer_.expires_at(std::min(now + stall_, messageEnd));
        timer_.async_wait([this, generation, messageEnd, onExpiry = std::move(onExpiry)](const asio::error_code& ec) {
            if (ec || generation != generation_) return;
            onExpiry(messageEnd);
        });
    }
    /// When the message in progress began to arrive. Precondition: armed.
    TimePoint partialSince() const { return *partialSince_; }
    void cancel() { timer_.cancel(); }

private:
    asio::steady_timer timer_;
    std::chrono::milliseconds stall_{0};
    uint64_t minBytesPerSecond_ = 0;
    std::optional<TimePoint> partialSince_;  // a message began, not yet complete
    uint64_t generation_ = 0;
};

}  // namespace rtpm::net
