// The viewer port's admission: slots, deadlines, Origin, token and viewer count, and its log lines.
#include "server/viewer/viewer_gate.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

#include "common/core/printable_text.h"
#include "server/viewer/viewer_model.h"

namespace rtpm::server {

namespace {

bool sameToken(const std::string& a, const std::string& b) {
    // Constant time in the common length: no early exit on the first differing byte.
    unsigned diff = a.size() == b.size() ? 0u : 1u;
    for (size_t i = 0; i < a.size(); ++i)
        diff |= unsigned(uint8_t(a[i]) ^ uint8_t(i < b.size() ? b[i] : 0));
    return diff == 0;
}

std::string lowered(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

}  // namespace

std::vector<std::string> normalizedOrigins(const std::vector<std::string>& origins) {
    std::vector<std::string> out;
    for (std::string origin : origins) {
        origin = lowered(origin);
        while (!origin.empty() && origin.back() == '/') origin.pop_back();
        if (origin.rfind("http://", 0) != 0 && origin.rfind("https://", 0) != 0)
            throw std::invalid_argument(
                "--viewer-origin must be http://HOST[:PORT] or https://HOST[:PORT], got '" +
                printableText(origin) + "'");
        out.push_back(origin);
    }
    return out;
}

std::string ViewerGate::UpgradeRefusals::text(int maxViewers) const {
    std::string t;
    if (origin)
        t += std::to_string(origin) + " WebSocket upgrades refused for their Origin (last \"" +
             lastOrigin + "\"; allow one with --viewer-origin)";
    if (full)
        t += std::string(t.empty() ? "" : ", ") + std::to_string(full) +
             " viewers refused: " + std::to_string(maxViewers) +
             " (--max-viewers) already watching";
    return t;
}

ViewerGate::ViewerGate(asio::io_context& io, WsEndpoint& ws, const ViewerOptions& options)
    : io_(io),
      ws_(ws),
      opt_(options),
      admission_(options.admission),
      deadlineTimer_(io),
      logTimer_(io) {}

bool ViewerGate::accept(ConnId id, const WsEndpoint::Peer& peer) {
    if (stopping_) return false;
    const auto now = Clock::now();
    const std::string source = Admission::sourceKey(peer.remote);
    const Admission::Verdict v = admission_.onConnect(id, source, now);
    armLog();
    if (v.decision != AdmissionDecision::Admit) return false;
    if (v.evict) {
        // Admission ended its slot already; the socket goes now.
        if (auto e = conns_.find(*v.evict); e != conns_.end()) e->second.pending = false;
        ws_.drop(*v.evict);
    }
    Conn c;
    c.source = source;
    const bool v6 = peer.local.find(':') != std::string::npos;
    c.origin =
        "http://" + (v6 ? "[" + peer.local + "]" : peer.local) + ":" + std::to_string(ws_.port());
    c.deadline = now + opt_.handshakeTimeout;
    conns_[id] = std::move(c);
    armDeadline();
    return true;
}

void ViewerGate::progress(ConnId id) { admission_.onProgress(id); }

int ViewerGate::validate(ConnId id, const std::string& path, const std::string& origin) {
    if (stopping_) return 503;
    if (path != "/ws") return 404;
    auto c = conns_.find(id);
    if (c == conns_.end() || !c->second.pending) return 503;  // its time is up
    // Only viewers that said hello count: sockets that never do time out instead.
    if (full()) {
        refuseUpgrade(false, origin);
        return 503;
    }
    // A page from another origin must not drive the master (cross-site WebSocket hijacking,
    // DNS rebinding: such a page chooses the Host header, so only the address the connection
    // reached and the --viewer-origin list are trusted). Non-browser clients send no Origin.
    if (!origin.empty() && !originAllowed(origin, c->second)) {
        refuseUpgrade(true, origin);
        return 403;
    }
    return 0;  // no progress yet: a WebSocket that never says hello stays evictable
}

// The token is checked as the cluster port checks its MAC: a source out of allowance is refused
// unevaluated, a wrong token is answered after the failure delay (holding the slot) and counted
// against the source. A missing token with publicView is a watcher, not a guess.
void ViewerGate::hello(ConnId id, const std::string& token, Admitted admitted) {
    auto c = conns_.find(id);
    if (c == conns_.end() || !c->second.pending) return;  // its time is up
    if (opt_.token.empty()) return admit(id, true, admitted);
    if (token.empty() && opt_.publicView) return admit(id, false, admitted);
    const auto now = Clock::now();
    if (auto limited = admission_.refuseAttempt(c->second.source, now)) {
        armLog();
        // 1008: policy violation.
        refuse(id, replyErrorJson(*limited), Admission::End::Closed, 1008, "rate limited");
        return;
    }
    if (sameToken(token, opt_.token)) return admit(id, true, admitted);
    Conn& conn = c->second;
    conn.deciding = true;
    conn.delay =
        std::make_shared<asio::steady_timer>(io_, admission_.onAuthFailure(conn.source, now));
    armLog();
    conn.delay->async_wait([this, id, admitted = std::move(admitted)](const asio::error_code& e) {
        auto it = conns_.find(id);
        if (e || it == conns_.end()) return;
        it->second.deciding = false;
        if (opt_.publicView) return admit(id, false, admitted);
        refuse(id,
               replyErrorJson(
                   "wrong or missing token: start the page with the cluster or viewer token"),
               Admission::End::FailedAuth, 1008, "token");
    });
}

bool ViewerGate::deciding(ConnId id) const {
    auto c = conns_.find(id);
    return c != conns_.end() && c->second.deciding;
}

void ViewerGate::gone(ConnId id) {
    endPending(id, Admission::End::Closed);
    auto c = conns_.find(id);
    if (c == conns_.end()) return;
    if (c->second.viewer) --viewers_;
    if (c->second.delay) c->second.delay->cancel();
    conns_.erase(c);
}

void ViewerGate::stop() {
    if (stopping_) return;
    stopping_ = true;
    deadlineTimer_.cancel();
    logTimer_.cancel();
    logSummary(true);
    logRunTotals();
}

void ViewerGate::dropPending() {
    for (const auto& [id, c] : conns_)
        if (c.pending) ws_.drop(id);
}

void ViewerGate::admit(ConnId id, bool control, const Admitted& admitted) {
    if (full()) {
        refuseUpgrade(false, "");
        refuse(id,
               replyErrorJson("the viewer has its maximum of " + std::to_string(opt_.maxViewers) +
                              " viewers (--max-viewers); retry later"),
               Admission::End::Closed, 1013, "full");  // 1013: try again later
        return;
    }
    endPending(id, Admission::End::Authenticated);
    ++viewers_;
    conns_[id].viewer = true;
    admitted(control);
}

void ViewerGate::refuse(ConnId id, const std::string& message, Admission::End how, uint16_t code,
                        const std::string& reason) {
    ws_.send(id, message.data(), message.size(), false);
    endPending(id, how);
    ws_.close(id, code, reason);
}

void ViewerGate::endPending(ConnId id, Admission::End how) {
    auto it = conns_.find(id);
    if (it == conns_.end() || !it->second.pending) return;
    it->second.pending = false;
    admission_.onPendingEnded(id, how);
}

bool ViewerGate::full() const { return viewers_ >= size_t(std::max(1, opt_.maxViewers)); }

bool ViewerGate::originAllowed(const std::string& origin, const Conn& c) const {
    const std::string o = lowered(origin);
    if (o == c.origin) return true;
    const bool loopback =
        c.origin.rfind("http://127.", 0) == 0 || c.origin.rfind("http://[::1]:", 0) == 0;
    if (loopback && o == "http://localhost:" + std::to_string(ws_.port())) return true;
    return std::find(opt_.allowedOrigins.begin(), opt_.allowedOrigins.end(), o) !=
           opt_.allowedOrigins.end();
}

void ViewerGate::refuseUpgrade(bool forOrigin, const std::string& origin) {
    for (UpgradeRefusals* r : {&refusedInterval_, &refusedTotal_}) {
        if (forOrigin) {
            ++r->origin;
            r->lastOrigin = printableText(origin);
        } else {
            ++r->full;
        }
    }
    armLog();
}

/// Every 100 ms while a connection is pending: reaps finished HTTP requests (websocketpp ends
/// those silently) and drops connections past their deadline.
void ViewerGate::armDeadline() {
    if (deadlineArmed_ || stopping_) return;
    deadlineArmed_ = true;
    deadlineTimer_.expires_after(std::chrono::milliseconds(100));
    deadlineTimer_.async_wait([this](const asio::error_code& e) {
        deadlineArmed_ = false;
        if (e || stopping_) return;
        ws_.sweep();
        const auto now = Clock::now();
        bool any = false;
        for (auto& [id, c] : conns_) {
            if (!c.pending) continue;
            if (now < c.deadline) {
                any = true;
                continue;
            }
            c.pending = false;
            admission_.onPendingEnded(id, Admission::End::TimedOut);
            ws_.drop(id);
        }
        armLog();
        if (any) armDeadline();
    });
}

void ViewerGate::armLog() {
    if (logArmed_ || stopping_) return;
    const auto next = admission_.nextSummary();
    if (!next) return;
    logArmed_ = true;
    logTimer_.expires_at(*next);
    logTimer_.async_wait([this](const asio::error_code& e) {
        logArmed_ = false;
        if (e) return;
        logSummary();
        armLog();
    });
}

// One line per interval at most, whatever a flood does (peer bytes escaped and bounded).
void ViewerGate::logSummary(bool final) {
    const auto line = admission_.summaryLine(Clock::now(), final);
    const std::string refusals = refusedInterval_.text(opt_.maxViewers);
    refusedInterval_ = UpgradeRefusals{};
    if (line)
        opt_.log("viewer port: " + *line + (refusals.empty() ? "" : "; " + refusals));
    else if (!refusals.empty())
        opt_.log("viewer port: " + refusals);
}

void ViewerGate::logRunTotals() {
    const AdmissionCounts& t = admission_.totals();
    if (!t.any() && !refusedTotal_.any()) return;
    std::string line =
        "viewer port over the run: " + std::to_string(t.connections) + " connections, " +
        std::to_string(t.admitted) + " viewers, " + std::to_string(t.refusedCapacity) +
        " refused (capacity), " + std::to_string(t.refusedRateLimited) + " refused (rate limit), " +
        std::to_string(t.evicted) + " evicted for a newcomer, " + std::to_string(t.timedOut) +
        " timed out, " + std::to_string(t.failedAuth) + " failed tokens";
    if (refusedTotal_.any()) line += "; " + refusedTotal_.text(opt_.maxViewers);
    opt_.log(line);
}

}  // namespace rtpm::server
