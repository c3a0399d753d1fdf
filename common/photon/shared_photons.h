// The photons every set shot in one frame, for the other sets' progressive passes: a still
// view's pixel draws on every set's photons, not only its own set's (docs/ARCHITECTURE.md §6.2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "common/photon/kd_tree.h"
#include "common/photon/photon.h"
#include "common/photon/set_photons.h"

namespace rtpm {

/// One kd-tree per set over SetPhotons of one frame, for the progressive passes' searches
/// (ProgressiveSet::pass).
/// Thread safety: const members may run concurrently.
class SharedPhotons {
public:
    struct Entry {
        uint32_t set = 0;
        uint32_t batches = 0;
        KdTree tree;
    };
    /// Builds a tree per entry of `sets` with photons and batches ≥ 1 (others are skipped), in
    /// ascending set order. Precondition: set ids distinct. Cost O(n log n), trees in parallel.
    void build(const Bounds& bounds, std::span<const SetPhotons> sets);
    /// The entries, ascending by set.
    const std::vector<Entry>& entries() const { return entries_; }
    /// Σ batches over every entry but `set`'s.
    uint32_t batchesExcept(uint32_t set) const;
    bool empty() const { return entries_.empty(); }

private:
    std::vector<Entry> entries_;
};

}  // namespace rtpm
