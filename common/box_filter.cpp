// Box filter: sliding vertical sums over whole rows, running horizontal sums, naive reference.
#include "common/box_filter.h"

#include <algorithm>
#include <bit>
#include <cstdint>

#include "common/check.h"

namespace rtpm {
namespace {

// NaN and ±Inf become 0. A bit test (exponent all ones) rather than std::isfinite so the row
// loops stay branch-free and vectorise; it is the same test for the add and the subtract of a
// row, so what enters a sum is exactly what later leaves it.
inline double finiteOrZero(float v) {
    return (std::bit_cast<uint32_t>(v) & 0x7f800000u) == 0x7f800000u ? 0.0 : static_cast<double>(v);
}

void checkArgs(std::span<const float> in, int width, int height, int f, std::span<float> out) {
    RTPM_CHECK(width >= 1 && height >= 1 && f >= 1);
    const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height) * 3;
    RTPM_CHECK(in.size() == n && out.size() == n);
    RTPM_CHECK(in.data() + n <= out.data() || out.data() + n <= in.data());
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
    colSum_.resize(rowFloats);
    padded_.assign((static_cast<size_t>(width) + win.r0 + 1 + win.r1) * 3, 0.0);
    invCols_.resize(static_cast<size_t>(width));
    for (int x = 0; x < width; ++x) invCols_[x] = 1.0 / win.validCount(x, width);

    auto row = [&](int y) { return in.data() + static_cast<size_t>(y) * rowFloats; };
    double* cs = colSum_.data();

    for (int y = 0; y < height; ++y) {
        const int lo = std::max(0, y - win.r0);
        const int hi = std::min(height - 1, y + win.r1);
        if (y % kResumRows == 0) {
            // Fresh sums: the start of the image, and periodically to cap rounding drift.
            std::fill(colSum_.begin(), colSum_.end(), 0.0);
            for (int yy = lo; yy <= hi; ++yy) {
                const float* r = row(yy);
                for (size_t i = 0; i < rowFloats; ++i) cs[i] += finiteOrZero(r[i]);
            }
        } else {
            // Slide down one row: the row y + r1 enters (if it exists), y − r0 − 1 leaves.
            if (y + win.r1 < height) {
                const float* r = row(y + win.r1);
                for (size_t i = 0; i < rowFloats; ++i) cs[i] += finiteOrZero(r[i]);
            }
            if (y - win.r0 - 1 >= 0) {
                const float* r = row(y - win.r0 - 1);
                for (size_t i = 0; i < rowFloats; ++i) cs[i] -= finiteOrZero(r[i]);
            }
        }

        // Horizontal pass over the column sums, zero-padded by r0 + 1 pixels on the left and r1
        // on the right so the running sum needs no border branches: at x it holds padded pixels
        // [x + 1, x + r0 + r1 + 1], i.e. image columns [x − r0, x + r1].
        std::copy(colSum_.begin(), colSum_.end(), padded_.begin() + (win.r0 + 1) * 3);
        const double* p = padded_.data();
        double s0 = 0.0, s1 = 0.0, s2 = 0.0;
        for (int k = 1; k <= win.r0 + win.r1; ++k) {  // window of x = −1, minus its entering pixel
            s0 += p[3 * k];
            s1 += p[3 * k + 1];
            s2 += p[3 * k + 2];
        }
        const double invRows = 1.0 / (hi - lo + 1);
        float* o = out.data() + static_cast<size_t>(y) * rowFloats;
        const int span = win.r0 + win.r1;
        for (int x = 0; x < width; ++x) {
            const double* enter = p + 3 * (x + 1 + span);
            const double* leave = p + 3 * x;
            s0 += enter[0] - leave[0];
            s1 += enter[1] - leave[1];
            s2 += enter[2] - leave[2];
            const double inv = invRows * invCols_[x];
            o[3 * x] = static_cast<float>(s0 * inv);
            o[3 * x + 1] = static_cast<float>(s1 * inv);
            o[3 * x + 2] = static_cast<float>(s2 * inv);
        }
    }
}

void boxFilter(std::span<const float> in, int width, int height, int f, std::span<float> out) {
    BoxFilter filter;
    filter.apply(in, width, height, f, out);
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
