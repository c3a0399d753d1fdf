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
/// KNNResultSet, with a radius bound). Not a binary heap: hits are appended to a buffer of up to
/// 2k entries; when it fills, a selection (std::nth_element, O(k)) keeps the k nearest and the
/// bound drops to the k-th distance. That is O(1) amortised per hit against O(log k) with
/// unpredictable branches for a heap's sift-down, which dominated the query profile at k = 64;
/// the price is a bound that tightens in steps (at k, then at every 2k hits) rather than per hit.
/// The readers (entries, size, full, farthestDist2) finish the selection on first use.
/// The caller owns it and reuses it across queries: `reset` allocates only when k exceeds every
/// k seen before, so steady-state queries never allocate. Not thread-safe: one per thread.
class KnnHeap {
public:
    KnnHeap() = default;
    explicit KnnHeap(uint32_t capacity) { entries_.reserve(2 * size_t(capacity)); }

    /// Empties the heap for a query of the k nearest within squared radius maxDist2 (m²).
    /// maxDist2 may be +inf (unbounded). k = 0 gives a heap that accepts nothing.
    void reset(uint32_t k, float maxDist2) {
        if (entries_.capacity() < 2 * size_t(k)) entries_.reserve(2 * size_t(k));
        entries_.clear();
        k_ = k;
        maxDist2_ = maxDist2;
        worst_ = k == 0 ? -1.0f : maxDist2;
        settled_ = true;
    }

    /// Current pruning bound: maxDist2 until k hits are held, then the k-th smallest dist2 among
    /// the hits at the last selection. Never increases during a query.
    float worstDist2() const { return worst_; }

    /// Offers a hit; kept only if dist2 < worstDist2(). O(1) amortised.
    void add(float dist2, uint32_t index) {
        if (!(dist2 < worst_)) return;
        entries_.push_back({dist2, index});
        settled_ = false;
        const size_t n = entries_.size();
        if (n == k_) {
            // The k-th hit: the bound becomes the farthest of them (what a heap's top would be).
            float m = 0.0f;
            for (const KnnEntry& e : entries_) m = std::max(m, e.dist2);
            worst_ = m;
        } else if (n == 2 * size_t(k_)) {
            select();
        }
    }

    uint32_t size() const {
        settle();
        return static_cast<uint32_t>(entries_.size());
    }
    bool empty() const { return entries_.empty(); }
    bool full() const { return size() == k_; }
    uint32_t k() const { return k_; }
    float maxDist2() const { return maxDist2_; }
    /// Largest dist2 held (the k-th nearest when full); 0 when empty. O(k).
    float farthestDist2() const {
        settle();
        float m = 0.0f;
        for (const KnnEntry& e : entries_) m = std::max(m, e.dist2);
        return m;
    }

    /// The hits, unsorted. Valid until the next reset/add.
    std::span<const KnnEntry> entries() const {
        settle();
        return entries_;
    }
    /// Sorts the hits nearest first; the heap accepts no more hits until reset.
    void sortNearestFirst() {
        settle();
        std::sort(entries_.begin(), entries_.end(),
                  [](const KnnEntry& a, const KnnEntry& b) { return a.dist2 < b.dist2; });
        worst_ = -1.0f;
    }

private:
    // Keeps the k nearest of the buffer (any order) and lowers the bound to the k-th distance.
    void select() const {
        std::nth_element(entries_.begin(), entries_.begin() + (k_ - 1), entries_.end(),
                         [](const KnnEntry& a, const KnnEntry& b) { return a.dist2 < b.dist2; });
        entries_.resize(k_);
        worst_ = entries_[k_ - 1].dist2;  // nth_element puts the k-th smallest at k - 1
    }
    void settle() const {
        if (settled_) return;
        if (entries_.size() > k_) select();
        settled_ = true;
    }

    // Mutable: the readers finish a pending selection (a cache of the same logical content).
    mutable std::vector<KnnEntry> entries_;
    uint32_t k_ = 0;
    float maxDist2_ = std::numeric_limits<float>::infinity();
    mutable float worst_ = -1.0f;
    mutable bool settled_ = true;
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
