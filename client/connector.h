// Reaching the master: resolve, connect, back off and try again within a connect or rejoin window.
#pragma once

#include <asio.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "client/worker.h"

namespace rtpm::client {

/// Makes TCP connections to the master for the worker, one attempt at a time on the io thread.
/// An attempt reads the port from --port-file when no port was given (a file that does not exist
/// yet, or holds no port yet, is read again every 2 ms for half a second, so a client started
/// beside its master connects as soon as the master listens; after that, it waits the backoff
/// as a failed connection does), resolves the host and connects within kAttemptTimeout. A failed
/// connection waits the backoff (100 ms, doubling to 2 s) and tries again until the window
/// closes; then it prints why and calls `gaveUp`. Not thread-safe (io thread).
class Connector {
public:
    using Clock = std::chrono::steady_clock;
    /// Called with the connected socket; the connector is idle until the next retry().
    using Connected = std::function<void(asio::ip::tcp::socket)>;

    Connector(asio::io_context& io, const WorkerOptions& options, Connected connected,
              std::function<void()> gaveUp);

    /// Opens a window of `seconds` from now for the attempts that follow: the connect window at
    /// start (`rejoin` false), a rejoin window after a session that had a Welcome was lost.
    void openWindow(double seconds, bool rejoin);
    /// Whether the current window has closed.
    bool windowClosed() const { return Clock::now() >= deadline_; }
    /// Seconds left in the current window (0 when closed).
    double secondsLeft() const;

    /// Starts the first attempt (posted to the io thread).
    void start();
    /// The connection made, or the session on it, failed for `why`: waits the backoff and tries
    /// again, or gives up once the window has closed.
    void retry(const std::string& why);
    /// A Welcome: the next failure waits the first backoff again.
    void resetBackoff() { backoff_ = kFirstBackoff; }
    /// Stops: closes an attempt in progress and cancels the timers; no callback follows.
    void cancel();

    /// "host:port" of the master as last tried ("[v6]:port"; "?" for a port not read yet).
    std::string address() const;

private:
    static constexpr auto kFirstBackoff = std::chrono::milliseconds(100);
    static constexpr auto kMaxBackoff = std::chrono::milliseconds(2000);

    void attempt();
    void scheduleRetry();
    bool readPortFile(uint16_t& out);

    asio::io_context& io_;
    const WorkerOptions& opt_;
    Connected connected_;
    std::function<void()> gaveUp_;
    asio::ip::tcp::socket socket_;
    asio::steady_timer attemptTimer_;
    asio::steady_timer retryTimer_;
    bool active_ = true;   ///< attempts are wanted (false once connected or cancelled)
    bool rejoin_ = false;  ///< the window is a rejoin window
    Clock::time_point deadline_;        ///< of the current window
    Clock::time_point nextWaitNotice_;  ///< the next "waiting for the server" line is due then
    Clock::duration backoff_ = kFirstBackoff;
    int attempts_ = 0;
    uint16_t port_ = 0;  ///< of the last attempt
    std::string lastError_ = "no attempt made";
};

/// `s` seconds (clamped at 0) as a steady_clock duration.
Connector::Clock::duration secondsDuration(double s);

}  // namespace rtpm::client
