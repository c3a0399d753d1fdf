// The progressive estimator's parts on their own: the disc rule (ProgressiveSet::choose) on
// rings of known photon densities, and the still view's pass budget.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "common/render/pass_budget.h"
#include "common/photon/density.h"
#include "common/photon/kd_tree.h"
#include "common/photon/shared_photons.h"
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
        rings.power2[j] = float(n);  // luminance 1 each
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

// An SPT pilot that hit outside the refined boxes carries up to 1 + R times a refined path's
// power: one such photon near the query among many light ones is noise, not a bright spot. The
// rule weighs the photons by their power ((Σw)²/Σw² equal ones), so it widens the disc over it as
// over a flat density (before: 30 photons counted as 30, and the disc stopped around the heavy
// one, which showed as a blotch the size of a disc in GLASS's shadow).
TEST(ProgressiveChoose, OneHeavyPhotonDoesNotPassForManyLightOnes) {
    auto rings = ringsOf([](double) { return 4000.0; });
    const int j = 10;  // a small inner disc: about 4000 π 0.57^10 ≈ 50 photons inside disc 10
    const float heavy = 60.0f;
    rings.count[j] += 1.0f;
    rings.power2[j] += heavy * heavy;
    for (int c = 0; c < 3; ++c) rings.power[3 * j + c] += heavy;
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, kScales, 1e30, c);
    EXPECT_LE(c[0].disc, 2) << "the heavy photon's noise spread over a wide disc";
    EXPECT_LT(c[0].effective, 0.8 * c[0].count) << "and its noise counted there";
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
    // A flat density takes the widest disc (above); with a cap the disc holding that many photons
    // is shown, whatever the rule would allow: it lies within the ring the cap falls in.
    const auto rings = ringsOf([](double) { return 4000.0; });
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, kScales, 500.0, c);
    for (const auto& choice : c) {
        EXPECT_LE(choice.count, 500.0);
        // The next wider whole disc would hold more than the cap.
        ASSERT_GT(choice.disc, 0);
        double wider = 0.0;
        for (int j = choice.disc - 1; j < kRadiusBins; ++j) wider += rings.count[j];
        EXPECT_GT(wider, 500.0) << "disc " << choice.disc;
    }
}

// The update of a pass: each photon lands in the ring between the two discs around its distance,
// the rings' sums grow pass by pass, and rings no longer kept (inside `active`) take nothing.
TEST(ProgressiveBin, APhotonLandsInTheRingAroundItsDistanceAndPassesAddUp) {
    const float outer2 = 4.0f;  // r₀ = 2
    auto r2 = [&](int j) { return double(outer2) * std::pow(kBinRatio2, double(j)); };
    std::vector<FoundPhoton> photons;
    for (int j = 0; j + 1 < kRadiusBins; ++j) {
        // Midway between disc j+1 and disc j (by r²), power j + 1 in red, 1 in green and blue.
        photons.push_back({float(0.5 * (r2(j) + r2(j + 1))), Vec3(float(j + 1), 1.0f, 1.0f)});
    }
    photons.push_back({0.0f, Vec3(100.0f, 0.0f, 0.0f)});  // at the end point: the innermost ring
    ProgressiveSet::Rings rings;
    ProgressiveSet::bin(rings, outer2, 0, photons);
    for (int j = 0; j + 1 < kRadiusBins; ++j) {
        EXPECT_EQ(rings.count[size_t(j)], 1.0f) << "ring " << j;
        EXPECT_EQ(rings.power[3 * size_t(j)], float(j + 1)) << "ring " << j;
        EXPECT_EQ(rings.power[3 * size_t(j) + 1], 1.0f) << "ring " << j;
    }
    EXPECT_EQ(rings.count[kRadiusBins - 1], 1.0f);
    EXPECT_EQ(rings.power[3 * (kRadiusBins - 1)], 100.0f);
    // A second pass of the same photons doubles every sum.
    ProgressiveSet::bin(rings, outer2, 0, photons);
    for (int j = 0; j < kRadiusBins; ++j) EXPECT_EQ(rings.count[size_t(j)], 2.0f) << "ring " << j;
    EXPECT_EQ(rings.power[3 * 5], 12.0f);
}

// A light of 1e26 W/sr (the most a scene may hold) sends photons of ~1e22 W: their squares would
// overflow float (the noise figure then read 0 photons and took the smallest disc). Kept in the
// maps' power unit, the squares stay small and photons of one power count as themselves.
TEST(ProgressiveBin, SquaredPowersStayInFloatRangeForAnyLightsWatts) {
    const float unit = 0x1p73f;  // a power of two near 1e22 W, as PhotonMaps::powerUnit
    const float outer2 = 1.0f;
    std::vector<FoundPhoton> photons(40, FoundPhoton{0.1f, Vec3(1.5f * unit)});
    ProgressiveSet::Rings rings;
    ProgressiveSet::bin(rings, outer2, 0, photons, unit);
    for (float v : rings.power2) EXPECT_TRUE(std::isfinite(v));
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, kScales, 1e30, c, unit);
    EXPECT_NEAR(c[0].effective, 40.0, 1e-3) << "40 photons of one power";
}

TEST(ProgressiveBin, ADiscsBoundaryBelongsToTheRingOutsideIt) {
    // A photon at exactly r_j (j ≥ 1) is not inside disc j: it counts in ring j − 1, so a disc
    // holds the photons strictly within its radius, as the gathers find them.
    const float outer2 = 1.0f;
    for (int j = 1; j < kRadiusBins; ++j) {
        ProgressiveSet::Rings rings;
        const float d2 = float(double(outer2) * std::pow(kBinRatio2, double(j)));
        const FoundPhoton p{d2, Vec3(1.0f)};
        ProgressiveSet::bin(rings, outer2, 0, std::span(&p, 1));
        EXPECT_EQ(rings.count[size_t(j - 1)], 1.0f) << "boundary of disc " << j;
    }
}

TEST(ProgressiveBin, RingsNoLongerKeptTakeNothing) {
    const float outer2 = 1.0f;
    std::vector<FoundPhoton> photons;
    for (int j = 0; j < kRadiusBins; ++j)
        photons.push_back({float(0.99 * std::pow(kBinRatio2, double(j))), Vec3(1.0f)});
    photons.push_back({2.0f * outer2, Vec3(1.0f)});  // beyond the outer disc (a restart's wider search)
    ProgressiveSet::Rings rings;
    ProgressiveSet::bin(rings, outer2, 7, photons);
    for (int j = 0; j < kRadiusBins; ++j)
        EXPECT_EQ(rings.count[size_t(j)], j < 7 ? 0.0f : 1.0f) << "ring " << j;
}

// Uniform floats in [0, 1) from a fixed seed (a 64-bit LCG's top bits): photon positions and
// powers the binning tests draw.
struct Uniform {
    uint64_t state;
    float operator()() {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return float(double(state >> 11) * 0x1p-53);
    }
};

// The box the binning tests' photons lie in: a floor 2 m square, ±0.1 m thick.
Bounds photonSlab() { return Bounds{Vec3(-1.0f, -0.1f, -1.0f), Vec3(1.0f, 0.1f, 1.0f)}; }

// `count` radius-search trees of `photons` photons each in photonSlab(), made by `make()` in turn.
template <class Make>
std::vector<KdTree> slabTrees(int count, int photons, Make make) {
    std::vector<KdTree> trees;
    for (int t = 0; t < count; ++t) {
        std::vector<Photon> list;
        for (int i = 0; i < photons; ++i) list.push_back(make());
        trees.emplace_back(photonSlab(), KdTree::kRadiusLeafSize);
        trees.back().build(list);
    }
    return trees;
}

// A pass bins what its searches find as they find it (binWithin): the rings, bit for bit, of one
// bin over the lists the same searches give (RadiusList, powers × the maps' unit, as the passes
// gathered them before they binned while searching): the pass's tree and two shared shots,
// photons from both sides of the surface, several end points and kept rings.
TEST(ProgressiveBin, BinningWhileSearchingEqualsBinningTheLists) {
    Uniform uniform{12345};
    const std::vector<KdTree> trees = slabTrees(3, 3000, [&] {
        const Vec3 x(2.0f * uniform() - 1.0f, 0.0f, 2.0f * uniform() - 1.0f);
        const Vec3 power(uniform() + 0.01f, uniform() + 0.01f, 0.5f * uniform() + 0.01f);
        // Most arrive from above (front of an upward normal), one in five from below.
        const Vec3 dir = glm::normalize(Vec3(uniform() - 0.5f, uniform() < 0.2f ? 0.7f : -0.7f, uniform() - 0.5f));
        return Photon::make(x, power, dir);
    });
    const std::vector<const KdTree*> order = {&trees[0], &trees[1], &trees[2]};
    const float unit = 0.25f;
    const Vec3 up(0.0f, 1.0f, 0.0f);
    const auto visible = [](const Photon&) { return true; };
    size_t binned = 0;
    for (int q = 0; q < 40; ++q) {
        const Vec3 x(1.6f * uniform() - 0.8f, 0.0f, 1.6f * uniform() - 0.8f);
        const float outer2 = 0.02f + 0.05f * uniform();
        const int active = q % 4;
        const float radius2 = float(double(outer2) * std::pow(kBinRatio2, double(active)));
        std::vector<FoundPhoton> list;
        for (const KdTree* tree : order) {
            const size_t first = list.size();
            RadiusList<KdTree, decltype(visible)> gather(*tree, up, radius2, visible, list);
            tree->search(x, gather);
            for (size_t i = first; i < list.size(); ++i) list[i].power *= unit;
        }
        binned += list.size();
        ProgressiveSet::Rings fromLists, whileSearching;
        for (int pass = 0; pass < 2; ++pass) {
            ProgressiveSet::bin(fromLists, outer2, active, list, 2.0f);
            ProgressiveSet::binWithin(whileSearching, outer2, active, order, 0, x, up, radius2, unit, 2.0f);
        }
        for (int j = 0; j < kRadiusBins; ++j) {
            for (int c = 0; c < 3; ++c)
                ASSERT_EQ(fromLists.power[3 * size_t(j) + size_t(c)], whileSearching.power[3 * size_t(j) + size_t(c)]) << "end point " << q << " ring " << j;
            ASSERT_EQ(fromLists.count[size_t(j)], whileSearching.count[size_t(j)]) << "end point " << q << " ring " << j;
            ASSERT_EQ(fromLists.power2[size_t(j)], whileSearching.power2[size_t(j)]) << "end point " << q << " ring " << j;
        }
    }
    EXPECT_GT(binned, 40u * 50u);  // the discs held photons
}

// A shared frame is one tree of every set's shot (SharedPhotons); a set's search of it bins the
// other sets' photons and not its own: the same photons, ring by ring, as searches of the other
// sets' shots alone, and batchesExcept counts theirs.
TEST(ProgressiveBin, ASharedFramesSearchLeavesTheSetsOwnPhotonsOut) {
    Uniform uniform{777};
    const Bounds box = photonSlab();
    std::vector<SetPhotons> shots;
    for (uint32_t set : {4u, 0u, 7u}) {
        SetPhotons shot{set, set + 1, {}};
        for (int i = 0; i < 2000; ++i) {
            const Vec3 x(2.0f * uniform() - 1.0f, 0.0f, 2.0f * uniform() - 1.0f);
            shot.photons.push_back(Photon::make(x, Vec3(uniform() + 0.01f), Vec3(0.0f, -1.0f, 0.0f)));
        }
        shots.push_back(std::move(shot));
    }
    shots.push_back(SetPhotons{2, 0, shots[0].photons});  // no batches: not shared
    SharedPhotons shared;
    shared.build(box, shots);
    EXPECT_EQ(shared.tree().size(), 6000u);
    EXPECT_EQ(shared.batchesExcept(0), 5u + 8u);
    EXPECT_EQ(shared.batchesExcept(4), 1u + 8u);
    EXPECT_EQ(shared.batchesExcept(3), 1u + 5u + 8u);
    const Vec3 up(0.0f, 1.0f, 0.0f);
    for (uint32_t set : {0u, 4u, 7u, 3u}) {
        std::vector<KdTree> others;
        for (size_t i = 0; i < 3; ++i)
            if (shots[i].set != set) {
                others.emplace_back(box, KdTree::kRadiusLeafSize);
                others.back().build(shots[i].photons);
            }
        std::vector<const KdTree*> separate;
        for (const KdTree& t : others) separate.push_back(&t);
        const KdTree* one = &shared.tree();
        for (int q = 0; q < 20; ++q) {
            const Vec3 x(1.6f * uniform() - 0.8f, 0.0f, 1.6f * uniform() - 0.8f);
            const float outer2 = 0.02f + 0.05f * uniform();
            ProgressiveSet::Rings fromShared, fromSeparate;
            ProgressiveSet::binWithin(fromShared, outer2, 0, std::span(&one, 1), set, x, up, outer2, 1.0f);
            ProgressiveSet::binWithin(fromSeparate, outer2, 0, separate, set, x, up, outer2, 1.0f);
            double photons = 0.0;
            for (int j = 0; j < kRadiusBins; ++j) {
                ASSERT_EQ(fromShared.count[size_t(j)], fromSeparate.count[size_t(j)]) << "set " << set << " ring " << j;
                // The same photons summed in another order.
                ASSERT_NEAR(fromShared.power[3 * size_t(j)], fromSeparate.power[3 * size_t(j)],
                            1e-5f * (1.0f + fromSeparate.power[3 * size_t(j)]));
                photons += fromShared.count[size_t(j)];
            }
            EXPECT_GT(photons, 0.0) << "set " << set << ", end point " << q;
        }
    }
}

// A hit whose discs are ellipses (Shape) bins, ring by ring, the photons within the ellipses:
// the same rings as one bin over every photon of the trees whose squared distance in the
// ellipses' metric, |o|²/a + (a − 1/a)(o·u)², lies within the active disc, at aspects whose
// ellipse is searched as one sphere (2) and as 2 or 3 slabs of its long axis (3, 4, 5: no photon
// binned twice, none missed at the slabs' borders).
TEST(ProgressiveBin, AnEllipsesRingsHoldThePhotonsWithinTheEllipses) {
    Uniform uniform{4242};
    const std::vector<KdTree> trees = slabTrees(2, 4000, [&] {
        return Photon::make(Vec3(2.0f * uniform() - 1.0f, 0.0f, 2.0f * uniform() - 1.0f), Vec3(uniform() + 0.01f),
                            Vec3(0.0f, -1.0f, 0.0f));
    });
    const std::vector<const KdTree*> order = {&trees[0], &trees[1]};
    const Vec3 up(0.0f, 1.0f, 0.0f);
    for (int q = 0; q < 32; ++q) {
        ProgressiveSet::Shape shape;
        shape.decided = true;
        shape.aspect = float(2 + q % 4);
        const float angle = 6.2831853f * uniform();
        shape.across = Vec3(std::cos(angle), 0.0f, std::sin(angle));
        const Vec3 x(1.2f * uniform() - 0.6f, 0.0f, 1.2f * uniform() - 0.6f);
        const float outer2 = 0.01f + 0.02f * uniform();
        const int active = q % 3;
        const float radius2 = float(double(outer2) * std::pow(kBinRatio2, double(active)));
        std::vector<FoundPhoton> inside;
        size_t beyondCircle = 0;
        for (const KdTree* tree : order)
            for (const Photon& p : tree->photons()) {
                const Vec3 o = p.position - x;
                const float t = dot(o, shape.across);
                const float m2 = dot(o, o) / shape.aspect + (shape.aspect - 1.0f / shape.aspect) * t * t;
                if (!(m2 < radius2)) continue;
                inside.push_back(FoundPhoton{m2, decodeRgb9e5(p.power), p.position});
                if (!(dot(o, o) < radius2)) ++beyondCircle;
            }
        ProgressiveSet::Rings expected, binned;
        ProgressiveSet::bin(expected, outer2, active, inside);
        ProgressiveSet::binWithin(binned, outer2, active, order, 0, x, up, radius2, 1.0f, 1.0f, nullptr, &shape);
        double photons = 0.0;
        for (int j = 0; j < kRadiusBins; ++j) {
            ASSERT_EQ(binned.count[size_t(j)], expected.count[size_t(j)]) << "end point " << q << " ring " << j;
            ASSERT_NEAR(binned.power[3 * size_t(j)], expected.power[3 * size_t(j)],
                        1e-5f * (1.0f + expected.power[3 * size_t(j)]));
            photons += binned.count[size_t(j)];
        }
        EXPECT_GT(photons, 20.0) << "end point " << q;
        EXPECT_GT(beyondCircle, 0u) << "end point " << q << ": the ellipse reaches beyond the circle";
    }
}

// A hit's shape is decided once kShapePhotons photons were binned: photons strung along a line
// through it give an ellipse of the largest aspect whose short axis crosses the line; photons
// spread evenly, or all at one point, keep a circle; fewer than kShapePhotons leave it undecided.
TEST(ProgressiveBin, PhotonsAlongALineMakeTheDiscsEllipsesAcrossIt) {
    Uniform uniform{99};
    const Bounds box = photonSlab();
    const Vec3 up(0.0f, 1.0f, 0.0f);
    const Vec3 along = glm::normalize(Vec3(1.0f, 0.0f, 0.5f));
    enum Spread { kLine, kEven, kOnePoint };
    auto shapeOf = [&](int count, Spread spread) {
        std::vector<Photon> photons;
        for (int i = 0; i < count; ++i) {
            const Vec3 x = spread == kLine ? along * (0.4f * uniform() - 0.2f) +
                                                 Vec3(-along.z, 0.0f, along.x) * (0.02f * uniform() - 0.01f)
                           : spread == kEven ? Vec3(0.4f * uniform() - 0.2f, 0.0f, 0.4f * uniform() - 0.2f)
                                             : Vec3(0.05f, 0.0f, -0.03f);
            photons.push_back(Photon::make(x, Vec3(1.0f), Vec3(0.0f, -1.0f, 0.0f)));
        }
        KdTree tree(box, KdTree::kRadiusLeafSize);
        tree.build(photons);
        const KdTree* one = &tree;
        ProgressiveSet::Shape shape;
        ProgressiveSet::Rings rings;
        ProgressiveSet::binWithin(rings, 0.04f, 0, std::span(&one, 1), 0, Vec3(0.0f), up, 0.04f, 1.0f, 1.0f, nullptr,
                                  &shape);
        return shape;
    };
    const ProgressiveSet::Shape line = shapeOf(400, kLine);
    EXPECT_TRUE(line.decided);
    EXPECT_FLOAT_EQ(line.aspect, float(kAspectMax));
    EXPECT_NEAR(std::abs(dot(line.across, along)), 0.0f, 0.02f);
    EXPECT_NEAR(glm::length(line.across), 1.0f, 1e-5f);
    const ProgressiveSet::Shape even = shapeOf(2000, kEven);
    EXPECT_TRUE(even.decided);
    EXPECT_EQ(even.aspect, 1.0f);
    const ProgressiveSet::Shape point = shapeOf(200, kOnePoint);
    EXPECT_TRUE(point.decided);
    EXPECT_EQ(point.aspect, 1.0f);
    const ProgressiveSet::Shape few = shapeOf(int(kShapePhotons) / 2, kLine);
    EXPECT_FALSE(few.decided);
    EXPECT_EQ(few.aspect, 1.0f);
}

TEST(ProgressiveChoose, TheCapEndsTheDiscInsideARingWithExactlyItsPhotons) {
    // A flat density and a cap that falls inside a ring: the shown disc holds exactly the cap's
    // photons, its r² between the two whole discs around it, and its estimate the density.
    const auto rings = ringsOf([](double) { return 4000.0; });
    ProgressiveSet::Choice c[2];
    ProgressiveSet::choose(rings, 0, 2.0, kScales, 500.0, c);
    for (const auto& choice : c) {
        EXPECT_DOUBLE_EQ(choice.count, 500.0);
        EXPECT_LT(choice.scale, std::pow(kBinRatio2, double(choice.disc - 1)));
        EXPECT_GT(choice.scale, std::pow(kBinRatio2, double(choice.disc)));
        const double density = choice.power.x / (3.141592653589793 * choice.scale);
        EXPECT_NEAR(density, 4000.0, 4000.0 * 0.02);
        EXPECT_TRUE(choice.capped);
    }
}

// Why a pass gathers no farther than the ring of a capped disc (ProgressiveSet::compose keeps
// kActiveMargin rings outside a disc the rule chose, none outside one the cap ended): the cap
// grows as √N while the photons in a disc grow as N, so with more photons of the same density the
// capped disc only narrows, and the rings outside it are never chosen again. (The passes of the
// curved mirror's defaults gathered 3 rings wider than that: the same image, 11 % slower.)
TEST(ProgressiveChoose, ACappedDiscOnlyNarrowsAsPhotonsAccumulate) {
    ProgressiveSet::Choice one[2], four[2];
    ProgressiveSet::choose(ringsOf([](double) { return 4000.0; }), 0, 2.0, kScales, maxDiscPhotons(64, kDiscCapPaths),
                           one);
    ProgressiveSet::choose(ringsOf([](double) { return 16000.0; }), 0, 2.0, kScales,
                           maxDiscPhotons(64, 4 * kDiscCapPaths), four);
    ASSERT_TRUE(one[0].capped);
    ASSERT_TRUE(four[0].capped);
    EXPECT_LT(four[0].scale, one[0].scale);
    EXPECT_GE(four[0].disc, one[0].disc);
    // A disc the rule chose is not capped.
    ProgressiveSet::Choice step[2];
    ProgressiveSet::choose(ringsOf([](double r) { return r < 0.3 ? 20000.0 : 0.0; }), 0, 2.0, kScales, 1e30, step);
    EXPECT_FALSE(step[0].capped);
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
    b.record(true, 0.3);  // over the budget: the sets take turns (no photon lost), the passes stay
    EXPECT_EQ(b.batches(), 4u);
    EXPECT_EQ(b.period(), 2u);
    b.record(false, 0.01);  // the view moved
    EXPECT_EQ(b.batches(), 1u);
    EXPECT_EQ(b.period(), 1u);
    for (int i = 0; i < 40; ++i) b.record(true, 0.0);
    EXPECT_EQ(b.batches(), kMaxPassBatches);
}

// A frame in which every set shot one batch predicts a pass's shooting: the next still view
// starts at the period that holds it to the budget instead of doubling from 1 turn by turn.
TEST(PassBudget, AStillViewStartsAtThePeriodItsLastBatchPerSetPredicts) {
    PassBudget b(0.05);
    b.expectShooting(0.26);  // 5.2 budgets: the power of two at or above
    EXPECT_EQ(b.period(), 1u) << "takes effect when the budget starts afresh";
    b.record(false, 0.4);  // the epoch's first frame
    EXPECT_EQ(b.period(), 8u);
    EXPECT_EQ(b.batches(), 1u);
    b.record(true, 0.3);  // the turn's frames decide from there (a whole turn of 8)
    EXPECT_EQ(b.period(), 8u);
    for (int i = 0; i < 7; ++i) b.record(true, 0.04);
    EXPECT_EQ(b.period(), 16u) << "mean 72 ms over the turn: over the budget";
    b.record(false, 0.1);  // the view moved: the prediction stays
    EXPECT_EQ(b.period(), 8u);
    b.expectShooting(0.03);  // within the budget: no turns
    b.record(false, 0.1);
    EXPECT_EQ(b.period(), 1u);
    b.expectShooting(100.0);
    b.record(false, 0.1);
    EXPECT_EQ(b.period(), kMaxPassPeriod);
    PassBudget fixed(0.0);  // one batch per pass, whatever the machine
    fixed.expectShooting(10.0);
    fixed.record(false, 0.1);
    EXPECT_EQ(fixed.period(), 1u);
    PassBudget accumulate(0.05, /*growBatches=*/false);  // expectFrame is an accumulation budget's
    accumulate.expectShooting(10.0);
    accumulate.record(false, 0.1);
    EXPECT_EQ(accumulate.period(), 1u);
}

// An accumulation budget (the knn estimator's still view) starts at the period its last frame of
// every set's batch predicts only where that frame cost more than a moving frame may (`beyond`);
// below, its period doubles from 1 as before.
TEST(PassBudget, AnAccumulationStartsAtItsPredictedPeriodOnlyBeyondAMovingFramesCost) {
    PassBudget accumulate(1.0 / 60.0, /*growBatches=*/false);
    accumulate.expectFrame(0.515, 0.2);  // HEADLIGHT: 515 ms against the orbit's 200 ms
    EXPECT_EQ(accumulate.period(), 1u) << "takes effect when the budget starts afresh";
    accumulate.record(false, 0.5);
    EXPECT_EQ(accumulate.period(), 32u) << "the power of two at or above 515 / 16.7";
    EXPECT_EQ(accumulate.batches(), 1u);
    accumulate.expectFrame(0.19, 0.2);  // CORNELL: within a moving frame's cost
    accumulate.record(false, 0.2);
    EXPECT_EQ(accumulate.period(), 1u);
    accumulate.expectFrame(0.02, 0.0);  // under kTurnStart × the budget: no turns
    accumulate.record(false, 0.02);
    EXPECT_EQ(accumulate.period(), 1u);
    accumulate.expectFrame(100.0, 0.2);
    accumulate.record(false, 0.2);
    EXPECT_EQ(accumulate.period(), kMaxPassPeriod);
    PassBudget passes(0.05);  // a progressive budget predicts by expectShooting, not expectFrame
    passes.expectFrame(10.0, 0.0);
    passes.record(false, 0.1);
    EXPECT_EQ(passes.period(), 1u);
    PassBudget fixed(0.0, /*growBatches=*/false);  // no budget: no turns, whatever the machine
    fixed.expectFrame(10.0, 0.0);
    fixed.record(false, 0.1);
    EXPECT_EQ(fixed.period(), 1u);
}

TEST(PassBudget, ZeroBudgetKeepsOneBatch) {
    PassBudget b(0.0);
    for (int i = 0; i < 10; ++i) b.record(true, 0.0);
    EXPECT_EQ(b.batches(), 1u);
    for (int i = 0; i < 10; ++i) b.record(true, 10.0);
    EXPECT_EQ(b.batches(), 1u);
    EXPECT_EQ(b.period(), 1u);
}

TEST(PassBudget, WithoutGrowingBatchesOnlyThePeriodChanges) {
    PassBudget b(0.2, /*growBatches=*/false);
    for (int i = 0; i < 10; ++i) b.record(true, 0.001);
    EXPECT_EQ(b.batches(), 1u);
    EXPECT_EQ(b.period(), 1u);
    b.record(true, 1.0);
    EXPECT_EQ(b.period(), 2u);
    for (int i = 0; i < 4; ++i) b.record(true, 0.001);  // fast turns shorten the turns, then stop
    EXPECT_EQ(b.period(), 1u);
    EXPECT_EQ(b.batches(), 1u);
    b.record(false, 1.0);
    EXPECT_EQ(b.period(), 1u);
    b.record(true, 1.0);
    EXPECT_EQ(b.period(), 2u) << "a reset budget keeps its kind";
    for (int i = 0; i < 8; ++i) b.record(true, 0.001);
    EXPECT_EQ(b.batches(), 1u);
}

TEST(PassBudget, SetsTakeTurnsWhenOneBatchPerSetExceedsTheBudget) {
    // One batch per set costs 1 s against a 0.2 s budget: the sets take turns, every 2nd, 4th,
    // then 8th frame, until a turn fits; each decision takes the mean frame time of one whole
    // turn (a frame's cost depends on whose turn it is). Fast turns then grow the passes: a set
    // off its turn loses no photon (it bins the others' shots at its next turn), and a longer
    // pass spreads the fixed cost of a pass (its binning and composing) over more photons.
    PassBudget b(0.2);
    b.record(true, 1.0);
    EXPECT_EQ(b.batches(), 1u);
    EXPECT_EQ(b.period(), 2u);
    b.record(true, 0.9);
    EXPECT_EQ(b.period(), 2u) << "half a turn decides nothing";
    b.record(true, 0.1);  // mean 0.5 s over the turn: paid (at most 0.9 s), still over the budget
    EXPECT_EQ(b.period(), 4u);
    for (double t : {0.6, 0.0, 0.6, 0.0}) b.record(true, t);  // mean 0.3 s
    EXPECT_EQ(b.period(), 8u);
    for (int i = 0; i < 8; ++i) b.record(true, i % 2 ? 0.05 : 0.2);  // mean 0.125 s: within the budget
    EXPECT_EQ(b.period(), 8u);
    EXPECT_EQ(b.batches(), 1u);
    for (int i = 0; i < 8; ++i) b.record(true, 0.05);
    EXPECT_EQ(b.period(), 8u);
    EXPECT_EQ(b.batches(), 2u) << "fast turns grow the passes";
    // Frames whose cost falls with the turns (20 s of shooting shared out) take turns up to the
    // limit, and the passes shrink only beyond it.
    for (int i = 0; i < 1000; ++i) b.record(true, 20.0 / b.period());
    EXPECT_EQ(b.batches(), 1u);
    EXPECT_EQ(b.period(), kMaxPassPeriod);
    b.record(false, 5.0);  // the view moved
    EXPECT_EQ(b.period(), 1u);
}

TEST(PassBudget, AccumulateFramesNearTheBudgetKeepEverySetShooting) {
    // Accumulate frames (an orbit over a growing map, knn's still view): a set off its turn shoots
    // nothing, so turns cost photons. One batch per set costing a little more than the budget
    // (0.22 s against 0.2 s, under kTurnStart × the budget): no turns. Clearly over it (0.3 s)
    // the turns begin.
    PassBudget b(0.2, /*growBatches=*/false);
    for (int i = 0; i < 20; ++i) b.record(true, 0.22);
    EXPECT_EQ(b.period(), 1u);
    EXPECT_EQ(b.batches(), 1u);
    b.record(true, 0.3);
    EXPECT_EQ(b.period(), 2u);
    b.record(true, 0.22);
    b.record(true, 0.22);  // paid (0.22 ≤ 0.9 × 0.3) and still over: turns once begun follow the budget
    EXPECT_EQ(b.period(), 4u);
}

TEST(PassBudget, ProgressivePassesTakeTurnsAsSoonAsAFrameExceedsTheBudget) {
    // Progressive passes: turns cost no photon, so they begin at once (0.22 s against 0.2 s).
    PassBudget b(0.2);
    b.record(true, 0.22);
    EXPECT_EQ(b.period(), 2u);
    EXPECT_EQ(b.batches(), 1u);
}

TEST(PassBudget, TurnsThatDoNotShortenTheFramesAreUndoneAndTriedLessOften) {
    // 1 s frames whatever the turns (a pass's cost is its binning, not its shooting): the trial
    // of a period of 2 is undone after its first whole turn; the next trial comes only after
    // kFirstTrialBackoff turns, the one after twice as many later; once the view moves, a new
    // still view may try at once.
    PassBudget b(0.2);
    b.record(true, 1.0);
    EXPECT_EQ(b.period(), 2u) << "a trial";
    b.record(true, 1.0);
    b.record(true, 0.9);  // mean 0.95 s: more than 0.9 × 1 s
    EXPECT_EQ(b.period(), 1u) << "undone";
    auto turnsUntilTrial = [&b] {
        int turns = 0;
        while (b.period() == 1 && turns < 1000) {
            b.record(true, 1.0);
            ++turns;
        }
        return turns;
    };
    EXPECT_EQ(turnsUntilTrial(), int(PassBudget::kFirstTrialBackoff));
    EXPECT_EQ(b.batches(), 1u);
    b.record(true, 1.0);
    b.record(true, 1.0);  // the second trial fails as well
    ASSERT_EQ(b.period(), 1u);
    EXPECT_EQ(turnsUntilTrial(), 2 * int(PassBudget::kFirstTrialBackoff));
    b.record(true, 1.0);
    b.record(true, 1.0);
    ASSERT_EQ(b.period(), 1u);
    b.record(false, 1.0);
    b.record(true, 1.0);
    EXPECT_EQ(b.period(), 2u) << "a new still view tries at once";
}

// One unlucky turn does not hold a still view at a short period: frames that pay for turns once
// the noise is gone reach the period at which they fit the budget.
TEST(PassBudget, ATrialUndoneByNoiseIsTriedAgain) {
    PassBudget b(0.02);
    const double shooting = 0.6;  // one batch per set: 30 budgets, spread over the turns
    b.record(true, shooting);
    ASSERT_EQ(b.period(), 2u);
    for (uint32_t i = 0; i < 2; ++i) b.record(true, shooting);  // a hiccup: no gain
    ASSERT_EQ(b.period(), 1u);
    for (int i = 0; i < 400; ++i) b.record(true, shooting / double(b.period()));
    EXPECT_EQ(b.period(), 32u) << "0.6 s / 32 = 19 ms fits the 20 ms budget";
}

TEST(PassBudget, TakingTurnsEverySetShootsOncePerPeriod) {
    for (uint32_t period : {1u, 2u, 3u, 4u, 8u, 16u, 64u}) {
        for (uint32_t set = 0; set < 9; ++set) {
            int shots = 0;
            for (uint64_t pass = 100; pass < 100 + period; ++pass) shots += passShoots(pass, set, 9, period) ? 1 : 0;
            EXPECT_EQ(shots, 1) << "set " << set << ", period " << period;
        }
        // A pass's shooting sets: about 9 / period of the nine, never all of them but with period 1.
        int shooting = 0;
        for (uint32_t set = 0; set < 9; ++set) shooting += passShoots(7, set, 9, period) ? 1 : 0;
        if (period > 1) {
            EXPECT_LT(shooting, 9);
        }
    }
}

TEST(PassBudget, WithMorePassesThanSetsTheSetsShootInConsecutivePasses) {
    // Periods longer than the nine sets: the passes with a set are one run, alternating between
    // two round-robin clients (even and odd ids), and the empty passes are another, so the two
    // frames in flight hold both clients' passes, or two empty ones.
    for (uint32_t period : {16u, 64u}) {
        std::vector<int> shooter(period, -1);
        for (uint64_t pass = 0; pass < period; ++pass)
            for (uint32_t set = 0; set < 9; ++set)
                if (passShoots(pass, set, 9, period)) {
                    EXPECT_EQ(shooter[pass], -1) << "two sets in pass " << pass << ", period " << period;
                    shooter[pass] = int(set);
                }
        int runs = 0;  // runs of passes with a set, cyclically
        for (uint32_t i = 0; i < period; ++i) {
            const int here = shooter[i], before = shooter[(i + period - 1) % period];
            if (here >= 0 && before < 0) ++runs;
            if (here >= 0 && before >= 0) {
                EXPECT_NE(here % 2, before % 2) << "period " << period << ", pass " << i;
            }
        }
        EXPECT_EQ(runs, 1) << "period " << period;
    }
}

TEST(PassBudget, TakingTurnsSpreadsAPassesShootingOverRoundRobinClients) {
    // Two clients get the nine sets round robin (even ids, odd ids). With turns of 2 or 4 passes
    // every pass that shoots more than one set shoots on both clients.
    for (uint32_t period : {2u, 4u}) {
        for (uint64_t pass = 1; pass <= period; ++pass) {
            int even = 0, odd = 0;
            for (uint32_t set = 0; set < 9; ++set)
                if (passShoots(pass, set, 9, period)) ++(set % 2 ? odd : even);
            EXPECT_GT(even, 0) << "period " << period << ", pass " << pass;
            EXPECT_GT(odd, 0) << "period " << period << ", pass " << pass;
        }
    }
}

}  // namespace
}  // namespace rtpm
