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

/// One kd-tree over every set's SetPhotons of one frame, each photon tagged with the set that
/// shot it, for the progressive passes' searches (ProgressiveSet::pass), which leave out the
/// searching set's own photons by the tag. One tree, not one per set: a hit's search descends
/// once and scans each leaf its disc touches once, where a tree per set cost M² − 1 descents
/// and edge leaves (the curved mirror's variant, 32 still frames of one batch at 320×240 on two
/// threads: 2.46 s wall and 4.66 CPU s against 2.55 and 5.0, the same image error 0.0356).
/// Thread safety: const members may run concurrently.
class SharedPhotons {
public:
    /// Builds the tree over the entries of `sets` with photons and batches ≥ 1 (others are
    /// skipped), their photons taken in ascending set order. Precondition: set ids distinct and
    /// below 2^16. Cost O(n·depth).
    void build(const Bounds& bounds, std::span<const SetPhotons> sets);
    /// Every shared photon, photonTag(i) the set that shot it.
    const KdTree& tree() const { return tree_; }
    /// Σ batches over every entry but `set`'s.
    uint32_t batchesExcept(uint32_t set) const;
    /// No set's shot (the tree may also be empty when every photon fell outside `bounds`; the
    /// shots' batches still count).
    bool empty() const { return entries_.empty(); }

private:
    struct Entry {
        uint32_t set = 0;
        uint32_t batches = 0;
    };
    std::vector<Entry> entries_;  ///< ascending by set
    KdTree tree_;
};

}  // namespace rtpm
