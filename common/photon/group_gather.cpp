// The grouped gather's per-query distance loop, compiled for the machine's ISA (group_gather.h).
#include "common/photon/group_gather.h"

namespace rtpm::detail {

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
