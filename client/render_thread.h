// The client's render side: one thread per session rendering what the master sent, in arrival order.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "client/frame_renderer.h"
#include "proto/messages.h"

namespace rtpm::client {

/// A FrameBegin and when it arrived (Stats.frameMs counts from then).
struct FrameItem {
    proto::FrameBegin begin;
    std::chrono::steady_clock::time_point received;
};
/// What the render thread consumes, in arrival order.
using RenderItem = std::variant<proto::Settings, proto::Scene, proto::Edit, FrameItem>;

/// `sets` as "0,3,6" ("none" when empty), for log lines.
std::string setList(const std::vector<uint32_t>& sets);

/// Where a render thread's results go. Called on the render thread: an implementation posts
/// them to the io thread and drops them there if `session` is no longer the current one.
class RenderSink {
public:
    enum class Failure {
        Protocol,  ///< the master's data cannot be used (ProtocolViolation, SceneError)
        Internal,  ///< anything else the renderer threw
    };
    virtual ~RenderSink() = default;
    /// Frame done: its encoded FrameData messages, then its Stats, to send in this order.
    virtual void frameRendered(uint64_t session, std::vector<std::vector<uint8_t>> messages) = 0;
    /// The thread stopped on `why`; it renders nothing more.
    virtual void renderFailed(uint64_t session, Failure failure, std::string why) = 0;
};

/// The render side of one session (Welcome to its end): its queue, thread and FrameRenderer
/// (photon maps). The thread takes Settings, Scene, Edit and FrameBegin in arrival order, so
/// frames render in order while the io thread receives the next. A rejoin starts a new one.
class RenderThread {
public:
    /// Starts the thread. `threads` is reported in Stats; `slowdown` is FrameRenderer's (tests
    /// only); `verbose` prints a line per frame to stdout; `framesRendered` counts frames across
    /// sessions.
    RenderThread(uint64_t session, uint32_t threads, double slowdown, bool verbose, RenderSink& sink,
                 std::atomic<uint64_t>& framesRendered);
    /// Stops and joins the thread (blocks for the item in progress).
    ~RenderThread();
    RenderThread(const RenderThread&) = delete;
    RenderThread& operator=(const RenderThread&) = delete;

    uint64_t session() const { return session_; }
    /// Queues `item` (io thread).
    void push(RenderItem item);
    /// The thread returns after its current item, without blocking the caller.
    void stop();
    /// The thread has returned (join will not block).
    bool finished() const { return finished_; }
    /// Waits for the thread (after stop()).
    void join();

private:
    void loop();
    /// Renders one item; throws what the renderer throws.
    void render(RenderItem& item);

    const uint64_t session_;
    const bool verbose_;
    RenderSink& sink_;
    std::atomic<uint64_t>& framesRendered_;
    FrameRenderer renderer_;
    std::mutex mu_;
    std::condition_variable cv_;
    std::deque<RenderItem> queue_;
    bool stop_ = false;
    std::atomic<bool> finished_{false};
    std::thread thread_;  // last: starts once everything above is built
};

/// The current session's render thread and the retired ones still finishing an item: retiring
/// never blocks the io thread; they are joined once done, or when the worker ends.
class RenderThreads {
public:
    ~RenderThreads() { joinAll(); }
    /// Joins the retired threads that are done, then starts `session`'s.
    void start(uint64_t session, uint32_t threads, double slowdown, bool verbose, RenderSink& sink,
               std::atomic<uint64_t>& framesRendered);
    /// The current session's thread, or nullptr between sessions.
    RenderThread* current() const { return current_.get(); }
    /// Queues `item` for the current thread (dropped between sessions).
    void push(RenderItem item) {
        if (current_) current_->push(std::move(item));
    }
    /// Stops the current thread after its item and keeps it until it is done.
    void retire();
    /// Retires the current thread and joins every thread.
    void joinAll();

private:
    std::unique_ptr<RenderThread> current_;
    std::vector<std::unique_ptr<RenderThread>> retired_;
};

}  // namespace rtpm::client
