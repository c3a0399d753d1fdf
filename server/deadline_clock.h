// The frame deadline on the clock: the deadline each new frame gets (deadline.h decides it from
// measured frame times) and the timer that wakes the frame loop when the oldest frame's runs out.
#pragma once

#include <asio.hpp>

#include <chrono>
#include <functional>
#include <optional>

#include "server/deadline.h"
#include "server/frame_assembler.h"

namespace rtpm::server {

/// Lives on the master's io_context; not thread-safe.
class DeadlineClock {
public:
    DeadlineClock(asio::io_context& io, DeadlinePolicy policy) : deadlines_(policy), timer_(io) {}

    /// The deadline a frame would get (FrameDeadline::forFrame), without beginning one.
    std::chrono::milliseconds forFrame(bool costUnknown, FrameCost cost = FrameCost::Retraced) const {
        return deadlines_.forFrame(costUnknown, cost);
    }
    /// The deadline of a frame that begins now; last() answers it until the next one begins.
    std::chrono::milliseconds begin(bool costUnknown, FrameCost cost) {
        last_ = deadlines_.forFrame(costUnknown, cost);
        return last_;
    }
    /// The deadline of the newest frame begun (told to evicted clients).
    std::chrono::milliseconds last() const { return last_; }
    /// A frame completed `took` after it became the oldest (FrameDeadline::completed).
    void completed(std::chrono::nanoseconds took, FrameCost cost) { deadlines_.completed(took, cost); }
    bool adaptive() const { return deadlines_.adaptive(); }

    /// Calls `onExpiry` at `at` (replacing any wait before); nullopt only cancels.
    void arm(std::optional<TimePoint> at, std::function<void()> onExpiry) {
        if (!at) {
            timer_.cancel();
            return;
        }
        timer_.expires_at(*at);
        timer_.async_wait([onExpiry = std::move(onExpiry)](const asio::error_code& ec) {
            if (!ec) onExpiry();
        });
    }
    void cancel() { timer_.cancel(); }
    /// The I/O thread's executor, for work handed back from the output stage.
    asio::any_io_executor executor() { return timer_.get_executor(); }

private:
    FrameDeadline deadlines_;
    asio::steady_timer timer_;
    std::chrono::milliseconds last_{0};
};

}  // namespace rtpm::server
