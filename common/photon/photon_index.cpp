// PhotonIndex: batch insertion per variant (incremental for the middle split, rebuild otherwise).
#include "common/photon/photon_index.h"

#include <algorithm>
#include <cmath>

namespace rtpm {

namespace {

std::variant<KdTree, MedianKdTree, PhotonGrid> makeIndex(PhotonTree kind, Bounds rootBox) {
    switch (kind) {
        case PhotonTree::MedianBalanced: return MedianKdTree();
        case PhotonTree::UniformGrid: return PhotonGrid();
        case PhotonTree::MiddleSplit: break;
    }
    return KdTree(rootBox);
}

// The photons of `old` followed by `batch`: the input of a from-scratch rebuild.
template <class Index>
std::vector<Photon> withBatch(const Index& old, std::span<const Photon> batch) {
    std::vector<Photon> all;
    all.reserve(old.size() + batch.size());
    all.insert(all.end(), old.photons().begin(), old.photons().end());
    all.insert(all.end(), batch.begin(), batch.end());
    return all;
}

}  // namespace

uint32_t gridResolution(uint64_t photons, Vec3 extent, uint32_t k, float rMax) {
    const double maxExtent = std::max({double(extent.x), double(extent.y), double(extent.z)});
    if (!(maxExtent > 0.0) || !std::isfinite(maxExtent)) return 1;
    double res = 1.0;
    if (rMax > 0.0f) res = std::max(res, std::ceil(maxExtent / double(rMax)));
    if (k > 0) res = std::max(res, std::ceil(std::sqrt(double(photons) / double(k))));
    uint32_t r = static_cast<uint32_t>(std::min(res, double(PhotonGrid::kMaxResolution)));
    const double maxCells = std::max(2.0 * double(photons), 4096.0);
    // Cell count as PhotonGrid::build computes it: ceil(side / cell) per axis, at least 1.
    const auto cells = [&](uint32_t n) {
        const double cell = maxExtent / double(n);
        double c = 1.0;
        for (int a = 0; a < 3; ++a) c *= std::clamp(std::ceil(double(extent[a]) / cell), 1.0, double(n));
        return c;
    };
    while (r > 1 && cells(r) > maxCells) --r;
    return r;
}

PhotonIndex::PhotonIndex(PhotonTree kind, Bounds rootBox) : index_(makeIndex(kind, rootBox)) {}

void PhotonIndex::insert(std::span<const Photon> batch, uint32_t k, float rMax) {
    if (KdTree* tree = std::get_if<KdTree>(&index_)) {
        tree->insert(batch);
    } else if (MedianKdTree* median = std::get_if<MedianKdTree>(&index_)) {
        median->build(withBatch(*median, batch));
    } else {
        PhotonGrid& old = std::get<PhotonGrid>(index_);
        const std::vector<Photon> all = withBatch(old, batch);
        Bounds b;
        for (const Photon& p : all) b.extend(p.position);
        const uint32_t res = all.empty() ? 1 : gridResolution(all.size(), b.extent(), k, rMax);
        PhotonGrid grid(res);
        grid.build(all);
        index_ = std::move(grid);
    }
}

size_t PhotonIndex::size() const {
    return visit([](const auto& index) { return index.size(); });
}

std::vector<Photon> PhotonIndex::photons() const {
    return visit([](const auto& index) {
        return std::vector<Photon>(index.photons().begin(), index.photons().end());
    });
}

}  // namespace rtpm
