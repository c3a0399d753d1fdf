// Static assignment of interleaving sets: round-robin deal and minimal-movement rebalancing.
#include "server/assignment.h"

#include <algorithm>

namespace rtpm::server {

std::vector<uint32_t> Assignment::setsOf(ClientId client) const {
    std::vector<uint32_t> sets;
    for (uint32_t s = 0; s < owner.size(); ++s)
        if (owner[s] == client) sets.push_back(s);
    return sets;
}

size_t Assignment::countOf(ClientId client) const {
    return static_cast<size_t>(std::count(owner.begin(), owner.end(), client));
}

Assignment dealSets(uint32_t setCount, std::span<const ClientId> clients) {
    Assignment a;
    a.owner.assign(setCount, kNoClient);
    if (clients.empty()) return a;
    for (uint32_t s = 0; s < setCount; ++s) a.owner[s] = clients[s % clients.size()];
    return a;
}

Assignment rebalance(const Assignment& previous, uint32_t setCount, std::span<const ClientId> clients) {
    if (previous.owner.size() != setCount || clients.empty()) return dealSets(setCount, clients);

    // counts[i] = sets held by clients[i]; index in join order doubles as the tie-breaker.
    std::vector<size_t> counts(clients.size(), 0);
    auto indexOf = [&](ClientId c) -> std::ptrdiff_t {
        auto it = std::find(clients.begin(), clients.end(), c);
        return it == clients.end() ? -1 : it - clients.begin();
    };
    Assignment a;
    a.owner.assign(setCount, kNoClient);
    bool anySurvivor = false;
    for (uint32_t s = 0; s < setCount; ++s) {
        std::ptrdiff_t i = previous.owner[s] == kNoClient ? -1 : indexOf(previous.owner[s]);
        if (i < 0) continue;
        a.owner[s] = clients[static_cast<size_t>(i)];
        ++counts[static_cast<size_t>(i)];
        anySurvivor = true;
    }
    if (!anySurvivor) return dealSets(setCount, clients);

    // min_element returns the first minimum: the earliest-joined least-loaded client.
    auto leastLoaded = [&] { return static_cast<size_t>(std::min_element(counts.begin(), counts.end()) - counts.begin()); };
    for (uint32_t s = 0; s < setCount; ++s) {
        if (a.owner[s] != kNoClient) continue;
        size_t i = leastLoaded();
        a.owner[s] = clients[i];
        ++counts[i];
    }
    for (;;) {
        size_t taker = leastLoaded();
        // Last maximum: among equally loaded donors the latest joiner gives a set away.
        size_t donor = 0;
        for (size_t i = 0; i < counts.size(); ++i)
            if (counts[i] >= counts[donor]) donor = i;
        if (counts[donor] <= counts[taker] + 1) break;
        for (uint32_t s = setCount; s-- > 0;) {
            if (a.owner[s] == clients[donor]) {
                a.owner[s] = clients[taker];
                break;
            }
        }
        --counts[donor];
        ++counts[taker];
    }
    return a;
}

std::vector<uint32_t> movedSets(const Assignment& before, const Assignment& after) {
    std::vector<uint32_t> moved;
    size_t n = std::max(before.owner.size(), after.owner.size());
    for (size_t s = 0; s < n; ++s) {
        ClientId b = s < before.owner.size() ? before.owner[s] : kNoClient;
        ClientId c = s < after.owner.size() ? after.owner[s] : kNoClient;
        if (b != c) moved.push_back(static_cast<uint32_t>(s));
    }
    return moved;
}

}  // namespace rtpm::server
