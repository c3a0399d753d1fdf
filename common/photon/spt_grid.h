// The Selective Photon Tracing grid: which photon paths share an elementary box of the steering
// dims, and each box's neighbours.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "common/core/halton.h"

namespace rtpm {

/// Selective Photon Tracing grid over the steering dims (docs/ARCHITECTURE.md §5.2):
/// N_g = Π b_d^{k_d}. Indices i and i + m·N_g lie in the same elementary box for every m.
struct SptGrid {
    int dims = 0;                       ///< steering dims 0 … dims−1
    std::array<uint32_t, kHaltonMaxDims> digits{};  ///< k_d
    std::array<uint64_t, kHaltonMaxDims> cells{};   ///< b_d^{k_d}
    uint64_t cellCount = 1;             ///< N_g
};

/// Largest balanced grid with N_g ≤ target: repeatedly adds a digit to the dim whose box side
/// b^{-k} is widest (ties: lower dim), skipping dims whose digit would exceed the target.
SptGrid makeSptGrid(int steeringDims, uint64_t targetCells);

/// Box coordinate of index i along dim d: the first k_d base-b digits of Φ_b(i), as an integer
/// in [0, b^{k_d}). Depends only on i mod b^{k_d}.
uint64_t sptBoxCoordinate(const SptGrid& grid, int dim, uint64_t index);

/// For every pilot index i in [0, N_g): the pilot indices of its 2·dims face neighbours in box
/// space (wrapping, as the Cranley–Patterson rotation makes the boxes a torus). Row-major
/// [i · 2·dims + 2·d + {0: −1, 1: +1}]. Cost O(N_g · dims · k).
std::vector<uint32_t> sptNeighbours(const SptGrid& grid);

}  // namespace rtpm
