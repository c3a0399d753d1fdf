// Worker: wiring only. The connector reaches the master, the session speaks to it, the render
// threads render; this file decides what a session's end means (rejoin, or exit with which code).
#include "client/worker.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <asio.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>

#include "client/connector.h"
#include "client/render_thread.h"
#include "client/session.h"
#include "common/core/printable_text.h"
#include "proto/messages.h"

namespace rtpm::client {

bool parseHostPort(const std::string& text, std::string& host, uint16_t& port) {
    std::string h, p;
    if (!text.empty() && text.front() == '[') {
        const size_t close = text.find(']');
        if (close == std::string::npos) return false;
        h = text.substr(1, close - 1);
        if (close + 1 == text.size()) p = std::to_string(proto::kDefaultPort);
        else if (text[close + 1] == ':') p = text.substr(close + 2);
        else return false;
    } else {
        const size_t colon = text.rfind(':');
        h = text.substr(0, colon);
        p = colon == std::string::npos ? std::to_string(proto::kDefaultPort) : text.substr(colon + 1);
    }
    if (h.empty() || p.empty() || p.size() > 5 || !std::all_of(p.begin(), p.end(), ::isdigit)) return false;
    const unsigned long v = std::stoul(p);
    if (v < 1 || v > 65535) return false;
    host = h;
    port = uint16_t(v);
    return true;
}

struct Worker::Impl : SessionEvents, RenderSink {
    explicit Impl(const WorkerOptions& o)
        : opt(o),
          connector(
              io, opt, [this](asio::ip::tcp::socket s) { session.open(std::move(s), connector.address()); },
              [this] { finish(lossCode.value_or(kExitStartup)); }),
          session(io, opt, threadCount(), *this) {}

    ~Impl() { renders.joinAll(); }

    uint32_t threadCount() const {
        return opt.threads > 0 ? uint32_t(opt.threads) : uint32_t(std::max(1, tbb::info::default_concurrency()));
    }

    int run() {
        connector.openWindow(opt.connectTimeoutSeconds, false);
        // As PID 1 in a container SIGTERM would otherwise be ignored; leave with a Bye instead.
        signals.async_wait([this](const asio::error_code& e, int sig) {
            if (e) return;
            std::fprintf(stderr, "rtpm-client: stopped by signal %d\n", sig);
            if (session.live())
                leave(proto::ByeReason::Shutdown, "client stopped by signal " + std::to_string(sig), 128 + sig);
            else
                finish(128 + sig);
        });
        connector.start();
        io.run();
        renders.joinAll();
        return exitCode;
    }

    // ---- the session's events (io thread) ------------------------------------------------------

    void onWelcome(const proto::Welcome& w) override {
        std::fprintf(stderr, "rtpm-client: %s %s as client %u (sets %s, %u threads)\n",
                     lossCode ? "rejoined" : "connected to", session.address().c_str(), w.clientId,
                     setList(w.sets).c_str(), threadCount());
        connector.resetBackoff();
        lossCode.reset();
        ++sessionsStarted;
        renders.start(sessionsStarted, threadCount(), opt.testSlowdown, opt.verbose, *this, framesRendered);
    }

    void onReject(const proto::Reject& r) override {
        std::fprintf(stderr, "rtpm-client: server %s refused the connection: %s: %s\n", session.address().c_str(),
                     proto::rejectReasonName(r.reason), printableText(r.text).c_str());
        if (!proto::rejectIsTransient(r.reason)) return finish(kExitRejected);
        // Capacity: a later attempt may get in. The window is the one in force.
        if (!lossCode) lossCode = kExitRejected;
        session.close();
        connector.retry(std::string("refused: ") + proto::rejectReasonName(r.reason));
    }

    void onWork(RenderItem item) override { renders.push(std::move(item)); }

    void onBye(const proto::Bye& bye) override {
        std::fprintf(stderr, "rtpm-client: server %s said bye (%s)%s%s; %llu frames rendered\n",
                     session.address().c_str(), proto::byeReasonName(bye.reason), bye.text.empty() ? "" : ": ",
                     printableText(bye.text).c_str(), (unsigned long long)framesRendered.load());
        switch (bye.reason) {
            case proto::ByeReason::Normal: return finish(kExitOk);
            case proto::ByeReason::Shutdown: return finish(kExitServerGone);  // stopped before the run ended
            case proto::ByeReason::Timeout: return lose(kExitEvicted, "evicted", std::nullopt, "");
            case proto::ByeReason::ProtocolError: return finish(kExitProtocolError);
        }
        finish(kExitProtocolError);
    }

    void onProtocolError(const std::string& why) override {
        std::fprintf(stderr, "rtpm-client: protocol error with server %s: %s\n", session.address().c_str(),
                     why.c_str());
        leave(proto::ByeReason::ProtocolError, why, kExitProtocolError);
    }

    void onClosed(bool wasRunning, bool wasLeaving, const std::string& why) override {
        if (done) return;
        if (wasLeaving) return finish(exitCode);  // our Bye is written (or the master hung up first)
        if (!wasRunning) {
            // Closed before Welcome: the master is starting, full or busy refusing others. A failed
            // attempt like a refused connect, within the same window.
            return connector.retry("the server closed the connection before Welcome (" + why + ")");
        }
        std::fprintf(stderr, "rtpm-client: server %s closed the connection (%s)\n", session.address().c_str(),
                     why.c_str());
        lose(kExitServerGone, "the server closed the connection", std::nullopt, "");
    }

    void onSilent(const std::string& text) override {
        lose(kExitServerGone, "the server fell silent", proto::ByeReason::Timeout, text);
    }

    // ---- the render thread's results (posted to the io thread) ---------------------------------

    /// Runs `f` on the io thread if `sessionId` is still the session being rendered for.
    template <class F>
    void post(uint64_t sessionId, F f) {
        asio::post(io, [this, sessionId, f = std::move(f)]() mutable {
            if (renders.current() && renders.current()->session() == sessionId &&
                session.state() == Session::State::Running)
                f();
        });
    }

    void frameRendered(uint64_t sessionId, std::vector<std::vector<uint8_t>> messages) override {
        post(sessionId, [this, m = std::move(messages)]() mutable {
            for (auto& bytes : m) session.send(std::move(bytes));
        });
    }

    void renderFailed(uint64_t sessionId, Failure failure, std::string why) override {
        post(sessionId, [this, failure, why = std::move(why)] {
            if (failure == Failure::Protocol) return onProtocolError(why);
            std::fprintf(stderr, "rtpm-client: internal error: %s\n", why.c_str());
            leave(proto::ByeReason::Shutdown, "client internal error: " + why, kExitStartup);
        });
    }

    // ---- leaving -------------------------------------------------------------------------------

    /// The session is over for a reason that may pass: say why (if `bye`), drop the session's
    /// render state and connect again with backoff within the rejoin window; once it has run out,
    /// exit with `code`.
    void lose(int code, const std::string& what, std::optional<proto::ByeReason> bye, const std::string& text) {
        if (leaving || done) return;
        const bool hadWelcome = session.welcomed();
        renders.retire();
        session.drop(bye ? std::optional<proto::Bye>(proto::Bye{*bye, text}) : std::nullopt);
        if (!lossCode || hadWelcome) lossCode = code;
        if (hadWelcome) connector.openWindow(opt.rejoinTimeoutSeconds, true);
        if (connector.windowClosed()) {
            std::fprintf(stderr, "rtpm-client: %s; not rejoining (--rejoin-timeout %.1f s)\n", what.c_str(),
                         opt.rejoinTimeoutSeconds);
            return finish(code);
        }
        std::fprintf(stderr, "rtpm-client: %s; rejoining %s (for up to %.1f s)\n", what.c_str(),
                     connector.address().c_str(), connector.secondsLeft());
        connector.retry(what);
    }

    /// Tells the server why we leave, then exits with `code` once that is written (or after kByeGrace).
    void leave(proto::ByeReason reason, const std::string& text, int code) {
        if (leaving || done) return;
        exitCode = code;
        leaving = true;
        renders.retire();
        if (!session.leave(proto::Bye{reason, text})) finish(code);  // else onClosed(wasLeaving) → finish
    }

    /// Ends the process's run with `code`: everything closes, io.run() returns.
    void finish(int code) {
        exitCode = code;
        done = true;
        connector.cancel();
        session.close();
        asio::error_code ignored;
        signals.cancel(ignored);
        renders.retire();
    }

    const WorkerOptions& opt;
    asio::io_context io;
    asio::signal_set signals{io, SIGINT, SIGTERM};
    Connector connector;
    Session session;
    RenderThreads renders;
    bool leaving = false;  ///< our Bye is queued: exit with exitCode once the connection closes
    bool done = false;     ///< finish() ran: io.run() returns once the handlers drain
    int exitCode = kExitStartup;
    /// Exit code of the session lost last (evicted, server gone, refused for capacity), while
    /// trying to (re)join; cleared by a Welcome.
    std::optional<int> lossCode;
    uint64_t sessionsStarted = 0;
    std::atomic<uint64_t> framesRendered{0};
};

Worker::Worker(WorkerOptions options) : options_(std::move(options)) {}
Worker::~Worker() = default;

int Worker::run() {
    try {
        std::unique_ptr<tbb::global_control> limit;
        if (options_.threads > 0)
            limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                          size_t(options_.threads));
        Impl impl(options_);
        return impl.run();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtpm-client: %s\n", e.what());
        return kExitStartup;
    }
}

}  // namespace rtpm::client
