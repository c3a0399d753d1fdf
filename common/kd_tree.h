// The caustic photon map: an unbalanced middle-split kd-tree with incremental batch insertion.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "common/check.h"
#include "common/knn.h"
#include "common/photon.h"

namespace rtpm {

namespace detail {

/// kd-tree node shared by KdTree and MedianKdTree. 8 bytes, depth-first order: an interior
/// node's left child is the next node, so a descent touches consecutive memory.
struct KdNode {
    float split;    ///< interior: split position (m); leaf: photon count (bit pattern of uint32)
    uint32_t bits;  ///< [1:0] axis (3 = leaf) | [31:2] right child (interior) or first photon (leaf)

    static constexpr uint32_t kLeafAxis = 3;
    static constexpr uint32_t kMaxPayload = (1u << 30) - 1;

    static KdNode interior(uint32_t axis, float splitPos, uint32_t rightChild) {
        return KdNode{splitPos, (rightChild << 2) | axis};
    }
    static KdNode leaf(uint32_t firstPhoton, uint32_t count) {
        return KdNode{std::bit_cast<float>(count), (firstPhoton << 2) | kLeafAxis};
    }
    bool isLeaf() const { return (bits & 3u) == kLeafAxis; }
    uint32_t axis() const { return bits & 3u; }
    uint32_t rightChild() const { return bits >> 2; }
    uint32_t firstPhoton() const { return bits >> 2; }
    uint32_t count() const { return std::bit_cast<uint32_t>(split); }
};
static_assert(sizeof(KdNode) == 8, "KdNode is the hot working set: keep it 8 bytes");

/// Deepest path any tree here may have; the traversal stack is sized by it.
inline constexpr uint32_t kMaxKdDepth = 60;

/// The one kd traversal (nanoflann style): near child first, a fixed stack, and a far child is
/// visited only if the squared distance from q to its cell (accumulated per axis from the split
/// planes crossed on the way, as in nanoflann) is below the result set's current bound.
/// Left subtrees hold photons with p[axis] <= split, right subtrees p[axis] >= split.
template <ResultSet R>
void searchKdNodes(const KdNode* nodes, const Photon* photons, Vec3 q, R& result) {
    struct Pending {
        uint32_t node;
        float dist2;  // squared distance from q to the node's region (lower bound)
        Vec3 offset;  // per-axis signed distance from q to that region
    };
    Pending stack[kMaxKdDepth + 4];
    uint32_t top = 0;
    uint32_t node = 0;
    float dist2 = 0.0f;
    Vec3 offset(0.0f);
    for (;;) {
        const KdNode n = nodes[node];
        if (!n.isLeaf()) {
            const uint32_t axis = n.axis();
            const float diff = q[axis] - n.split;
            const uint32_t nearChild = diff < 0.0f ? node + 1 : n.rightChild();
            const uint32_t farChild = diff < 0.0f ? n.rightChild() : node + 1;
            const float farDist2 = dist2 - offset[axis] * offset[axis] + diff * diff;
            if (farDist2 < result.worstDist2()) {
                RTPM_DCHECK(top < kMaxKdDepth + 4);
                Pending& p = stack[top++];
                p.node = farChild;
                p.dist2 = farDist2;
                p.offset = offset;
                p.offset[axis] = diff;
            }
            node = nearChild;
            continue;
        }
        // Leaf: photons of one leaf are contiguous, so this loop streams memory.
        const uint32_t first = n.firstPhoton();
        const uint32_t end = first + n.count();
        float worst = result.worstDist2();
        for (uint32_t i = first; i < end; ++i) {
            const Vec3 d = photons[i].position - q;
            const float d2 = d.x * d.x + d.y * d.y + d.z * d.z;
            if (d2 < worst) {
                result.add(d2, i);
                worst = result.worstDist2();
            }
        }
        // Pop the next far child that can still hold a closer photon.
        for (;;) {
            if (top == 0) return;
            const Pending& p = stack[--top];
            if (p.dist2 < worst) {
                node = p.node;
                dist2 = p.dist2;
                offset = p.offset;
                break;
            }
        }
    }
}

}  // namespace detail

/// Unbalanced middle-split kd-tree over caustic photons (paper §5.2, §5.4; DESIGN §5).
///
/// Cells are implicit bisections of a fixed root box: a node splits its cell at the spatial
/// middle of the cell's largest extent, so split planes depend only on the subdivision, never on
/// the photons. Inserting a batch (descend, append to the leaf, split every leaf that now holds
/// more than `leafSize` photons) therefore gives exactly the node array a bulk build of the same
/// photons gives; only the order of photons inside a leaf differs.
///
/// Storage: nodes in depth-first order (8 bytes each) and photons in one array in leaf order, so
/// a query streams contiguous memory. `insert` keeps that layout: it routes the batch to its
/// leaves, opens gaps by moving leaves back-to-front in place (O(size) memmove, no second photon
/// array), fills them, then splits overfull leaves in place. A batch of b photons costs
/// O(b·depth + size + nodes); a rebuild costs O(size·depth).
///
/// Root box: photons whose position is non-finite or outside the root box are rejected and
/// counted (`rejectedCount()`), never clamped: clamping would pile flux onto the box faces.
/// The box given at construction is inflated by 1e-3 of its diagonal on every axis (so photons
/// on scene faces are kept). A tree constructed with an empty box takes the (inflated) bounds of
/// its first non-empty build/insert batch — only right for a bulk build; for accumulation pass
/// the scene bounds.
///
/// Degenerate inputs: a leaf is not split below the depth cap `kMaxDepth` or when its cell's
/// largest extent is below `kMinExtentRelative` × root diagonal (or the middle rounds onto a
/// face), so coincident photons end in one oversized leaf instead of recursing forever.
///
/// Thread safety: const members (queries) may run concurrently; build/insert/clear need
/// exclusive access.
class KdTree {
public:
    static constexpr uint32_t kDefaultLeafSize = 12;
    static constexpr uint32_t kMaxDepth = 40;
    static constexpr float kMinExtentRelative = 1e-6f;
    static constexpr float kRootInflation = 1e-3f;

    /// `rootBox` in world metres (scene bounds); `leafSize` ≥ 1 is the bucket size B.
    explicit KdTree(Bounds rootBox = {}, uint32_t leafSize = kDefaultLeafSize);

    /// Replaces the content with `photons` (bulk build from scratch). Cost O(n·depth).
    void build(std::span<const Photon> photons);
    /// Adds a batch to the existing tree (accumulation, paper §5.4). Cost O(b·depth + size()).
    void insert(std::span<const Photon> photons);
    /// Removes every photon; keeps the root box, the counters reset, capacity is kept.
    void clear();
    /// Reserves storage for `photonCount` photons (e.g. the accumulation cap) so that
    /// insertions never reallocate below it.
    void reserve(size_t photonCount);

    size_t size() const { return photons_.size(); }
    bool empty() const { return photons_.empty(); }
    /// Photons in leaf order; indices in query results refer to this array.
    std::span<const Photon> photons() const { return photons_; }
    /// The (inflated) root box; photons outside it are rejected.
    const Bounds& bounds() const { return root_; }
    /// Photons rejected since construction or the last clear(): outside the root box or NaN.
    uint64_t rejectedCount() const { return rejected_; }
    uint32_t leafSize() const { return leafSize_; }
    size_t nodeCount() const { return nodes_.size(); }
    /// Deepest leaf (0 for a single leaf). O(nodes).
    uint32_t depth() const;
    /// Heap bytes held (photon and node arrays by capacity; no scratch survives a build/insert).
    size_t memoryBytes() const;

    /// The k nearest photons strictly closer than sqrt(maxDist2) (m², may be +inf) into `heap`
    /// (reset first, unsorted). No allocation once the heap has seen k. Thread-safe.
    void knn(Vec3 q, uint32_t k, float maxDist2, KnnHeap& heap) const {
        heap.reset(k, maxDist2);
        search(q, heap);
    }
    /// Every photon strictly closer than sqrt(maxDist2) into `out` (cleared first, unsorted).
    void radius(Vec3 q, float maxDist2, std::vector<KnnEntry>& out) const {
        RadiusResultSet set(maxDist2, out);
        search(q, set);
    }
    /// The generic traversal: feeds every photon that can beat `result.worstDist2()` to it.
    template <ResultSet R>
    void search(Vec3 q, R& result) const {
        if (photons_.empty()) return;
        detail::searchKdNodes(nodes_.data(), photons_.data(), q, result);
    }

private:
    bool accept(const Photon& p) const;
    void setRootFrom(std::span<const Photon> photons);
    void splitOverfullLeaves();
    void relink(uint32_t oldNode, Bounds cell, uint32_t depth);
    void buildRange(uint32_t first, uint32_t count, Bounds cell, uint32_t depth);
    void growPhotons(size_t newSize);

    Bounds root_;
    float minExtent_ = 0.0f;
    uint32_t leafSize_;
    uint64_t rejected_ = 0;
    std::vector<detail::KdNode> nodes_;
    std::vector<Photon> photons_;
    // Insertion scratch, released after each batch (see kd_tree.cpp).
    std::vector<detail::KdNode> nodeScratch_;
    std::vector<Photon> batchScratch_;
    std::vector<uint32_t> leafOfScratch_;
    std::vector<uint32_t> leafCountScratch_;
};

}  // namespace rtpm
