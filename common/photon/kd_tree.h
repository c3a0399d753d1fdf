// The caustic photon map: an unbalanced middle-split kd-tree with incremental batch insertion.
#pragma once

#include <bit>
#include <utility>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <span>
#include <vector>

#include "common/core/check.h"
#include "common/photon/knn.h"
#include "common/photon/photon.h"
#include "common/photon/photon_array.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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
/// `scanLeaf(first, end, worst)` offers photons [first, end) to the result set and returns the
/// bound after them; it is where the photon layout lives (PhotonColumns::scan, or a Photon array).
template <ResultSet R, class ScanLeaf>
void searchKdNodes(const KdNode* nodes, Vec3 q, R& result, ScanLeaf&& scanLeaf) {
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
    float worst = result.worstDist2();
    for (;;) {
        const KdNode n = nodes[node];
        if (!n.isLeaf()) {
            const uint32_t axis = n.axis();
            const float diff = q[axis] - n.split;
            const uint32_t nearChild = diff < 0.0f ? node + 1 : n.rightChild();
            const uint32_t farChild = diff < 0.0f ? n.rightChild() : node + 1;
            const float farDist2 = dist2 - offset[axis] * offset[axis] + diff * diff;
            if (farDist2 < worst) {
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
        worst = scanLeaf(n.firstPhoton(), n.firstPhoton() + n.count(), worst);
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

/// Power and direction of a photon, fetched only for photons a result set keeps.
struct PhotonPayload {
    uint32_t power;     ///< RGB9E5
    uint32_t incoming;  ///< octahedral
};

/// Photons as columns: x, y, z and payload arrays in leaf order (20 bytes per photon, as the
/// Photon struct). The leaf scan reads only the three coordinate columns, 4 photons per SSE
/// step; every column carries kPad spare entries after the last photon so a step may read past
/// a leaf's end (those lanes are masked off). Not thread-safe for writes.
class PhotonColumns {
public:
    static constexpr uint32_t kPad = 3;

    size_t size() const { return size_; }
    /// Sets the size; new photons are unspecified. Grows capacity to `capacity` if below it.
    void resize(size_t n, size_t capacity);
    void clear() { resize(0, 0); }
    void shrinkToFit();
    size_t capacity() const { return payload_.capacity(); }
    size_t memoryBytes() const {
        return (x_.capacity() + y_.capacity() + z_.capacity()) * sizeof(float) +
               payload_.capacity() * sizeof(PhotonPayload) + tag_.capacity() * sizeof(uint16_t);
    }
    /// Whether a tag column is kept (KdTree::build with tags); resize() keeps it sized.
    bool tagged() const { return tagged_; }
    void setTagged(bool tagged) {
        tagged_ = tagged;
        tag_.resize(tagged ? size_ : 0);
    }
    uint16_t tag(size_t i) const { return tag_[i]; }
    void setTag(size_t i, uint16_t t) { tag_[i] = t; }

    Vec3 position(size_t i) const { return Vec3(x_[i], y_[i], z_[i]); }
    float coordinate(size_t i, uint32_t axis) const {
        return axis == 0 ? x_[i] : axis == 1 ? y_[i] : z_[i];
    }
    const float* axisColumn(uint32_t axis) const {
        return axis == 0 ? x_.data() : axis == 1 ? y_.data() : z_.data();
    }
    Photon photon(size_t i) const {
        return Photon{position(i), payload_[i].power, payload_[i].incoming};
    }
    uint32_t incoming(size_t i) const { return payload_[i].incoming; }
    uint32_t power(size_t i) const { return payload_[i].power; }
    void set(size_t i, const Photon& p) {
        x_[i] = p.position.x;
        y_[i] = p.position.y;
        z_[i] = p.position.z;
        payload_[i] = {p.power, p.incoming};
    }
    void swap(size_t i, size_t j) {
        std::swap(x_[i], x_[j]);
        std::swap(y_[i], y_[j]);
        std::swap(z_[i], z_[j]);
        std::swap(payload_[i], payload_[j]);
        if (tagged_) std::swap(tag_[i], tag_[j]);
    }
    /// memmove of photons [src, src + count) to dst in every column.
    void move(size_t dst, size_t src, size_t count);
    /// Hoare partition of [first, first + count) by coordinate[axis] < split; returns the size of
    /// the left part.
    uint32_t partition(uint32_t first, uint32_t count, uint32_t axis, float split);

    /// Offers photons [first, end) to `result`; `worst` is its current bound. Distances are
    /// computed as in photon_array.h's scanPhotons (same operation order, so both give bit-identical dist2).
    template <ResultSet R>
    float scan(uint32_t first, uint32_t end, Vec3 q, R& result, float worst) const {
        const float* xs = x_.data();
        const float* ys = y_.data();
        const float* zs = z_.data();
#if defined(__SSE2__)
        // 4 photons per step, one compare and movemask; a hit (rare once the heap is full) is
        // added lane by lane, re-testing against the bound the previous add may have lowered.
        const __m128 qx = _mm_set1_ps(q.x), qy = _mm_set1_ps(q.y), qz = _mm_set1_ps(q.z);
        __m128 bound = _mm_set1_ps(worst);
        for (uint32_t i = first; i < end; i += 4) {
            const __m128 dx = _mm_sub_ps(_mm_loadu_ps(xs + i), qx);
            const __m128 dy = _mm_sub_ps(_mm_loadu_ps(ys + i), qy);
            const __m128 dz = _mm_sub_ps(_mm_loadu_ps(zs + i), qz);
            const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                                         _mm_mul_ps(dz, dz));
            uint32_t mask = static_cast<uint32_t>(_mm_movemask_ps(_mm_cmplt_ps(d2, bound)));
            if (end - i < 4) mask &= (1u << (end - i)) - 1u;
            if (mask == 0) continue;
            alignas(16) float lane[4];
            _mm_store_ps(lane, d2);
            do {
                const uint32_t l = static_cast<uint32_t>(std::countr_zero(mask));
                mask &= mask - 1;
                if (lane[l] < worst) {
                    result.add(lane[l], i + l);
                    worst = result.worstDist2();
                }
            } while (mask != 0);
            bound = _mm_set1_ps(worst);
        }
#else
        for (uint32_t i = first; i < end; ++i) {
            const float dx = xs[i] - q.x, dy = ys[i] - q.y, dz = zs[i] - q.z;
            const float d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < worst) {
                result.add(d2, i);
                worst = result.worstDist2();
            }
        }
#endif
        return worst;
    }

private:
    size_t size_ = 0;
    std::vector<float> x_, y_, z_;  // size_ + kPad entries each
    std::vector<PhotonPayload> payload_;
    bool tagged_ = false;
    std::vector<uint16_t> tag_;  ///< size_ entries when tagged_, else none
};

}  // namespace detail

/// Unbalanced middle-split kd-tree over caustic photons
/// (paper §5.2, §5.4; docs/ARCHITECTURE.md §5.4).
///
/// Cells are implicit bisections of a fixed root box: a node splits its cell at the spatial
/// middle of the cell's largest extent, so split planes depend only on the subdivision, never on
/// the photons. Inserting a batch (descend, append to the leaf, split every leaf that now holds
/// more than `leafSize` photons) therefore gives exactly the node array a bulk build of the same
/// photons gives; only the order of photons inside a leaf differs.
///
/// Storage: nodes in depth-first order (8 bytes each) and photons as columns in leaf order
/// (detail::PhotonColumns: x, y, z, payload), so a leaf scan streams three contiguous float
/// columns 4 photons at a time and power/direction are read only for the photons a result set
/// keeps. `insert` keeps that layout: it routes the batch to its leaves, opens gaps by moving
/// leaves back-to-front in place (O(size) memmove, no second photon array), fills them, then
/// splits overfull leaves in place. A batch of b photons costs O(b·depth + size + nodes); a
/// rebuild costs O(size·depth). Capacity grows to the new size plus 1/32 slack, so an
/// accumulating map holds ≤ ~21 bytes of photon storage per photon without any reserve().
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
    /// The bucket size of trees that only radius searches read (a progressive pass's photons and
    /// the other sets' shared shots, searched within discs of a few dozen of their photons): a
    /// leaf's photons are scanned in one vectorised loop, so a shallower tree with larger leaves
    /// finds them sooner (curved mirror, 24 frames on one thread: 2.55 s with 12, 2.45 with 24,
    /// 2.45 with 48, 2.5 with 96; 2.75 with 6).
    static constexpr uint32_t kRadiusLeafSize = 32;
    static constexpr uint32_t kMaxDepth = 40;
    static constexpr float kMinExtentRelative = 1e-6f;
    static constexpr float kRootInflation = 1e-3f;

    /// `rootBox` in world metres (scene bounds); `leafSize` ≥ 1 is the bucket size B.
    explicit KdTree(Bounds rootBox = {}, uint32_t leafSize = kDefaultLeafSize);

    /// Replaces the content with `photons` (bulk build from scratch). Cost O(n·depth).
    void build(std::span<const Photon> photons);
    /// The same, each photon carrying a tag (tags.size() == photons.size()) that photonTag
    /// answers in leaf order: one tree over photons of several sources that a search tells
    /// apart (SharedPhotons: the set that shot each). A tagged tree takes no insert; clear() or
    /// build() without tags drops them.
    void build(std::span<const Photon> photons, std::span<const uint16_t> tags);
    /// Adds a batch to the existing tree (accumulation, paper §5.4). Cost O(b·depth + size()).
    void insert(std::span<const Photon> photons);
    /// Removes every photon; keeps the root box, the counters reset, capacity is kept.
    void clear();
    /// Reserves storage for `photonCount` photons (e.g. the accumulation cap) so that
    /// insertions never reallocate below it.
    void reserve(size_t photonCount);

    /// A read-only sequence of the stored photons in leaf order, decoded from the columns on
    /// access (`view[i]`, range-for by value). Indices in query results refer to it.
    class PhotonView {
    public:
        class Iterator {
        public:
            using iterator_category = std::input_iterator_tag;
            using value_type = Photon;
            using difference_type = std::ptrdiff_t;
            using pointer = void;
            using reference = Photon;
            Iterator() = default;
            Iterator(const detail::PhotonColumns* c, size_t i) : columns_(c), i_(i) {}
            Photon operator*() const { return columns_->photon(i_); }
            Iterator& operator++() {
                ++i_;
                return *this;
            }
            Iterator operator++(int) {
                Iterator old = *this;
                ++i_;
                return old;
            }
            bool operator==(const Iterator& o) const { return i_ == o.i_; }

        private:
            const detail::PhotonColumns* columns_ = nullptr;
            size_t i_ = 0;
        };
        explicit PhotonView(const detail::PhotonColumns& c) : columns_(&c) {}
        size_t size() const { return columns_->size(); }
        bool empty() const { return columns_->size() == 0; }
        Photon operator[](size_t i) const { return columns_->photon(i); }
        Iterator begin() const { return Iterator(columns_, 0); }
        Iterator end() const { return Iterator(columns_, columns_->size()); }

    private:
        const detail::PhotonColumns* columns_;
    };

    size_t size() const { return photons_.size(); }
    bool empty() const { return photons_.size() == 0; }
    /// Photons in leaf order; indices in query results refer to this sequence.
    PhotonView photons() const { return PhotonView(photons_); }
    /// Photon `i` of photons() (i < size()). O(1).
    Photon photon(uint32_t i) const { return photons_.photon(i); }
    /// Encoded incoming direction / power of photon `i` without decoding the rest.
    uint32_t photonIncoming(uint32_t i) const { return photons_.incoming(i); }
    uint32_t photonPower(uint32_t i) const { return photons_.power(i); }
    Vec3 photonPosition(uint32_t i) const { return photons_.position(i); }
    /// Whether the tree was built with tags, and photon `i`'s tag (tagged trees only).
    bool tagged() const { return photons_.tagged(); }
    uint16_t photonTag(uint32_t i) const { return photons_.tag(i); }
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

    /// The generic traversal: feeds every photon that can beat `result.worstDist2()` to it
    /// (knn.h's knnSearch / radiusSearch drive it). Thread-safe.
    template <ResultSet R>
    void search(Vec3 q, R& result) const {
        if (photons_.size() == 0) return;
        detail::searchKdNodes(nodes_.data(), q, result, [&](uint32_t first, uint32_t end, float worst) {
            return photons_.scan(first, end, q, result, worst);
        });
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
    detail::PhotonColumns photons_;
    // Insertion scratch, released after each batch (see kd_tree.cpp).
    std::vector<detail::KdNode> nodeScratch_;
    std::vector<Photon> batchScratch_;
    std::vector<uint32_t> leafOfScratch_;
    std::vector<uint32_t> leafCountScratch_;
};

}  // namespace rtpm
