// Connections from accept to close: admission, the handshake of each, the registry, heartbeats.
#include "server/peers.h"

#include <cstdio>

#include "common/core/printable_text.h"
#include "proto/auth.h"

namespace rtpm::server {

namespace {

/// An authenticated peer's message must arrive at least this fast on average (after the read
/// timeout's allowance): a 24 MiB float32 frame may take ≈ 100 s, a trickle is still bounded.
constexpr uint64_t kMinReadBytesPerSecond = 256 * 1024;

}  // namespace

Peers::Peers(asio::io_context& io, const MasterOptions& options, PeerEvents& events)
    : io_(io),
      opt_(options),
      events_(events),
      acceptor_(io, options.listen, options.port, options.tlsCert, options.tlsKey,
                [this](asio::ip::tcp::socket sock) { admit(std::move(sock)); }),
      admission_(options.admission),
      admissionLogTimer_(io),
      heartbeatTimer_(io),
      readStall_(options.readTimeout) {}

void Peers::start() {
    acceptor_.start();
    heartbeat();
}

// Every second, a Heartbeat to each client with nothing queued: its idle timeout then tells a
// frozen master from an idle one (paused, waiting for clients, a client without sets).
void Peers::heartbeat() {
    heartbeatTimer_.expires_after(proto::kHeartbeatInterval);
    heartbeatTimer_.async_wait([this](const asio::error_code& ec) {
        if (ec || closing_) return;
        static const net::Connection::Buffer message =
            std::make_shared<const std::vector<uint8_t>>(proto::encode(proto::Heartbeat{}));
        for (const auto& [id, c] : registry_.clients())
            if (c.connection->queuedBytes() == 0) c.connection->send(message);
        heartbeat();
    });
}

// A new socket: budgets first (server/admission.h), then the handshake with only a Hello allowed.
// Refusals and failures are counted into one summary line per interval, never one line each.
void Peers::admit(asio::ip::tcp::socket sock) {
    if (closing_) return;
    asio::error_code ec;
    const auto ep = sock.remote_endpoint(ec);
    if (ec) return;  // already gone
    const std::string source = Admission::sourceKey(ep.address().to_string());
    const uint64_t id = connections_.nextId();
    // A slot given to the newcomer is taken from a connection that sent nothing before one whose
    // first bytes (a real client's Hello, perhaps) wait unread behind the accepts.
    const Admission::Verdict v = admission_.onConnect(id, source, Admission::Clock::now(), [this](uint64_t pending) {
        const auto owned = connections_.withSession(pending);
        return owned && owned->peerSentBytes();
    });
    armAdmissionLog();
    if (v.decision != AdmissionDecision::Admit) {
        ++counts_.refused;
        // A plain Reject would be garbage to a TLS client; a TLS handshake per refusal is what a flood wants.
        if (acceptor_.tls()) return;
        Acceptor::refuseNow(sock,
                            v.decision == AdmissionDecision::RefuseCapacity ? proto::RejectReason::Capacity
                                                                            : proto::RejectReason::RateLimited,
                            v.text);
        return;
    }
    if (v.evict)
        if (auto owned = connections_.withSession(*v.evict)) {
            owned->send(proto::Reject{proto::RejectReason::Capacity,
                                      "handshake slot given to a newer connection (this one had "
                                      "sent nothing yet); retry later"});
            owned->closeAfterFlush(std::chrono::milliseconds(200));
        }
    auto c = std::make_shared<net::Connection>(std::move(sock), *this, opt_.maxQueuedBytes);
    if (acceptor_.tls()) c->useTls(*acceptor_.tls(), true);
    connections_.add(c, HandshakeSession(id, source));
    c->expectOnly(proto::MessageType::Hello, proto::payloadLimit(proto::MessageType::Hello));
    c->start(opt_.handshakeTimeout);
}

void Peers::armAdmissionLog() {
    if (admissionLogArmed_ || closing_) return;
    const auto next = admission_.nextSummary();
    if (!next) return;
    admissionLogArmed_ = true;
    admissionLogTimer_.expires_at(*next);
    admissionLogTimer_.async_wait([this](const asio::error_code& ec) {
        admissionLogArmed_ = false;
        if (ec) return;
        if (auto line = admission_.summaryLine(Admission::Clock::now())) std::fprintf(stderr, "rtpm-server: %s\n", line->c_str());
        armAdmissionLog();
    });
}

// Refuses a peer in its handshake. Not logged one by one (a flood would fill the disk): the
// admission summary line counts it.
void Peers::reject(net::Connection& c, proto::RejectReason reason, const std::string& text) {
    if (reason == proto::RejectReason::BadToken) ++counts_.failedAuth;
    else if (reason == proto::RejectReason::ProtocolError) ++counts_.protocolErrors;
    else ++counts_.refused;
    c.send(proto::Reject{reason, text.substr(0, proto::kMaxTextBytes)});
    c.closeAfterFlush();
}

void Peers::protocolError(net::Connection& c, const std::string& why) {
    std::fprintf(stderr, "rtpm-server: closing %s: protocol error: %s\n", registry_.describe(c).c_str(), why.c_str());
    ++counts_.protocolErrors;
    c.send(proto::Bye{proto::ByeReason::ProtocolError, why.substr(0, proto::kMaxTextBytes)});
    c.closeAfterFlush();
    dropClientOf(c, "protocol error");
}

void Peers::evict(ClientId id, const std::string& why) {
    ClientInfo* c = registry_.find(id);
    if (!c) return;
    auto connection = c->connection;
    connection->send(proto::Bye{proto::ByeReason::Timeout, why});
    connection->closeAfterFlush();
    dropClientOf(*connection, "evicted (late or frozen)");
}

void Peers::sendToAll(const net::Connection::Buffer& bytes) {
    for (const auto& [id, c] : registry_.clients()) c.connection->send(bytes);
}

void Peers::dropClientOf(net::Connection& c, const std::string& why) {
    std::optional<ClientInfo> gone = registry_.remove(c);
    if (!gone) return;
    std::fprintf(stderr, "rtpm-server: client %u (%s) left: %s\n", gone->id, gone->name.c_str(), why.c_str());
    events_.clientLeft(*gone, why);
}

void Peers::onBadBytes(net::Connection& c, const proto::Error& e) {
    std::string why = std::string(proto::errorCodeName(e.code)) + ": " + e.message;
    if (!registry_.find(c)) {
        endPending(c, Admission::End::ProtocolError);
        reject(c,
               e.code == proto::ErrorCode::BadVersion ? proto::RejectReason::VersionMismatch
                                                      : proto::RejectReason::ProtocolError,
               why);
        return;
    }
    protocolError(c, why);
}

void Peers::endPending(const net::Connection& c, Admission::End how) {
    if (const auto id = connections_.endPending(c)) admission_.onPendingEnded(*id, how);
}

void Peers::onClosed(net::Connection& c, const std::string& why) {
    endPending(c, c.handshakeTimedOut() ? Admission::End::TimedOut : Admission::End::Closed);
    dropClientOf(c, why);
    const bool none = connections_.remove(c);
    if (closing_ && none) events_.allClosed();
}

void Peers::onMessage(net::Connection& c, proto::Message&& m, size_t wireBytes) {
    if (closing_) return;
    ClientInfo* client = registry_.find(c);
    if (!client) {
        if (PeerConnections::Pending* p = connections_.pending(c)) handshake(c, *p, m);  // else: closing
        return;
    }
    if (std::holds_alternative<proto::FrameData>(m) || std::holds_alternative<proto::Stats>(m)) {
        events_.clientMessage(*client, std::move(m), wireBytes);
    } else if (auto* bye = std::get_if<proto::Bye>(&m)) {
        std::string why = "said Bye (" + std::to_string(static_cast<int>(bye->reason)) + ") " + printableText(bye->text);
        c.closeAfterFlush();
        dropClientOf(c, why);
    } else {
        protocolError(c, std::string("unexpected ") + proto::messageTypeName(proto::typeOf(m)) + " from a client");
    }
}

// Hello → Challenge{nonce} → Auth{HMAC} → Welcome (PROTOCOL.md §7). The token never travels.
void Peers::handshake(net::Connection& c, PeerConnections::Pending& p, const proto::Message& m) {
    HandshakeSession& s = p.session;
    HandshakeStep step;
    if (s.awaitingAuth() && !opt_.insecureNoToken)
        if (auto limited = admission_.refuseAttempt(s.source(), Admission::Clock::now())) {
            armAdmissionLog();
            step = s.refuse(proto::RejectReason::RateLimited, *limited);
            endPending(c, Admission::End::Closed);
            reject(c, step.reason, step.text);
            return;
        }
    step = s.onMessage(m, opt_.token, opt_.insecureNoToken);
    switch (step.action) {
        case HandshakeStep::Action::Ignore: return;  // its refusal is on the way
        case HandshakeStep::Action::Challenge:
            admission_.onProgress(s.id());  // a valid Hello: its slot is no longer taken for an idle newcomer
            c.expectOnly(proto::MessageType::Auth, proto::payloadLimit(proto::MessageType::Auth));
            c.send(proto::Challenge{s.nonce()});
            return;
        case HandshakeStep::Action::Refuse:
            endPending(c, Admission::End::ProtocolError);
            reject(c, step.reason, step.text);
            return;
        case HandshakeStep::Action::RefuseLater: {
            // The answer waits (the slot stays taken): guesses from one address are slowed and then
            // refused at connect (server/admission.h) instead of answered in a fraction of a millisecond.
            p.delay = std::make_shared<asio::steady_timer>(io_, admission_.onAuthFailure(s.source(), Admission::Clock::now()));
            armAdmissionLog();
            std::shared_ptr<net::Connection> owned = connections_.ownerOf(c);
            p.delay->async_wait([this, owned, text = step.text](const asio::error_code& ec) {
                if (ec || !owned) return;
                endPending(*owned, Admission::End::FailedAuth);
                reject(*owned, proto::RejectReason::BadToken, text);
            });
            return;
        }
        case HandshakeStep::Action::Authenticated: break;
    }
    if (registry_.size() >= static_cast<size_t>(opt_.maxPeers)) {
        endPending(c, Admission::End::Closed);
        reject(c, proto::RejectReason::Capacity,
               "the server has its maximum of " + std::to_string(opt_.maxPeers) + " clients; retry later");
        return;
    }
    join(c, s);
}

void Peers::join(net::Connection& c, const HandshakeSession& session) {
    const std::string name = session.name();
    const unsigned cores = session.cores();
    endPending(c, Admission::End::Authenticated);  // destroys `session`
    c.markAuthenticated();
    c.setReadDeadline(readStall_, kMinReadBytesPerSecond);
    c.capPayload(clientPayloadCap_);
    const ClientId id = registry_.add(connections_.ownerOf(c), name, cores);
    ++counts_.joined;
    std::fprintf(stderr, "rtpm-server: client %u (%s, %s, %u cores) joined\n", id, name.c_str(), c.peer().c_str(),
                 cores);
    events_.clientJoined(*registry_.find(id));
}

void Peers::raisePayloadCap(const RenderSettings& settings) {
    const uint64_t m = uint64_t(settings.interleave);
    const uint64_t setPixels = ((uint64_t(settings.width) + m - 1) / m) * ((uint64_t(settings.height) + m - 1) / m);
    // The largest FrameData of a set: float32 pixels (24 B), one own weight (1 B) a pixel, the
    // set's shot (20 B a photon, at most its share of kMaxSharedPhotons) and the fixed fields
    // (PROTOCOL.md §5.7: 61 bytes; 96 leaves room).
    const uint64_t shot = 20 * (uint64_t(proto::kMaxSharedPhotons) / (m * m));
    const uint64_t cap = std::min<uint64_t>(std::max<uint64_t>(4096, 96 + 25 * setPixels + shot),
                                            proto::payloadLimit(proto::MessageType::FrameData));
    if (cap <= clientPayloadCap_) return;
    clientPayloadCap_ = uint32_t(cap);
    for (const auto& [id, info] : registry_.clients()) info.connection->capPayload(clientPayloadCap_);
}

// A frame that moved sets to a client waits the deadline's ceiling for it (new owners build maps);
// without this bound, a client that joined and stopped halfway through a message held that frame,
// and every frame behind it, for the whole read timeout: 10 s per join.
void Peers::boundReadStall(std::chrono::milliseconds frameDeadline) {
    if (opt_.readTimeout.count() <= 0) return;  // --read-timeout-ms 0: never
    const auto stall = std::min(opt_.readTimeout, std::max(kMinReadStall, frameDeadline));
    if (stall == readStall_) return;
    readStall_ = stall;
    for (const auto& [id, info] : registry_.clients()) info.connection->setReadDeadline(readStall_, kMinReadBytesPerSecond);
}

void Peers::quiesce() {
    closing_ = true;
    acceptor_.stopAccepting();
}

bool Peers::closeAll(proto::ByeReason reason, const std::string& text) {
    quiesce();
    acceptor_.close();
    heartbeatTimer_.cancel();
    admissionLogTimer_.cancel();
    connections_.cancelDelays();
    if (admission_.totals().any()) {
        const AdmissionCounts& t = admission_.totals();
        std::fprintf(stderr,
                     "rtpm-server: admission over the run: %llu connections, %llu authenticated, %llu refused "
                     "(capacity), %llu refused (rate limit), %llu evicted, %llu timed out, %llu protocol errors, "
                     "%llu failed authentications\n",
                     (unsigned long long)t.connections, (unsigned long long)t.admitted,
                     (unsigned long long)t.refusedCapacity, (unsigned long long)t.refusedRateLimited,
                     (unsigned long long)t.evicted, (unsigned long long)t.timedOut,
                     (unsigned long long)t.protocolErrors, (unsigned long long)t.failedAuth);
    }
    for (const auto& c : connections_.all()) {
        if (registry_.find(*c)) c->send(proto::Bye{reason, text});
        c->closeAfterFlush();
    }
    return !connections_.empty();
}

}  // namespace rtpm::server
