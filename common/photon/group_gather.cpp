// The grouped gather's per-query selection and distance loop (group_gather.h).
#include "common/photon/group_gather.h"

#include <algorithm>

namespace rtpm::detail {

namespace {

// Buckets of `selectNearest`: with d² spread evenly over [0, bound²) (a locally uniform photon
// density fills area, i.e. d², evenly), m kept candidates leave ≈ m / 128 in the bucket the
// k-th falls in, so the final exact selection is over one or two entries.
constexpr uint32_t kSelectBuckets = 128;

bool nearerEntry(const KnnEntry& a, const KnnEntry& b) { return a.dist2 < b.dist2; }

}  // namespace

// Replaces an nth_element over all m, whose partition loop was 42 % of a grouped gather on RING.
// The compaction is branch-free and a write never passes the read position.
void selectNearest(KnnEntry* kept, size_t m, uint32_t k, float bound2, KnnEntry* tied, uint32_t* buckets) {
    if (m <= k) return;
    const float scale = float(kSelectBuckets) / bound2;
    if (!(scale <= 1e30f)) {  // bound2 near the smallest floats (coincident photons): no buckets
        std::nth_element(kept, kept + (k - 1), kept + m, nearerEntry);
        return;
    }
    // Bucket numbers first (a vectorisable pass), then two interleaved histograms, so that
    // neighbours falling into one bucket do not wait on each other's increment.
    for (size_t j = 0; j < m; ++j)
        buckets[j] = std::min(uint32_t(kept[j].dist2 * scale), kSelectBuckets - 1);  // d2 ≥ 0
    uint32_t count[2][kSelectBuckets] = {};
    size_t j = 0;
    for (; j + 1 < m; j += 2) {
        ++count[0][buckets[j]];
        ++count[1][buckets[j + 1]];
    }
    if (j < m) ++count[0][buckets[j]];
    uint32_t b = 0, before = 0;  // bucket of the k-th; entries in nearer buckets
    for (uint32_t inB = count[0][0] + count[1][0]; before + inB < k; inB = count[0][b] + count[1][b]) {
        before += inB;
        ++b;
    }
    size_t near = 0, tie = 0;
    for (j = 0; j < m; ++j) {
        const KnnEntry e = kept[j];
        kept[near] = e;
        near += buckets[j] < b ? 1u : 0u;
        tied[tie] = e;
        tie += buckets[j] == b ? 1u : 0u;
    }
    std::copy(tied, tied + tie, kept + before);
    std::nth_element(kept + before, kept + (k - 1), kept + before + tie, nearerEntry);
}

// Compiled twice: for AVX2 (eight floats per operation) and for baseline x86-64, picked at load
// time by the CPU (GCC function multiversioning), as the box filter's row loops. AVX2 without FMA:
// the same multiplications and additions in the same order, so the same bits as the baseline.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define RTPM_GATHER_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define RTPM_GATHER_CLONES
#endif

RTPM_GATHER_CLONES void squaredDistances(const float* x, const float* y, const float* z, size_t n, Vec3 q,
                                         float* d2) {
    const float qx = q.x, qy = q.y, qz = q.z;
    for (size_t j = 0; j < n; ++j) {
        const float ex = x[j] - qx, ey = y[j] - qy, ez = z[j] - qz;
        d2[j] = ex * ex + ey * ey + ez * ez;
    }
}

}  // namespace rtpm::detail
