// Worker: one Asio io_context for connect/receive/send, one render thread fed in arrival order.
#include "client/worker.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <array>
#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <deque>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>
#include <variant>

#include "client/frame_renderer.h"
#include "common/core/printable_text.h"
#include "proto/auth.h"
#include "proto/messages.h"
#include "proto/net/connection.h"

namespace rtpm::client {

namespace {

using Clock = std::chrono::steady_clock;
using asio::ip::tcp;

constexpr auto kFirstBackoff = std::chrono::milliseconds(100);
constexpr auto kMaxBackoff = std::chrono::milliseconds(2000);
/// How often a client that cannot reach its master says whom it is waiting for.
constexpr auto kWaitNoticeInterval = std::chrono::seconds(5);
/// One connection attempt may not take longer than this (a silent host drops SYNs).
constexpr auto kAttemptTimeout = std::chrono::seconds(5);
/// After a Bye is queued the socket is closed when it is written, or after this at the latest.
constexpr auto kByeGrace = std::chrono::seconds(2);
/// Unsent bytes after which the master is taken as not reading (a few pipelined float32 frames).
constexpr size_t kMaxQueuedBytes = size_t(256) << 20;


std::string setList(const std::vector<uint32_t>& sets) {
    std::string s;
    for (uint32_t v : sets) {
        if (!s.empty()) s += ',';
        s += std::to_string(v);
    }
    return s.empty() ? "none" : s;
}

// Clips texts from the network or exceptions to what Bye may carry.
std::string clip(std::string s) {
    if (s.size() > proto::kMaxTextBytes) s.resize(proto::kMaxTextBytes);
    return s;
}

}  // namespace

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

struct Worker::Impl : net::ConnectionHandler {
    enum class State { Connecting, AwaitWelcome, Running, Done };
    /// What the render thread consumes, in arrival order.
    struct FrameItem {
        proto::FrameBegin begin;
        Clock::time_point received;
    };
    using Item = std::variant<proto::Settings, proto::Scene, proto::Edit, FrameItem>;
    /// The render side of one session (Welcome to its end): its queue, thread and photon maps.
    /// A rejoin starts a new one; the old thread finishes its current item and is joined later.
    struct Session {
        explicit Session(uint64_t id, uint32_t threads) : id(id), renderer(threads) {}
        const uint64_t id;
        std::mutex mu;
        std::condition_variable cv;
        std::deque<Item> queue;
        bool stop = false;
        std::atomic<bool> finished{false};  ///< the render thread has returned (join will not block)
        std::thread thread;
        FrameRenderer renderer;
    };

    explicit Impl(WorkerOptions o) : opt(std::move(o)) {
        if (opt.tls) {
            tls = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
            tls->set_options(asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1);
            asio::error_code ec;
            if (opt.tlsCa.empty()) tls->set_default_verify_paths(ec);
            else tls->load_verify_file(opt.tlsCa, ec);
            if (ec) throw std::runtime_error("TLS trust store " + (opt.tlsCa.empty() ? "(system)" : opt.tlsCa) + ": " + ec.message());
        }
    }

    ~Impl() { joinSessions(); }

    uint32_t threadCount() const {
        return opt.threads > 0 ? uint32_t(opt.threads) : uint32_t(std::max(1, tbb::info::default_concurrency()));
    }

    static Clock::duration seconds(double s) {
        return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(0.0, s)));
    }

    int run() {
        deadline = Clock::now() + seconds(opt.connectTimeoutSeconds);
        nextWaitNotice = {};
        // As PID 1 in a container SIGTERM would otherwise be ignored; leave with a Bye instead.
        signals.async_wait([this](const asio::error_code& e, int sig) {
            if (e) return;
            std::fprintf(stderr, "rtpm-client: stopped by signal %d\n", sig);
            if (state == State::AwaitWelcome || state == State::Running)
                leave(proto::ByeReason::Shutdown, "client stopped by signal " + std::to_string(sig), 128 + sig);
            else
                finish(128 + sig);
        });
        asio::post(io, [this] { attempt(); });
        io.run();
        joinSessions();
        return exitCode;
    }

    // ---- connecting --------------------------------------------------------------------------

    bool readPortFile(uint16_t& out) {
        std::ifstream in(opt.portFile);
        if (!in) {
            lastError = "port file " + opt.portFile + " does not exist yet";
            return false;
        }
        std::string text;
        in >> text;
        std::string h = "x";
        if (!parseHostPort("x:" + text, h, out)) {
            lastError = "port file " + opt.portFile + " holds no port yet (\"" + clip(text) + "\")";
            return false;
        }
        return true;
    }

    void attempt() {
        if (state != State::Connecting) return;
        if (Clock::now() >= deadline) {
            const bool rejoin = sessionsStarted > 0;
            std::fprintf(stderr, "rtpm-client: could not %s %s within %.1f s (%d attempts): %s\n",
                         rejoin ? "rejoin" : "connect to", addrText().c_str(),
                         rejoin ? opt.rejoinTimeoutSeconds : opt.connectTimeoutSeconds, attempts, lastError.c_str());
            return finish(lossCode.value_or(kExitStartup));
        }
        ++attempts;
        port = opt.port;
        if (port == 0 && !readPortFile(port)) {
            scheduleRetry();
            return;
        }
        asio::error_code ec;
        tcp::resolver resolver(io);
        auto endpoints = resolver.resolve(opt.host, std::to_string(port), ec);
        if (ec) {
            lastError = "cannot resolve " + opt.host + ": " + ec.message();
            scheduleRetry();
            return;
        }
        socket = tcp::socket(io);
        const uint64_t id = attempts;
        asio::async_connect(socket, endpoints, [this, id](const asio::error_code& e, const tcp::endpoint&) {
            if (id != uint64_t(attempts) || state != State::Connecting) return;
            attemptTimer.cancel();
            if (e) {
                lastError = e == asio::error::operation_aborted ? "connection attempt timed out" : e.message();
                asio::error_code ignored;
                socket.close(ignored);
                scheduleRetry();
                return;
            }
            onConnected();
        });
        attemptTimer.expires_after(std::min<Clock::duration>(kAttemptTimeout, deadline - Clock::now()));
        attemptTimer.async_wait([this, id](const asio::error_code& e) {
            if (e || id != uint64_t(attempts) || state != State::Connecting) return;
            asio::error_code ignored;
            socket.close(ignored);  // completes the pending connect with operation_aborted
        });
    }

    void scheduleRetry() {
        // Says whom it waits for and why, at the first failed attempt and every few seconds after,
        // so a client started before its master is not silent for the whole window.
        const auto now = Clock::now();
        if (now >= nextWaitNotice && deadline > now) {
            nextWaitNotice = now + kWaitNoticeInterval;
            const double left = std::chrono::duration<double>(deadline - now).count();
            if (port == 0 && opt.port == 0)
                std::fprintf(stderr, "rtpm-client: waiting for the server at %s, port from %s (%s); retrying for %.0f s "
                             "more\n", opt.host.c_str(), opt.portFile.c_str(), lastError.c_str(), left);
            else
                std::fprintf(stderr, "rtpm-client: waiting for the server at %s (%s); retrying for %.0f s more\n",
                             addrText().c_str(), lastError.c_str(), left);
        }
        const auto wait = std::min<Clock::duration>(backoff, std::max<Clock::duration>(deadline - Clock::now(), {}));
        backoff = std::min<Clock::duration>(backoff * 2, kMaxBackoff);
        retryTimer.expires_after(wait);
        retryTimer.async_wait([this](const asio::error_code& e) {
            if (!e && state == State::Connecting) attempt();
        });
    }

    std::string addrText() const {
        const std::string p = port ? std::to_string(port) : (opt.port ? std::to_string(opt.port) : "?");
        return (opt.host.find(':') != std::string::npos ? "[" + opt.host + "]" : opt.host) + ":" + p;
    }

    void onConnected() {
        state = State::AwaitWelcome;
        // The same connection class as the master's (framed reads, one write in flight).
        conn = std::make_shared<net::Connection>(std::move(socket), *this, kMaxQueuedBytes);
        if (tls) conn->useTls(*tls, false, opt.host);
        hello = proto::Hello{};
        challenged = false;
        hello.cores = threadCount();
        hello.clientName = opt.name;
        conn->send(hello);  // the token never travels: the server's Challenge is answered with a MAC
        conn->start(std::chrono::milliseconds(0));
        watchIdle();
    }

    // ---- idle timeout ------------------------------------------------------------------------

    /// Checks a few times per idle timeout that bytes keep arriving from the master (it sends a
    /// Heartbeat every second). A tick that comes much later than asked means this process was
    /// stopped (SIGSTOP, a suspended VM): that gap is not the master's silence.
    void watchIdle() {
        const Clock::duration idle = seconds(opt.idleTimeoutSeconds);
        if (idle <= Clock::duration::zero()) return;
        const Clock::duration tick = std::min<Clock::duration>(idle / 4, std::chrono::seconds(1));
        lastBytes = conn->bytesReceived();
        lastProgress = lastTick = Clock::now();
        const auto watched = conn.get();
        idleTimer.expires_after(tick);
        idleTimer.async_wait([this, watched, idle, tick](const asio::error_code& e) {
            if (!e) idleTick(watched, idle, tick);
        });
    }

    void idleTick(const net::Connection* watched, Clock::duration idle, Clock::duration tick) {
        if (!conn || conn.get() != watched || (state != State::AwaitWelcome && state != State::Running)) return;
        const auto now = Clock::now();
        if (conn->bytesReceived() != lastBytes || now - lastTick > tick + idle / 2) {
            lastBytes = conn->bytesReceived();
            lastProgress = now;
        }
        lastTick = now;
        if (now - lastProgress >= idle) {
            const double s = std::chrono::duration<double>(now - lastProgress).count();
            std::fprintf(stderr, "rtpm-client: no message from server %s for %.1f s (idle timeout %.1f s): it is "
                                 "frozen or unreachable\n",
                         addrText().c_str(), s, opt.idleTimeoutSeconds);
            char text[96];
            std::snprintf(text, sizeof text, "no message from the server for %.1f s", s);
            return lose(kExitServerGone, "the server fell silent", proto::ByeReason::Timeout, text);
        }
        idleTimer.expires_after(tick);
        idleTimer.async_wait([this, watched, idle, tick](const asio::error_code& e) {
            if (!e) idleTick(watched, idle, tick);
        });
    }

    // ---- receiving (net::ConnectionHandler, io thread) ----------------------------------------

    void onMessage(net::Connection& c, proto::Message&& m, size_t) override {
        // A previous session's connection still flushing its Bye, or ours after we said Bye.
        if (&c != conn.get() || leaving) return;
        if (state == State::AwaitWelcome || state == State::Running) handle(std::move(m));
    }

    void onBadBytes(net::Connection& c, const proto::Error& e) override {
        if (&c != conn.get() || leaving) return;
        if (state == State::AwaitWelcome || state == State::Running)
            protocolError("undecodable bytes: " + e.message);
    }

    void onClosed(net::Connection& c, const std::string& why) override {
        if (&c != conn.get()) return;
        conn.reset();
        if (state == State::Done) return;
        if (leaving) return finish(exitCode);  // our Bye is written (or the master hung up first)
        if (state == State::AwaitWelcome) {
            // Closed before Welcome: the master is starting, full or busy refusing others. A failed
            // attempt like a refused connect, within the same window.
            lastError = "the server closed the connection before Welcome (" + why + ")";
            stopIdle();
            state = State::Connecting;
            return scheduleRetry();
        }
        if (state != State::Running) return;
        std::fprintf(stderr, "rtpm-client: server %s closed the connection (%s)\n", addrText().c_str(), why.c_str());
        lose(kExitServerGone, "the server closed the connection", std::nullopt, "");
    }

    void handle(proto::Message msg) {
        const proto::MessageType type = proto::typeOf(msg);
        if (auto* bye = std::get_if<proto::Bye>(&msg)) return handleBye(*bye);
        if (type == proto::MessageType::Heartbeat) return;  // its bytes already reset the idle timer
        if (state == State::AwaitWelcome) {
            if (auto* ch = std::get_if<proto::Challenge>(&msg)) {
                if (challenged) return protocolError("a second Challenge");
                challenged = true;
                conn->send(proto::Auth{proto::authMac(opt.token, ch->nonce, hello)});
                return;
            }
            if (auto* w = std::get_if<proto::Welcome>(&msg)) {
                if (!challenged) return protocolError("Welcome without a Challenge");
                std::fprintf(stderr, "rtpm-client: %s %s as client %u (sets %s, %u threads)\n",
                             lossCode ? "rejoined" : "connected to", addrText().c_str(), w->clientId,
                             setList(w->sets).c_str(), threadCount());
                state = State::Running;
                conn->markAuthenticated();
                backoff = kFirstBackoff;
                lossCode.reset();
                ++sessionsStarted;
                pruneSessions();  // earlier sessions' photon maps are freed, not kept for the run
                session = std::make_shared<Session>(sessionsStarted, threadCount());
                session->thread = std::thread([this, s = session] { renderLoop(s); });
                return;
            }
            if (auto* r = std::get_if<proto::Reject>(&msg)) {
                std::fprintf(stderr, "rtpm-client: server %s refused the connection: %s: %s\n", addrText().c_str(),
                             proto::rejectReasonName(r->reason), printableText(r->text).c_str());
                if (proto::rejectIsTransient(r->reason)) {
                    // Capacity: a later attempt may get in. The window is the one in force.
                    lastError = std::string("refused: ") + proto::rejectReasonName(r->reason);
                    if (!lossCode) lossCode = kExitRejected;
                    closeConnection();
                    state = State::Connecting;
                    return scheduleRetry();
                }
                return finish(kExitRejected);
            }
            return protocolError(std::string("expected Welcome or Reject, got ") + proto::messageTypeName(type));
        }
        switch (type) {
            case proto::MessageType::Settings: return enqueue(std::get<proto::Settings>(std::move(msg)));
            case proto::MessageType::Scene: return enqueue(std::get<proto::Scene>(std::move(msg)));
            case proto::MessageType::Edit: return enqueue(std::get<proto::Edit>(std::move(msg)));
            case proto::MessageType::FrameBegin:
                return enqueue(FrameItem{std::get<proto::FrameBegin>(std::move(msg)), Clock::now()});
            default: return protocolError(std::string("unexpected ") + proto::messageTypeName(type) + " after Welcome");
        }
    }

    void handleBye(const proto::Bye& bye) {
        std::fprintf(stderr, "rtpm-client: server %s said bye (%s)%s%s; %llu frames rendered\n", addrText().c_str(),
                     proto::byeReasonName(bye.reason), bye.text.empty() ? "" : ": ",
                     printableText(bye.text).c_str(), (unsigned long long)framesRendered.load());
        switch (bye.reason) {
            case proto::ByeReason::Normal: return finish(kExitOk);
            case proto::ByeReason::Shutdown: return finish(kExitServerGone);  // stopped before the run ended
            case proto::ByeReason::Timeout: return lose(kExitEvicted, "evicted", std::nullopt, "");
            case proto::ByeReason::ProtocolError: return finish(kExitProtocolError);
        }
        finish(kExitProtocolError);
    }

    // ---- leaving -----------------------------------------------------------------------------

    /// The session is over for a reason that may pass: say why (if `bye`), drop the session's
    /// render state and connect again with backoff within the rejoin window; once it has run out,
    /// exit with `code`.
    void lose(int code, const std::string& what, std::optional<proto::ByeReason> bye, const std::string& text) {
        if (leaving || state == State::Done) return;
        const bool hadWelcome = state == State::Running;
        retireSession();
        stopIdle();
        if (conn) {
            auto old = conn;
            conn.reset();  // its onClosed is ignored from now on
            if (bye) {
                old->dropUnsent();
                old->send(proto::Bye{*bye, clip(text)});
                old->closeAfterFlush(kByeGrace);
            } else {
                old->close("session lost");
            }
        }
        if (!lossCode || hadWelcome) lossCode = code;
        if (hadWelcome) {
            deadline = Clock::now() + seconds(opt.rejoinTimeoutSeconds);
            nextWaitNotice = {};
        }
        if (Clock::now() >= deadline) {
            std::fprintf(stderr, "rtpm-client: %s; not rejoining (--rejoin-timeout %.1f s)\n", what.c_str(),
                         opt.rejoinTimeoutSeconds);
            return finish(code);
        }
        std::fprintf(stderr, "rtpm-client: %s; rejoining %s (for up to %.1f s)\n", what.c_str(), addrText().c_str(),
                     std::chrono::duration<double>(deadline - Clock::now()).count());
        lastError = what;
        state = State::Connecting;
        scheduleRetry();
    }

    /// Tells the server why we leave, then exits with `code` once that is written (or after kByeGrace).
    void leave(proto::ByeReason reason, const std::string& text, int code) {
        if (leaving || state == State::Done) return;
        exitCode = code;
        leaving = true;
        retireSession();
        stopIdle();
        if (!conn) return finish(code);
        // Frames not yet on the wire are moot; keep only the write in progress.
        conn->dropUnsent();
        conn->send(proto::Bye{reason, clip(text)});
        conn->closeAfterFlush(kByeGrace);  // onClosed → finish
    }

    void protocolError(const std::string& why) {
        std::fprintf(stderr, "rtpm-client: protocol error with server %s: %s\n", addrText().c_str(), why.c_str());
        leave(proto::ByeReason::ProtocolError, why, kExitProtocolError);
    }

    void closeConnection() {
        stopIdle();
        if (!conn) return;
        auto old = conn;
        conn.reset();
        old->close("client done");
    }

    void stopIdle() {
        asio::error_code ignored;
        idleTimer.cancel();
    }

    /// Ends the process's run with `code`: everything closes, io.run() returns.
    void finish(int code) {
        exitCode = code;
        state = State::Done;
        asio::error_code ignored;
        socket.close(ignored);  // a connection attempt in progress
        closeConnection();
        attemptTimer.cancel();
        retryTimer.cancel();
        asio::error_code ignoredSignal;
        signals.cancel(ignoredSignal);
        retireSession();
    }

    // ---- render thread -----------------------------------------------------------------------

    void enqueue(Item item) {
        if (!session) return;
        {
            std::lock_guard<std::mutex> lock(session->mu);
            session->queue.push_back(std::move(item));
        }
        session->cv.notify_one();
    }

    /// Stops the current session's render thread after its current item, without blocking the
    /// io thread; it is joined when run() returns (or at once if it is already done).
    void retireSession() {
        if (!session) return;
        {
            std::lock_guard<std::mutex> lock(session->mu);
            session->stop = true;
        }
        session->cv.notify_all();
        retired.push_back(std::move(session));
        session.reset();
    }

    /// Joins and frees the retired sessions whose thread has returned (without blocking).
    void pruneSessions() {
        std::erase_if(retired, [](const std::shared_ptr<Session>& s) {
            if (!s->finished) return false;
            if (s->thread.joinable()) s->thread.join();
            return true;
        });
    }

    void joinSessions() {
        retireSession();
        for (auto& s : retired)
            if (s->thread.joinable()) s->thread.join();
        retired.clear();
    }

    void renderLoop(std::shared_ptr<Session> s) {
        struct Finished {
            Session& s;
            ~Finished() { s.finished = true; }
        } finished{*s};
        FrameRenderer& renderer = s->renderer;
        const uint64_t sid = s->id;
        // Results are posted to the io thread, which sends them only if this session still runs.
        auto post = [this, sid](auto f) {
            asio::post(io, [this, sid, f = std::move(f)]() mutable {
                if (session && session->id == sid && state == State::Running) f();
            });
        };
        for (;;) {
            Item item;
            {
                std::unique_lock<std::mutex> lock(s->mu);
                s->cv.wait(lock, [&] { return s->stop || !s->queue.empty(); });
                if (s->stop) return;
                item = std::move(s->queue.front());
                s->queue.pop_front();
            }
            try {
                if (auto* st = std::get_if<proto::Settings>(&item)) {
                    renderer.setSettings(*st);
                } else if (auto* sc = std::get_if<proto::Scene>(&item)) {
                    const auto t0 = Clock::now();
                    renderer.setScene(*sc);
                    std::fprintf(stderr, "rtpm-client: scene %s loaded in %.0f ms\n",
                                 sc->source == proto::Scene::Source::Builtin ? sc->builtinName.c_str() : "(glTF)",
                                 std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
                } else if (auto* e = std::get_if<proto::Edit>(&item)) {
                    renderer.queueEdit(*e);
                } else {
                    const FrameItem& f = std::get<FrameItem>(item);
                    RenderedFrame r = renderer.render(f.begin, f.received);
                    std::vector<std::vector<uint8_t>> bytes;
                    for (const proto::FrameData& d : r.data) {
                        auto enc = proto::tryEncode(d);
                        if (!enc.ok())
                            throw std::runtime_error("set " + std::to_string(d.set) +
                                                     " does not fit one FrameData: " + enc.error().message);
                        bytes.push_back(std::move(enc.value()));
                    }
                    bytes.push_back(proto::encode(r.stats));
                    ++framesRendered;
                    if (opt.verbose)
                        std::printf("frame %llu: sets %s, photons %.1f ms, eye %.1f ms, encode %.1f ms, %llu stored\n",
                                    (unsigned long long)f.begin.frame, setList(f.begin.sets).c_str(),
                                    double(r.stats.photonMs), double(r.stats.renderMs), double(r.stats.encodeMs),
                                    (unsigned long long)r.stats.photonsStored);
                    if (opt.verbose) std::fflush(stdout);  // scripts and tests follow progress live
                    post([this, b = std::move(bytes)]() mutable {
                        for (auto& m : b) conn->send(std::make_shared<const std::vector<uint8_t>>(std::move(m)));
                    });
                }
            } catch (const ProtocolViolation& e) {
                post([this, why = std::string(e.what())] { protocolError(why); });
                return;
            } catch (const SceneError& e) {
                post([this, why = std::string(e.what())] { protocolError(why); });
                return;
            } catch (const std::exception& e) {
                post([this, why = std::string(e.what())] {
                    std::fprintf(stderr, "rtpm-client: internal error: %s\n", why.c_str());
                    leave(proto::ByeReason::Shutdown, "client internal error: " + why, kExitStartup);
                });
                return;
            }
        }
    }

    WorkerOptions opt;
    asio::io_context io;
    tcp::socket socket{io};
    asio::steady_timer attemptTimer{io};
    asio::steady_timer retryTimer{io};
    asio::steady_timer idleTimer{io};
    asio::signal_set signals{io, SIGINT, SIGTERM};
    State state = State::Connecting;
    bool leaving = false;  ///< our Bye is queued: exit with exitCode once the connection closes
    int exitCode = kExitStartup;
    /// Exit code of the session lost last (evicted, server gone, refused for capacity), while
    /// trying to (re)join; cleared by a Welcome.
    std::optional<int> lossCode;

    Clock::time_point deadline;  ///< of the current connect or rejoin window
    Clock::time_point nextWaitNotice;  ///< the next "waiting for the server" line is due then
    Clock::duration backoff = kFirstBackoff;
    int attempts = 0;
    uint16_t port = 0;
    std::string lastError = "no attempt made";

    uint64_t lastBytes = 0;
    Clock::time_point lastProgress, lastTick;

    std::unique_ptr<asio::ssl::context> tls;  ///< --tls
    proto::Hello hello;                     ///< what this connection said (the Auth MAC covers it)
    bool challenged = false;                ///< the Challenge of this connection was answered

    std::shared_ptr<net::Connection> conn;  ///< the current session's, once connected
    std::shared_ptr<Session> session;       ///< the current session's render side, after Welcome
    std::vector<std::shared_ptr<Session>> retired;
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
