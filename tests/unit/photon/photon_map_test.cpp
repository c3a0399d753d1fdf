// PhotonMaps: the three spatial index variants answer alike, and stored powers are relative to a
// power unit so that the light's scale does not change the stored codes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>
#include <vector>

#include "common/photon/density.h"
#include "common/trace/embree_scene.h"
#include "common/photon/photon_map.h"
#include "tests/support/test_scenes.h"

namespace rtpm {
namespace {

using namespace testscenes;

// Floor y = 0 (4 × 4 m), a glass slab and a mirror above it, and a coloured point light:
// refracted and reflected caustics of different densities on the floor, and (with diffuse
// bounces) indirect ones. `intensity` scales the light.
Scene causticScene(float intensity) {
    Scene s;
    const uint32_t floor = addMaterial(s, MaterialType::Diffuse, Vec3(0.6f, 0.5f, 0.4f));
    addMesh(s, quad(Vec3(0.0f), Vec3(2, 0, 0), Vec3(0, 0, -2), floor));
    const uint32_t glass = addMaterial(s, MaterialType::Dielectric, Vec3(1.0f), 1.5f);
    addMesh(s, box(Vec3(-1.2f, 0.4f, -0.6f), Vec3(0.2f, 0.6f, 0.6f), glass));
    const uint32_t mirror = addMaterial(s, MaterialType::Mirror, Vec3(0.9f));
    addMesh(s, quad(Vec3(0.9f, 0.8f, 0.0f), Vec3(0.0f, 0.3f, 0.0f), Vec3(0.0f, 0.0f, 0.3f), mirror));
    addPointLight(s, Vec3(-0.3f, 1.5f, 0.1f), Vec3(1.0f, 0.8f, 0.3f) * intensity);
    s.validate("caustic scene");
    return s;
}

using PhotonKey = std::tuple<float, float, float, uint32_t, uint32_t>;
PhotonKey key(const Photon& p) { return {p.position.x, p.position.y, p.position.z, p.power, p.incoming}; }

std::vector<PhotonKey> sortedKeys(const std::vector<Photon>& photons) {
    std::vector<PhotonKey> keys;
    for (const Photon& p : photons) keys.push_back(key(p));
    std::sort(keys.begin(), keys.end());
    return keys;
}

// The k front-facing nearest photons of `index` around x: sorted squared distances, and the
// photons strictly closer than the k-th (those are the same set for every index; photons *at*
// the k-th distance may be swapped for others at that same distance).
struct Gathered {
    std::vector<float> dist2;
    std::vector<PhotonKey> inner;
};

template <class Index>
Gathered gather(const Index& index, Vec3 x, Vec3 normal, uint32_t k, float rMax) {
    KnnHeap heap;
    heap.reset(k, rMax * rMax);
    FrontFacingKnn<Index> policy(heap, index, normal);
    index.search(x, policy);
    Gathered g;
    for (const KnnEntry& e : heap.entries()) g.dist2.push_back(e.dist2);
    std::sort(g.dist2.begin(), g.dist2.end());
    const float last = g.dist2.empty() ? 0.0f : g.dist2.back();
    for (const KnnEntry& e : heap.entries())
        if (e.dist2 < last) g.inner.push_back(key(index.photon(e.index)));
    std::sort(g.inner.begin(), g.inner.end());
    return g;
}

// Set 0's map of causticScene(2) after three batches of 6000 paths (k = 40, one diffuse bounce,
// no cap) in the index variant `tree`.
std::unique_ptr<PhotonMaps> threeBatchMap(const EmbreeScene& es, PhotonTree tree) {
    PhotonSettings ps;
    ps.photonsPerBatch = 6000;
    ps.diffuseBounces = 1;
    ps.k = 40;
    ps.capPhotons = 0;
    ps.tree = tree;
    auto maps = std::make_unique<PhotonMaps>(ps, std::vector<uint32_t>{0});
    for (int b = 0; b < 3; ++b) maps->shootBatch(es, 0);
    return maps;
}

TEST(PhotonMaps, TreeVariantsGiveTheSameCausticEstimates) {
    const Scene scene = causticScene(2.0f);
    const EmbreeScene es(scene);  // keeps a reference to the scene
    const std::vector<PhotonTree> variants = {PhotonTree::MiddleSplit, PhotonTree::MedianBalanced,
                                              PhotonTree::UniformGrid};
    std::vector<std::unique_ptr<PhotonMaps>> maps;
    for (PhotonTree t : variants) maps.push_back(threeBatchMap(es, t));
    // Only the selected index exists.
    EXPECT_NE(maps[0]->index<KdTree>(0), nullptr);
    EXPECT_EQ(maps[0]->index<MedianKdTree>(0), nullptr);
    EXPECT_NE(maps[1]->index<MedianKdTree>(0), nullptr);
    EXPECT_EQ(maps[1]->index<PhotonGrid>(0), nullptr);
    EXPECT_NE(maps[2]->index<PhotonGrid>(0), nullptr);
    EXPECT_EQ(maps[2]->index<KdTree>(0), nullptr);

    // The same photons in every map (shooting does not depend on the index).
    const std::vector<PhotonKey> reference = sortedKeys(maps[0]->photons(0));
    ASSERT_GT(reference.size(), 2000u);
    for (size_t v = 1; v < maps.size(); ++v) {
        EXPECT_EQ(maps[v]->stats(0).photonsStored, reference.size());
        EXPECT_TRUE(sortedKeys(maps[v]->photons(0)) == reference) << photonTreeName(variants[v]);
        EXPECT_EQ(maps[v]->powerUnit(), maps[0]->powerUnit());
    }

    // Queries: every 37th photon (dense caustic interiors, edges) and a lattice over the floor
    // (empty regions, where fewer than k photons lie within rMax).
    std::vector<Vec3> queries;
    const std::vector<Photon> all = maps[0]->photons(0);
    for (size_t i = 0; i < all.size(); i += 37) queries.push_back(all[i].position);
    for (float x = -1.9f; x < 2.0f; x += 0.3f)
        for (float z = -1.9f; z < 2.0f; z += 0.3f) queries.push_back(Vec3(x, 0.0f, z));
    const Vec3 up(0.0f, 1.0f, 0.0f);
    const uint32_t k = maps[0]->settings().k;
    const float rMax = maps[0]->gatherRadius();
    size_t nonZero = 0, hinted = 0;
    std::vector<GatherHint> hints(maps.size());  // carried from query to query, as along a row
    for (const Vec3& q : queries) {
        const Gathered a = gather(*maps[0]->index<KdTree>(0), q, up, k, rMax);
        const Gathered b = gather(*maps[1]->index<MedianKdTree>(0), q, up, k, rMax);
        const Gathered c = gather(*maps[2]->index<PhotonGrid>(0), q, up, k, rMax);
        ASSERT_EQ(a.dist2, b.dist2);
        ASSERT_EQ(a.dist2, c.dist2);
        ASSERT_TRUE(a.inner == b.inner);
        ASSERT_TRUE(a.inner == c.inner);

        SurfaceHit hit;
        hit.position = q;
        hit.geometricNormal = hit.shadingNormal = up;
        const Vec3 la = maps[0]->radiance(es, 0, hit, up, Vec3(0.5f));
        nonZero += la.x > 0.0f;
        // A hint only speeds the search up: the same photons (summed in another order).
        for (size_t v = 0; v < maps.size(); ++v) {
            hinted += hints[v].radius2 > 0.0f;
            const Vec3 lh = maps[v]->radiance(es, 0, hit, up, Vec3(0.5f), &hints[v]);
            for (int ch = 0; ch < 3; ++ch)
                ASSERT_NEAR(lh[ch], la[ch], 1e-5f * la[ch] + 1e-30f) << "hinted " << photonTreeName(variants[v]);
        }
        for (size_t v = 1; v < maps.size(); ++v) {
            const Vec3 lv = maps[v]->radiance(es, 0, hit, up, Vec3(0.5f));
            // Same photons, summed in another order (and ties at the k-th distance carry the
            // same distance but possibly other powers): float rounding only.
            for (int ch = 0; ch < 3; ++ch)
                ASSERT_NEAR(lv[ch], la[ch], 1e-5f * la[ch] + 1e-30f) << photonTreeName(variants[v]);
        }
    }
    EXPECT_GT(nonZero, queries.size() / 2);
    EXPECT_GT(hinted, queries.size());  // most queries ran with a guess

    // Groups of 8 consecutive queries (radianceGroup, group_gather.h) give every query what
    // radiance gives it: the same photons and radius, and PowerSum makes the sum exact in any order.
    std::vector<SurfaceHit> hits(queries.size());
    for (size_t i = 0; i < queries.size(); ++i) {
        hits[i].position = queries[i];
        hits[i].geometricNormal = hits[i].shadingNormal = up;
    }
    for (size_t v = 0; v < maps.size(); ++v) {
        GatherHint hint;
        size_t differing = 0;
        for (size_t q0 = 0; q0 < queries.size(); q0 += 8) {
            const size_t n = std::min<size_t>(8, queries.size() - q0);
            std::vector<CausticQuery> group(n);
            for (size_t i = 0; i < n; ++i) group[i] = CausticQuery{&hits[q0 + i], up, Vec3(0.5f)};
            std::vector<Vec3> out(n);
            maps[v]->radianceGroup(es, 0, group, out, &hint);
            std::vector<DensityGather> gathers(n);
            maps[v]->gatherMapGroup(es, 0, group, gathers);
            for (size_t i = 0; i < n; ++i) {
                const Vec3 single = maps[v]->radiance(es, 0, hits[q0 + i], up, Vec3(0.5f));
                const DensityGather g = maps[v]->gatherMap(es, 0, hits[q0 + i], up);
                differing += out[i] != single;
                for (int ch = 0; ch < 3; ++ch)
                    ASSERT_NEAR(out[i][ch], single[ch], 1e-5f * single[ch] + 1e-30f) << photonTreeName(variants[v]);
                ASSERT_EQ(gathers[i].count, g.count);
                ASSERT_EQ(gathers[i].radius2, g.radius2);
            }
        }
        EXPECT_EQ(differing, 0u) << photonTreeName(variants[v]);  // no ties at the k-th photon here
    }
}

// gatherMapKnnWithin (the progressive restart's one search) gives the k-NN disc and count that
// gatherMap's k-NN search gives, and exactly the photons a radius search of the reach it returns
// gives, in the same order, whatever the guess: none, far too small, about right, beyond rMax.
TEST(PhotonMaps, KnnWithinGivesTheKnnDiscAndThePhotonsOfItsReach) {
    const Scene scene = causticScene(2.0f);
    const EmbreeScene es(scene);
    for (PhotonTree t : {PhotonTree::MiddleSplit, PhotonTree::MedianBalanced, PhotonTree::UniformGrid}) {
        const std::unique_ptr<PhotonMaps> owned = threeBatchMap(es, t);
        const PhotonMaps& maps = *owned;
        const uint32_t k = maps.settings().k;
        const std::vector<Photon> all = maps.photons(0);
        ASSERT_GT(all.size(), 2000u);
        std::vector<Vec3> queries;
        for (size_t i = 0; i < all.size(); i += 53) queries.push_back(all[i].position);
        for (float x = -1.9f; x < 2.0f; x += 0.4f)
            for (float z = -1.9f; z < 2.0f; z += 0.4f) queries.push_back(Vec3(x, 0.0f, z));
        const Vec3 up(0.0f, 1.0f, 0.0f);
        const float rMax2 = maps.gatherRadius() * maps.gatherRadius();
        size_t full = 0, sparse = 0, searchedTwice = 0;
        for (const Vec3& q : queries) {
            SurfaceHit hit;
            hit.position = q;
            hit.geometricNormal = hit.shadingNormal = up;
            const DensityGather knn = maps.gatherMap(es, 0, hit, up);
            for (float guess : {0.0f, 1e-6f * rMax2, 1.3f * knn.radius2, 0.5f * rMax2, 2.0f * rMax2}) {
                float reach2 = guess;
                std::vector<FoundPhoton> out;
                const DensityGather g = maps.gatherMapKnnWithin(es, 0, hit, up, reach2, out);
                ASSERT_EQ(g.count, knn.count) << photonTreeName(t);
                ASSERT_EQ(g.radius2, knn.radius2) << photonTreeName(t);
                ASSERT_GT(reach2, 0.0f);
                if (guess > 0.0f && guess < rMax2) {
                    ASSERT_TRUE(reach2 == guess || reach2 > rMax2);
                    searchedTwice += reach2 != guess;
                } else {
                    ASSERT_GT(reach2, rMax2);  // all of rMax, just beyond
                }
                std::vector<FoundPhoton> direct;
                maps.gatherMapPhotons(es, 0, hit, up, reach2, direct);
                ASSERT_EQ(out.size(), direct.size());
                for (size_t i = 0; i < out.size(); ++i) {
                    ASSERT_EQ(out[i].dist2, direct[i].dist2);
                    ASSERT_EQ(out[i].power, direct[i].power);
                }
                full += g.count == k;
                sparse += g.count > 0 && g.count < k;
            }
        }
        EXPECT_GT(full, queries.size());          // dense caustics: k photons within reach
        EXPECT_GT(sparse, 0u);                    // and floor points with fewer within rMax
        EXPECT_GT(searchedTwice, queries.size()); // the small guesses fell short
    }
}

// Scaling the light by 2^±40 scales the power unit by exactly that, so the stored codes are
// bit-identical and the radiance scales exactly; in watts a photon of the dim light would have
// been far below RGB9E5's smallest step (2^-29 W) and one of the bright light far above its clamp.
TEST(PhotonMaps, StoredPowersAreRelativeToThePowerUnit) {
    const float scales[] = {1.0f, std::ldexp(1.0f, -40), std::ldexp(1.0f, 40)};
    std::vector<std::unique_ptr<PhotonMaps>> maps;
    std::vector<Vec3> flux;
    std::vector<std::unique_ptr<Scene>> scenes;       // EmbreeScene keeps a reference
    std::vector<std::unique_ptr<EmbreeScene>> embree;  // the radiance queries below take it
    for (float scale : scales) {
        scenes.push_back(std::make_unique<Scene>(causticScene(scale)));
        embree.push_back(std::make_unique<EmbreeScene>(*scenes.back()));
        const EmbreeScene& es = *embree.back();
        Vec3 f(0.0f);
        for (const Emitter& e : buildEmitters(es)) f += e.flux;
        flux.push_back(f);
        PhotonSettings ps;
        ps.photonsPerBatch = 4000;
        ps.diffuseBounces = 0;
        ps.capPhotons = 0;
        maps.push_back(std::make_unique<PhotonMaps>(ps, std::vector<uint32_t>{0}));
        EXPECT_EQ(maps.back()->powerUnit(), 1.0f);  // before the first batch
        maps.back()->shootBatch(es, 0);
        maps.back()->shootBatch(es, 0);
    }
    const std::vector<Photon> reference = maps[0]->photons(0);
    ASSERT_GT(reference.size(), 500u);
    // Largest channel of any stored photon: below 2 units (the unit is the largest path power
    // rounded down to a power of two, and a path's power never grows).
    float largest = 0.0f;
    for (const Photon& p : reference) {
        const Vec3 c = p.powerRgb();
        largest = std::max({largest, c.x, c.y, c.z});
    }
    EXPECT_LT(largest, 2.0f);
    EXPECT_GT(largest, 0.25f);
    for (size_t i = 1; i < maps.size(); ++i) {
        EXPECT_EQ(maps[i]->powerUnit(), maps[0]->powerUnit() * scales[i]);
        const std::vector<Photon> photons = maps[i]->photons(0);
        ASSERT_EQ(photons.size(), reference.size());
        for (size_t j = 0; j < photons.size(); ++j) {
            ASSERT_EQ(photons[j].power, reference[j].power) << "scale " << scales[i];
            ASSERT_EQ(photons[j].position, reference[j].position);
        }
        // Energy: with no diffuse bounce a path stores at most once.
        const Vec3 stored = maps[i]->storedPowerPerBatch(0);
        for (int c = 0; c < 3; ++c) {
            EXPECT_GT(stored[c], 0.0f);
            EXPECT_LE(stored[c], flux[i][c]);
            EXPECT_FLOAT_EQ(stored[c], maps[0]->storedPowerPerBatch(0)[c] * scales[i]);
        }
        SurfaceHit hit;
        hit.position = Vec3(-0.4f, 0.0f, 0.0f);  // under the slab
        hit.geometricNormal = hit.shadingNormal = Vec3(0.0f, 1.0f, 0.0f);
        const Vec3 l0 = maps[0]->radiance(*embree[0], 0, hit, hit.shadingNormal, Vec3(0.5f));
        const Vec3 li = maps[i]->radiance(*embree[i], 0, hit, hit.shadingNormal, Vec3(0.5f));
        ASSERT_GT(l0.x, 0.0f);
        for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(li[c], l0[c] * scales[i]);
    }
    // Photon powers in watts undo the unit.
    const Vec3 w = maps[2]->powerWatts(maps[2]->photons(0)[0]);
    EXPECT_FLOAT_EQ(w.x, reference[0].powerRgb().x * maps[0]->powerUnit() * scales[2]);
}

TEST(PhotonMaps, TreeNamesRoundTripAndUnknownNamesAreRefused) {
    for (PhotonTree t : {PhotonTree::MiddleSplit, PhotonTree::MedianBalanced, PhotonTree::UniformGrid})
        EXPECT_EQ(parsePhotonTree(photonTreeName(t)), t);
    EXPECT_FALSE(parsePhotonTree("kd").has_value());
    EXPECT_FALSE(parsePhotonTree("").has_value());
    EXPECT_FALSE(parsePhotonTree("Middle").has_value());
}

TEST(GridResolution, CellsAreAtMostRMaxAndTheTableStaysSmall) {
    const uint32_t kMax = PhotonGrid::kMaxResolution;
    const auto cells = [](uint32_t res, Vec3 e) {
        const double cell = std::max({e.x, e.y, e.z}) / double(res);
        double n = 1.0;
        for (int a = 0; a < 3; ++a) n *= std::clamp(std::ceil(double(e[a]) / cell), 1.0, double(res));
        return n;
    };
    // Flat photon bounds (a floor caustic): the table allows cells of rMax.
    EXPECT_EQ(gridResolution(100000, Vec3(10.0f, 0.0f, 10.0f), 64, 0.2f), 50u);
    // Many photons: cells shrink until about k photons per cell of a face (√(n/k)).
    EXPECT_EQ(gridResolution(4'000'000, Vec3(10.0f, 0.0f, 10.0f), 64, 0.2f), 250u);
    EXPECT_EQ(gridResolution(40'000'000, Vec3(10.0f, 0.0f, 10.0f), 64, 0.2f), kMax);
    // Cubic bounds: the table is limited to max(2n, 4096) cells.
    for (uint64_t n : {0ull, 1000ull, 100000ull, 2000000ull, 50000000ull}) {
        const Vec3 e(5.0f, 5.0f, 5.0f);
        const uint32_t r = gridResolution(n, e, 64, 0.05f);
        EXPECT_GE(r, 1u);
        EXPECT_LE(r, kMax);
        EXPECT_LE(cells(r, e), std::max(2.0 * double(n), 4096.0)) << n;
        if (r < kMax) {  // the largest resolution that fits
            EXPECT_GT(cells(r + 1, e), std::max(2.0 * double(n), 4096.0)) << n;
        }
    }
    EXPECT_LE(gridResolution(1ull << 40, Vec3(1.0f, 0.0f, 0.0f), 1, 1e-9f), kMax);
    // Degenerate bounds and radii.
    EXPECT_EQ(gridResolution(10, Vec3(0.0f), 64, 0.1f), 1u);
    EXPECT_EQ(gridResolution(10, Vec3(std::nanf("")), 64, 0.1f), 1u);
    EXPECT_GE(gridResolution(10, Vec3(1.0f), 0, 0.0f), 1u);
}

}  // namespace
}  // namespace rtpm
