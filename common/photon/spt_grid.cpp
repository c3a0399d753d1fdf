// The Selective Photon Tracing grid: box coordinates from the radical inverse, and the pilot
// indices of each box's face neighbours.
#include "common/photon/spt_grid.h"

#include "common/core/check.h"

namespace rtpm {

SptGrid makeSptGrid(int steeringDims, uint64_t targetCells) {
    RTPM_CHECK(steeringDims >= 1 && steeringDims <= kHaltonMaxDims);
    SptGrid g;
    g.dims = steeringDims;
    for (int d = 0; d < steeringDims; ++d) g.cells[static_cast<size_t>(d)] = 1;
    g.cellCount = 1;
    for (;;) {
        // Widest box side that can still take a digit.
        int best = -1;
        double bestWidth = 0.0;
        for (int d = 0; d < steeringDims; ++d) {
            const uint64_t b = kHaltonPrimes[static_cast<size_t>(d)];
            if (g.cellCount > targetCells / b) continue;
            const double width = 1.0 / static_cast<double>(g.cells[static_cast<size_t>(d)]);
            if (width > bestWidth) {
                bestWidth = width;
                best = d;
            }
        }
        if (best < 0) break;
        const auto bd = static_cast<size_t>(best);
        g.cells[bd] *= kHaltonPrimes[bd];
        g.digits[bd] += 1;
        g.cellCount *= kHaltonPrimes[bd];
    }
    return g;
}

uint64_t sptBoxCoordinate(const SptGrid& g, int dim, uint64_t index) {
    const auto d = static_cast<size_t>(dim);
    const uint64_t b = kHaltonPrimes[d];
    uint64_t r = index % g.cells[d];
    // Mirror the k lowest digits of r: they are the first k digits of Φ_b(index).
    uint64_t c = 0;
    for (uint32_t k = 0; k < g.digits[d]; ++k) {
        c = c * b + r % b;
        r /= b;
    }
    return c;
}

std::vector<uint32_t> sptNeighbours(const SptGrid& g) {
    const uint64_t n = g.cellCount;
    RTPM_CHECK(n < (uint64_t{1} << 32));
    const auto dims = static_cast<size_t>(g.dims);
    // Mixed-radix key of a cell's box coordinates → its pilot index (a bijection by the CRT).
    std::vector<uint64_t> stride(dims);
    uint64_t s = 1;
    for (size_t d = 0; d < dims; ++d) {
        stride[d] = s;
        s *= g.cells[d];
    }
    std::vector<uint32_t> pilotOfKey(n);
    std::vector<uint64_t> coords(n * dims);
    for (uint64_t i = 0; i < n; ++i) {
        uint64_t key = 0;
        for (size_t d = 0; d < dims; ++d) {
            const uint64_t c = sptBoxCoordinate(g, static_cast<int>(d), i);
            coords[i * dims + d] = c;
            key += c * stride[d];
        }
        pilotOfKey[key] = static_cast<uint32_t>(i);
    }
    std::vector<uint32_t> out(n * 2 * dims);
    for (uint64_t i = 0; i < n; ++i) {
        uint64_t key = 0;
        for (size_t d = 0; d < dims; ++d) key += coords[i * dims + d] * stride[d];
        for (size_t d = 0; d < dims; ++d) {
            const uint64_t c = coords[i * dims + d];
            const uint64_t m = g.cells[d];
            const uint64_t down = (c + m - 1) % m;
            const uint64_t up = (c + 1) % m;
            out[(i * dims + d) * 2 + 0] = pilotOfKey[key - c * stride[d] + down * stride[d]];
            out[(i * dims + d) * 2 + 1] = pilotOfKey[key - c * stride[d] + up * stride[d]];
        }
    }
    return out;
}

}  // namespace rtpm
