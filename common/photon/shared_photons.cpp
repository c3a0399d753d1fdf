// SharedPhotons: one kd-tree over every set's shot photons of a frame, tagged by set.
#include "common/photon/shared_photons.h"

#include <algorithm>
#include <limits>

#include "common/core/check.h"

namespace rtpm {

void SharedPhotons::build(const Bounds& bounds, std::span<const SetPhotons> sets) {
    std::vector<const SetPhotons*> used;
    for (const SetPhotons& s : sets)
        if (s.batches > 0 && !s.photons.empty()) used.push_back(&s);
    std::sort(used.begin(), used.end(), [](const SetPhotons* a, const SetPhotons* b) { return a->set < b->set; });
    for (size_t i = 1; i < used.size(); ++i) RTPM_CHECK(used[i - 1]->set != used[i]->set);
    entries_.clear();
    size_t total = 0;
    for (const SetPhotons* s : used) {
        RTPM_CHECK(s->set <= std::numeric_limits<uint16_t>::max());
        entries_.push_back(Entry{s->set, s->batches});
        total += s->photons.size();
    }
    std::vector<Photon> photons;
    std::vector<uint16_t> tags;
    photons.reserve(total);
    tags.reserve(total);
    for (const SetPhotons* s : used) {
        photons.insert(photons.end(), s->photons.begin(), s->photons.end());
        tags.insert(tags.end(), s->photons.size(), uint16_t(s->set));
    }
    tree_ = KdTree(bounds, KdTree::kRadiusLeafSize);
    tree_.build(photons, tags);
}

uint32_t SharedPhotons::batchesExcept(uint32_t set) const {
    uint32_t n = 0;
    for (const Entry& e : entries_)
        if (e.set != set) n += e.batches;
    return n;
}

}  // namespace rtpm
