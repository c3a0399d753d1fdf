// The photon array the rebuilt-from-scratch indices (median kd-tree, grid) order and read.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "common/core/math.h"
#include "common/photon/knn.h"
#include "common/photon/photon.h"

namespace rtpm::detail {

/// Leaf scan over an array of Photon (MedianKdTree leaves, PhotonGrid cell runs): feeds
/// photons [first, end) closer than `worst` to `result`; returns the updated bound.
template <ResultSet R>
float scanPhotons(const Photon* photons, uint32_t first, uint32_t end, Vec3 q, R& result,
                  float worst) {
    for (uint32_t i = first; i < end; ++i) {
        const Vec3 d = photons[i].position - q;
        const float d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        if (d2 < worst) {
            result.add(d2, i);
            worst = result.worstDist2();
        }
    }
    return worst;
}

/// Photons in an index's own order plus their bounding box, with the read accessors every
/// photon index offers (KdTree keeps columns instead and has its own). MedianKdTree and
/// PhotonGrid derive from it; indices in query results refer to photons().
class PhotonArray {
public:
    size_t size() const { return photons_.size(); }
    bool empty() const { return photons_.empty(); }
    /// Photons in the index's order; indices in query results refer to this array.
    std::span<const Photon> photons() const { return photons_; }
    /// Photon `i` (i < size()). O(1).
    Photon photon(uint32_t i) const { return photons_[i]; }
    /// Encoded incoming direction / power of photon `i`.
    uint32_t photonIncoming(uint32_t i) const { return photons_[i].incoming; }
    uint32_t photonPower(uint32_t i) const { return photons_[i].power; }
    /// Bounding box of the photons (empty before the first non-empty build).
    const Bounds& bounds() const { return bounds_; }

protected:
    /// Appends the photons of `in` with a finite position to `out` and extends bounds_ by them;
    /// the others are skipped (a build never sees NaN coordinates).
    void keepFinite(std::span<const Photon> in, std::vector<Photon>& out) {
        out.reserve(out.size() + in.size());
        for (const Photon& p : in) {
            const Vec3 x = p.position;
            if (std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z)) {
                out.push_back(p);
                bounds_.extend(x);
            }
        }
    }

    std::vector<Photon> photons_;
    Bounds bounds_;
};

}  // namespace rtpm::detail
