// Box filter: sliding vertical sums over whole rows, running horizontal sums, naive reference.
#include "common/image/box_filter.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "common/core/check.h"

namespace rtpm {
namespace {

// NaN and ±Inf become 0. A bit test (exponent all ones) rather than std::isfinite, written as an
// integer mask so the row loops have no branch and GCC vectorises them; it is the same test for
// the add and the subtract of a row, so what enters a sum is exactly what later leaves it.
inline float finiteOrZeroFloat(float v) {
    const uint32_t bits = std::bit_cast<uint32_t>(v);
    const uint32_t keep = (bits & 0x7f800000u) == 0x7f800000u ? 0u : ~0u;
    return std::bit_cast<float>(bits & keep);
}
inline double finiteOrZero(float v) { return static_cast<double>(finiteOrZeroFloat(v)); }

// Rec. 709 luminance, in float, as the edge test weighs pixels.
inline float luminance(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

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

/// A row of RGB triples split into finite channel planes (NaN and ±Inf to 0) and their
/// luminance; the noise plane's absolute noise σ = rel · l (infinite stays infinite: unknown).
/// Separate loops so each vectorises.
RTPM_ROW_CLONES void splitRow(const float* __restrict px, const float* __restrict rel, int width, float* __restrict r,
                              float* __restrict g, float* __restrict b, float* __restrict l, float* __restrict sd) {
    for (int x = 0; x < width; ++x) {
        r[x] = finiteOrZeroFloat(px[3 * x]);
        g[x] = finiteOrZeroFloat(px[3 * x + 1]);
        b[x] = finiteOrZeroFloat(px[3 * x + 2]);
        l[x] = luminance(r[x], g[x], b[x]);
    }
    if (!rel) {
        std::fill_n(sd, width, 0.0f);
        return;
    }
    for (int x = 0; x < width; ++x) {
        const float n = rel[x];
        sd[x] = n > 0.0f ? (std::isinf(n) ? n : n * l[x]) : 0.0f;
    }
}

/// out[3x + c] = acc_c[x] / w[x] over the row: the weighted averages, interleaved again.
RTPM_ROW_CLONES void divideRow(const float* __restrict accR, const float* __restrict accG,
                               const float* __restrict accB, const float* __restrict accW, int width,
                               float* __restrict out) {
    for (int x = 0; x < width; ++x) {
        const float inverse = 1.0f / accW[x];
        out[3 * x] = accR[x] * inverse;
        out[3 * x + 1] = accG[x] * inverse;
        out[3 * x + 2] = accB[x] * inverse;
    }
}
/// The floors of a row of the box's output: kEdgeFloor × each pixel's luminance.
RTPM_ROW_CLONES void floorRow(const float* __restrict box, int width, float* __restrict floor) {
    for (int x = 0; x < width; ++x)
        floor[x] = kEdgeFloor * luminance(box[3 * x], box[3 * x + 1], box[3 * x + 2]);
}

/// One neighbour offset of the edge-stopping box over a row span: for each x in [x0, x1), the
/// neighbour at x + dx of the window row (luminance `lq`, its noise `sq`, finite channels `rq`,
/// `gq`, `bq`) gets weight clamp(1 + (floor − d) / (excess · min + floor), 0, 1), where min is
/// the lesser luminance of the two and d their difference less kEdgeNoise × their combined noise
/// (0 also where that is not a number: both black), added to the accumulators. Contiguous in x,
/// so it vectorises.
RTPM_ROW_CLONES void addEdgeNeighbours(const float* __restrict lp, const float* __restrict sp,
                                       const float* __restrict floor, const float* __restrict lq,
                                       const float* __restrict sq, const float* __restrict rq,
                                       const float* __restrict gq, const float* __restrict bq, int dx, float excess,
                                       int x0, int x1, float* __restrict accR, float* __restrict accG,
                                       float* __restrict accB, float* __restrict accW) {
    for (int x = x0; x < x1; ++x) {
        const float l = lp[x], m = lq[x + dx], a = sp[x], b = sq[x + dx];
        const float low = std::min(l, m);
        const float d = std::max(0.0f, std::max(l, m) - low - kEdgeNoise * std::sqrt(a * a + b * b));
        const float w0 = 1.0f + (floor[x] - d) / (excess * low + floor[x]);
        const float w = w0 > 1.0f ? 1.0f : (w0 > 0.0f ? w0 : 0.0f);
        accR[x] += w * rq[x + dx];
        accG[x] += w * gq[x + dx];
        accB[x] += w * bq[x + dx];
        accW[x] += w;
    }
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

void edgeStoppingBox(std::span<const float> in, std::span<const float> box, std::span<const float> noise,
                     int width, int height, int f, float ratio, std::span<float> out) {
    checkArgs(in, width, height, f, out);
    RTPM_CHECK(box.size() == in.size());
    RTPM_CHECK(noise.empty() || noise.size() * 3 == in.size());
    if (!(ratio > 0.0f)) {
        std::copy(box.begin(), box.end(), out.begin());
        return;
    }
    // Per row: the pixel itself with weight 1, then every other offset of its window as a
    // contiguous pass over the row (addEdgeNeighbours), so the division and clamps vectorise.
    const BoxWindow win(f);
    const float excess = std::max(ratio, 1.0f) - 1.0f;  // (0, 1) acts as 1: a near step
    // Per worker: the accumulators, a ring of F window rows as planes (luminance, the finite
    // channels, the noise) and the row's floors; kept for the whole image, not per band of rows.
    const int ring = win.r0 + win.r1 + 1;
    struct Scratch {
        std::vector<float> acc, planes, floors;
    };
    tbb::enumerable_thread_specific<Scratch> scratch;
    tbb::parallel_for(tbb::blocked_range<int>(0, height, 8), [&](const tbb::blocked_range<int>& rows) {
        Scratch& mine = scratch.local();
        mine.acc.resize(size_t(width) * 4);
        mine.planes.resize(size_t(width) * 5 * size_t(ring));
        mine.floors.resize(size_t(width));
        std::vector<float>& acc = mine.acc;
        std::vector<float>& planes = mine.planes;
        std::vector<float>& floors = mine.floors;
        auto plane = [&](int yy, int k) { return planes.data() + (size_t(yy % ring) * 5 + size_t(k)) * size_t(width); };
        auto fill = [&](int yy) {
            // Infinite noise (unknown) makes every difference noise: the box's weight.
            splitRow(in.data() + 3 * static_cast<size_t>(yy) * width,
                     noise.empty() ? nullptr : noise.data() + static_cast<size_t>(yy) * width, width, plane(yy, 1),
                     plane(yy, 2), plane(yy, 3), plane(yy, 0), plane(yy, 4));
        };
        int filled = -1;  // the ring holds the rows up to this one
        for (int y = rows.begin(); y < rows.end(); ++y) {
            const int y0 = std::max(0, y - win.r0), y1 = std::min(height - 1, y + win.r1);
            for (int yy = std::max(y0, filled + 1); yy <= y1; ++yy) fill(yy);
            filled = std::max(filled, y1);
            const size_t row = static_cast<size_t>(y) * width;
            const float* lp = plane(y, 0);
            const float* bx = box.data() + 3 * row;
            floorRow(bx, width, floors.data());
            float* accR = acc.data();
            float* accG = accR + width;
            float* accB = accG + width;
            float* accW = accB + width;
            std::copy_n(plane(y, 1), width, accR);
            std::copy_n(plane(y, 2), width, accG);
            std::copy_n(plane(y, 3), width, accB);
            std::fill_n(accW, width, 1.0f);
            for (int yy = y0; yy <= y1; ++yy)
                for (int dx = -win.r0; dx <= win.r1; ++dx) {
                    if (yy == y && dx == 0) continue;
                    // x with x + dx inside the row.
                    const int x0 = std::max(0, -dx), x1 = std::min(width, width - dx);
                    addEdgeNeighbours(lp, plane(y, 4), floors.data(), plane(yy, 0), plane(yy, 4), plane(yy, 1),
                                      plane(yy, 2), plane(yy, 3), dx, excess, x0, x1, accR, accG, accB, accW);
                }
            float* o = out.data() + 3 * row;
            divideRow(accR, accG, accB, accW, width, o);
        }
    });
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
