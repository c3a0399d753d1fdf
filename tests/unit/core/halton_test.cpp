// Tests of the radical inverse, the Halton box (periodicity) property SPT relies on, the per-set
// rotation, the hashed random numbers and the SPT grid bookkeeping.
#include "common/core/halton.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "common/photon/spt_grid.h"

namespace rtpm {
namespace {

// Elementary interval of x at width 1/cells; the tiny nudge absorbs the rounding of values that
// are exact multiples of 1/cells (e.g. Φ_3(3) = 1/9 in double times 9).
int box(double x, int cells) { return static_cast<int>(std::floor(x * cells + 1e-9)); }

TEST(Halton, Base2MatchesKnownValues) {
    const double expected[] = {0.0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875, 0.0625, 0.5625};
    for (uint64_t i = 0; i < 10; ++i) {
        EXPECT_EQ(radicalInverse(0, i), expected[i]) << "i = " << i;
        EXPECT_EQ(radicalInverseBase2(i), expected[i]) << "i = " << i;
    }
    EXPECT_DOUBLE_EQ(radicalInverse(0, 13), 0.6875);  // 1101₂ → 0.1011₂
}

TEST(Halton, Base3MatchesKnownValues) {
    const double expected[] = {0.0,       1.0 / 3.0, 2.0 / 3.0, 1.0 / 9.0, 4.0 / 9.0,
                               7.0 / 9.0, 2.0 / 9.0, 5.0 / 9.0, 8.0 / 9.0, 1.0 / 27.0};
    for (uint64_t i = 0; i < 10; ++i)
        EXPECT_NEAR(radicalInverse(1, i), expected[i], 1e-15) << "i = " << i;
    EXPECT_NEAR(radicalInverse(1, 13), 13.0 / 27.0, 1e-15);  // 111₃ → 0.111₃
}

TEST(Halton, Base5MatchesDigitMirror) {
    // 1234 = 14414₅ → 0.41441₅
    const double expected = (4.0 + 1.0 / 5 + 4.0 / 25 + 4.0 / 125 + 1.0 / 625) / 5.0;
    EXPECT_NEAR(radicalInverse(2, 1234), expected, 1e-15);
}

TEST(Halton, StaysBelowOneForHugeIndices) {
    for (int d = 0; d < kHaltonMaxDims; ++d) {
        for (uint64_t i : {~uint64_t{0}, ~uint64_t{0} - 1, uint64_t{1} << 63, uint64_t{123456789012345}}) {
            const double r = radicalInverse(d, i);
            EXPECT_GE(r, 0.0);
            EXPECT_LT(r, 1.0);
        }
    }
    const Halton h(1, 2);
    for (int d = 0; d < kHaltonMaxDims; ++d) {
        const float s = h.sample(d, ~uint64_t{0});
        EXPECT_GE(s, 0.0f);
        EXPECT_LT(s, 1.0f);
    }
}

TEST(Halton, IndicesOnePeriodApartShareTheElementaryBox) {
    // i and i + j·2^a·3^b lie in the same 2^-a × 3^-b box (docs/ARCHITECTURE.md §5.2).
    const uint64_t period = 8 * 9;
    for (uint64_t i = 0; i < period; ++i) {
        const auto boxX = box(radicalInverse(0, i), 8);
        const auto boxY = box(radicalInverse(1, i), 9);
        for (uint64_t j = 1; j < 40; ++j) {
            const uint64_t k = i + j * period;
            EXPECT_EQ(box(radicalInverse(0, k), 8), boxX);
            EXPECT_EQ(box(radicalInverse(1, k), 9), boxY);
        }
    }
}

TEST(Halton, OnePeriodOfPilotsCoversEveryBoxOnce) {
    std::set<std::pair<int, int>> boxes;
    for (uint64_t i = 0; i < 72; ++i)
        boxes.insert({box(radicalInverse(0, i), 8), box(radicalInverse(1, i), 9)});
    EXPECT_EQ(boxes.size(), 72u);
}

TEST(Halton, RotationDiffersPerSetAndKeepsBoxes) {
    const Halton h0(7, hashKeys(0, 0));
    const Halton h1(7, hashKeys(1, 0));
    int sameRotation = 0;
    for (int d = 0; d < kHaltonMaxDims; ++d) {
        if (std::abs(h0.rotation(d) - h1.rotation(d)) < 1e-6) ++sameRotation;
        EXPECT_GE(h0.rotation(d), 0.0);
        EXPECT_LT(h0.rotation(d), 1.0);
    }
    EXPECT_EQ(sameRotation, 0);
    EXPECT_NE(h0.sample(0, 5), h1.sample(0, 5));
    // The rotated points of one period-class still share a (shifted, wrapped) box: their rotated
    // coordinates differ from the pilot's by less than the box width on the torus.
    for (uint64_t i = 0; i < 72; ++i) {
        for (uint64_t j = 1; j < 10; ++j) {
            const uint64_t k = i + j * 72;
            for (int d = 0; d < 2; ++d) {
                const double width = d == 0 ? 1.0 / 8 : 1.0 / 9;
                double diff = std::abs(static_cast<double>(h1.sample(d, i)) - h1.sample(d, k));
                diff = std::min(diff, 1.0 - diff);
                EXPECT_LT(diff, width + 1e-6);
            }
        }
    }
    // Same seed and stream: identical sequence.
    const Halton again(7, hashKeys(1, 0));
    EXPECT_EQ(again.sample(3, 999), h1.sample(3, 999));
}

TEST(Halton, HashedNumbersAreUniformAndKeyed) {
    double sum = 0.0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) sum += hashToUnit(hashKeys(1, 2, static_cast<uint64_t>(i), 3, 4));
    // Mean of n uniforms has standard deviation 1/sqrt(12 n) ≈ 9e-4; 5σ bound.
    EXPECT_NEAR(sum / n, 0.5, 5.0 / std::sqrt(12.0 * n));
    EXPECT_NE(hashKeys(1, 2, 3), hashKeys(2, 1, 3));
    EXPECT_NE(hashKeys(1, 2, 3, 4, 5), hashKeys(1, 2, 3, 4, 6));
}

TEST(SptGrid, CellCountIsProductOfBasePowersBelowTarget) {
    const SptGrid g = makeSptGrid(2, 5000);
    EXPECT_LE(g.cellCount, 5000u);
    EXPECT_EQ(g.cellCount, g.cells[0] * g.cells[1]);
    EXPECT_EQ(g.cells[0], uint64_t{1} << g.digits[0]);
    EXPECT_GE(g.digits[0], 1u);
    EXPECT_GE(g.digits[1], 1u);
    // Balanced: box sides within a factor of the larger base.
    const double w0 = 1.0 / g.cells[0], w1 = 1.0 / g.cells[1];
    EXPECT_LT(std::max(w0, w1) / std::min(w0, w1), 3.0 + 1e-9);
    const SptGrid g6 = makeSptGrid(6, 40000);
    EXPECT_EQ(g6.cellCount, 2u * 3 * 5 * 7 * 11 * 13);
}

TEST(SptGrid, BoxCoordinateMatchesRadicalInverse) {
    const SptGrid g = makeSptGrid(3, 3000);
    for (uint64_t i = 0; i < 5000; i += 7) {
        for (int d = 0; d < 3; ++d) {
            const auto expected = static_cast<uint64_t>(box(radicalInverse(d, i), static_cast<int>(g.cells[static_cast<size_t>(d)])));
            EXPECT_EQ(sptBoxCoordinate(g, d, i), expected) << "i=" << i << " d=" << d;
        }
    }
}

TEST(SptGrid, NeighboursDifferByOneBoxInOneDim) {
    const SptGrid g = makeSptGrid(3, 2000);
    const std::vector<uint32_t> nb = sptNeighbours(g);
    ASSERT_EQ(nb.size(), g.cellCount * 6);
    for (uint64_t i = 0; i < g.cellCount; ++i) {
        for (int d = 0; d < 3; ++d) {
            for (int s = 0; s < 2; ++s) {
                const uint32_t j = nb[(i * 3 + static_cast<uint64_t>(d)) * 2 + static_cast<uint64_t>(s)];
                ASSERT_LT(j, g.cellCount);
                for (int e = 0; e < 3; ++e) {
                    const uint64_t m = g.cells[static_cast<size_t>(e)];
                    const uint64_t ci = sptBoxCoordinate(g, e, i), cj = sptBoxCoordinate(g, e, j);
                    if (e != d) {
                        EXPECT_EQ(ci, cj);
                    } else {
                        EXPECT_EQ(cj, s == 0 ? (ci + m - 1) % m : (ci + 1) % m);
                    }
                }
            }
        }
    }
}

}  // namespace
}  // namespace rtpm
