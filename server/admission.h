// Admission of new connections before they authenticate: budgets per source address and
// overall, fair-share eviction, failed-authentication rate limits, and one summary log line per
// interval. Pure and clock-injected (the master feeds it events and times; tests drive it alone).
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>

namespace rtpm::server {

/// Limits of the pre-authentication state (docs/ARCHITECTURE.md §1: the master accepts and
/// authenticates clients). Authenticated clients are counted elsewhere (MasterOptions::maxPeers):
/// they never compete with pending sockets for a slot.
struct AdmissionLimits {
    size_t maxPending = 128;          ///< connections still in their handshake, all sources together
    size_t maxPendingPerSource = 16;  ///< of which from one source address (IPv6: one /64)
    /// Failed authentications a source may make in a burst, and how fast that allowance refills.
    /// Each failure is also answered only after failureDelay, holding the source's pending slot,
    /// so one source guesses at most maxPendingPerSource / failureDelay per second even in a burst.
    double failureBurst = 10.0;
    double failureRefillPerSecond = 1.0;
    std::chrono::milliseconds failureDelay{500};
    std::chrono::milliseconds logInterval{10000};  ///< at most one summary line per interval
    size_t maxSources = 4096;        ///< per-source records kept (idle ones are forgotten first)
};

/// What to do with a new connection.
enum class AdmissionDecision {
    Admit,          ///< start its handshake
    RefuseCapacity, ///< tell it RejectReason::Capacity and close (it may retry with backoff)
    RefuseRateLimited,  ///< tell it RejectReason::RateLimited and close
};

/// Counters of one log interval (and, in totals(), of the whole run).
struct AdmissionCounts {
    uint64_t connections = 0;       ///< onConnect calls
    uint64_t refusedCapacity = 0;
    uint64_t refusedRateLimited = 0;
    uint64_t evicted = 0;           ///< pending connections closed to make room for another source
    uint64_t timedOut = 0;          ///< handshakes not finished within their timeout
    uint64_t failedAuth = 0;        ///< wrong MAC (or a refused Hello/Auth of another kind)
    uint64_t protocolErrors = 0;    ///< pre-authentication bytes that broke the protocol
    uint64_t admitted = 0;          ///< handshakes completed
    bool any() const {
        return refusedCapacity || refusedRateLimited || evicted || timedOut || failedAuth || protocolErrors;
    }
};

/// The pre-authentication bookkeeping of the master. Connections are named by an id the caller
/// chooses (unique while pending). Not thread-safe (the master's I/O thread owns it).
class Admission {
public:
    using Clock = std::chrono::steady_clock;
    using TimePoint = Clock::time_point;

    explicit Admission(AdmissionLimits limits);

    /// The budget key of an address: IPv4 as is, IPv6 by its /64 (one host usually holds a whole
    /// /64), IPv4-mapped IPv6 as the IPv4 address. `address` is Asio's to_string() form.
    static std::string sourceKey(const std::string& address);

    struct Verdict {
        AdmissionDecision decision = AdmissionDecision::Admit;
        std::optional<uint64_t> evict;  ///< when admitted: close this pending connection first
        std::string text;               ///< when refused: what to tell the peer
    };
    /// Whether pending connection `id` has sent any byte yet (read or waiting to be read).
    using SentBytes = std::function<bool(uint64_t id)>;
    /// A new connection from `source`. Admitted connections count as pending until
    /// onPendingEnded(). Only idle slots (no onProgress yet) are ever taken from another
    /// connection, those that sent nothing at all (`sentBytes`, when given) before those whose
    /// first bytes are in but not yet a valid Hello (a real client's Hello may wait unread behind
    /// a flood's accepts), oldest first: a peer that sent a valid Hello never loses its slot to
    /// one that sent nothing. When the source's slots are all taken, the newcomer takes its source's
    /// oldest idle slot (so an idle flood from a shared address cannot keep a real client of that
    /// address out), else it is refused. When every slot is taken, it takes the oldest idle slot
    /// of a source holding at least two more than the newcomer's — of those, the one that
    /// connected most often lately (a flooder, not a host starting several clients at once).
    Verdict onConnect(uint64_t id, const std::string& source, TimePoint now, const SentBytes& sentBytes = {});

    /// The pending connection `id` made progress (sent a valid Hello, a whole request): its slot
    /// is no longer taken for a newcomer. Unknown ids are ignored.
    void onProgress(uint64_t id);

    /// Why a pending connection stopped being pending.
    enum class End { Authenticated, TimedOut, FailedAuth, ProtocolError, Closed, Evicted };
    /// Frees its slot and counts the outcome. Unknown ids are ignored.
    void onPendingEnded(uint64_t id, End how);

    /// Before an Auth from `source` is checked: nullopt when the source may make an attempt,
    /// otherwise the refusal text (RejectReason::RateLimited; counted). The guess is then never
    /// evaluated, so evaluated guesses per source stay within the allowance even when many of
    /// its connections passed onConnect together.
    std::optional<std::string> refuseAttempt(const std::string& source, TimePoint now);

    /// A failed authentication from `source`: uses one of its allowance and returns how long to
    /// wait before answering (the connection keeps its pending slot meanwhile).
    std::chrono::milliseconds onAuthFailure(const std::string& source, TimePoint now);

    /// One summary line of the interval that ended, or nullopt when nothing worth a line happened
    /// or the interval has not ended (`final`: ends it now, at shutdown). Call it often (it is
    /// O(1) until an interval ends).
    std::optional<std::string> summaryLine(TimePoint now, bool final = false);
    /// The end of the current interval (for a timer), nullopt when nothing is counted.
    std::optional<TimePoint> nextSummary() const;

    size_t pending() const { return pendingById_.size(); }
    size_t pendingFrom(const std::string& source) const;
    size_t sourcesKept() const { return sources_.size(); }
    const AdmissionCounts& totals() const { return totals_; }

private:
    struct Source {
        std::deque<uint64_t> pending;  ///< ids, oldest first
        double allowance = 0.0;        ///< failed authentications left (refills over time)
        TimePoint refilled{};
        double recentConnections = 0.0;  ///< connections, decayed with a 10 s time constant
        TimePoint counted{};
        uint64_t failuresInInterval = 0;
    };
    struct Pending {
        std::string source;
        bool progressed = false;
    };
    /// The oldest pending connection of `s` without progress, one that sent nothing first.
    std::optional<uint64_t> oldestIdle(const Source& s, const SentBytes& sentBytes) const;
    Source& source(const std::string& key, TimePoint now);
    void refill(Source& s, TimePoint now) const;
    void count(uint64_t AdmissionCounts::*field);
    void forgetIdleSources(TimePoint now);
    std::string rateLimitText(const std::string& key, const Source& s) const;
    static double decayed(const Source& s, TimePoint now);

    AdmissionLimits limits_;
    std::unordered_map<std::string, Source> sources_;
    std::unordered_map<uint64_t, Pending> pendingById_;
    AdmissionCounts interval_;
    AdmissionCounts totals_;
    std::optional<TimePoint> intervalStart_;
};

}  // namespace rtpm::server
