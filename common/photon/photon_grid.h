// Uniform grid over photons (paper §5.3): the alternative to the kd-tree, kept for comparison.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "common/photon/knn.h"
#include "common/photon/photon.h"
#include "common/photon/photon_array.h"

namespace rtpm {

/// Uniform grid of cubic cells over the photons' bounding box. Photons are sorted into cell order
/// (x-major, z fastest) and the grid is a table of 4-byte first-photon indices (cell c holds
/// photons [first[c], first[c+1])), as in the paper. A query visits the cells overlapping the
/// search sphere, x and y centre-out, skipping rows and cells farther than the current k-th
/// distance (the paper visits every cell within the maximum radius).
/// Unlike the paper's grid, nothing stops it from being used with maxDist2 = +inf (it then
/// visits every non-pruned cell). Same query API as KdTree; `--tree grid` selects it
/// (PhotonIndex rebuilds it from all photons every batch).
/// Thread safety: const members may run concurrently; build/clear need exclusive access.
class PhotonGrid : public detail::PhotonArray {
public:
    static constexpr uint32_t kMaxResolution = 256;

    /// `resolution` = cells along the largest extent of the photon bounds (1…256); the other
    /// axes get as many cells of the same size as they need.
    explicit PhotonGrid(uint32_t resolution = 64);

    /// Replaces the content with the finite-position photons of `photons`. Cost O(n + cells).
    void build(std::span<const Photon> photons);
    void clear();

    std::array<uint32_t, 3> dims() const { return dims_; }
    size_t memoryBytes() const {
        return photons_.capacity() * sizeof(Photon) + first_.capacity() * sizeof(uint32_t);
    }

    template <ResultSet R>
    void search(Vec3 q, R& result) const {
        if (photons_.empty()) return;
        // Cell range overlapping the sphere of the initial bound (all cells if unbounded).
        int lo[3], hi[3];
        const float r = std::sqrt(result.worstDist2());
        for (int a = 0; a < 3; ++a) {
            const float rel0 = (q[a] - r - bounds_.lo[a]) * invCell_;
            const float rel1 = (q[a] + r - bounds_.lo[a]) * invCell_;
            const int n = static_cast<int>(dims_[a]);
            if (!(rel1 >= 0.0f) || !(rel0 < static_cast<float>(n))) return;  // sphere misses
            lo[a] = rel0 <= 0.0f ? 0 : static_cast<int>(rel0);
            hi[a] = rel1 >= static_cast<float>(n - 1) ? n - 1 : static_cast<int>(rel1);
        }
        const auto axisDist2 = [&](int a, int i) {  // squared distance from q to slab i of axis a
            const float c0 = bounds_.lo[a] + static_cast<float>(i) * cellSize_;
            const float d = std::max({0.0f, c0 - q[a], q[a] - (c0 + cellSize_)});
            return d * d;
        };
        // Visit rows centre-out (the cell of q first, then alternating ±1, ±2, …) so the heap
        // fills with near photons early and the k-th distance prunes the outer cells.
        const auto centre = [&](int a) {
            const float rel = (q[a] - bounds_.lo[a]) * invCell_;
            return rel <= static_cast<float>(lo[a]) ? lo[a]
                   : rel >= static_cast<float>(hi[a]) ? hi[a] : static_cast<int>(rel);
        };
        const auto nth = [](int c, int l, int h, int step) {  // step-th index of a centre-out walk
            int below = c - l, above = h - c;
            const int both = std::min(below, above);
            if (step <= 2 * both) return (step & 1) ? c + (step + 1) / 2 : c - step / 2;
            return above > below ? c + (step - both) : c - (step - both);
        };
        const int cx = centre(0), cy = centre(1);
        const Photon* photons = photons_.data();
        for (int sx = 0; sx <= hi[0] - lo[0]; ++sx) {
            const int ix = nth(cx, lo[0], hi[0], sx);
            const float dx2 = axisDist2(0, ix);
            if (!(dx2 < result.worstDist2())) continue;
            for (int sy = 0; sy <= hi[1] - lo[1]; ++sy) {
                const int iy = nth(cy, lo[1], hi[1], sy);
                const float dxy2 = dx2 + axisDist2(1, iy);
                float worst = result.worstDist2();
                if (!(dxy2 < worst)) continue;
                // Trim the z run to the cells that can still hold a closer photon; the photons
                // of consecutive z cells are contiguous, so the run is one linear scan.
                int z0 = lo[2], z1 = hi[2];
                while (z0 <= z1 && !(dxy2 + axisDist2(2, z0) < worst)) ++z0;
                while (z1 >= z0 && !(dxy2 + axisDist2(2, z1) < worst)) --z1;
                if (z0 > z1) continue;
                const size_t row = (static_cast<size_t>(ix) * dims_[1] + iy) * dims_[2];
                const uint32_t begin = first_[row + z0];
                const uint32_t end = first_[row + z1 + 1];
                detail::scanPhotons(photons, begin, end, q, result, worst);
            }
        }
    }

private:
    uint32_t resolution_;
    float cellSize_ = 1.0f;
    float invCell_ = 1.0f;
    std::array<uint32_t, 3> dims_{1, 1, 1};
    std::vector<uint32_t> first_;  // cells + 1 entries
};

}  // namespace rtpm
