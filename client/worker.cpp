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
#include <sstream>
#include <thread>
#include <variant>

#include "client/frame_renderer.h"
#include "proto/auth.h"
#include "proto/messages.h"
#include "proto/net/connection.h"

namespace rtpm::client {

namespace {

using Clock = std::chrono::steady_clock;
using asio::ip::tcp;

constexpr auto kFirstBackoff = std::chrono::milliseconds(100);
constexpr auto kMaxBackoff = std::chrono::milliseconds(2000);
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
        if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':') return false;
        h = text.substr(1, close - 1);
        p = text.substr(close + 2);
    } else {
        const size_t colon = text.rfind(':');
        if (colon == std::string::npos) return false;
        h = text.substr(0, colon);
        p = text.substr(colon + 1);
    }
    if (h.empty() || p.empty() || p.size() > 5 || !std::all_of(p.begin(), p.end(), ::isdigit)) return false;
    const unsigned long v = std::stoul(p);
    if (v < 1 || v > 65535) return false;
    host = h;
    port = uint16_t(v);
    return true;
}

struct Worker::Impl : net::ConnectionHandler {
    enum class State { Connecting, AwaitWelcome, Running, Closing, Done };
    /// What the render thread consumes, in arrival order.
    struct FrameItem {
        proto::FrameBegin begin;
        Clock::time_point received;
    };
    using Item = std::variant<proto::Settings, proto::Scene, proto::Edit, FrameItem>;

    explicit Impl(WorkerOptions o) : opt(std::move(o)), renderer(threadCount()) {
        if (opt.tls) {
            tls = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
            tls->set_options(asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1);
            asio::error_code ec;
            if (opt.tlsCa.empty()) tls->set_default_verify_paths(ec);
            else tls->load_verify_file(opt.tlsCa, ec);
            if (ec) throw std::runtime_error("TLS trust store " + (opt.tlsCa.empty() ? "(system)" : opt.tlsCa) + ": " + ec.message());
        }
    }

    ~Impl() { stopRenderThread(); }

    uint32_t threadCount() const {
        return opt.threads > 0 ? uint32_t(opt.threads) : uint32_t(std::max(1, tbb::info::default_concurrency()));
    }

    int run() {
        deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(std::max(0.0, opt.connectTimeoutSeconds)));
        // As PID 1 in a container SIGTERM would otherwise be ignored; leave with a Bye instead.
        signals.async_wait([this](const asio::error_code& e, int sig) {
            if (e) return;
            std::fprintf(stderr, "rtpm-client: stopped by signal %d\n", sig);
            if (state == State::AwaitWelcome || state == State::Running) {
                sayByeAndClose(proto::ByeReason::Shutdown, "client stopped by signal " + std::to_string(sig),
                               128 + sig);
            } else {
                exitCode = 128 + sig;
                closeNow();
            }
        });
        asio::post(io, [this] { attempt(); });
        io.run();
        stopRenderThread();
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
        if (Clock::now() >= deadline) {
            std::fprintf(stderr, "rtpm-client: could not connect to %s within %.1f s (%d attempts): %s\n",
                         addrText().c_str(), opt.connectTimeoutSeconds, attempts, lastError.c_str());
            exitCode = kExitStartup;
            return closeNow();
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
    }

    // ---- receiving (net::ConnectionHandler, io thread) ----------------------------------------

    void onMessage(net::Connection&, proto::Message&& m, size_t) override {
        if (state == State::AwaitWelcome || state == State::Running) handle(std::move(m));
    }

    void onBadBytes(net::Connection&, const proto::Error& e) override {
        if (state == State::AwaitWelcome || state == State::Running)
            protocolError("undecodable bytes: " + e.message);
    }

    void onClosed(net::Connection&, const std::string& why) override {
        if (state == State::Done) return;
        // Closing: we said Bye and the server hung up first (or the Bye was written); nothing is lost.
        if (state == State::Closing) return closeNow();
        serverGone(why);
    }

    void handle(proto::Message msg) {
        const proto::MessageType type = proto::typeOf(msg);
        if (auto* bye = std::get_if<proto::Bye>(&msg)) return handleBye(*bye);
        if (state == State::AwaitWelcome) {
            if (auto* ch = std::get_if<proto::Challenge>(&msg)) {
                if (challenged) return protocolError("a second Challenge");
                challenged = true;
                conn->send(proto::Auth{proto::authMac(opt.token, ch->nonce, hello)});
                return;
            }
            if (auto* w = std::get_if<proto::Welcome>(&msg)) {
                if (!challenged) return protocolError("Welcome without a Challenge");
                std::fprintf(stderr, "rtpm-client: connected to %s as client %u (sets %s, %u threads)\n",
                             addrText().c_str(), w->clientId, setList(w->sets).c_str(), threadCount());
                state = State::Running;
                conn->markAuthenticated();
                renderThread = std::thread([this] { renderLoop(); });
                return;
            }
            if (auto* r = std::get_if<proto::Reject>(&msg)) {
                std::fprintf(stderr, "rtpm-client: server %s refused the connection: %s: %s\n", addrText().c_str(),
                             proto::rejectReasonName(r->reason), r->text.c_str());
                exitCode = kExitRejected;
                return closeNow();
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
        const bool normal = bye.reason == proto::ByeReason::Normal || bye.reason == proto::ByeReason::Shutdown;
        std::fprintf(stderr, "rtpm-client: server %s said bye (%s)%s%s; %llu frames rendered\n", addrText().c_str(),
                     proto::byeReasonName(bye.reason), bye.text.empty() ? "" : ": ", bye.text.c_str(),
                     (unsigned long long)framesRendered.load());
        exitCode = normal ? kExitOk : kExitProtocolError;
        closeNow();
    }

    void serverGone(const std::string& why) {
        std::fprintf(stderr, "rtpm-client: server %s closed the connection (%s)\n", addrText().c_str(), why.c_str());
        exitCode = kExitServerGone;
        closeNow();
    }

    // ---- leaving -----------------------------------------------------------------------------

    /// Tells the server why we leave, then closes once that is written (or after kByeGrace).
    void sayByeAndClose(proto::ByeReason reason, const std::string& text, int code) {
        if (state == State::Closing || state == State::Done) return;
        exitCode = code;
        state = State::Closing;
        stopRenderThread(false);
        if (!conn) return closeNow();
        // Frames not yet on the wire are moot; keep only the write in progress.
        conn->dropUnsent();
        conn->send(proto::Bye{reason, clip(text)});
        conn->closeAfterFlush(kByeGrace);  // onClosed → closeNow
    }

    void protocolError(const std::string& why) {
        std::fprintf(stderr, "rtpm-client: protocol error with server %s: %s\n", addrText().c_str(), why.c_str());
        sayByeAndClose(proto::ByeReason::ProtocolError, why, kExitProtocolError);
    }

    void closeNow() {
        state = State::Done;
        asio::error_code ignored;
        socket.close(ignored);  // a connection attempt in progress
        if (conn) conn->close("client done");
        attemptTimer.cancel();
        retryTimer.cancel();
        asio::error_code ignoredSignal;
        signals.cancel(ignoredSignal);
        stopRenderThread(false);
    }

    // ---- render thread -----------------------------------------------------------------------

    void enqueue(Item item) {
        {
            std::lock_guard<std::mutex> lock(mu);
            queue.push_back(std::move(item));
        }
        cv.notify_one();
    }

    /// Stops the render thread after its current item; joins it unless called from an io handler
    /// that must not block (join = false: the thread is joined when run() returns).
    void stopRenderThread(bool join = true) {
        {
            std::lock_guard<std::mutex> lock(mu);
            stopRender = true;
        }
        cv.notify_all();
        if (join && renderThread.joinable()) renderThread.join();
    }

    void renderLoop() {
        for (;;) {
            Item item;
            {
                std::unique_lock<std::mutex> lock(mu);
                cv.wait(lock, [this] { return stopRender || !queue.empty(); });
                if (stopRender) return;
                item = std::move(queue.front());
                queue.pop_front();
            }
            try {
                if (auto* s = std::get_if<proto::Settings>(&item)) {
                    renderer.setSettings(*s);
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
                    asio::post(io, [this, b = std::move(bytes)]() mutable {
                        if (state != State::Running) return;
                        for (auto& m : b) conn->send(std::make_shared<const std::vector<uint8_t>>(std::move(m)));
                    });
                }
            } catch (const ProtocolViolation& e) {
                asio::post(io, [this, why = std::string(e.what())] { protocolError(why); });
                return;
            } catch (const SceneError& e) {
                asio::post(io, [this, why = std::string(e.what())] { protocolError(why); });
                return;
            } catch (const std::exception& e) {
                asio::post(io, [this, why = std::string(e.what())] {
                    std::fprintf(stderr, "rtpm-client: internal error: %s\n", why.c_str());
                    sayByeAndClose(proto::ByeReason::Shutdown, "client internal error: " + why, kExitStartup);
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
    asio::signal_set signals{io, SIGINT, SIGTERM};
    State state = State::Connecting;
    int exitCode = kExitStartup;

    Clock::time_point deadline;
    Clock::duration backoff = kFirstBackoff;
    int attempts = 0;
    uint16_t port = 0;
    std::string lastError = "no attempt made";

    std::unique_ptr<asio::ssl::context> tls;  ///< --tls
    std::shared_ptr<net::Connection> conn;  ///< once connected
    proto::Hello hello;                     ///< what this connection said (the Auth MAC covers it)
    bool challenged = false;                ///< the Challenge of this connection was answered

    std::mutex mu;
    std::condition_variable cv;
    std::deque<Item> queue;
    bool stopRender = false;
    std::thread renderThread;
    std::atomic<uint64_t> framesRendered{0};
    FrameRenderer renderer;
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
