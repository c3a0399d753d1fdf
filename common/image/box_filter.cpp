// Box filter: sliding vertical sums over whole rows, running horizontal sums, naive reference.
#include "common/image/box_filter.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <vector>

#include "common/core/check.h"

namespace rtpm {
namespace {

// NaN and ±Inf become 0. A bit test (exponent all ones) rather than std::isfinite, written as an
// integer mask so the row loops have no branch and GCC vectorises them; it is the same test for
// the add and the subtract of a row, so what enters a sum is exactly what later leaves it.
inline double finiteOrZero(float v) {
    const uint32_t bits = std::bit_cast<uint32_t>(v);
    const uint32_t keep = (bits & 0x7f800000u) == 0x7f800000u ? 0u : ~0u;
    return static_cast<double>(std::bit_cast<float>(bits & keep));
}

// One pixel's running sums: R, G, B and a fourth lane that rides along unused, so a pixel is one
// 256-bit operation (two 128-bit ones on plain x86-64) instead of three scalar chains.
typedef double Double4 __attribute__((vector_size(32)));
typedef float Float4 __attribute__((vector_size(16)));

inline void addPixel(Double4& sum, const double* enter, const double* leave) {  // unaligned
    Double4 e, l;
    std::memcpy(&e, enter, sizeof e);
    std::memcpy(&l, leave, sizeof l);
    sum += e - l;
}

void checkArgs(std::span<const float> in, int width, int height, int f, std::span<float> out) {
    RTPM_CHECK(width >= 1 && height >= 1 && f >= 1);
    const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height) * 3;
    RTPM_CHECK(in.size() == n && out.size() == n);
    RTPM_CHECK(in.data() + n <= out.data() || out.data() + n <= in.data());
}

// The row loops, compiled twice: for AVX2 (four doubles per operation) and for baseline x86-64,
// picked at load time by the CPU (GCC function multiversioning), so the binary still runs on any
// x86-64 client. Elsewhere the attribute is left out and the compiler's defaults apply.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define RTPM_ROW_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define RTPM_ROW_CLONES
#endif

/// colSum[i] += row[i] (add) or −= row[i] (!add), over n values; contiguous, vectorises.
RTPM_ROW_CLONES void accumulateRow(double* colSum, const float* row, size_t n, bool add) {
    if (add)
        for (size_t i = 0; i < n; ++i) colSum[i] += finiteOrZero(row[i]);
    else
        for (size_t i = 0; i < n; ++i) colSum[i] -= finiteOrZero(row[i]);
}

/// colSum[i] += enter[i] − leave[i]: one slide of the vertical window in one pass.
RTPM_ROW_CLONES void slideRow(double* colSum, const float* enter, const float* leave, size_t n) {
    for (size_t i = 0; i < n; ++i) colSum[i] += finiteOrZero(enter[i]) - finiteOrZero(leave[i]);
}

/// Horizontal pass of one row. `p` holds the vertical sums zero-padded by r0 + 1 pixels before and
/// r1 after, plus one spare double (the fourth lane of the last load). Before pixel x the running
/// sum holds padded pixels [x, x + span]; adding x + 1 + span and removing x gives image columns
/// [x − r0, x + r1]. The 16-byte store of pixel x spills one float into pixel x + 1, which the
/// next step overwrites; the last pixel stores its three floats only.
RTPM_ROW_CLONES void horizontalRow(const double* p, int width, int span, double invRows,
                                   const double* invCols, float* o) {
    static const double kZero[4] = {0.0, 0.0, 0.0, 0.0};
    Double4 s = {0.0, 0.0, 0.0, 0.0};
    for (int k = 0; k <= span; ++k) addPixel(s, p + 3 * k, kZero);
    Float4 v;
    for (int x = 0; x + 1 < width; ++x) {
        addPixel(s, p + 3 * (x + 1 + span), p + 3 * x);
        v = __builtin_convertvector(s * (invRows * invCols[x]), Float4);
        std::memcpy(o + 3 * x, &v, sizeof v);
    }
    const int x = width - 1;
    addPixel(s, p + 3 * (x + 1 + span), p + 3 * x);
    v = __builtin_convertvector(s * (invRows * invCols[x]), Float4);
    std::memcpy(o + 3 * x, &v, 3 * sizeof(float));
}

}  // namespace

int BoxWindow::validCount(int i, int n) const {
    return std::min(n - 1, i + r1) - std::max(0, i - r0) + 1;
}

void BoxFilter::apply(std::span<const float> in, int width, int height, int f,
                      std::span<float> out) {
    checkArgs(in, width, height, f, out);
    const BoxWindow win(f);
    const size_t rowFloats = static_cast<size_t>(width) * 3;
    // The vertical sums live inside the padded row, so the horizontal pass reads them in place;
    // the margins are zeroed here and never written again.
    padded_.assign((static_cast<size_t>(width) + win.r0 + 1 + win.r1) * 3 + 1, 0.0);
    invCols_.resize(static_cast<size_t>(width));
    for (int x = 0; x < width; ++x) invCols_[x] = 1.0 / win.validCount(x, width);

    auto row = [&](int y) { return in.data() + static_cast<size_t>(y) * rowFloats; };
    double* cs = padded_.data() + (win.r0 + 1) * 3;
    const int span = win.r0 + win.r1;

    for (int y = 0; y < height; ++y) {
        const int lo = std::max(0, y - win.r0);
        const int hi = std::min(height - 1, y + win.r1);
        const bool enters = y + win.r1 < height, leaves = y - win.r0 - 1 >= 0;
        if (y % kResumRows == 0) {
            // Fresh sums: the start of the image, and periodically to cap rounding drift.
            std::fill(cs, cs + rowFloats, 0.0);
            for (int yy = lo; yy <= hi; ++yy) accumulateRow(cs, row(yy), rowFloats, true);
        } else if (enters && leaves) {
            slideRow(cs, row(y + win.r1), row(y - win.r0 - 1), rowFloats);
        } else if (enters) {  // near the top: the window only grows
            accumulateRow(cs, row(y + win.r1), rowFloats, true);
        } else if (leaves) {  // near the bottom: the window only shrinks
            accumulateRow(cs, row(y - win.r0 - 1), rowFloats, false);
        }
        horizontalRow(padded_.data(), width, span, 1.0 / (hi - lo + 1), invCols_.data(),
                      out.data() + static_cast<size_t>(y) * rowFloats);
    }
}

void boxFilter(std::span<const float> in, int width, int height, int f, std::span<float> out) {
    BoxFilter filter;
    filter.apply(in, width, height, f, out);
}

void edgeStoppingBox(std::span<const float> in, std::span<const float> box, int width, int height, int f,
                     float ratio, std::span<float> out) {
    checkArgs(in, width, height, f, out);
    RTPM_CHECK(box.size() == in.size());
    if (!(ratio > 0.0f)) {
        std::copy(box.begin(), box.end(), out.begin());
        return;
    }
    const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
    auto luminanceAt = [](const float* px) {
        return 0.2126f * finiteOrZero(px[0]) + 0.7152f * finiteOrZero(px[1]) + 0.0722f * finiteOrZero(px[2]);
    };
    std::vector<float> lum(n);
    for (size_t i = 0; i < n; ++i) lum[i] = luminanceAt(in.data() + 3 * i);
    const BoxWindow win(f);
    for (int y = 0; y < height; ++y) {
        const int y0 = std::max(0, y - win.r0), y1 = std::min(height - 1, y + win.r1);
        for (int x = 0; x < width; ++x) {
            const int x0 = std::max(0, x - win.r0), x1 = std::min(width - 1, x + win.r1);
            const size_t p = static_cast<size_t>(y) * width + x;
            const float lp = lum[p];
            const float floor = kEdgeFloor * luminanceAt(box.data() + 3 * p);
            double sum[3] = {0.0, 0.0, 0.0};
            double weights = 0.0;
            for (int yy = y0; yy <= y1; ++yy) {
                for (int xx = x0; xx <= x1; ++xx) {
                    const size_t q = static_cast<size_t>(yy) * width + xx;
                    const float lq = lum[q];
                    // 1 within half the ratio, 0 from the ratio on, linear between: a value near
                    // either end moves the pixel about as little as it moves itself.
                    const double bound = 0.5 * double(ratio) * std::min(lp, lq) + floor;
                    const double w = q == p ? 1.0 : std::clamp(2.0 - double(std::max(lp, lq)) / bound, 0.0, 1.0);
                    if (!(w > 0.0)) continue;
                    const float* px = in.data() + 3 * q;
                    for (int c = 0; c < 3; ++c) sum[c] += w * finiteOrZero(px[c]);
                    weights += w;
                }
            }
            float* o = out.data() + 3 * p;
            for (int c = 0; c < 3; ++c) o[c] = static_cast<float>(sum[c] / weights);
        }
    }
}

void boxFilterNaive(std::span<const float> in, int width, int height, int f,
                    std::span<float> out) {
    checkArgs(in, width, height, f, out);
    const BoxWindow win(f);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            double sum[3] = {0.0, 0.0, 0.0};
            int count = 0;
            for (int yy = y - win.r0; yy <= y + win.r1; ++yy) {
                for (int xx = x - win.r0; xx <= x + win.r1; ++xx) {
                    if (yy < 0 || yy >= height || xx < 0 || xx >= width) continue;
                    const float* px = in.data() + (static_cast<size_t>(yy) * width + xx) * 3;
                    for (int c = 0; c < 3; ++c) sum[c] += finiteOrZero(px[c]);
                    ++count;
                }
            }
            float* o = out.data() + (static_cast<size_t>(y) * width + x) * 3;
            for (int c = 0; c < 3; ++c) o[c] = static_cast<float>(sum[c] / count);
        }
    }
}

}  // namespace rtpm
