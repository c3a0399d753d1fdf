// The progressive estimator's parts on their own: the disc rule (ProgressiveSet::choose) on
// rings of known photon densities, and the still view's pass budget.
#include <cmath>

#include <gtest/gtest.h>

#include "common/render/pass_budget.h"
#include "common/render/progressive.h"

namespace rtpm {
namespace {

// Rings holding the photons of a radial density ρ(r) (photons per unit area, each of power 1)
// around the query: ring j is the annulus between discs j+1 and j (the innermost ring the whole
// innermost disc), outer disc of squared radius 1.
template <class Density>
ProgressiveSet::Rings ringsOf(Density rho) {
    ProgressiveSet::Rings rings;
    for (int j = 0; j < kRadiusBins; ++j) {
        const double outer2 = std::pow(kBinRatio2, double(j));
        const double inner2 = j + 1 < kRadiusBins ? std::pow(kBinRatio2, double(j + 1)) : 0.0;
        // Midpoint rule over r² (the annulus area is π Δr²).
        double n = 0.0;
        const int steps = 64;
        for (int s = 0; s < steps; ++s) {
            const double r2 = inner2 + (outer2 - inner2) * (s + 0.5) / steps;
            n += rho(std::sqrt(r2)) * 3.141592653589793 * (outer2 - inner2) / steps;
        }
        n = std::round(n);
        rings.count[j] = float(n);
        for (int c = 0; c < 3; ++c) rings.power[3 * j + c] = float(n);
    }
    return rings;
}

const double kScales[2] = {1.0, 1.0};

TEST(ProgressiveChoose, AFlatDensityTakesTheWidestDisc) {
    const auto rings = ringsOf([](double) { return 4000.0; });
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, kScales, 1e30, c);
    EXPECT_EQ(c[0].disc, 0) << "nothing varies: the widest disc has the least noise";
}

TEST(ProgressiveChoose, AStepStopsTheDiscBeforeItReachesTheStep) {
    // Bright inside r < 0.3, dark outside: a disc reaching past 0.3 averages in the dark side.
    const auto rings = ringsOf([](double r) { return r < 0.3 ? 20000.0 : 0.0; });
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, kScales, 1e30, c);
    const double radius = std::sqrt(std::pow(kBinRatio2, double(c[0].disc)));
    EXPECT_LE(radius, 0.3 / std::sqrt(kBinRatio2) + 1e-9) << "disc " << c[0].disc;
    EXPECT_GT(radius, 0.3 * kBinRatio2) << "but as wide as the step allows";
}

TEST(ProgressiveChoose, AWiderNoiseScaleNeverTakesANarrowerDisc) {
    // Choice 1 with the full noise (a pixel's own set), choice 0 with a ninth of the variance (the
    // box filter's average): less noise allowed means a disc at most as wide.
    const auto rings = ringsOf([](double r) { return 2000.0 * (1.0 + 4.0 * r * r); });
    const double scales[2] = {1.0 / 3.0, 1.0};
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, scales, 1e30, c);
    EXPECT_GE(c[0].disc, c[1].disc);
}

TEST(ProgressiveChoose, InactiveRingsAreNeverChosen) {
    const auto rings = ringsOf([](double) { return 4000.0; });
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 5, 2.0, kScales, 1e30, c);
    EXPECT_GE(c[0].disc, 5);
}

TEST(ProgressiveChoose, NoDiscHoldsMoreThanTheCap) {
    // A flat density takes the widest disc (above); with a cap the widest disc holding at most
    // that many photons is shown, whatever the rule would allow.
    const auto rings = ringsOf([](double) { return 4000.0; });
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, kScales, 500.0, c);
    for (const auto& choice : c) {
        EXPECT_LE(choice.count, 500.0);
        // The next wider disc would hold more than the cap.
        ASSERT_GT(choice.disc, 0);
        double wider = 0.0;
        for (int j = choice.disc - 1; j < kRadiusBins; ++j) wider += rings.count[j];
        EXPECT_GT(wider, 500.0) << "disc " << choice.disc;
    }
}

TEST(ProgressiveChoose, TheCapCountsPhotonsNotPasses) {
    // k at one default batch, growing as the square root of the paths traced: the same paths give
    // the same cap however they were batched, and the shown disc still shrinks (N / cap grows).
    EXPECT_DOUBLE_EQ(maxDiscPhotons(64, kDiscCapPaths), 64.0);
    EXPECT_DOUBLE_EQ(maxDiscPhotons(64, 100 * kDiscCapPaths), 640.0);
    EXPECT_DOUBLE_EQ(maxDiscPhotons(64, 1.0), 64.0) << "never below k";
    EXPECT_GT(maxDiscPhotons(64, 4e8) / 4e8, 0.0);
    EXPECT_LT(maxDiscPhotons(64, 4e8) / 4e8, maxDiscPhotons(64, 4e6) / 4e6);
}

TEST(PassBudget, GrowsWhileStillAndFastAndResetsOnMotion) {
    PassBudget b(0.2);
    EXPECT_EQ(b.batches(), 1u);
    b.record(true, 0.05);
    EXPECT_EQ(b.batches(), 2u);
    b.record(true, 0.05);
    EXPECT_EQ(b.batches(), 4u);
    b.record(true, 0.15);  // within the budget but above half: holds
    EXPECT_EQ(b.batches(), 4u);
    b.record(true, 0.3);  // over the budget: halves
    EXPECT_EQ(b.batches(), 2u);
    b.record(false, 0.01);  // the view moved
    EXPECT_EQ(b.batches(), 1u);
    for (int i = 0; i < 40; ++i) b.record(true, 0.0);
    EXPECT_EQ(b.batches(), kMaxPassBatches);
}

TEST(PassBudget, ZeroBudgetKeepsOneBatch) {
    PassBudget b(0.0);
    for (int i = 0; i < 10; ++i) b.record(true, 0.0);
    EXPECT_EQ(b.batches(), 1u);
}

}  // namespace
}  // namespace rtpm
