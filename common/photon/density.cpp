// The renderer's entry point to the density estimate: the template instantiated for KdTree.
#include "common/photon/density.h"

namespace rtpm {

Vec3 causticRadiance(const KdTree& tree, Vec3 x, Vec3 normal, Vec3 albedo, uint32_t k, float rMax,
                     float powerScale, KnnHeap& heap) {
    return causticRadiance<KdTree>(tree, x, normal, albedo, k, rMax, powerScale, heap);
}

}  // namespace rtpm
