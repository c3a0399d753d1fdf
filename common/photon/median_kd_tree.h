// Balanced median-split kd-tree over photons: the paper's baseline, kept for comparison (Table 5).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "common/photon/kd_tree.h"
#include "common/photon/photon_array.h"

namespace rtpm {

/// Classic balanced kd-tree (Jensen): each node splits at the median photon along the largest
/// dimension of its photons' bounding box (std::nth_element), built from scratch only.
/// Same node format and traversal as KdTree; `--tree median` selects it (PhotonIndex rebuilds it
/// from all photons every batch).
/// Thread safety: const members may run concurrently; build/clear need exclusive access.
class MedianKdTree : public detail::PhotonArray {
public:
    explicit MedianKdTree(uint32_t leafSize = KdTree::kDefaultLeafSize);

    /// Replaces the content with the finite-position photons of `photons` (others are skipped).
    /// Cost O(n log n).
    void build(std::span<const Photon> photons);
    void clear();

    size_t nodeCount() const { return nodes_.size(); }
    size_t memoryBytes() const {
        return photons_.capacity() * sizeof(Photon) + nodes_.capacity() * sizeof(detail::KdNode);
    }

    /// The generic traversal (knn.h's knnSearch / radiusSearch drive it).
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
    std::vector<detail::KdNode> nodes_;
};

}  // namespace rtpm
