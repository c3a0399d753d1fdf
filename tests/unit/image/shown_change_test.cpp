// ShownChange: which frames it keeps, what it compares them with, and when it restarts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
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

double changeBetween(uint64_t n, uint64_t base) {
    const std::vector<float> a = frame(n), b = frame(base);
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

// The figure at frame n against baseline m: their change scaled as nested Poisson noise.
double figureBetween(uint64_t n, double work, uint64_t base, double baseWork) {
    return changeBetween(n, base) / std::sqrt(work / baseWork - 1.0);
}

// The figures of successive comparisons as ShownChange gives them: each one's scaled change, but
// no less than the last figure × √(its work / this work).
struct Floored {
    double figure = 0.0, work = 0.0;
    double next(double change, double atWork) {
        figure = figure > 0.0 ? std::max(change, figure * std::sqrt(work / atWork)) : change;
        work = atWork;
        return figure;
    }
};

TEST(ShownChange, ComparesAKeptFrameWithItsBaselineAndHoldsTheFigureBetween) {
    ShownChange change(1);  // every kept frame a baseline
    EXPECT_EQ(change.add(false, 1, double(1), frame(1), kW, kH), 0.0) << "a first frame has no baseline";
    // One batch a frame: frame n's baseline is the oldest image still held with at least
    // 2^-1/4 · n/6 and at most n/3 batches; below half of the last frame's work only the frames
    // b·2^k with b ∈ {1, 3} stay (frame 5 goes at frame 12, 7 at 20, 10 at 24, 14 at 32).
    // Frame 2 has none (frame 1 holds half its work): no figure yet.
    EXPECT_EQ(change.add(true, 1, double(2), frame(2), kW, kH), 0.0) << "no baseline of a third";
    const std::vector<std::pair<uint64_t, uint64_t>> baseOf{{3, 1},  {4, 1},  {5, 1},  {6, 1},  {7, 1},
                                                            {8, 2},  {10, 2}, {12, 2}, {14, 2}, {16, 3}, {20, 3},
                                                            {24, 4}, {28, 4}, {32, 6}, {40, 6}};
    size_t next = 0;
    Floored expected;
    size_t mostImages = 0;
    for (uint64_t n = 3; n <= 40; ++n) {
        const double figure = change.add(true, 1, double(n), frame(n), kW, kH);
        EXPECT_EQ(change.frame(), n);
        mostImages = std::max(mostImages, change.keptImages());
        if (next < baseOf.size() && baseOf[next].first == n) {
            const uint64_t base = baseOf[next++].second;
            expected.next(figureBetween(n, double(n), base, double(base)), double(n));
        }
        ASSERT_GT(expected.figure, 0.0);
        EXPECT_DOUBLE_EQ(figure, expected.figure) << "frame " << n;
    }
    EXPECT_EQ(next, baseOf.size());
    EXPECT_LE(mostImages, 10u) << "the images held stay about two doublings' worth";
}

TEST(ShownChange, ANewProgressionStartsAgain) {
    ShownChange change(1);  // every kept frame a baseline
    change.add(false, 1, double(1), frame(1), kW, kH);
    change.add(true, 1, double(2), frame(2), kW, kH);
    change.add(true, 1, double(3), frame(3), kW, kH);
    EXPECT_GT(change.figure(), 0.0);
    // A moving frame: the next still frame is a progression's first again, with no figure.
    EXPECT_EQ(change.add(false, 1, double(1), frame(1), kW, kH), 0.0);
    EXPECT_EQ(change.frame(), 1u);
    EXPECT_EQ(change.add(true, 1, double(2), frame(2), kW, kH), 0.0);
    EXPECT_DOUBLE_EQ(change.add(true, 1, double(3), frame(3), kW, kH), figureBetween(3, 3.0, 1, 1.0));
}

TEST(ShownChange, WaitsUntilEverySetTookATurnSinceTheBaseline) {
    // Sets take turns of 4 frames: frame n is compared with a baseline only once 4 frames lie
    // between, else a set that has not shot since would show no change.
    ShownChange change(1);  // every kept frame a baseline
    Floored expected;
    change.add(false, 4, double(1), frame(1), kW, kH);
    for (uint64_t n = 2; n <= 4; ++n) EXPECT_EQ(change.add(true, 4, double(n), frame(n), kW, kH), 0.0) << "frame " << n;
    for (uint64_t n = 5; n <= 7; ++n)
        EXPECT_DOUBLE_EQ(change.add(true, 4, double(n), frame(n), kW, kH),
                         expected.next(figureBetween(n, double(n), 1, 1.0), double(n)))
            << "frame " << n;
    // Frame 8: frame 1 holds less than 2^-1/4 · 8/6 batches, frame 2 is the oldest baseline left.
    EXPECT_DOUBLE_EQ(change.add(true, 4, double(8), frame(8), kW, kH), expected.next(figureBetween(8, 8.0, 2, 2.0), 8.0));
}

// Where photons grow more slowly than frames (the sets take turns; a restart from a map of many
// batches), the baseline is chosen by photons, not frames.
TEST(ShownChange, TheBaselineIsAShareOfThePhotonsNotOfTheFrames) {
    ShownChange change(1);  // every kept frame a baseline
    auto work = [](uint64_t n) { return 8.0 + double(n); };  // 8 batches at the restart, one a frame
    change.add(false, 1, work(1), frame(1), kW, kH);
    for (uint64_t n = 2; n <= 19; ++n)
        EXPECT_EQ(change.add(true, 1, work(n), frame(n), kW, kH), 0.0) << "frame " << n << ": no image of a third of its work";
    // Frame 20 holds 28 batches: frame 1's 9 are less than a third (frame 7's 15 would be a
    // third of the frames).
    EXPECT_DOUBLE_EQ(change.add(true, 1, work(20), frame(20), kW, kH), figureBetween(20, 28.0, 1, 9.0));
    // Every kept frame to 24 takes frame 1 (9 batches: more than a sixth of 32, the most work by
    // frame 24; frame 4 would be a sixth of the frames).
    Floored expected{figureBetween(20, 28.0, 1, 9.0), 28.0};
    for (uint64_t n = 21; n <= 24; ++n) {
        change.add(true, 1, work(n), frame(n), kW, kH);
        if (ShownChange::kept(n)) expected.next(figureBetween(n, work(n), 1, 9.0), work(n));
    }
    EXPECT_DOUBLE_EQ(change.figure(), expected.figure);
    // A frame whose work is not known (a set missing) is counted, not kept or compared.
    EXPECT_DOUBLE_EQ(change.add(true, 1, 0.0, frame(1), kW, kH), expected.figure);
    EXPECT_EQ(change.frame(), 25u);
}

// The change since a baseline misses what both images share: where the image stops changing, the
// figure falls from the last one no faster than photon noise does, as √(its work / work).
TEST(ShownChange, TheFigureFallsNoFasterThanPhotonNoise) {
    ShownChange change(1);  // every kept frame a baseline
    change.add(false, 1, 1.0, frame(1), kW, kH);
    change.add(true, 1, 2.0, frame(2), kW, kH);
    const double first = change.add(true, 1, 3.0, frame(3), kW, kH);
    EXPECT_DOUBLE_EQ(first, changeBetween(3, 1) / std::sqrt(2.0));
    // Frame 4 shows frame 3's image: its change since frame 1 over √3 is less than the floor.
    const double fourth = change.add(true, 1, 4.0, frame(3), kW, kH);
    EXPECT_LT(changeBetween(3, 1) / std::sqrt(3.0), fourth);
    EXPECT_DOUBLE_EQ(fourth, first * std::sqrt(3.0 / 4.0));
    // A frame that changed more than the floor says reads its own change.
    const std::vector<float> far = image(3.0f);
    const double fifth = change.add(true, 1, 5.0, far, kW, kH);
    EXPECT_DOUBLE_EQ(fifth, compareRgb(far, frame(1), far, kW, kH).caustic.relMae / std::sqrt(4.0));
    EXPECT_GT(fifth, fourth * std::sqrt(4.0 / 5.0));
}

// A progression whose only error is nested noise, as Poisson's: the image of N batches is the
// truth plus the mean of N independent noise fields, the first M of them shared with the image
// of M batches. Their change is then √(N/M − 1) × the noise at N, and the figure, the change over
// that factor, reads the true error whichever baseline it took (a figure without the factor would
// read √5 ≈ 2.2 × at a sixth).
TEST(ShownChange, NestedNoiseReadsItsOwnErrorWhateverTheBaseline) {
    constexpr int w = 96, h = 64;
    std::vector<float> truth(size_t(w) * h * 3, 0.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double r2 = (x - 48.0) * (x - 48.0) + (y - 32.0) * (y - 32.0);
            for (int c = 0; c < 3; ++c) truth[3 * (size_t(y) * w + x) + c] = float(1.0 + 4.0 * std::exp(-r2 / 300.0));
        }
    std::mt19937 rng(7);
    std::normal_distribution<double> unit(0.0, 1.0);
    std::vector<double> sum(truth.size(), 0.0);
    ShownChange change(1);  // every kept frame a baseline
    for (int n = 1; n <= 64; ++n) {
        for (size_t i = 0; i < sum.size(); ++i) sum[i] += 0.5 * double(truth[i]) * unit(rng);
        std::vector<float> img(truth.size());
        for (size_t i = 0; i < img.size(); ++i) img[i] = truth[i] + float(sum[i] / double(n));
        const double figure = change.add(n > 1, 1, double(n), img, w, h);
        if (n < 4 || !ShownChange::kept(uint64_t(n))) continue;
        const double truthError = compareRgb(img, truth, img, w, h).caustic.relMae;
        EXPECT_NEAR(figure / truthError, 1.0, 0.1) << "frame " << n << ": figure " << figure << ", true " << truthError;
    }
}

// As rtpm-render and the master count (kFirstBaseline): the first two frames, which lack the other
// sets' shared photons, are no baseline, so with one batch a frame the first figure compares
// frame 10 with frame 3.
TEST(ShownChange, TheFirstFramesAreNoBaseline) {
    ShownChange change;
    change.add(false, 1, 1.0, frame(1), kW, kH);
    for (uint64_t n = 2; n <= 9; ++n)
        EXPECT_EQ(change.add(true, 1, double(n), frame(n), kW, kH), 0.0) << "frame " << n;
    EXPECT_DOUBLE_EQ(change.add(true, 1, 10.0, frame(10), kW, kH), figureBetween(10, 10.0, 3, 3.0));
}

TEST(ShownChange, AnotherImageSizeStartsAgain) {
    ShownChange change(1);  // every kept frame a baseline
    change.add(false, 1, double(1), frame(1), kW, kH);
    change.add(true, 1, double(2), frame(2), kW, kH);
    const std::vector<float> other(size_t(kW) * 2 * kH * 3, 1.0f);
    EXPECT_EQ(change.add(true, 1, 2.0, other, kW * 2, kH), 0.0);
    EXPECT_EQ(change.frame(), 1u);
}

TEST(ShownChange, NoCausticNoFigure) {
    ShownChange change(1);  // every kept frame a baseline
    const std::vector<float> dark(size_t(kW) * kH * 3, 0.0f);
    change.add(false, 1, 1.0, dark, kW, kH);
    EXPECT_EQ(change.add(true, 1, 2.0, dark, kW, kH), 0.0);
}

TEST(ShownChange, TheFigureShownIsTheChangeWhereTheEstimatorComposedAndAChangeIsKnown) {
    EXPECT_EQ(shownErrorFigure(0.05, 0.03), kShownChangeScale * 0.03);
    EXPECT_EQ(shownErrorFigure(0.05, 0.0), 0.0) << "no change known yet: no figure";
    EXPECT_EQ(shownErrorFigure(0.0, 0.03), 0.0) << "knn or a moving frame: none";
}

}  // namespace
}  // namespace rtpm
