// Uniform photon grid construction: a counting sort of the photons into cell order.
#include "common/photon/photon_grid.h"

#include "common/core/check.h"

namespace rtpm {

PhotonGrid::PhotonGrid(uint32_t resolution)
    : resolution_(std::clamp(resolution, 1u, kMaxResolution)) {
    clear();
}

void PhotonGrid::clear() {
    photons_.clear();
    bounds_ = Bounds{};
    dims_ = {1, 1, 1};
    first_.assign(2, 0);
}

void PhotonGrid::build(std::span<const Photon> photons) {
    clear();
    std::vector<Photon> kept;
    keepFinite(photons, kept);
    if (kept.empty()) return;
    RTPM_CHECK(kept.size() < UINT32_MAX);
    const Vec3 e = bounds_.extent();
    const float maxExtent = std::max({e.x, e.y, e.z});
    cellSize_ = maxExtent > 0.0f ? maxExtent / static_cast<float>(resolution_) : 1.0f;
    invCell_ = 1.0f / cellSize_;
    for (int a = 0; a < 3; ++a) {
        const float n = std::ceil(e[a] * invCell_);
        dims_[a] = std::clamp(static_cast<uint32_t>(n), 1u, resolution_);
    }
    const size_t cells = static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2];
    const auto cellOf = [&](Vec3 x) {
        uint32_t c[3];
        for (int a = 0; a < 3; ++a) {
            const float rel = (x[a] - bounds_.lo[a]) * invCell_;
            c[a] = std::min(static_cast<uint32_t>(std::max(rel, 0.0f)), dims_[a] - 1);
        }
        return (static_cast<size_t>(c[0]) * dims_[1] + c[1]) * dims_[2] + c[2];
    };
    // Counting sort: histogram, exclusive prefix sum into first_, scatter.
    first_.assign(cells + 1, 0);
    for (const Photon& p : kept) ++first_[cellOf(p.position) + 1];
    for (size_t c = 1; c <= cells; ++c) first_[c] += first_[c - 1];
    photons_.resize(kept.size());
    std::vector<uint32_t> cursor(first_.begin(), first_.end() - 1);
    for (const Photon& p : kept) photons_[cursor[cellOf(p.position)]++] = p;
}

}  // namespace rtpm
