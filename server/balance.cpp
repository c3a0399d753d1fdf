// Load balance by measured cost: per-client cost per set and greedy shares with hysteresis.
#include "server/balance.h"

#include <algorithm>

namespace rtpm::server {

Balance::Balance(BalanceOptions options) : options_(options) {
    options_.minSamples = std::max<size_t>(1, options_.minSamples);
    options_.window = std::max(options_.window, options_.minSamples);
}

void Balance::measured(ClientId id, uint32_t sets, double workMs) {
    if (sets == 0 || !(workMs >= 0.0)) return;
    Client& c = clients_[id];
    if (c.sets != sets) {  // a new share: the old figures say how it did before
        c.sets = sets;
        c.msPerSet.clear();
    }
    c.msPerSet.push_back(workMs / double(sets));
    while (c.msPerSet.size() > options_.window) c.msPerSet.pop_front();
}

void Balance::clientLeft(ClientId id) { clients_.erase(id); }

std::optional<double> Balance::msPerSet(ClientId id) const {
    auto it = clients_.find(id);
    if (it == clients_.end() || it->second.msPerSet.size() < options_.minSamples) return std::nullopt;
    std::vector<double> v(it->second.msPerSet.begin(), it->second.msPerSet.end());
    auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return std::max(*mid, 1e-3);
}

bool Balance::measuredAll(const std::vector<ClientId>& clients) const {
    for (ClientId id : clients)
        if (!msPerSet(id)) return false;
    return !clients.empty();
}

std::optional<Assignment> Balance::propose(const Assignment& current, const std::vector<ClientId>& clients) const {
    if (!options_.enabled || clients.size() < 2 || !measuredAll(clients)) return std::nullopt;
    const size_t n = clients.size();
    const auto setCount = uint32_t(current.owner.size());
    if (setCount < n) return std::nullopt;
    std::vector<double> cost(n);
    std::vector<size_t> have(n, 0);
    for (size_t i = 0; i < n; ++i) {
        cost[i] = *msPerSet(clients[i]);
        have[i] = current.countOf(clients[i]);
        if (clients_.at(clients[i]).sets != have[i]) return std::nullopt;  // figures of an older share
    }
    auto frameTime = [&](const std::vector<size_t>& counts) {
        double t = 0.0;
        for (size_t i = 0; i < n; ++i) t = std::max(t, double(counts[i]) * cost[i]);
        return t;
    };
    // Greedy makespan for equal sets: one each, then every further set to whoever finishes it
    // first (ties: the earlier joiner).
    std::vector<size_t> want(n, 1);
    for (uint32_t s = uint32_t(n); s < setCount; ++s) {
        size_t best = 0;
        for (size_t i = 1; i < n; ++i)
            if (double(want[i] + 1) * cost[i] < double(want[best] + 1) * cost[best]) best = i;
        ++want[best];
    }
    const double now = frameTime(have);
    if (frameTime(want) > now * (1.0 - options_.minGain)) return std::nullopt;

    // The smallest move towards that share that gains: one set at a time, the slowest client
    // above its share giving its highest set to the client furthest below its share (ties: the
    // earlier joiner), until the predicted frame time falls by minGain (with two clients one set;
    // more where equally slow clients must each give one). A client's cost per set is measured
    // at the share it holds and need not hold at another: one held to a CPU quota works at full
    // speed while its frames fit in the quota's burst, so at two sets of nine it looks as fast as
    // any and at four it is throttled (tests/bench/RESULTS.md, "Load balance by measured cost").
    // Moving the whole way on such figures swung between 7/2 and 5/4; the next move waits for
    // figures at the new share, at a later epoch.
    Assignment next = current;
    std::vector<size_t> count = have;
    while (count != want) {
        size_t donor = n, taker = n;
        for (size_t i = 0; i < n; ++i) {
            if (count[i] > want[i] && (donor == n || double(count[i]) * cost[i] > double(count[donor]) * cost[donor]))
                donor = i;
            if (count[i] < want[i] && (taker == n || want[i] - count[i] > want[taker] - count[taker])) taker = i;
        }
        for (uint32_t s = setCount; s-- > 0;)
            if (next.owner[s] == clients[donor]) {
                next.owner[s] = clients[taker];
                break;
            }
        --count[donor];
        ++count[taker];
        if (frameTime(count) <= now * (1.0 - options_.minGain)) return next;
    }
    return std::nullopt;
}

}  // namespace rtpm::server
