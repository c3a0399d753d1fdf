// SharedPhotons: a kd-tree per set over one frame's shot photons.
#include "common/photon/shared_photons.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "common/core/check.h"

namespace rtpm {

void SharedPhotons::build(const Bounds& bounds, std::span<const SetPhotons> sets) {
    std::vector<const SetPhotons*> used;
    for (const SetPhotons& s : sets)
        if (s.batches > 0 && !s.photons.empty()) used.push_back(&s);
    std::sort(used.begin(), used.end(), [](const SetPhotons* a, const SetPhotons* b) { return a->set < b->set; });
    for (size_t i = 1; i < used.size(); ++i) RTPM_CHECK(used[i - 1]->set != used[i]->set);
    entries_.clear();
    entries_.resize(used.size());
    tbb::parallel_for(size_t(0), used.size(), [&](size_t i) {
        Entry& e = entries_[i];
        e.set = used[i]->set;
        e.batches = used[i]->batches;
        e.tree = KdTree(bounds, KdTree::kRadiusLeafSize);
        e.tree.build(used[i]->photons);
    });
}

uint32_t SharedPhotons::batchesExcept(uint32_t set) const {
    uint32_t n = 0;
    for (const Entry& e : entries_)
        if (e.set != set) n += e.batches;
    return n;
}

}  // namespace rtpm
