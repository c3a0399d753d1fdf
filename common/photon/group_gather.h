// k-NN density gathers of a group of nearby query points at once: one radius search for the
// group, then a per-query selection among its candidates (coherent eye rays, issue 10).
//
// Neighbouring pixels of a row shade neighbouring surface points, and their k nearest photons
// are mostly the same photons. A per-query k-NN search (density.h gatherKnn) descends the tree,
// scans ~20 leaves and keeps a heap per query; here a group of G queries (≤ 8: one primary-ray
// packet) shares one radius search around the group's bounding sphere (centre c, radius ρ) with
// radius ρ + R, where R² is the search bound (a guess from the previous group's r_k, or rMax):
// every photon within R of any query is among those candidates. Each query then computes its
// squared distances to the candidates (contiguous, vectorised), keeps the front-facing ones
// strictly within R and, when at least k are kept, selects the k nearest (selectNearest): these
// are exactly the k nearest front-facing photons within rMax (the k-th lies within R ≤ rMax).
// With R = rMax and fewer than k kept, they are all the photons within rMax (radius rMax, as
// gatherKnn). Only a query whose guess R < rMax found fewer than k falls back to gatherKnn.
// A group spread wider than kMaxSpreadRatio · R is split in halves (down to single queries,
// which take gatherKnn with the guess), and one whose candidate search overflows a cap (the
// guess came from a sparser neighbour) gathers per query, so a group never costs more than its
// queries would alone by much.
// Result: the same photons, radius and (PowerSum is exact) power as gatherKnn for every query,
// ties at the k-th distance aside.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "common/photon/density.h"
#include "common/photon/knn.h"
#include "common/photon/photon.h"

namespace rtpm {

/// One query of a group: the shading point and its normal facing the viewer.
struct GatherQuery {
    Vec3 position{0.0f};
    Vec3 normal{0.0f};
};

/// Scratch one thread reuses across groups; it only allocates when a group needs more room
/// than any before.
struct GroupGatherScratch {
    std::vector<KnnEntry> found;    ///< the group's radius search
    std::vector<float> x, y, z;     ///< candidate positions (m)
    std::vector<float> dx, dy, dz;  ///< candidate incoming directions (unnormalised)
    std::vector<Vec3> power;        ///< candidate powers, decoded once for the group
    std::vector<float> d2;          ///< one query's squared distances
    std::vector<KnnEntry> kept;     ///< one query's front-facing candidates within R
    std::vector<KnnEntry> tied;     ///< selectNearest's entries in the k-th's bucket
    std::vector<uint32_t> buckets;  ///< selectNearest's bucket of every kept entry
    KnnHeap heap;                   ///< the per-query fallback's heap
};

/// A neighbour's r_k² times this is the next search bound (1.12 × r_k; measured on RING as the
/// per-query hint: 1.1–1.5 gave the same saving, a tighter one costs repeated searches).
inline constexpr float kGuessScale = 1.25f;

/// A group wider than this multiple of the search radius R is split (its candidate ball of
/// radius ρ + R would hold (1 + ρ/R)² times the photons of one query's ball).
inline constexpr float kMaxSpreadRatio = 1.5f;

/// A group whose candidate search finds more than kMaxCandidatesPerK · k + 64 photons gathers
/// per query instead: each of its queries would scan about three times the photons its own k-NN
/// search visits (≈ 2k photons and 50 nodes on the Table 5 maps), which no longer pays; the
/// value was chosen on HEADLIGHT's 750 k-photon maps (RESULTS.md, "gather by groups").
inline constexpr uint32_t kMaxCandidatesPerK = 6;

namespace detail {

/// Radius search policy that stops the traversal once it holds `cap` hits (the bound drops below
/// every distance, which a result set may do): the caller then takes another route.
class CappedRadiusSet {
public:
    CappedRadiusSet(float maxDist2, size_t cap, std::vector<KnnEntry>& out)
        : bound_(maxDist2), cap_(cap), out_(out) {
        out_.clear();
    }
    float worstDist2() const { return bound_; }
    void add(float dist2, uint32_t index) {
        if (!(dist2 < bound_)) return;
        out_.push_back({dist2, index});
        if (out_.size() >= cap_) bound_ = -1.0f;
    }
    bool capped() const { return bound_ < 0.0f; }

private:
    float bound_;
    size_t cap_;
    std::vector<KnnEntry>& out_;
};
static_assert(ResultSet<CappedRadiusSet>);

/// Moves the k nearest of `kept[0, m)` (every dist2 in [0, bound2); k ≤ m) to its front, in no
/// particular order: the contract of nth_element at k − 1, up to which of several entries tied
/// at the k-th distance is taken. Buckets d² linearly over [0, bound2), finds the bucket holding
/// the k-th by a prefix sum, compacts the nearer buckets to the front and runs nth_element over
/// that bucket's few entries only (group_gather.cpp). `tied` has room for m + 1 entries,
/// `buckets` for m.
void selectNearest(KnnEntry* kept, size_t m, uint32_t k, float bound2, KnnEntry* tied, uint32_t* buckets);

/// d2[j] = |(x, y, z)[j] − q|² for j < n, in the leaf scan's operation order (kd_tree.h
/// PhotonColumns::scan). Compiled for AVX2 with a baseline fallback (group_gather.cpp).
void squaredDistances(const float* x, const float* y, const float* z, size_t n, Vec3 q, float* d2);

/// Keeps the front-facing candidates of `q` strictly within sqrt(bound2) in `kept` (distance,
/// candidate slot); returns how many. `d2` holds q's squared distance to every candidate.
inline size_t keepWithin(const GroupGatherScratch& s, size_t n, Vec3 nrm, float bound2,
                         KnnEntry* kept) {
    size_t m = 0;
    for (size_t j = 0; j < n; ++j) {
        // arrivesFromBehind: dot(incoming, n) > 0 is behind.
        const bool front = !(s.dx[j] * nrm.x + s.dy[j] * nrm.y + s.dz[j] * nrm.z > 0.0f);
        kept[m] = KnnEntry{s.d2[j], uint32_t(j)};
        m += (front && s.d2[j] < bound2) ? 1u : 0u;
    }
    return m;
}

template <class Index>
void gatherGroupRange(const Index& index, std::span<const GatherQuery> queries, uint32_t k,
                      float rMax, float guess2, GroupGatherScratch& s,
                      std::span<DensityGather> out) {
    const auto alwaysVisible = [](const Photon&) { return true; };
    const float maxDist2 = rMax * rMax;
    if (!(guess2 > 0.0f) && queries.size() > 1) {
        // No guess: the first query alone with rMax, its r_k the guess of the others (a group
        // searched with rMax in a dense caustic would collect far more than k candidates each).
        // If it found fewer than k, the photons are sparse here: the others search rMax as a
        // group (the candidate cap still sends a dense group to per-query searches).
        out[0] = gatherKnn(index, queries[0].position, queries[0].normal, k, rMax, s.heap,
                           alwaysVisible);
        const float next = out[0].count == k ? kGuessScale * out[0].radius2 : maxDist2;
        gatherGroupRange(index, queries.subspan(1), k, rMax, next, s, out.subspan(1));
        return;
    }
    const float bound2 = guess2 > 0.0f && guess2 < maxDist2 ? guess2 : maxDist2;
    if (queries.size() == 1) {
        out[0] = gatherKnn(index, queries[0].position, queries[0].normal, k, rMax, s.heap,
                           alwaysVisible, bound2 < maxDist2 ? bound2 : 0.0f);
        return;
    }
    Bounds box;
    for (const GatherQuery& q : queries) box.extend(q.position);
    const Vec3 centre = 0.5f * (box.lo + box.hi);
    float spread2 = 0.0f;
    for (const GatherQuery& q : queries) {
        const Vec3 d = q.position - centre;
        spread2 = std::max(spread2, glm::dot(d, d));
    }
    const float spread = std::sqrt(spread2);
    const float bound = std::sqrt(bound2);
    if (!(spread <= kMaxSpreadRatio * bound)) {  // also catches NaN
        const size_t half = queries.size() / 2;
        gatherGroupRange(index, queries.first(half), k, rMax, guess2, s, out.first(half));
        gatherGroupRange(index, queries.subspan(half), k, rMax, guess2, s, out.subspan(half));
        return;
    }

    // Candidates: every photon within R of some query lies within ρ + R of the centre (the
    // relative margin covers the rounding of ρ, R and the distances).
    const float reach = (spread + bound) * (1.0f + 1e-5f);
    CappedRadiusSet candidates(reach * reach, kMaxCandidatesPerK * k + 64, s.found);
    index.search(centre, candidates);
    if (candidates.capped()) {
        // Too many for the group (a guess from a sparser neighbour, or a dense caustic): each
        // query searches alone, guessing from its predecessor's r_k.
        float next = guess2;
        for (size_t qi = 0; qi < queries.size(); ++qi) {
            const float g2 = next > 0.0f && next < maxDist2 ? next : 0.0f;
            out[qi] = gatherKnn(index, queries[qi].position, queries[qi].normal, k, rMax, s.heap, alwaysVisible, g2);
            next = out[qi].count == k ? kGuessScale * out[qi].radius2 : guess2;
        }
        return;
    }
    const size_t n = s.found.size();
    for (auto* v : {&s.x, &s.y, &s.z, &s.dx, &s.dy, &s.dz, &s.d2})
        if (v->size() < n) v->resize(n);
    if (s.power.size() < n) s.power.resize(n);
    if (s.kept.size() < n) s.kept.resize(n);
    if (s.tied.size() < n + 1) s.tied.resize(n + 1);
    if (s.buckets.size() < n) s.buckets.resize(n);
    for (size_t j = 0; j < n; ++j) {
        const Photon p = index.photon(s.found[j].index);
        s.x[j] = p.position.x;
        s.y[j] = p.position.y;
        s.z[j] = p.position.z;
        const Vec3 d = decodeOctahedralUnnormalized(p.incoming);
        s.dx[j] = d.x;
        s.dy[j] = d.y;
        s.dz[j] = d.z;
        s.power[j] = decodeRgb9e5(index.photonPower(s.found[j].index));
    }
    const float rMin = kMinDensityRadiusRelative * index.bounds().diagonal();

    // Each query first keeps the candidates within a bound from its predecessor's r_k (so the
    // selection sorts out little more than k), then within R if that kept fewer than k.
    float local2 = bound2;
    for (size_t qi = 0; qi < queries.size(); ++qi) {
        const Vec3 q = queries[qi].position;
        const Vec3 nrm = queries[qi].normal;
        squaredDistances(s.x.data(), s.y.data(), s.z.data(), n, q, s.d2.data());
        KnnEntry* kept = s.kept.data();
        float keptWithin2 = local2;
        size_t m = keepWithin(s, n, nrm, local2, kept);
        if (m < k && local2 < bound2) {
            keptWithin2 = bound2;
            m = keepWithin(s, n, nrm, bound2, kept);
        }
        DensityGather& g = out[qi];
        g = DensityGather{};
        local2 = bound2;
        if (m >= k) {
            selectNearest(kept, m, k, keptWithin2, s.tied.data(), s.buckets.data());
            PowerSum sum;
            float farthest = 0.0f;
            for (uint32_t e = 0; e < k; ++e) {
                sum.add(s.power[kept[e].index]);
                farthest = std::max(farthest, kept[e].dist2);
            }
            g.power = sum.value();
            g.count = k;
            g.radius2 = std::max(farthest, rMin * rMin);
            local2 = std::min(bound2, kGuessScale * farthest);
        } else if (bound2 >= maxDist2) {
            if (m == 0) continue;  // nothing within rMax: no estimate
            PowerSum sum;
            for (size_t e = 0; e < m; ++e) sum.add(s.power[kept[e].index]);
            g.power = sum.value();
            g.count = uint32_t(m);
            g.radius2 = maxDist2;
        } else {
            g = gatherKnn(index, q, nrm, k, rMax, s.heap, alwaysVisible);
        }
    }
}

}  // namespace detail

/// The k-NN gathers of `queries` (a group of nearby points, e.g. one row packet of an image) into
/// `out` (same size): for each query what gatherKnn(index, position, normal, k, rMax, heap,
/// every photon visible) returns — the same photons, radius and power (ties at the k-th
/// distance may pick another of the tied photons). `guess2` (m², 0 = none)
/// is a squared radius the k-th photons are expected within (the previous group's largest r_k²,
/// enlarged): the candidates are searched within it and a query that finds fewer than k there
/// repeats its search with rMax. Cost per group: one radius search, then per query O(candidates)
/// plus O(kept) for the selection. No allocation once `scratch` has grown. Thread-safe per scratch.
template <class Index>
void gatherKnnGroup(const Index& index, std::span<const GatherQuery> queries, uint32_t k,
                    float rMax, float guess2, GroupGatherScratch& scratch,
                    std::span<DensityGather> out) {
    RTPM_CHECK(out.size() == queries.size());
    if (queries.empty()) return;
    if (index.size() == 0 || k == 0 || !(rMax > 0.0f)) {
        for (DensityGather& g : out) g = DensityGather{};
        return;
    }
    detail::gatherGroupRange(index, queries, k, rMax, guess2, scratch, out);
}

}  // namespace rtpm
