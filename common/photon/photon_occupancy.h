// A coarse, conservative "is any photon within r of x?" test kept beside a photon map, so a
// pixel far from every stored photon skips its k-NN query (issue 10: model only what each pixel
// needs).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/core/math.h"
#include "common/photon/photon.h"

namespace rtpm {

/// A hashed bit grid over space with cells of 2.5·r. Inserting a photon at p sets the bit of
/// every cell its box [p − r', p + r'] overlaps (r' = r slightly enlarged against rounding; at
/// most 2 cells per axis, so ≤ 8 bits), so a photon within r of x always set the bit of x's cell:
/// `mayHaveWithin(x) == false` proves no stored photon lies within r of x. Cells hash into a
/// fixed 2^20-bit table (128 KiB), so memory does not grow with the scene or the map and a
/// collision only costs an unnecessary query (never a wrong answer). Photons are never removed
/// (the maps only grow until a reset), so the test stays conservative.
/// Not thread-safe for insert; `mayHaveWithin` may run concurrently.
class PhotonOccupancy {
public:
    static constexpr uint32_t kTableBits = 20;

    /// `radius` in metres (> 0 and finite, else every query answers true and nothing is
    /// allocated).
    explicit PhotonOccupancy(float radius = 0.0f);

    /// Marks the neighbourhood of every photon with a finite position.
    void insert(std::span<const Photon> photons);
    /// Forgets every photon.
    void clear();
    /// False only if no inserted photon lies within the radius of x. O(1).
    bool mayHaveWithin(Vec3 x) const;
    float radius() const { return radius_; }
    size_t memoryBytes() const { return bits_.capacity() * sizeof(uint64_t); }

private:
    int64_t cellOf(float v) const;
    static uint32_t slot(int64_t x, int64_t y, int64_t z);

    float radius_;
    float margin_;    // r enlarged by a relative 1e-3 against float rounding of p ± r
    float invCell_;   // 1 / (2.5 r); 0 when disabled
    std::vector<uint64_t> bits_;
};

}  // namespace rtpm
