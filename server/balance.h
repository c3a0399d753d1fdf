// Load balance by measured cost: each client's work per set from its Stats, and the share of
// sets that evens the clients' frame times, with hysteresis. Pure: no sockets, no clock, no
// threads (docs/ARCHITECTURE.md §3).
//
// Where sets may move. A set's state (its photon map and progressive estimate) lives on the
// client that renders it and grows with every frame of the epoch. The share changes only at an
// epoch's first frame, where every client restarts every map anyway: a set that moves there
// starts on its new owner exactly as it would have on the old one, so the image stays bit for bit
// what a single process renders, and the move costs nothing. Within an epoch sets stay where they
// are (a still view or an orbit keeps the share it had when its epoch began). Moving a set with
// its state mid-epoch was weighed: shipping the state needs the progressive estimator's
// internals on the wire (megabytes per set); replaying the set's deterministic history on its
// new owner costs that history again and depends on everything a set's passes read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <vector>

#include "server/assignment.h"

namespace rtpm::server {

/// How Balance decides (rtpm-server --static-sets turns it off).
struct BalanceOptions {
    bool enabled = true;
    /// A move must cut the predicted frame time (the slowest client's sets × its cost per set)
    /// by at least this fraction: measurement noise then never moves sets back and forth.
    double minGain = 0.10;
    /// Frames a client must have reported at its current share before it is judged (its cost
    /// per set is measured afresh after every change of share, so a move waits for new figures).
    size_t minSamples = 3;
    /// Figures kept per client; their median is its cost per set.
    size_t window = 5;
};

/// The measured costs and the decision to move sets. Not thread-safe.
class Balance {
public:
    explicit Balance(BalanceOptions options = {});

    bool enabled() const { return options_.enabled; }

    /// Stats of `id` for a frame in which it rendered `sets` sets and worked `workMs` (photon +
    /// eye + encode ms: its own time, not the wait behind other frames). Frames without sets are
    /// ignored.
    void measured(ClientId id, uint32_t sets, double workMs);
    void clientLeft(ClientId id);
    /// Median work per set of `id` in ms; nullopt before minSamples figures at its current share.
    std::optional<double> msPerSet(ClientId id) const;
    /// True when every client in `clients` (at least one) has a cost per set.
    bool measuredAll(const std::vector<ClientId>& clients) const;

    /// The smallest move towards the share that lowers the predicted frame time the most
    /// (greedy over equal sets, at least one set each) that cuts the predicted frame time by
    /// minGain: one set at a time, the slowest client above that share giving its highest set to
    /// the client furthest below it; nullopt unless every client is measured at the share it
    /// holds in `current` and some such move gains. The smallest, because a cost per set
    /// measured at one share need not hold at another (a client under a CPU quota runs at full
    /// speed while its frames fit in the quota's burst); the next move waits for figures at the
    /// new share. `clients` must hold every owner in `current`. Cost O(sets² · clients).
    std::optional<Assignment> propose(const Assignment& current, const std::vector<ClientId>& clients) const;

private:
    struct Client {
        uint32_t sets = 0;            // share the figures were measured at
        std::deque<double> msPerSet;  // newest last
    };
    BalanceOptions options_;
    std::map<ClientId, Client> clients_;
};

}  // namespace rtpm::server
