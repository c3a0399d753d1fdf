// Session: the client side of the handshake and the dispatch of the master's messages, one connection at a time.
#include "client/session.h"

#include <algorithm>
#include <cstdio>

#include "client/connector.h"
#include "proto/auth.h"

namespace rtpm::client {

namespace {

/// After a Bye is queued the socket is closed when it is written, or after this at the latest.
constexpr auto kByeGrace = std::chrono::seconds(2);
/// Unsent bytes after which the master is taken as not reading (a few pipelined float32 frames).
constexpr size_t kMaxQueuedBytes = size_t(256) << 20;

// Clips texts from the network or exceptions to what Bye may carry.
proto::Bye clipped(proto::Bye bye) {
    if (bye.text.size() > proto::kMaxTextBytes) bye.text.resize(proto::kMaxTextBytes);
    return bye;
}

}  // namespace

// ---- IdleWatch -----------------------------------------------------------------------------------

IdleWatch::IdleWatch(asio::io_context& io, double idleSeconds)
    : timer_(io), idle_(secondsDuration(idleSeconds)),
      tick_(std::min<Clock::duration>(idle_ / 4, std::chrono::seconds(1))) {}

void IdleWatch::watch(const net::Connection& conn, std::function<void(double)> silent) {
    stop();
    if (idle_ <= Clock::duration::zero()) return;
    conn_ = &conn;
    silent_ = std::move(silent);
    lastBytes_ = conn.bytesReceived();
    lastProgress_ = lastTick_ = Clock::now();
    timer_.expires_after(tick_);
    timer_.async_wait([this, g = generation_](const asio::error_code& e) {
        if (!e && g == generation_) tick();
    });
}

void IdleWatch::stop() {
    ++generation_;
    conn_ = nullptr;
    timer_.cancel();
}

void IdleWatch::tick() {
    const auto now = Clock::now();
    if (conn_->bytesReceived() != lastBytes_ || now - lastTick_ > tick_ + idle_ / 2) {
        lastBytes_ = conn_->bytesReceived();
        lastProgress_ = now;
    }
    lastTick_ = now;
    if (now - lastProgress_ >= idle_) {
        auto silent = std::move(silent_);
        stop();
        return silent(std::chrono::duration<double>(now - lastProgress_).count());
    }
    timer_.expires_after(tick_);
    timer_.async_wait([this, g = generation_](const asio::error_code& e) {
        if (!e && g == generation_) tick();
    });
}

// ---- Session -------------------------------------------------------------------------------------

Session::Session(asio::io_context& io, const WorkerOptions& options, uint32_t cores, SessionEvents& events)
    : opt_(options), events_(events), cores_(cores), idle_(io, options.idleTimeoutSeconds) {
    if (!opt_.tls) return;
    tls_ = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
    tls_->set_options(asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1);
    asio::error_code ec;
    if (opt_.tlsCa.empty()) tls_->set_default_verify_paths(ec);
    else tls_->load_verify_file(opt_.tlsCa, ec);
    if (ec)
        throw std::runtime_error("TLS trust store " + (opt_.tlsCa.empty() ? "(system)" : opt_.tlsCa) + ": " +
                                 ec.message());
}

void Session::open(asio::ip::tcp::socket socket, std::string address) {
    address_ = std::move(address);
    state_ = State::AwaitWelcome;
    welcomed_ = false;
    // The same connection class as the master's (framed reads, one write in flight).
    conn_ = std::make_shared<net::Connection>(std::move(socket), *this, kMaxQueuedBytes);
    if (tls_) conn_->useTls(*tls_, false, opt_.host);
    hello_ = proto::Hello{};
    challenged_ = false;
    hello_.cores = cores_;
    hello_.clientName = opt_.name;
    conn_->send(hello_);  // the token never travels: the server's Challenge is answered with a MAC
    conn_->start(std::chrono::milliseconds(0));
    idle_.watch(*conn_, [this](double s) {
        std::fprintf(stderr, "rtpm-client: no message from server %s for %.1f s (idle timeout %.1f s): it is "
                             "frozen or unreachable\n",
                     address_.c_str(), s, opt_.idleTimeoutSeconds);
        char text[96];
        std::snprintf(text, sizeof text, "no message from the server for %.1f s", s);
        events_.onSilent(text);
    });
}

void Session::send(std::vector<uint8_t> bytes) {
    if (conn_ && state_ == State::Running) conn_->send(std::make_shared<const std::vector<uint8_t>>(std::move(bytes)));
}

std::shared_ptr<net::Connection> Session::release() {
    idle_.stop();
    state_ = State::Closed;
    return std::exchange(conn_, nullptr);
}

void Session::drop(std::optional<proto::Bye> bye) {
    welcomed_ = false;
    auto old = release();  // its onClosed is ignored from now on
    if (!old) return;
    if (bye) {
        old->dropUnsent();
        old->send(clipped(*bye));
        old->closeAfterFlush(kByeGrace);
    } else {
        old->close("session lost");
    }
}

bool Session::leave(const proto::Bye& bye) {
    idle_.stop();
    if (!conn_) return false;
    state_ = State::Leaving;
    // Frames not yet on the wire are moot; keep only the write in progress.
    conn_->dropUnsent();
    conn_->send(clipped(bye));
    conn_->closeAfterFlush(kByeGrace);  // onClosed → events_.onClosed(wasLeaving)
    return true;
}

void Session::close() {
    if (auto old = release()) old->close("client done");
}

// ---- receiving (net::ConnectionHandler) ------------------------------------------------------------

void Session::onMessage(net::Connection& c, proto::Message&& m, size_t) {
    // A previous connection still flushing its Bye, or ours after we said Bye.
    if (&c != conn_.get() || !live()) return;
    if (auto* bye = std::get_if<proto::Bye>(&m)) return events_.onBye(*bye);
    if (std::holds_alternative<proto::Heartbeat>(m)) return;  // its bytes already reset the idle watch
    if (state_ == State::AwaitWelcome) return handshake(m);
    dispatch(std::move(m));
}

void Session::onBadBytes(net::Connection& c, const proto::Error& e) {
    if (&c != conn_.get() || !live()) return;
    events_.onProtocolError("undecodable bytes: " + e.message);
}

void Session::onClosed(net::Connection& c, const std::string& why) {
    if (&c != conn_.get()) return;
    const State was = state_;
    release();
    events_.onClosed(was == State::Running, was == State::Leaving, why);
}

void Session::handshake(proto::Message& msg) {
    if (auto* ch = std::get_if<proto::Challenge>(&msg)) {
        if (challenged_) return events_.onProtocolError("a second Challenge");
        challenged_ = true;
        conn_->send(proto::Auth{proto::authMac(opt_.token, ch->nonce, hello_)});
        return;
    }
    if (auto* w = std::get_if<proto::Welcome>(&msg)) {
        if (!challenged_) return events_.onProtocolError("Welcome without a Challenge");
        state_ = State::Running;
        welcomed_ = true;
        conn_->markAuthenticated();
        return events_.onWelcome(*w);
    }
    if (auto* r = std::get_if<proto::Reject>(&msg)) return events_.onReject(*r);
    events_.onProtocolError(std::string("expected Welcome or Reject, got ") +
                            proto::messageTypeName(proto::typeOf(msg)));
}

void Session::dispatch(proto::Message&& msg) {
    const proto::MessageType type = proto::typeOf(msg);
    switch (type) {
        case proto::MessageType::Settings: return events_.onWork(std::get<proto::Settings>(std::move(msg)));
        case proto::MessageType::Scene: return events_.onWork(std::get<proto::Scene>(std::move(msg)));
        case proto::MessageType::Edit: return events_.onWork(std::get<proto::Edit>(std::move(msg)));
        case proto::MessageType::FrameBegin:
            return events_.onWork(
                FrameItem{std::get<proto::FrameBegin>(std::move(msg)), std::chrono::steady_clock::now()});
        default:
            events_.onProtocolError(std::string("unexpected ") + proto::messageTypeName(type) + " after Welcome");
    }
}

}  // namespace rtpm::client
