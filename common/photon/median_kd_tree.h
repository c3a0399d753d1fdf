// Balanced median-split kd-tree over photons: the paper's baseline, kept for comparison (Table 5).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "common/photon/kd_tree.h"

namespace rtpm {

/// Classic balanced kd-tree (Jensen): each node splits at the median photon along the largest
/// dimension of its photons' bounding box (std::nth_element), built from scratch only.
/// Same node format, traversal and query API as KdTree; selected with `--tree median`.
/// Thread safety: const members may run concurrently; build/clear need exclusive access.
class MedianKdTree {
public:
    explicit MedianKdTree(uint32_t leafSize = KdTree::kDefaultLeafSize);

    /// Replaces the content with the finite-position photons of `photons` (others are skipped).
    /// Cost O(n log n).
    void build(std::span<const Photon> photons);
    void clear();

    size_t size() const { return photons_.size(); }
    bool empty() const { return photons_.empty(); }
    /// Photons in leaf order; indices in query results refer to this array.
    std::span<const Photon> photons() const { return photons_; }
    Photon photon(uint32_t i) const { return photons_[i]; }
    uint32_t photonIncoming(uint32_t i) const { return photons_[i].incoming; }
    uint32_t photonPower(uint32_t i) const { return photons_[i].power; }
    /// Bounding box of the photons.
    const Bounds& bounds() const { return bounds_; }
    size_t nodeCount() const { return nodes_.size(); }
    size_t memoryBytes() const {
        return photons_.capacity() * sizeof(Photon) + nodes_.capacity() * sizeof(detail::KdNode);
    }

    /// As KdTree::knn.
    void knn(Vec3 q, uint32_t k, float maxDist2, KnnHeap& heap) const {
        heap.reset(k, maxDist2);
        search(q, heap);
    }
    /// As KdTree::radius.
    void radius(Vec3 q, float maxDist2, std::vector<KnnEntry>& out) const {
        RadiusResultSet set(maxDist2, out);
        search(q, set);
    }
    template <ResultSet R>
    void search(Vec3 q, R& result) const {
        if (photons_.empty()) return;
        detail::searchKdNodes(nodes_.data(), q, result, [&](uint32_t first, uint32_t end, float worst) {
            return detail::scanPhotons(photons_.data(), first, end, q, result, worst);
        });
    }

private:
    void buildRange(uint32_t first, uint32_t count);

    uint32_t leafSize_;
    Bounds bounds_;
    std::vector<detail::KdNode> nodes_;
    std::vector<Photon> photons_;
};

}  // namespace rtpm
