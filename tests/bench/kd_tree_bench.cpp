// Photon index benchmarks (paper Table 5): build and kNN of middle/median kd-trees, grid, nanoflann
// on the real caustic photon maps of the built-in RING and GLASS scenes.
//
// Run: build-*/tests/bench/kd_tree_bench --benchmark_counters_tabular=true
//
// Photons: PhotonMaps (SPT, default settings) shoots batches into interleaving set 0 of the scene
// until ≥ 320 000 caustic photons are stored; that pool is shuffled (fixed seed) and the 25k /
// 100k / 320k sets are its first n photons, i.e. uniform subsamples of one real map (the same
// distribution a map of n photons has). Queries: one per pixel of the scene camera's 640×480
// image in scan order (as a frame issues them): the first diffuse hit of the primary ray, found
// by following the specular chain (mirror: reflect; dielectric: refract, reflect on total internal
// reflection — the transmitted branch is the one that looks at the caustic), at most 8 bounces;
// pixels that miss or never reach a diffuse surface issue no query. rMax is the renderer's
// automatic gather radius (2 % of the scene diagonal). Single-threaded, like the paper's numbers.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <nanoflann.hpp>

#include "common/trace/embree_scene.h"
#include "common/photon/density.h"
#include "common/photon/group_gather.h"
#include "common/photon/kd_tree.h"
#include "common/photon/median_kd_tree.h"
#include "common/trace/optics.h"
#include "common/photon/photon_grid.h"
#include "common/photon/photon_map.h"
#include "common/scene/scene_loader.h"
#include "tests/bench/bench_util.h"

namespace rtpm {
namespace {

constexpr uint32_t kLeafSize = KdTree::kDefaultLeafSize;
// Under the smoke switch (bench_util.h) a pool of 2 000 photons and a 64×48 image: every size
// then takes the whole pool.
const int kImageWidth = bench::sized(640, 64), kImageHeight = bench::sized(480, 48);
const size_t kPoolSize = bench::sized<size_t>(320000, 2000);
constexpr int kMaxSpecularBounces = 8;

/// One scene's photon pool and query points, built once per process.
struct PhotonScene {
    Scene scene;
    std::unique_ptr<EmbreeScene> embree;
    Bounds bounds;                ///< root box the photon maps get (scene bounds)
    float rMax = 0.0f;            ///< m
    std::vector<Photon> pool;     ///< ≥ kPoolSize photons of one map, shuffled
    std::vector<Vec3> queries;    ///< diffuse hits in scan order
    std::vector<Vec3> normals;    ///< their shading normals, facing the arriving ray
    uint32_t batches = 0;
};

// First diffuse hit along the camera ray of pixel (x, y), following specular surfaces.
bool diffuseHit(const EmbreeScene& es, const Camera& camera, int x, int y, Vec3& out,
                Vec3& normal) {
    Ray ray{camera.position, camera.rayDirection(x, y, kImageWidth, kImageHeight)};
    for (int bounce = 0; bounce <= kMaxSpecularBounces; ++bounce) {
        SurfaceHit hit;
        if (!es.intersect(ray, hit)) return false;
        const Material& mat = es.scene().materials[hit.material];
        if (mat.type == MaterialType::Diffuse) {
            out = hit.position;
            normal = glm::dot(ray.dir, hit.geometricNormal) > 0.0f ? -hit.shadingNormal
                                                                    : hit.shadingNormal;
            return true;
        }
        const Vec3 dir = glm::normalize(ray.dir);
        const Vec3 ng = glm::dot(dir, hit.geometricNormal) > 0.0f ? -hit.geometricNormal
                                                                   : hit.geometricNormal;
        Vec3 next = glm::normalize(reflect(dir, ng));
        if (mat.type == MaterialType::Dielectric) {
            const DielectricInterface side = dielectricInterface(dir, hit.geometricNormal, mat.ior);
            Vec3 t;
            if (refract(dir, side.normal, side.etaI / side.etaT, t)) next = t;
        }
        ray = Ray{es.offsetOrigin(hit.position, ng, next), next};
    }
    return false;
}

const PhotonScene& photonScene(const std::string& name) {
    static std::map<std::string, std::unique_ptr<PhotonScene>> cache;
    auto& slot = cache[name];
    if (slot) return *slot;
    slot = std::make_unique<PhotonScene>();
    PhotonScene& s = *slot;
    s.scene = loadScene(name);
    s.embree = std::make_unique<EmbreeScene>(s.scene);
    s.bounds = s.embree->bounds();
    PhotonSettings settings;
    settings.capPhotons = 0;
    PhotonMaps maps(settings, {0});
    while (maps.index<KdTree>(0) == nullptr || maps.index<KdTree>(0)->size() < kPoolSize) {
        maps.shootBatch(*s.embree, 0);
        if (++s.batches > 5000) {
            std::fprintf(stderr, "%s: only %zu caustic photons after %u batches\n", name.c_str(),
                         maps.index<KdTree>(0)->size(), s.batches);
            std::exit(1);
        }
    }
    s.rMax = maps.gatherRadius();
    for (const Photon& p : maps.index<KdTree>(0)->photons()) s.pool.push_back(p);
    std::shuffle(s.pool.begin(), s.pool.end(), std::mt19937(20040621));
    const Camera camera = *s.scene.camera;
    for (int y = 0; y < kImageHeight; ++y)
        for (int x = 0; x < kImageWidth; ++x) {
            Vec3 p, n;
            if (diffuseHit(*s.embree, camera, x, y, p, n)) {
                s.queries.push_back(p);
                s.normals.push_back(n);
            }
        }
    std::fprintf(stderr, "%s: %zu photons after %u batches, rMax %.4f m, %zu queries\n",
                 name.c_str(), s.pool.size(), s.batches, double(s.rMax), s.queries.size());
    return s;
}

std::span<const Photon> photonSet(const PhotonScene& s, size_t n) {
    return std::span<const Photon>(s.pool).first(std::min(n, s.pool.size()));
}

// ---- nanoflann over the same photons -------------------------------------------------------

struct PhotonCloud {
    std::span<const Photon> photons;
    size_t kdtree_get_point_count() const { return photons.size(); }
    float kdtree_get_pt(size_t i, size_t dim) const { return photons[i].position[int(dim)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const { return false; }
};
using NanoTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, PhotonCloud>, PhotonCloud, 3, uint32_t>;

// Our bounded heap with r_max behind nanoflann's result-set interface, so both trees answer the
// identical query with the identical result set (nanoflann 1.4's KNNResultSet has no radius
// bound): the ratio measures the trees, not the heaps.
struct NanoHeapAdaptor {
    KnnHeap& heap;
    float worstDist() const { return heap.worstDist2(); }
    bool full() const { return heap.full(); }
    bool addPoint(float d2, uint32_t i) {
        heap.add(d2, i);
        return true;
    }
};

// ---- benchmarks ----------------------------------------------------------------------------

void setPhotonCounters(benchmark::State& state, size_t photons, size_t bytes) {
    state.counters["photons"] = double(photons);
    state.counters["B/photon"] = double(bytes) / double(photons);
}

void buildMiddle(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    const auto photons = photonSet(s, size_t(state.range(0)));
    KdTree tree(s.bounds, kLeafSize);
    for (auto _ : state) {
        tree.build(photons);
        benchmark::DoNotOptimize(tree.nodeCount());
    }
    setPhotonCounters(state, photons.size(), tree.memoryBytes());
    state.counters["depth"] = tree.depth();
}

void buildMedian(benchmark::State& state, const std::string& scene) {
    const auto photons = photonSet(photonScene(scene), size_t(state.range(0)));
    MedianKdTree tree(kLeafSize);
    for (auto _ : state) {
        tree.build(photons);
        benchmark::DoNotOptimize(tree.nodeCount());
    }
    setPhotonCounters(state, photons.size(), tree.memoryBytes());
}

void buildGrid(benchmark::State& state, const std::string& scene) {
    const auto photons = photonSet(photonScene(scene), size_t(state.range(0)));
    PhotonGrid grid(uint32_t(state.range(1)));
    for (auto _ : state) {
        grid.build(photons);
        benchmark::DoNotOptimize(grid.size());
    }
    setPhotonCounters(state, photons.size(), grid.memoryBytes());
}

void buildNanoflann(benchmark::State& state, const std::string& scene) {
    const auto photons = photonSet(photonScene(scene), size_t(state.range(0)));
    PhotonCloud cloud{photons};
    size_t bytes = 0;
    for (auto _ : state) {
        NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
        benchmark::DoNotOptimize(tree.root_node);
        bytes = tree.usedMemory(tree) + photons.size() * sizeof(Photon);
    }
    setPhotonCounters(state, photons.size(), bytes);
}

void setQueryCounters(benchmark::State& state, const PhotonScene& s, uint64_t found) {
    state.counters["found/query"] = double(found) / double(s.queries.size());
    state.counters["Mquery/s"] = benchmark::Counter(
        double(s.queries.size()) * double(state.iterations()) / 1e6, benchmark::Counter::kIsRate);
}

// One frame of kNN queries with r_max; "found/query" checks every index answered the same.
template <class Index>
void runQueries(benchmark::State& state, const PhotonScene& s, const Index& index, uint32_t k) {
    KnnHeap heap(k);
    uint64_t found = 0;
    const float maxDist2 = s.rMax * s.rMax;
    for (auto _ : state) {
        found = 0;
        for (const Vec3 q : s.queries) {
            knnSearch(index, q, k, maxDist2, heap);
            found += heap.size();
        }
        benchmark::DoNotOptimize(found);
    }
    setQueryCounters(state, s, found);
}

void queryMiddle(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    KdTree tree(s.bounds, kLeafSize);
    tree.build(photonSet(s, size_t(state.range(0))));
    runQueries(state, s, tree, uint32_t(state.range(1)));
}

// One frame of the renderer's gather (density.h causticRadiance: k-NN within rMax skipping
// photons from behind the shading normal, then the power sum): what a pixel pays, per query.
void gatherMiddle(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    KdTree tree(s.bounds, kLeafSize);
    tree.build(photonSet(s, size_t(state.range(0))));
    const uint32_t k = uint32_t(state.range(1));
    KnnHeap heap(k);
    uint64_t found = 0, none = 0;
    Vec3 sum(0.0f);
    for (auto _ : state) {
        found = none = 0;
        for (size_t i = 0; i < s.queries.size(); ++i) {
            sum += causticRadiance(tree, s.queries[i], s.normals[i], Vec3(0.8f), k, s.rMax, 1.0f,
                                   heap);
            found += heap.size();
            none += heap.empty() ? 1 : 0;
        }
        benchmark::DoNotOptimize(sum);
    }
    setQueryCounters(state, s, found);
    state.counters["none/query"] = double(none) / double(s.queries.size());
}

// The same frame of gathers as the renderer now issues them (group_gather.h): 8 consecutive
// queries of the scan order share one radius search, each group guessing its radius from the
// previous group's largest r_k² of a full gather (× kGuessScale, as PhotonMaps::radianceGroup). Same photons and power per
// query as gather/middle ("found/query" and the radiance sum agree).
void gatherGroupMiddle(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    KdTree tree(s.bounds, kLeafSize);
    tree.build(photonSet(s, size_t(state.range(0))));
    const uint32_t k = uint32_t(state.range(1));
    std::vector<GatherQuery> queries(s.queries.size());
    for (size_t i = 0; i < queries.size(); ++i) queries[i] = GatherQuery{s.queries[i], s.normals[i]};
    GroupGatherScratch scratch;
    DensityGather gathers[8];
    uint64_t found = 0, none = 0;
    Vec3 sum(0.0f);
    for (auto _ : state) {
        found = none = 0;
        float hint2 = 0.0f;
        for (size_t q0 = 0; q0 < queries.size(); q0 += 8) {
            const size_t n = std::min<size_t>(8, queries.size() - q0);
            gatherKnnGroup(tree, std::span(queries).subspan(q0, n), k, s.rMax, kGuessScale * hint2, scratch,
                           std::span(gathers, n));
            hint2 = 0.0f;
            for (size_t i = 0; i < n; ++i) {
                sum += causticRadianceFrom(gathers[i], Vec3(0.8f), 1.0f);
                found += gathers[i].count;
                none += gathers[i].count == 0 ? 1 : 0;
                if (gathers[i].count == k) hint2 = std::max(hint2, gathers[i].radius2);
            }
        }
        benchmark::DoNotOptimize(sum);
    }
    setQueryCounters(state, s, found);
    state.counters["none/query"] = double(none) / double(s.queries.size());
}

// Ten equal batches inserted into one tree, as accumulation builds a map (paper §5.4).
void insertInTenBatches(KdTree& tree, std::span<const Photon> photons) {
    const size_t batch = (photons.size() + 9) / 10;
    for (size_t first = 0; first < photons.size(); first += batch)
        tree.insert(photons.subspan(first, std::min(batch, photons.size() - first)));
}

void queryMiddleIncremental(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    KdTree tree(s.bounds, kLeafSize);
    insertInTenBatches(tree, photonSet(s, size_t(state.range(0))));
    runQueries(state, s, tree, uint32_t(state.range(1)));
}

void queryMedian(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    MedianKdTree tree(kLeafSize);
    tree.build(photonSet(s, size_t(state.range(0))));
    runQueries(state, s, tree, uint32_t(state.range(1)));
}

void queryGrid(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    PhotonGrid grid(uint32_t(state.range(2)));
    grid.build(photonSet(s, size_t(state.range(0))));
    runQueries(state, s, grid, uint32_t(state.range(1)));
}

void queryNanoflann(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    PhotonCloud cloud{photonSet(s, size_t(state.range(0)))};
    NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
    const uint32_t k = uint32_t(state.range(1));
    const float maxDist2 = s.rMax * s.rMax;
    KnnHeap heap(k);
    uint64_t found = 0;
    for (auto _ : state) {
        found = 0;
        for (const Vec3 q : s.queries) {
            heap.reset(k, maxDist2);
            NanoHeapAdaptor result{heap};
            const float p[3] = {q.x, q.y, q.z};
            tree.findNeighbors(result, p, nanoflann::SearchParams());
            found += heap.size();
        }
        benchmark::DoNotOptimize(found);
    }
    setQueryCounters(state, s, found);
}

// Accumulation (paper §5.4): ten frames each adding n/10 photons. "insert" grows one tree;
// "rebuild" builds a tree from scratch over everything accumulated so far, every frame.
void accumulateInsert(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    const auto photons = photonSet(s, size_t(state.range(0)));
    size_t bytes = 0;
    for (auto _ : state) {
        KdTree tree(s.bounds, kLeafSize);
        insertInTenBatches(tree, photons);
        benchmark::DoNotOptimize(tree.nodeCount());
        bytes = tree.memoryBytes();
    }
    setPhotonCounters(state, photons.size(), bytes);
}

void accumulateRebuild(benchmark::State& state, const std::string& scene) {
    const PhotonScene& s = photonScene(scene);
    const auto photons = photonSet(s, size_t(state.range(0)));
    const size_t batch = (photons.size() + 9) / 10;
    size_t bytes = 0;
    for (auto _ : state) {
        KdTree tree(s.bounds, kLeafSize);
        for (size_t end = batch; end < photons.size() + batch; end += batch) {
            tree.build(photons.first(std::min(end, photons.size())));
            benchmark::DoNotOptimize(tree.nodeCount());
        }
        bytes = tree.memoryBytes();
    }
    setPhotonCounters(state, photons.size(), bytes);
}

void accumulateRebuildNanoflann(benchmark::State& state, const std::string& scene) {
    const auto photons = photonSet(photonScene(scene), size_t(state.range(0)));
    const size_t batch = (photons.size() + 9) / 10;
    for (auto _ : state) {
        for (size_t end = batch; end < photons.size() + batch; end += batch) {
            PhotonCloud cloud{photons.first(std::min(end, photons.size()))};
            NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
            benchmark::DoNotOptimize(tree.root_node);
        }
    }
    setPhotonCounters(state, photons.size(), 0);
}

const std::vector<int64_t> kSizes = {25000, 100000, 320000};
const std::vector<int64_t> kKs = {50, 64, 100};

void registerAll() {
    using benchmark::kMillisecond;
    using Fn = void (*)(benchmark::State&, const std::string&);
    const auto reg = [](const std::string& name, const std::string& scene, Fn fn) {
        benchmark::internal::Benchmark* b =
            benchmark::RegisterBenchmark((name + "/" + scene).c_str(), fn, scene)->Unit(kMillisecond);
        bench::smokeOnce(b);
        return b;
    };
    for (const std::string scene : {"RING", "GLASS"}) {
        for (int64_t n : kSizes) {
            reg("build/middle", scene, buildMiddle)->Arg(n);
            reg("build/median", scene, buildMedian)->Arg(n);
            reg("build/nanoflann", scene, buildNanoflann)->Arg(n);
            for (int64_t res : {64, 256}) reg("build/grid", scene, buildGrid)->Args({n, res});
        }
        for (int64_t n : kSizes) {
            for (int64_t k : kKs) {
                reg("knn/middle", scene, queryMiddle)->Args({n, k});
                reg("gather/middle", scene, gatherMiddle)->Args({n, k});
                reg("gather-group/middle", scene, gatherGroupMiddle)->Args({n, k});
                reg("knn/middle-incremental", scene, queryMiddleIncremental)->Args({n, k});
                reg("knn/median", scene, queryMedian)->Args({n, k});
                reg("knn/nanoflann", scene, queryNanoflann)->Args({n, k});
                for (int64_t res : {64, 256}) reg("knn/grid", scene, queryGrid)->Args({n, k, res});
            }
        }
        for (int64_t n : kSizes) {
            reg("accumulate10/insert", scene, accumulateInsert)->Arg(n);
            reg("accumulate10/rebuild", scene, accumulateRebuild)->Arg(n);
            reg("accumulate10/rebuild-nanoflann", scene, accumulateRebuildNanoflann)->Arg(n);
        }
    }
}

}  // namespace
}  // namespace rtpm

int main(int argc, char** argv) {
    rtpm::registerAll();
    return rtpm::bench::runBenchmarks(argc, argv);
}
