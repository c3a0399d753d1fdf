// Median-split kd-tree construction (the balanced baseline of paper §5.2).
#include "common/photon/median_kd_tree.h"

#include <algorithm>
#include <cmath>

namespace rtpm {

using detail::KdNode;

MedianKdTree::MedianKdTree(uint32_t leafSize) : leafSize_(std::max(leafSize, 1u)) { clear(); }

void MedianKdTree::clear() {
    photons_.clear();
    nodes_.clear();
    nodes_.push_back(KdNode::leaf(0, 0));
    bounds_ = Bounds{};
}

void MedianKdTree::build(std::span<const Photon> photons) {
    clear();
    keepFinite(photons, photons_);
    RTPM_CHECK(photons_.size() <= KdNode::kMaxPayload);
    nodes_.clear();
    nodes_.reserve(2 * (photons_.size() / leafSize_ + 1));
    buildRange(0, static_cast<uint32_t>(photons_.size()));
}

void MedianKdTree::buildRange(uint32_t first, uint32_t count) {
    // Halving the count each level keeps the depth at log2(n / leafSize) + 1 < kMaxKdDepth.
    if (count <= leafSize_) {
        nodes_.push_back(KdNode::leaf(first, count));
        return;
    }
    Photon* begin = photons_.data() + first;
    Bounds b;
    for (uint32_t i = 0; i < count; ++i) b.extend(begin[i].position);
    const Vec3 e = b.extent();
    const uint32_t axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    const uint32_t half = count / 2;
    std::nth_element(begin, begin + half, begin + count, [axis](const Photon& a, const Photon& c) {
        return a.position[axis] < c.position[axis];
    });
    // Left holds photons <= split, right photons >= split: the traversal's invariant.
    const float split = begin[half].position[axis];
    const uint32_t self = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(KdNode::interior(axis, split, 0));
    buildRange(first, half);
    nodes_[self] = KdNode::interior(axis, split, static_cast<uint32_t>(nodes_.size()));
    buildRange(first + half, count - half);
}

}  // namespace rtpm
