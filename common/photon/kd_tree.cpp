// Middle-split kd-tree construction and in-place incremental batch insertion.
#include "common/photon/kd_tree.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace rtpm {

using detail::KdNode;

namespace {

uint32_t largestAxis(Vec3 extent) {
    if (extent.x >= extent.y && extent.x >= extent.z) return 0;
    return extent.y >= extent.z ? 1 : 2;
}

Bounds inflate(Bounds b, float relative) {
    if (b.empty()) return b;
    // Inflate by a fraction of the diagonal; a degenerate (point) box by a fraction of its
    // coordinate magnitude, so a box of one photon still gets a usable extent.
    float pad = relative * b.diagonal();
    if (!(pad > 0.0f)) {
        const float mag = std::max({std::abs(b.lo.x), std::abs(b.lo.y), std::abs(b.lo.z), 1.0f});
        pad = relative * mag;
    }
    b.lo -= Vec3(pad);
    b.hi += Vec3(pad);
    return b;
}


}  // namespace

namespace detail {

void PhotonColumns::resize(size_t n, size_t capacity) {
    const size_t cap = std::max(capacity, n);
    if (cap > payload_.capacity()) {
        for (std::vector<float>* c : {&x_, &y_, &z_}) c->reserve(cap + kPad);
        payload_.reserve(cap);
    }
    for (std::vector<float>* c : {&x_, &y_, &z_}) c->resize(n + kPad, 0.0f);
    payload_.resize(n);
    if (tagged_) tag_.resize(n);
    size_ = n;
}

void PhotonColumns::shrinkToFit() {
    for (std::vector<float>* c : {&x_, &y_, &z_}) c->shrink_to_fit();
    payload_.shrink_to_fit();
    tag_.shrink_to_fit();
}

void PhotonColumns::move(size_t dst, size_t src, size_t count) {
    if (dst == src || count == 0) return;
    for (std::vector<float>* c : {&x_, &y_, &z_})
        std::memmove(c->data() + dst, c->data() + src, count * sizeof(float));
    std::memmove(payload_.data() + dst, payload_.data() + src, count * sizeof(PhotonPayload));
    if (tagged_) std::memmove(tag_.data() + dst, tag_.data() + src, count * sizeof(uint16_t));
}

uint32_t PhotonColumns::partition(uint32_t first, uint32_t count, uint32_t axis, float split) {
    // Hoare scheme on the split axis' column only; the swap moves all four columns.
    const float* c = axisColumn(axis);
    uint32_t i = first, j = first + count;
    for (;;) {
        while (i < j && c[i] < split) ++i;
        while (i < j && !(c[j - 1] < split)) --j;
        if (j - i < 2) break;
        swap(i, j - 1);
        ++i;
        --j;
    }
    return i - first;
}

}  // namespace detail

KdTree::KdTree(Bounds rootBox, uint32_t leafSize) : leafSize_(std::max(leafSize, 1u)) {
    if (!rootBox.empty()) {
        RTPM_CHECK(finite(rootBox.lo) && finite(rootBox.hi));
        root_ = inflate(rootBox, kRootInflation);
        minExtent_ = kMinExtentRelative * root_.diagonal();
    }
    clear();
}

void KdTree::clear() {
    photons_.setTagged(false);
    photons_.clear();
    nodes_.clear();
    nodes_.push_back(KdNode::leaf(0, 0));
    rejected_ = 0;
}

void KdTree::reserve(size_t photonCount) { photons_.resize(photons_.size(), photonCount); }

bool KdTree::accept(const Photon& p) const {
    const Vec3 x = p.position;
    // Written so that NaN fails every comparison and is rejected.
    return x.x >= root_.lo.x && x.x <= root_.hi.x && x.y >= root_.lo.y && x.y <= root_.hi.y &&
           x.z >= root_.lo.z && x.z <= root_.hi.z;
}

void KdTree::setRootFrom(std::span<const Photon> photons) {
    Bounds b;
    for (const Photon& p : photons)
        if (finite(p.position)) b.extend(p.position);
    if (b.empty()) return;
    root_ = inflate(b, kRootInflation);
    minExtent_ = kMinExtentRelative * root_.diagonal();
}

void KdTree::growPhotons(size_t newSize) {
    // Capacity is budgeted memory (bytes per photon), so grow to the new size plus 1/32 only,
    // not geometrically: every insert already moves O(size) photons to open the leaf gaps, so a
    // reallocation per batch adds one more copy of the same order, not a change in complexity.
    // A batch smaller than the slack (late, small accumulation batches) fits without a copy.
    const size_t capacity =
        newSize > photons_.capacity() ? newSize + newSize / 32 : photons_.capacity();
    photons_.resize(newSize, capacity);
}

void KdTree::build(std::span<const Photon> photons) { build(photons, {}); }

void KdTree::build(std::span<const Photon> photons, std::span<const uint16_t> tags) {
    RTPM_CHECK(tags.empty() || tags.size() == photons.size());
    clear();
    if (root_.empty()) setRootFrom(photons);
    if (root_.empty()) {  // nothing finite to index
        rejected_ += photons.size();
        return;
    }
    size_t accepted = 0;
    for (const Photon& p : photons) accepted += accept(p) ? 1 : 0;
    rejected_ += photons.size() - accepted;
    photons_.setTagged(!tags.empty());
    photons_.resize(accepted, accepted);
    size_t next = 0;
    for (size_t i = 0; i < photons.size(); ++i) {
        if (!accept(photons[i])) continue;
        if (!tags.empty()) photons_.setTag(next, tags[i]);
        photons_.set(next++, photons[i]);
    }
    RTPM_CHECK(photons_.size() <= KdNode::kMaxPayload);
    nodes_[0] = KdNode::leaf(0, static_cast<uint32_t>(photons_.size()));
    splitOverfullLeaves();
}

void KdTree::insert(std::span<const Photon> photons) {
    RTPM_CHECK(!photons_.tagged());
    if (photons.empty()) return;
    if (root_.empty()) {
        build(photons);
        return;
    }
    // 1. Route each accepted photon to its leaf, then counting-sort the batch by leaf node.
    //    Nodes are in depth-first order, so node order is also the leaves' photon order.
    std::vector<uint32_t>& leafOf = leafOfScratch_;
    std::vector<uint32_t>& leafCount = leafCountScratch_;
    leafOf.clear();
    leafCount.assign(nodes_.size() + 1, 0);
    const KdNode* nodes = nodes_.data();
    size_t acceptedCount = 0;
    for (const Photon& p : photons) {
        if (!accept(p)) {
            ++rejected_;
            leafOf.push_back(UINT32_MAX);
            continue;
        }
        uint32_t node = 0;
        while (!nodes[node].isLeaf()) {
            const KdNode& n = nodes[node];
            node = p.position[n.axis()] < n.split ? node + 1 : n.rightChild();
        }
        leafOf.push_back(node);
        ++leafCount[node + 1];
        ++acceptedCount;
    }
    if (acceptedCount == 0) return;
    RTPM_CHECK(photons_.size() + acceptedCount <= KdNode::kMaxPayload);
    for (size_t i = 1; i < leafCount.size(); ++i) leafCount[i] += leafCount[i - 1];
    // leafCount[n] is now the start of leaf n's photons in the sorted batch.
    batchScratch_.resize(acceptedCount);
    for (size_t i = 0; i < photons.size(); ++i)
        if (leafOf[i] != UINT32_MAX) batchScratch_[leafCount[leafOf[i]]++] = photons[i];
    // leafCount[n] is now the end of leaf n's batch range (= start of leaf n+1's).

    // 2. Open a gap after every receiving leaf, back to front so nothing is overwritten before
    //    it moved: every leaf moves right by the number of batch photons routed to leaves
    //    before it. Leaves before the first receiving leaf do not move at all.
    const size_t oldSize = photons_.size();
    growPhotons(oldSize + acceptedCount);
    size_t batchEnd = acceptedCount;
    bool overfull = false;
    for (size_t i = nodes_.size(); i-- > 0 && batchEnd > 0;) {
        KdNode& n = nodes_[i];
        if (!n.isLeaf()) continue;
        const uint32_t batchStart = i == 0 ? 0 : leafCount[i - 1];
        const uint32_t added = leafCount[i] - batchStart;
        const uint32_t first = n.firstPhoton();
        const uint32_t count = n.count();
        const uint32_t newFirst = first + static_cast<uint32_t>(batchEnd - added);
        photons_.move(newFirst, first, count);
        for (uint32_t j = 0; j < added; ++j)
            photons_.set(newFirst + count + j, batchScratch_[batchStart + j]);
        n = KdNode::leaf(newFirst, count + added);
        overfull |= count + added > leafSize_;
        batchEnd -= added;
    }
    RTPM_DCHECK(batchEnd == 0);

    // 3. Split the leaves that overflowed (same rule as a bulk build).
    if (overfull) splitOverfullLeaves();
    // The routing scratch is batch-sized; freeing it keeps memoryBytes() at the stored map.
    std::vector<Photon>().swap(batchScratch_);
    std::vector<uint32_t>().swap(leafOfScratch_);
    std::vector<uint32_t>().swap(leafCountScratch_);
}

void KdTree::splitOverfullLeaves() {
    // Re-emit the node array depth first, splitting overfull leaves in place; photon ranges of
    // untouched leaves stay where they are. O(nodes) plus the partitions of the split leaves.
    nodeScratch_.clear();
    // A split leaf of c photons adds about 4c/B nodes (empty siblings included).
    nodeScratch_.reserve(nodes_.size() + 4 * photons_.size() / leafSize_ / 8 + 16);
    std::swap(nodes_, nodeScratch_);  // nodes_ is the output now, nodeScratch_ the old tree
    relink(0, root_, 0);
    RTPM_CHECK(nodes_.size() <= KdNode::kMaxPayload);
    // Nodes are a few bytes per photon: return the old array and the growth slack rather than
    // hold them between batches (re-allocating ~3 B/photon per batch costs far less than a copy
    // of the photons).
    std::vector<KdNode>().swap(nodeScratch_);  // (`= {}` would keep the capacity)
    if (nodes_.capacity() > nodes_.size() + nodes_.size() / 8) nodes_.shrink_to_fit();
}

void KdTree::relink(uint32_t oldNode, Bounds cell, uint32_t depth) {
    const KdNode n = nodeScratch_[oldNode];
    if (n.isLeaf()) {
        buildRange(n.firstPhoton(), n.count(), cell, depth);
        return;
    }
    const uint32_t axis = n.axis();
    const uint32_t self = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(n);
    Bounds lo = cell, hi = cell;
    lo.hi[axis] = n.split;
    hi.lo[axis] = n.split;
    relink(oldNode + 1, lo, depth + 1);
    nodes_[self] = KdNode::interior(axis, n.split, static_cast<uint32_t>(nodes_.size()));
    relink(n.rightChild(), hi, depth + 1);
}

void KdTree::buildRange(uint32_t first, uint32_t count, Bounds cell, uint32_t depth) {
    const Vec3 extent = cell.hi - cell.lo;
    const uint32_t axis = largestAxis(extent);
    const float split = 0.5f * (cell.lo[axis] + cell.hi[axis]);
    // Stop: small enough, depth cap, cell below the extent cap, or the middle rounds onto a face
    // (huge coordinates, tiny cell) — in all of these a split could not separate the photons.
    if (count <= leafSize_ || depth >= kMaxDepth || extent[axis] < minExtent_ ||
        !(split > cell.lo[axis] && split < cell.hi[axis])) {
        nodes_.push_back(KdNode::leaf(first, count));
        return;
    }
    const uint32_t leftCount = photons_.partition(first, count, axis, split);

    const uint32_t self = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(KdNode::interior(axis, split, 0));
    Bounds lo = cell, hi = cell;
    lo.hi[axis] = split;
    hi.lo[axis] = split;
    buildRange(first, leftCount, lo, depth + 1);
    nodes_[self] = KdNode::interior(axis, split, static_cast<uint32_t>(nodes_.size()));
    buildRange(first + leftCount, count - leftCount, hi, depth + 1);
}

uint32_t KdTree::depth() const {
    // Depth-first order: walk with an explicit stack of (node, depth).
    uint32_t deepest = 0;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};
    while (!stack.empty()) {
        auto [node, d] = stack.back();
        stack.pop_back();
        const KdNode& n = nodes_[node];
        if (n.isLeaf()) {
            deepest = std::max(deepest, d);
            continue;
        }
        stack.push_back({node + 1, d + 1});
        stack.push_back({n.rightChild(), d + 1});
    }
    return deepest;
}

size_t KdTree::memoryBytes() const {
    return photons_.memoryBytes() + nodes_.capacity() * sizeof(KdNode) +
           nodeScratch_.capacity() * sizeof(KdNode) + batchScratch_.capacity() * sizeof(Photon) +
           (leafOfScratch_.capacity() + leafCountScratch_.capacity()) * sizeof(uint32_t);
}

}  // namespace rtpm
