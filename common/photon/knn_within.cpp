// PhotonMaps::gatherMapKnnWithin: one radius search that gives a hit both its k-NN disc and the
// photons around it (the progressive restart's gather; photon_map.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/photon/density.h"
#include "common/photon/group_gather.h"
#include "common/photon/photon_map.h"

namespace rtpm {

DensityGather PhotonMaps::gatherMapKnnWithin(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit,
                                             Vec3 normal, float& reach2, std::vector<FoundPhoton>& out) const {
    // A k-NN gather counts the photons strictly within rMax; "all of rMax" searches just beyond
    // it, so that `out` also serves a caller's disc of exactly rMax² (the restart's ladder, whose
    // outer disc lies just beyond its squared radius).
    const float rMax2 = rMax_ * rMax_;
    const float all2 = std::nextafter(rMax2, std::numeric_limits<float>::infinity());
    if (!(reach2 > 0.0f) || reach2 >= rMax2) reach2 = all2;
    out.clear();
    const auto& owned = ownedSets();
    if (std::find(owned.begin(), owned.end(), set) == owned.end() || stats(set).batches == 0 || settings_.k == 0)
        return {};
    const PhotonIndex* index = indexOf(set);
    if (!index) return {};
    auto withinRMax = [&] {
        return reach2 < rMax2 ? out.size()
                              : size_t(std::count_if(out.begin(), out.end(),
                                                     [rMax2](const FoundPhoton& p) { return p.dist2 < rMax2; }));
    };
    gatherMapPhotons(scene, set, hit, normal, reach2, out);
    size_t n = withinRMax();
    if (n < settings_.k && reach2 < all2) {
        out.clear();
        reach2 = all2;
        gatherMapPhotons(scene, set, hit, normal, reach2, out);
        n = withinRMax();
    }
    if (n < settings_.k) return n > 0 ? DensityGather{Vec3(0.0f), rMax2, uint32_t(n)} : DensityGather{};
    // The k-th nearest of them (every nearer photon lies within reach, so it is the map's):
    // the grouped gather's bucket selection over their distances.
    const float bound2 = std::min(reach2, rMax2);
    thread_local std::vector<KnnEntry> entries, tied;
    thread_local std::vector<uint32_t> buckets;
    entries.clear();
    for (size_t i = 0; i < out.size(); ++i)
        if (out[i].dist2 < bound2) entries.push_back(KnnEntry{out[i].dist2, uint32_t(i)});
    tied.resize(entries.size() + 1);
    buckets.resize(entries.size());
    detail::selectNearest(entries.data(), entries.size(), settings_.k, bound2, tied.data(), buckets.data());
    float farthest = 0.0f;
    for (uint32_t i = 0; i < settings_.k; ++i) farthest = std::max(farthest, entries[i].dist2);
    const float rMin = index->visit([](const auto& idx) { return kMinDensityRadiusRelative * idx.bounds().diagonal(); });
    return DensityGather{Vec3(0.0f), std::max(farthest, rMin * rMin), settings_.k};
}

}  // namespace rtpm
