// ShownChange: which frames it keeps, what it compares them with, and when it restarts.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "common/image/error_metrics.h"
#include "common/image/shown_change.h"

namespace rtpm {
namespace {

constexpr int kW = 8, kH = 6;

// A caustic image whose bright half is `bright` and dark half 0.1: the region is the bright half.
std::vector<float> image(float bright) {
    std::vector<float> v(size_t(kW) * kH * 3, 0.1f);
    for (size_t p = 0; p < v.size() / 6; ++p)
        for (int c = 0; c < 3; ++c) v[3 * p + size_t(c)] = bright;
    return v;
}

// The image at frame n: its brightness falls as 1 + 1/n, so each frame differs from every other.
std::vector<float> frame(uint64_t n) { return image(float(1.0 + 1.0 / double(n))); }

double changeBetween(uint64_t n, uint64_t half) {
    const std::vector<float> a = frame(n), b = frame(half);
    return compareRgb(a, b, a, kW, kH).caustic.relMae;
}

TEST(ShownChange, KeepsFourFramesPerDoubling) {
    std::vector<uint64_t> kept;
    for (uint64_t n = 1; n <= 64; ++n)
        if (ShownChange::kept(n)) kept.push_back(n);
    const std::vector<uint64_t> expected{1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 20, 24, 28, 32, 40, 48, 56, 64};
    EXPECT_EQ(kept, expected);
    EXPECT_FALSE(ShownChange::kept(0));
}

TEST(ShownChange, ComparesAKeptFrameWithItsHalfAndHoldsTheFigureBetween) {
    ShownChange change;
    EXPECT_EQ(change.add(false, 1, frame(1), kW, kH), 0.0) << "a first frame has no half";
    for (uint64_t n = 2; n <= 40; ++n) {
        const double figure = change.add(true, 1, frame(n), kW, kH);
        EXPECT_EQ(change.frame(), n);
        uint64_t last = n;  // the last kept even frame up to n
        while (!(ShownChange::kept(last) && last % 2 == 0)) --last;
        EXPECT_DOUBLE_EQ(figure, changeBetween(last, last / 2)) << "frame " << n;
        EXPECT_GT(figure, 0.0);
    }
}

TEST(ShownChange, ANewProgressionStartsAgain) {
    ShownChange change;
    change.add(false, 1, frame(1), kW, kH);
    change.add(true, 1, frame(2), kW, kH);
    EXPECT_GT(change.figure(), 0.0);
    // A moving frame: the next still frame is a progression's first again, with no figure.
    EXPECT_EQ(change.add(false, 1, frame(1), kW, kH), 0.0);
    EXPECT_EQ(change.frame(), 1u);
    EXPECT_DOUBLE_EQ(change.add(true, 1, frame(2), kW, kH), changeBetween(2, 1));
}

TEST(ShownChange, WaitsUntilEverySetTookATurnSinceTheHalf) {
    // Sets take turns of 4 frames: frame n is compared with n/2 only once n/2 ≥ 4 frames lie
    // between, else a set that has not shot since would show no change.
    ShownChange change;
    change.add(false, 4, frame(1), kW, kH);
    for (uint64_t n = 2; n <= 7; ++n) EXPECT_EQ(change.add(true, 4, frame(n), kW, kH), 0.0) << "frame " << n;
    EXPECT_DOUBLE_EQ(change.add(true, 4, frame(8), kW, kH), changeBetween(8, 4));
}

TEST(ShownChange, AnotherImageSizeStartsAgain) {
    ShownChange change;
    change.add(false, 1, frame(1), kW, kH);
    change.add(true, 1, frame(2), kW, kH);
    const std::vector<float> other(size_t(kW) * 2 * kH * 3, 1.0f);
    EXPECT_EQ(change.add(true, 1, other, kW * 2, kH), 0.0);
    EXPECT_EQ(change.frame(), 1u);
}

TEST(ShownChange, NoCausticNoFigure) {
    ShownChange change;
    const std::vector<float> dark(size_t(kW) * kH * 3, 0.0f);
    change.add(false, 1, dark, kW, kH);
    EXPECT_EQ(change.add(true, 1, dark, kW, kH), 0.0);
}

TEST(ShownChange, TheFigureShownIsTheChangeWhereTheEstimatorComposedAndAChangeIsKnown) {
    EXPECT_EQ(shownErrorFigure(0.05, 0.03), 0.03);
    EXPECT_EQ(shownErrorFigure(0.05, 0.0), 0.05) << "no change known yet: the estimator's own figure";
    EXPECT_EQ(shownErrorFigure(0.0, 0.03), 0.0) << "knn or a moving frame: none";
}

}  // namespace
}  // namespace rtpm
