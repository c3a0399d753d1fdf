// Result-set policies for photon searches: the bounded kNN max-heap and a radius collector.
#pragma once

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "common/core/check.h"
#include "common/core/math.h"

namespace rtpm {

/// One search hit: squared distance (m²) from the query point and the photon's index in the
/// searched structure's `photons()` array.
struct KnnEntry {
    float dist2 = 0.0f;
    uint32_t index = 0;
};

/// A result-set policy is what the generic traversal (`KdTree::search`, `MedianKdTree::search`,
/// `PhotonGrid::search`) talks to. It needs exactly two members:
///   float worstDist2() const;          // a candidate is useful only if dist2 < worstDist2()
///   void add(float dist2, uint32_t i); // called for candidates with dist2 < worstDist2()
/// `worstDist2()` must never increase during one search (the traversal prunes with it).
template <class T>
concept ResultSet = requires(T& set, const T& constSet, float d2, uint32_t i) {
    { constSet.worstDist2() } -> std::convertible_to<float>;
    set.add(d2, i);
};

/// The k nearest hits strictly closer than sqrt(maxDist2) (the role of nanoflann's
/// KNNResultSet, with a radius bound): a bounded binary max-heap keyed on dist2. Hits are
/// appended until k are held (the bound stays maxDist2), then the array is heapified once and
/// every later hit that beats the farthest replaces it with one sift-down (≤ log2 k levels,
/// child choice by conditional move). The bound therefore tightens with every kept hit, so the
/// traversal prunes as early as it can; a hit that does not beat the bound costs one compare in
/// the caller's leaf scan and never reaches the heap.
/// The caller owns it and reuses it across queries: `reset` allocates only when k exceeds every
/// k seen before, so steady-state queries never allocate. Not thread-safe: one per thread.
class KnnHeap {
public:
    KnnHeap() = default;
    explicit KnnHeap(uint32_t capacity) { entries_.reserve(size_t(capacity) + 1); }

    /// Empties the heap for a query of the k nearest within squared radius maxDist2 (m²).
    /// maxDist2 may be +inf (unbounded). k = 0 gives a heap that accepts nothing.
    void reset(uint32_t k, float maxDist2) {
        if (entries_.size() < size_t(k) + 1) entries_.resize(size_t(k) + 1);
        entries_[k] = {-1.0f, 0};  // sentinel for the sift-down
        size_ = 0;
        k_ = k;
        maxDist2_ = maxDist2;
        worst_ = k == 0 ? -1.0f : maxDist2;
    }

    /// Current pruning bound: maxDist2 until k hits are held, then the k-th smallest dist2 held.
    /// Never increases during a query.
    float worstDist2() const { return worst_; }

    /// Offers a hit; kept only if dist2 < worstDist2(). O(1) until k hits are held, then
    /// O(log k) per kept hit.
    void add(float dist2, uint32_t index) {
        if (!(dist2 < worst_)) return;
        KnnEntry* h = entries_.data();
        if (size_ < k_) {
            h[size_++] = {dist2, index};
            if (size_ == k_) {
                std::make_heap(h, h + k_, farther);
                worst_ = h[0].dist2;
            }
            return;
        }
        // Replace the farthest (the root) and sift the new entry down. entries_[k] is a
        // sentinel (dist2 = -1), so the right child of the last parent can always be read and
        // the larger child is chosen without a branch.
        const uint32_t n = k_;
        uint32_t i = 0;
        for (;;) {
            uint32_t c = 2 * i + 1;
            if (c >= n) break;
            c += h[c + 1].dist2 > h[c].dist2 ? 1u : 0u;
            if (!(h[c].dist2 > dist2)) break;
            h[i] = h[c];
            i = c;
        }
        h[i] = {dist2, index};
        worst_ = h[0].dist2;
    }

    uint32_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    bool full() const { return size_ == k_; }
    uint32_t k() const { return k_; }
    float maxDist2() const { return maxDist2_; }
    /// Largest dist2 held (the k-th nearest when full); 0 when empty. O(1) when full, else O(size).
    float farthestDist2() const {
        if (size_ == 0) return 0.0f;
        if (size_ == k_) return entries_[0].dist2;
        float m = 0.0f;
        for (uint32_t i = 0; i < size_; ++i) m = std::max(m, entries_[i].dist2);
        return m;
    }

    /// The hits, unsorted. Valid until the next reset/add.
    std::span<const KnnEntry> entries() const { return {entries_.data(), size_}; }
    /// Sorts the hits nearest first; the heap accepts no more hits until reset.
    void sortNearestFirst() {
        std::sort(entries_.begin(), entries_.begin() + size_,
                  [](const KnnEntry& a, const KnnEntry& b) { return a.dist2 < b.dist2; });
        worst_ = -1.0f;
    }

private:
    static bool farther(const KnnEntry& a, const KnnEntry& b) { return a.dist2 < b.dist2; }

    std::vector<KnnEntry> entries_;  // k slots and a sentinel; [0, size_) used; a max-heap once full
    uint32_t size_ = 0;
    uint32_t k_ = 0;
    float maxDist2_ = std::numeric_limits<float>::infinity();
    float worst_ = -1.0f;
};

/// Radius search policy: collects every hit strictly closer than sqrt(maxDist2) into a
/// caller-owned vector (cleared first; it only allocates when it grows past its capacity).
class RadiusResultSet {
public:
    RadiusResultSet(float maxDist2, std::vector<KnnEntry>& out) : maxDist2_(maxDist2), out_(out) {
        out_.clear();
    }
    float worstDist2() const { return maxDist2_; }
    void add(float dist2, uint32_t index) {
        if (dist2 < maxDist2_) out_.push_back({dist2, index});
    }

private:
    float maxDist2_;
    std::vector<KnnEntry>& out_;
};

static_assert(ResultSet<KnnHeap>);
static_assert(ResultSet<RadiusResultSet>);

/// The k nearest photons of `index` (KdTree, MedianKdTree, PhotonGrid: anything with
/// `search(q, resultSet)`) strictly closer than sqrt(maxDist2) (m², may be +inf) into `heap`
/// (reset first, unsorted). No allocation once the heap has seen k. Thread-safe per heap.
template <class Index>
void knnSearch(const Index& index, Vec3 q, uint32_t k, float maxDist2, KnnHeap& heap) {
    heap.reset(k, maxDist2);
    index.search(q, heap);
}

/// Every photon of `index` strictly closer than sqrt(maxDist2) into `out` (cleared first,
/// unsorted). Allocates only when `out` grows past its capacity.
template <class Index>
void radiusSearch(const Index& index, Vec3 q, float maxDist2, std::vector<KnnEntry>& out) {
    RadiusResultSet set(maxDist2, out);
    index.search(q, set);
}

}  // namespace rtpm
