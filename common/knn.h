// Result-set policies for photon searches: the bounded kNN max-heap and a radius collector.
#pragma once

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "common/check.h"

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

/// Bounded max-heap of the k nearest hits strictly closer than sqrt(maxDist2) (nanoflann's
/// KNNResultSet with a radius bound). The caller owns it and reuses it across queries: `reset`
/// allocates only when k exceeds every k seen before, so steady-state queries never allocate.
/// Not thread-safe: use one heap per thread.
class KnnHeap {
public:
    KnnHeap() = default;
    explicit KnnHeap(uint32_t capacity) { entries_.reserve(capacity); }

    /// Empties the heap for a query of the k nearest within squared radius maxDist2 (m²).
    /// maxDist2 may be +inf (unbounded). k = 0 gives a heap that accepts nothing.
    void reset(uint32_t k, float maxDist2) {
        if (entries_.capacity() < k) entries_.reserve(k);
        entries_.clear();
        k_ = k;
        maxDist2_ = maxDist2;
        worst_ = k == 0 ? -1.0f : maxDist2;
    }

    /// Current pruning bound: maxDist2 until k hits are held, then the k-th smallest dist2.
    float worstDist2() const { return worst_; }

    /// Offers a hit; kept only if dist2 < worstDist2(). O(log k).
    void add(float dist2, uint32_t index) {
        if (!(dist2 < worst_)) return;
        if (entries_.size() < k_) {
            // Filling: append unordered; order the heap once when the k-th hit arrives. Until
            // then the bound stays maxDist2, so no hit is compared against the heap top.
            entries_.push_back({dist2, index});
            if (entries_.size() == k_) {
                std::make_heap(entries_.begin(), entries_.end(), farther);
                worst_ = entries_.front().dist2;
            }
            return;
        }
        // Full: the new hit replaces the farthest (the root) and sifts down; one pass, no swap.
        KnnEntry* heap = entries_.data();
        const size_t n = entries_.size();
        size_t hole = 0;
        for (;;) {
            size_t child = 2 * hole + 1;
            if (child >= n) break;
            if (child + 1 < n && heap[child + 1].dist2 > heap[child].dist2) ++child;
            if (heap[child].dist2 <= dist2) break;
            heap[hole] = heap[child];
            hole = child;
        }
        heap[hole] = {dist2, index};
        worst_ = heap[0].dist2;
    }

    uint32_t size() const { return static_cast<uint32_t>(entries_.size()); }
    bool empty() const { return entries_.empty(); }
    bool full() const { return entries_.size() == k_; }
    uint32_t k() const { return k_; }
    float maxDist2() const { return maxDist2_; }
    /// Largest dist2 held (the k-th nearest when full); 0 when empty. O(1) when full, O(size)
    /// while filling (the entries are only heap-ordered once k arrived).
    float farthestDist2() const {
        if (entries_.empty()) return 0.0f;
        if (full()) return entries_.front().dist2;
        float m = 0.0f;
        for (const KnnEntry& e : entries_) m = std::max(m, e.dist2);
        return m;
    }

    /// The hits, unsorted. Valid until the next reset/add.
    std::span<const KnnEntry> entries() const { return entries_; }
    /// Sorts the hits nearest first (destroys the heap property; call reset before reuse).
    void sortNearestFirst() {
        std::sort(entries_.begin(), entries_.end(),
                  [](const KnnEntry& a, const KnnEntry& b) { return a.dist2 < b.dist2; });
        worst_ = -1.0f;  // a sorted heap must not accept more hits
    }

private:
    static bool farther(const KnnEntry& a, const KnnEntry& b) { return a.dist2 < b.dist2; }

    std::vector<KnnEntry> entries_;
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

}  // namespace rtpm
