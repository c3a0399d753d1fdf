// Static assignment of interleaving sets to clients: the initial deal and the rebalancing policy.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace rtpm::server {

/// A connected client's id, unique for the server's lifetime (never reused after a disconnect).
using ClientId = uint32_t;
inline constexpr ClientId kNoClient = std::numeric_limits<ClientId>::max();

/// Who renders each interleaving set. Sets are assigned statically (paper §4.3): a client keeps
/// its sets frame after frame so its photon maps accumulate; they change only when clients join
/// or leave, and then at a frame boundary.
struct Assignment {
    std::vector<ClientId> owner;  ///< owner[s] for every set s; kNoClient when nobody holds it

    /// Sets held by `client`, ascending. Cost O(sets).
    std::vector<uint32_t> setsOf(ClientId client) const;
    /// Number of sets held by `client`. Cost O(sets).
    size_t countOf(ClientId client) const;
    bool operator==(const Assignment&) const = default;
};

/// The initial deal: with N clients (in join order) client i gets {s : s mod N == i}.
/// When N does not divide `setCount` the first (setCount mod N) clients hold one set more (the
/// documented imbalance: at most one set). With N > setCount clients i ≥ setCount are spares
/// (no sets). With no clients every set is unowned. Pure; cost O(setCount).
Assignment dealSets(uint32_t setCount, std::span<const ClientId> clientsInJoinOrder);

/// Reassignment at a frame boundary when clients joined or left while photon maps are warm.
/// Policy (minimal movement, because a set that changes owner restarts accumulation on its new
/// owner from batch 0):
///  1. every set whose owner is still connected stays with it;
///  2. orphaned sets (owner left), ascending, each go to the client holding the fewest sets
///     (ties: earliest in join order) — spares are therefore the first to take work;
///  3. while the most loaded client holds more than one set over the least loaded, its highest
///     set moves to the least loaded (ties: the latest-joined donor, the earliest-joined taker),
///     so a (re)joining client gets work again and loads differ by at most one set.
/// If `previous` does not describe `setCount` sets, or no surviving client holds a set, this is
/// dealSets(). Pure; cost O(setCount · clients).
Assignment rebalance(const Assignment& previous, uint32_t setCount,
                     std::span<const ClientId> clientsInJoinOrder);

/// Sets whose owner differs between `before` and `after` (both over the same set count),
/// ascending. These restart accumulation on their new owner.
std::vector<uint32_t> movedSets(const Assignment& before, const Assignment& after);

}  // namespace rtpm::server
