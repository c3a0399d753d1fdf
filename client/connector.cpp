// Connector: one connection attempt at a time, exponential backoff, within a connect or rejoin window.
#include "client/connector.h"

#include <algorithm>
#include <cstdio>
#include <fstream>

#include "proto/messages.h"

namespace rtpm::client {

namespace {

using asio::ip::tcp;

/// How often a client that cannot reach its master says whom it is waiting for.
constexpr auto kWaitNoticeInterval = std::chrono::seconds(5);
/// One connection attempt may not take longer than this (a silent host drops SYNs).
constexpr auto kAttemptTimeout = std::chrono::seconds(5);
/// A port file that does not exist yet (or holds no port yet) is read again this often, without
/// backoff, for the first kPortFileQuiet: a client started beside its master connects within
/// this of the master listening (the master takes about 9 ms to listen; a first backoff of
/// 100 ms was most of a short run's start). Reading a small file is one open and one read.
constexpr auto kPortFilePoll = std::chrono::milliseconds(2);
/// How long a client polls for a port file before it says so and backs off: started with its
/// master (as deploy/run-local.sh starts them), it finds the file well within this and stays quiet.
constexpr auto kPortFileQuiet = std::chrono::milliseconds(500);

}  // namespace

Connector::Clock::duration secondsDuration(double s) {
    return std::chrono::duration_cast<Connector::Clock::duration>(std::chrono::duration<double>(std::max(0.0, s)));
}

Connector::Connector(asio::io_context& io, const WorkerOptions& options, Connected connected,
                     std::function<void()> gaveUp)
    : io_(io), opt_(options), connected_(std::move(connected)), gaveUp_(std::move(gaveUp)), socket_(io),
      attemptTimer_(io), retryTimer_(io) {}

void Connector::openWindow(double seconds, bool rejoin) {
    deadline_ = Clock::now() + secondsDuration(seconds);
    nextWaitNotice_ = {};
    rejoin_ = rejoin;
}

double Connector::secondsLeft() const {
    return std::max(0.0, std::chrono::duration<double>(deadline_ - Clock::now()).count());
}

void Connector::start() {
    active_ = true;
    asio::post(io_, [this] { attempt(); });
}

void Connector::retry(const std::string& why) {
    lastError_ = why;
    active_ = true;
    scheduleRetry();
}

void Connector::cancel() {
    active_ = false;
    asio::error_code ignored;
    socket_.close(ignored);  // a connection attempt in progress
    attemptTimer_.cancel();
    retryTimer_.cancel();
}

std::string Connector::address() const {
    const std::string p = port_ ? std::to_string(port_) : (opt_.port ? std::to_string(opt_.port) : "?");
    return (opt_.host.find(':') != std::string::npos ? "[" + opt_.host + "]" : opt_.host) + ":" + p;
}

bool Connector::readPortFile(uint16_t& out) {
    std::ifstream in(opt_.portFile);
    if (!in) {
        lastError_ = "port file " + opt_.portFile + " does not exist yet";
        return false;
    }
    std::string text;
    in >> text;
    std::string h = "x";
    if (!parseHostPort("x:" + text, h, out)) {
        if (text.size() > proto::kMaxTextBytes) text.resize(proto::kMaxTextBytes);
        lastError_ = "port file " + opt_.portFile + " holds no port yet (\"" + text + "\")";
        return false;
    }
    return true;
}

void Connector::attempt() {
    if (!active_) return;
    if (windowClosed()) {
        std::fprintf(stderr, "rtpm-client: could not %s %s within %.1f s (%d connection attempts): %s\n",
                     rejoin_ ? "rejoin" : "connect to", address().c_str(),
                     rejoin_ ? opt_.rejoinTimeoutSeconds : opt_.connectTimeoutSeconds, attempts_, lastError_.c_str());
        active_ = false;
        return gaveUp_();
    }
    port_ = opt_.port;
    if (port_ == 0 && !readPortFile(port_)) return scheduleRetry();
    ++attempts_;  // connection attempts: a port file read again is not one
    asio::error_code ec;
    tcp::resolver resolver(io_);
    auto endpoints = resolver.resolve(opt_.host, std::to_string(port_), ec);
    if (ec) {
        lastError_ = "cannot resolve " + opt_.host + ": " + ec.message();
        return scheduleRetry();
    }
    socket_ = tcp::socket(io_);
    const int id = attempts_;
    asio::async_connect(socket_, endpoints, [this, id](const asio::error_code& e, const tcp::endpoint&) {
        if (id != attempts_ || !active_) return;
        attemptTimer_.cancel();
        if (e) {
            lastError_ = e == asio::error::operation_aborted ? "connection attempt timed out" : e.message();
            asio::error_code ignored;
            socket_.close(ignored);
            return scheduleRetry();
        }
        active_ = false;
        connected_(std::move(socket_));
    });
    attemptTimer_.expires_after(std::min<Clock::duration>(kAttemptTimeout, deadline_ - Clock::now()));
    attemptTimer_.async_wait([this, id](const asio::error_code& e) {
        if (e || id != attempts_ || !active_) return;
        asio::error_code ignored;
        socket_.close(ignored);  // completes the pending connect with operation_aborted
    });
}

void Connector::scheduleRetry() {
    // Says whom it waits for and why, at the first failed attempt (for a port file, once it has
    // waited kPortFileQuiet) and every few seconds after, so a client started before its master
    // is not silent for the whole window.
    const auto now = Clock::now();
    const bool portFile = port_ == 0 && opt_.port == 0;  // the port file gave no port yet
    if (portFile && nextWaitNotice_ == Clock::time_point{}) nextWaitNotice_ = now + kPortFileQuiet;
    // Read at once again while a master started beside this client may still be starting; after
    // that, the backoff (a client waiting for a master that is not there uses no CPU to speak of).
    const bool poll = portFile && now < nextWaitNotice_;
    if (now >= nextWaitNotice_ && deadline_ > now) {
        nextWaitNotice_ = now + kWaitNoticeInterval;
        const double left = std::chrono::duration<double>(deadline_ - now).count();
        if (portFile)
            std::fprintf(stderr, "rtpm-client: waiting for the server at %s, port from %s (%s); retrying for %.0f s "
                         "more\n", opt_.host.c_str(), opt_.portFile.c_str(), lastError_.c_str(), left);
        else
            std::fprintf(stderr, "rtpm-client: waiting for the server at %s (%s); retrying for %.0f s more\n",
                         address().c_str(), lastError_.c_str(), left);
    }
    const auto remaining = std::max<Clock::duration>(deadline_ - Clock::now(), {});
    if (poll) {
        retryTimer_.expires_after(std::min<Clock::duration>(kPortFilePoll, remaining));
    } else {
        retryTimer_.expires_after(std::min<Clock::duration>(backoff_, remaining));
        backoff_ = std::min<Clock::duration>(backoff_ * 2, kMaxBackoff);
    }
    retryTimer_.async_wait([this](const asio::error_code& e) {
        if (!e && active_) attempt();
    });
}

}  // namespace rtpm::client
