// Constant-time-per-pixel F×F box filter of an RGB float image
// (paper §4.1, docs/ARCHITECTURE.md §4).
#pragma once

#include <span>
#include <vector>

namespace rtpm {

/// The window of width F around pixel x covers [x − r0, x + r1] with r0 = ⌊(F−1)/2⌋ and
/// r1 = F − 1 − r0: centred for odd F; for even F the extra pixel is on the right (below).
/// Borders: only pixels inside the image count, and the sum is divided by their number, which
/// is separable: validRows(y) × validCols(x). This is the one place the border rule lives.
struct BoxWindow {
    int r0 = 0;  ///< pixels before (left of / above) the anchor
    int r1 = 0;  ///< pixels after (right of / below) the anchor
    explicit BoxWindow(int f) : r0((f - 1) / 2), r1(f - 1 - (f - 1) / 2) {}
    /// Number of indices of [i − r0, i + r1] inside [0, n).
    int validCount(int i, int n) const;
};

/// Box filter with reusable scratch memory (one per thread; not thread-safe).
///
/// Algorithm: a row of vertical window sums (one per pixel and channel) slides down the image,
/// adding the row that enters and subtracting the one that leaves (one contiguous loop over W·3
/// values that vectorises); along each row a running horizontal sum over those sums, kept
/// zero-padded in place so the loop has no border branch, gives every window sum with one add
/// and one subtract of a whole pixel (RGB as one 4-lane vector). Cost O(W·H·3) whatever F. On
/// x86-64 the row loops are compiled for AVX2 and for baseline SSE2, chosen at load time.
///
/// Precision: sums are kept in double. Subtracting a bright value that left the window can
/// still leave rounding residue, so the vertical sums are recomputed from scratch every
/// kResumRows rows, and the horizontal sum restarts on every row: drift cannot build up across
/// the image. Versus the O(F²) reference the relative difference is ~1e-12 for values within
/// a 1e6 dynamic range, far below float output precision.
///
/// Non-finite input (NaN, ±Inf) is treated as 0 and counted as a valid pixel, so one bad pixel
/// cannot spread over its F×F neighbourhood (it darkens it by 1/count instead). Output is
/// finite whenever the finite inputs' sums are finite (|v| < ~1e38 / F²).
class BoxFilter {
public:
    /// Rows between full recomputations of the vertical sums (see Precision above).
    static constexpr int kResumRows = 64;

    /// Filters `in` (width × height pixels, 3 interleaved floats each, row-major) with an f × f
    /// window into `out` (same layout). Preconditions (checked, a bug otherwise): width, height,
    /// f ≥ 1; in and out hold width·height·3 floats and do not overlap.
    /// Allocates only when the image is wider than any seen before.
    void apply(std::span<const float> in, int width, int height, int f, std::span<float> out);

private:
    /// Vertical window sums of the current row (W·3) with r0+1 zero pixels before, r1 after and
    /// one spare value (the unused fourth lane of the last pixel's load).
    std::vector<double> padded_;
    std::vector<double> invCols_; ///< 1 / validCols(x)
};

/// One-shot convenience: BoxFilter{}.apply(...).
void boxFilter(std::span<const float> in, int width, int height, int f, std::span<float> out);

/// The box filter that stops at a caustic's edges (docs/ARCHITECTURE.md §4): pixel p averages the
/// neighbours q of its F×F window (same window and border rule as the box) weighted by how far
/// their luminances l_p, l_q differ beyond noise: with low = min(l_p, l_q) and d = max(0, |l_p −
/// l_q| − kEdgeNoise·√(σ_p² + σ_q²)) (σ = the pixel's relative `noise` × its luminance), weight 1
/// while d ≤ floor, 0 from d = (ratio − 1)·low + 2·floor on (the brighter about `ratio` × the
/// dimmer, once noise is allowed for), linear between; floor = kEdgeFloor × the luminance of p's
/// plain box average `box`, so that near-black neighbours of a dark pixel still average; p
/// itself has weight 1. Where every neighbour differs by no more than the noise and the floor (a
/// smooth caustic, a noisy one) the result is the box's; across a fold line or a caustic's rim
/// the window keeps the pixel's own side instead of blurring the two. The weights are continuous
/// in the values, so a value that moves a little moves the result a little.
/// Non-finite values count as 0, as in the box. `box` is BoxFilter::apply's output for `in` and
/// the same f; `noise` has one relative noise per pixel (infinite: unknown, every difference
/// there is noise), or is empty (none at all). ratio ≤ 0 copies `box` (the paper's filter); a
/// ratio in (0, 1) acts as 1. O(W·H·F²), rows in parallel.
inline constexpr float kEdgeFloor = 0.05f;
inline constexpr float kEdgeNoise = 2.0f;
void edgeStoppingBox(std::span<const float> in, std::span<const float> box, std::span<const float> noise,
                     int width, int height, int f, float ratio, std::span<float> out);

/// Reference: the same filter (window, border rule, non-finite rule) summed directly over the
/// F×F window in double. O(W·H·F²); for tests and benchmarks only.
void boxFilterNaive(std::span<const float> in, int width, int height, int f, std::span<float> out);

}  // namespace rtpm
