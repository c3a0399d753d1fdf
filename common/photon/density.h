// Caustic radiance from a photon map by k-nearest-neighbour density estimation (paper §3.1).
//
// Known limitation of the gather (thin occluders): the gather is a sphere with a front-facing test only, no
// visibility or surface test, so photons on the far side of a thin wall that stands on the
// same plane (same normal) as x are counted. Query points within r_k (≤ rMax) of the wall's
// foot on its dark side get up to the lit side's estimate there (HardCases test: 0.26 vs 0.28
// W/(m²·sr) at ±5 mm; zero beyond rMax). The band narrows as r_k shrinks with more photons.
// No cheap principled fix exists: a Photon has no spare bits (12 B position, 32-bit RGB9E5,
// 2×16-bit direction; bits could be taken from the direction, whose sign test is all this
// uses), but a surface id does not separate two halves of one floor; a disc-shaped gather
// (reject photons far from the tangent plane) rejects nothing on one plane; a visibility ray
// to the k-th photon only says that one photon is hidden, not which of the k are, and
// shrinking r at the first hidden photon would bias every estimate near any contact edge; a
// ray per gathered photon is exact for planar receivers but costs k (64) rays per estimate,
// more than the rest of the eye pass. That exact test is offered as an option:
// causticRadianceIf counts only the k nearest photons p for which `visible(p)` holds
// (PhotonSettings::gatherVisibility casts one shadow ray per gathered photon); r stays r_k, so
// the estimate is unchanged wherever every found photon is visible.
#pragma once

#include <algorithm>
#include <cstdint>
#include <numbers>
#include <vector>

#include "common/photon/kd_tree.h"
#include "common/photon/knn.h"
#include "common/photon/photon.h"

namespace rtpm {

/// Smallest estimation radius, relative to the photon index's bounds diagonal: k photons that
/// coincide with x would otherwise give r → 0 and infinite radiance. 1e-5 of a 5 m scene is
/// 0.05 mm, far below any pixel footprint, so it only ever acts on degenerate clusters.
inline constexpr float kMinDensityRadiusRelative = 1e-5f;

/// Result-set policy for density estimation: a kNN heap that ignores photons arriving from
/// behind the surface (dot(incoming, normal) > 0: the photon travelled away from the front
/// side). Back photons are skipped *during* the search, so they never take one of the k slots.
/// The direction is tested (arrivesFromBehind: no normalisation) only for photons that would
/// enter the heap. `Index` is any photon
/// index with photonIncoming(i) (KdTree, MedianKdTree, PhotonGrid).
template <class Index>
class FrontFacingKnn {
public:
    FrontFacingKnn(KnnHeap& heap, const Index& index, Vec3 normal)
        : heap_(heap), index_(index), normal_(normal) {}
    float worstDist2() const { return heap_.worstDist2(); }
    void add(float dist2, uint32_t index) {
        if (!(dist2 < heap_.worstDist2())) return;
        if (arrivesFromBehind(index_.photonIncoming(index), normal_)) return;
        heap_.add(dist2, index);
    }

private:
    KnnHeap& heap_;
    const Index& index_;
    Vec3 normal_;
};

/// Σ of RGB9E5 photon powers, exact and therefore independent of the order of the terms: a
/// decoded channel is m·2^(e−29) with a 9-bit m and 0 ≤ e < 32 (PhotonPowerWord, bias 20), so
/// every term is an integer multiple of 2^−29 below 2^11, i.e. below 2^40 such units, and a sum
/// of up to 2^12 terms stays below 2^52 units: exact in double.
/// (Gathers that reach the same photons in another order, e.g. gatherKnnGroup, give bit-identical
/// power.) Longer sums are still correct, only rounded.
class PowerSum {
public:
    void add(uint32_t packed) { add(decodeRgb9e5(packed)); }
    /// A power already decoded by decodeRgb9e5 (the same exact terms).
    void add(Vec3 v) {
        r_ += double(v.x);
        g_ += double(v.y);
        b_ += double(v.z);
    }
    Vec3 value() const { return Vec3(float(r_), float(g_), float(b_)); }

private:
    double r_ = 0.0, g_ = 0.0, b_ = 0.0;
};

/// The raw pieces of one k-NN gather (what causticRadianceIf turns into radiance and the
/// progressive estimator takes as a pixel's starting state): Σ decoded stored power of the
/// counted photons, the estimate's squared radius (r_k², clamped below; rMax² when fewer than k
/// were found) and the number of photons counted.
struct DensityGather {
    Vec3 power{0.0f};
    float radius2 = 0.0f;
    uint32_t count = 0;
};

/// The gather of causticRadianceIf below, without turning it into radiance. radius2 = 0 when
/// nothing can be estimated (empty index, k = 0, rMax ≤ 0, no photon found).
/// `guess2` (m², optional): a squared radius the k-th photon is expected within (a neighbouring
/// pixel's r_k², enlarged). The search first runs with that bound; if it finds k photons they are
/// exactly the k nearest, found with a tight bound from the start (fewer cells, fewer heap
/// replacements); if not, it runs again with rMax. The result is the one without a guess.
template <class Index, class Visible>
DensityGather gatherKnn(const Index& index, Vec3 x, Vec3 normal, uint32_t k, float rMax,
                        KnnHeap& heap, const Visible& visible, float guess2 = 0.0f) {
    DensityGather g;
    if (index.size() == 0 || k == 0 || !(rMax > 0.0f)) return g;
    const float maxDist2 = rMax * rMax;
    FrontFacingKnn<Index> policy(heap, index, normal);
    bool done = false;
    if (guess2 > 0.0f && guess2 < maxDist2) {
        heap.reset(k, guess2);
        index.search(x, policy);
        done = heap.full();
    }
    if (!done) {
        heap.reset(k, maxDist2);
        index.search(x, policy);
    }
    if (heap.empty()) return g;
    PowerSum sum;
    for (const KnnEntry& e : heap.entries())
        if (visible(index.photon(e.index))) {
            sum.add(index.photonPower(e.index));
            ++g.count;
        }
    g.power = sum.value();
    const float rMin = kMinDensityRadiusRelative * index.bounds().diagonal();
    g.radius2 = heap.full() ? std::max(heap.farthestDist2(), rMin * rMin) : maxDist2;
    return g;
}

/// Caustic radiance (W/(m²·sr)) leaving a Lambertian point x with albedo ρ toward any direction:
///   L = ρ/π · Σ_p Φ_p·powerScale / (π r²)
/// (Φ_p: the decoded stored power; PhotonMaps passes powerUnit / batches, so Φ_p·powerScale is
/// W per batch whatever unit the map stores in)
/// over the k nearest photons within rMax (m) that arrive from the front of `normal`
/// (photons with dot(incomingDir, normal) > 0 are ignored). r is the distance to the k-th such
/// photon; when fewer than k are found within rMax, r = rMax (the search disc is the area the
/// found photons are spread over: an under-estimate at the caustic's edge, never a spike).
/// r is clamped below by kMinDensityRadiusRelative × bounds diagonal. Returns 0 for an empty
/// map, k = 0, rMax ≤ 0 or no photon found; never NaN/Inf for finite inputs.
/// causticRadianceIf counts only the k nearest photons p for which `visible(p)` holds (r stays
/// r_k, so the estimate is unchanged wherever every found photon is visible); the file's opening
/// comment says why this is the thin-wall fix.
/// `Index` is KdTree, MedianKdTree or PhotonGrid (anything with size(), photonIncoming(),
/// photonPower(), bounds(), search()). Thread-safe if each thread has its own heap; no allocation once the heap saw k.
/// The radiance of a gather (formula above); 0 when it estimated nothing.
inline Vec3 causticRadianceFrom(const DensityGather& g, Vec3 albedo, float powerScale) {
    if (!(g.radius2 > 0.0f)) return Vec3(0.0f);
    return albedo * kInvPi * g.power * (powerScale / (kPi * g.radius2));
}

template <class Index, class Visible>
Vec3 causticRadianceIf(const Index& index, Vec3 x, Vec3 normal, Vec3 albedo, uint32_t k, float rMax,
                       float powerScale, KnnHeap& heap, const Visible& visible) {
    return causticRadianceFrom(gatherKnn(index, x, normal, k, rMax, heap, visible), albedo, powerScale);
}

/// Whether a radius search of `radius2` around a point with `normal` keeps photon `i` of `index`
/// at squared distance `dist2`: strictly within, arriving from the front of `normal`, and visible
/// (`visible` null: no visibility test, and no photon fetched for one). The test every radius
/// result set applies (RadiusList here, the passes' binning in progressive.cpp).
template <class Index, class Visible>
bool keptWithin(const Index& index, uint32_t i, float dist2, float radius2, Vec3 normal, const Visible* visible) {
    return dist2 < radius2 && !arrivesFromBehind(index.photonIncoming(i), normal) &&
           (visible == nullptr || (*visible)(index.photon(i)));
}

/// Radius search policy that lists every front-facing, visible photon strictly within
/// sqrt(radius2): its squared distance and decoded stored power (progressive.h bins them).
struct FoundPhoton {
    float dist2 = 0.0f;
    Vec3 power{0.0f};     ///< decoded stored power (units of the map's powerUnit, one batch)
    Vec3 position{0.0f};  ///< where it landed
};
template <class Index, class Visible>
class RadiusList {
public:
    RadiusList(const Index& index, Vec3 normal, float radius2, const Visible& visible,
               std::vector<FoundPhoton>& out)
        : index_(index), normal_(normal), radius2_(radius2), visible_(visible), out_(out) {}
    float worstDist2() const { return radius2_; }
    void add(float dist2, uint32_t i) {
        if (keptWithin(index_, i, dist2, radius2_, normal_, &visible_))
            out_.push_back(FoundPhoton{dist2, decodeRgb9e5(index_.photonPower(i)), index_.photon(i).position});
    }

private:
    const Index& index_;
    Vec3 normal_;
    float radius2_;
    const Visible& visible_;
    std::vector<FoundPhoton>& out_;
};

/// The estimate above with every found photon counted (no visibility test).
template <class Index>
Vec3 causticRadiance(const Index& index, Vec3 x, Vec3 normal, Vec3 albedo, uint32_t k, float rMax,
                     float powerScale, KnnHeap& heap) {
    return causticRadianceIf(index, x, normal, albedo, k, rMax, powerScale, heap,
                             [](const Photon&) { return true; });
}

/// The kd-tree estimate the renderer uses (non-template entry point; see the template above).
Vec3 causticRadiance(const KdTree& tree, Vec3 x, Vec3 normal, Vec3 albedo, uint32_t k, float rMax,
                     float powerScale, KnnHeap& heap);

}  // namespace rtpm
