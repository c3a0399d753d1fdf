// Interleaved sampling: which pixels belong to which of the M×M sets (docs/ARCHITECTURE.md §3).
#pragma once

#include <cstdint>

#include "common/core/check.h"

namespace rtpm {

/// Pixel (x, y) belongs to set (y mod M)·M + (x mod M). Sets are ragged when W or H is not a
/// multiple of M. Pixels of a set are ordered row-major (the order clients send them in).
struct Interleave {
    int width = 0;
    int height = 0;
    int m = 1;

    int setCount() const { return m * m; }
    int setOf(int x, int y) const { return (y % m) * m + (x % m); }
    int setColumns(int set) const { return (width - set % m + m - 1) / m; }
    int setRows(int set) const { return (height - set / m + m - 1) / m; }
    int pixelCount(int set) const { return setColumns(set) * setRows(set); }
    /// Image column/row of the n-th pixel of `set`.
    int pixelX(int set, int n) const { return set % m + (n % setColumns(set)) * m; }
    int pixelY(int set, int n) const { return set / m + (n / setColumns(set)) * m; }
};

}  // namespace rtpm
