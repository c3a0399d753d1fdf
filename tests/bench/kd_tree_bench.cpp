// Photon index benchmarks (paper Table 5): build and kNN of middle/median kd-trees, grid, nanoflann.
//
// Run: build-*/tests/bench/kd_tree_bench --benchmark_counters_tabular=true
// Every photon set comes from makePhotonSet(); to measure real RING/GLASS maps, replace its body
// by a loader. Queries are a 640×480 raster over the lit region of the plane, in scan order
// (as a frame queries them), single-threaded like the paper's Pentium-4 numbers.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include <nanoflann.hpp>

#include "common/kd_tree.h"
#include "common/median_kd_tree.h"
#include "common/photon_grid.h"

namespace rtpm {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr uint32_t kLeafSize = KdTree::kDefaultLeafSize;
constexpr float kMaxRadius = 0.1f;  // m: the density estimate's r_max for these scenes
constexpr int kImageWidth = 640, kImageHeight = 480;
// Scene bounds the photon map's root box is given (a 4 m floor, 1.5 m of room above it).
const Bounds kSceneBounds{Vec3(-2.0f, -2.0f, 0.0f), Vec3(2.0f, 2.0f, 1.5f)};

/// Synthetic caustic-like photon map on the floor z = 0: 65 % on a sharp nephroid (the caustic
/// of a ring lit from the side, σ = 4 mm across the curve, denser near the cusps as a real
/// caustic is), 25 % spread over its interior, 10 % sparse background over the whole floor.
std::vector<Photon> makePhotonSet(size_t count, uint32_t seed = 1) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::normal_distribution<float> across(0.0f, 0.004f);
    const float a = 0.2f;  // nephroid x = a(3cos t − cos 3t), y = a(3 sin t − sin 3t): ~1.6 m wide
    std::vector<Photon> out;
    out.reserve(count);
    const Vec3 down(0.0f, 0.0f, -1.0f);
    for (size_t i = 0; i < count; ++i) {
        const float pick = u(rng);
        Vec3 p;
        if (pick < 0.65f) {
            // Sample t with extra weight near the cusps (t = 0, π), where flux concentrates.
            float t = u(rng) * 2.0f * kPi;
            t += 0.35f * std::sin(2.0f * t);
            p = Vec3(a * (3 * std::cos(t) - std::cos(3 * t)), a * (3 * std::sin(t) - std::sin(3 * t)), 0);
            p.x += across(rng);
            p.y += across(rng);
        } else if (pick < 0.9f) {
            const float r = 0.55f * std::sqrt(u(rng)), phi = 2.0f * kPi * u(rng);
            p = Vec3(r * std::cos(phi) * 1.4f, r * std::sin(phi), 0.0f);
        } else {
            p = Vec3(-2.0f + 4.0f * u(rng), -2.0f + 4.0f * u(rng), 0.0f);
        }
        out.push_back(Photon::make(p, Vec3(1e-3f), down));
    }
    return out;
}

std::vector<Vec3> makeQueries() {
    // The image looks straight down at a 1.6 m × 1.2 m window around the caustic.
    std::vector<Vec3> q;
    q.reserve(size_t(kImageWidth) * kImageHeight);
    for (int y = 0; y < kImageHeight; ++y)
        for (int x = 0; x < kImageWidth; ++x)
            q.push_back(Vec3(-0.8f + 1.6f * (x + 0.5f) / kImageWidth,
                             0.6f - 1.2f * (y + 0.5f) / kImageHeight, 0.0f));
    return q;
}

const std::vector<Photon>& photonSet(size_t n) {
    static std::vector<std::pair<size_t, std::unique_ptr<std::vector<Photon>>>> cache;
    for (auto& [size, set] : cache)
        if (size == n) return *set;
    cache.emplace_back(n, std::make_unique<std::vector<Photon>>(makePhotonSet(n)));
    return *cache.back().second;
}

const std::vector<Vec3>& queries() {
    static const std::vector<Vec3> q = makeQueries();
    return q;
}

// ---- nanoflann over the same photons -------------------------------------------------------

struct PhotonCloud {
    const std::vector<Photon>* photons;
    size_t kdtree_get_point_count() const { return photons->size(); }
    float kdtree_get_pt(size_t i, size_t dim) const { return (*photons)[i].position[int(dim)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const { return false; }
};
using NanoTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, PhotonCloud>, PhotonCloud, 3, uint32_t>;

// Our bounded heap with r_max behind nanoflann's result-set interface, so both trees answer the
// identical query (nanoflann 1.4's KNNResultSet has no radius bound).
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

void BM_BuildMiddle(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    KdTree tree(kSceneBounds, kLeafSize);
    for (auto _ : state) {
        tree.build(photons);
        benchmark::DoNotOptimize(tree.nodeCount());
    }
    setPhotonCounters(state, photons.size(), tree.memoryBytes());
    state.counters["depth"] = tree.depth();
}

void BM_BuildMedian(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    MedianKdTree tree(kLeafSize);
    for (auto _ : state) {
        tree.build(photons);
        benchmark::DoNotOptimize(tree.nodeCount());
    }
    setPhotonCounters(state, photons.size(), tree.memoryBytes());
}

void BM_BuildGrid(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    PhotonGrid grid(uint32_t(state.range(1)));
    for (auto _ : state) {
        grid.build(photons);
        benchmark::DoNotOptimize(grid.size());
    }
    setPhotonCounters(state, photons.size(), grid.memoryBytes());
}

void BM_BuildNanoflann(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    PhotonCloud cloud{&photons};
    size_t bytes = 0;
    for (auto _ : state) {
        NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
        benchmark::DoNotOptimize(tree.root_node);
        bytes = tree.usedMemory(tree) + photons.size() * sizeof(Photon);
    }
    setPhotonCounters(state, photons.size(), bytes);
}

// Full 640×480 frame of kNN queries with r_max; reports the mean photons found as a sanity check
// that every structure answered the same thing.
template <class Index>
void runQueries(benchmark::State& state, const Index& index, uint32_t k) {
    KnnHeap heap(k);
    uint64_t found = 0;
    for (auto _ : state) {
        found = 0;
        for (const Vec3 q : queries()) {
            index.knn(q, k, kMaxRadius * kMaxRadius, heap);
            found += heap.size();
        }
        benchmark::DoNotOptimize(found);
    }
    state.counters["found/query"] = double(found) / double(queries().size());
    state.counters["Mquery/s"] = benchmark::Counter(double(queries().size()) * state.iterations() / 1e6,
                                                    benchmark::Counter::kIsRate);
}

void BM_QueryMiddle(benchmark::State& state) {
    KdTree tree(kSceneBounds, kLeafSize);
    tree.build(photonSet(size_t(state.range(0))));
    runQueries(state, tree, uint32_t(state.range(1)));
}

void BM_QueryMiddleIncremental(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    KdTree tree(kSceneBounds, kLeafSize);
    const size_t batch = (photons.size() + 9) / 10;
    for (size_t first = 0; first < photons.size(); first += batch)
        tree.insert(std::span<const Photon>(photons).subspan(first, std::min(batch, photons.size() - first)));
    runQueries(state, tree, uint32_t(state.range(1)));
}

void BM_QueryMedian(benchmark::State& state) {
    MedianKdTree tree(kLeafSize);
    tree.build(photonSet(size_t(state.range(0))));
    runQueries(state, tree, uint32_t(state.range(1)));
}

void BM_QueryGrid(benchmark::State& state) {
    PhotonGrid grid(uint32_t(state.range(2)));
    grid.build(photonSet(size_t(state.range(0))));
    runQueries(state, grid, uint32_t(state.range(1)));
}

void BM_QueryNanoflann(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    PhotonCloud cloud{&photons};
    NanoTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
    const uint32_t k = uint32_t(state.range(1));
    KnnHeap heap(k);
    uint64_t found = 0;
    for (auto _ : state) {
        found = 0;
        for (const Vec3 q : queries()) {
            heap.reset(k, kMaxRadius * kMaxRadius);
            NanoHeapAdaptor result{heap};
            const float p[3] = {q.x, q.y, q.z};
            tree.findNeighbors(result, p, nanoflann::SearchParams());
            found += heap.size();
        }
        benchmark::DoNotOptimize(found);
    }
    state.counters["found/query"] = double(found) / double(queries().size());
    state.counters["Mquery/s"] = benchmark::Counter(double(queries().size()) * state.iterations() / 1e6,
                                                    benchmark::Counter::kIsRate);
}

// Accumulation (paper §5.4): ten frames each adding n/10 photons. "Insert" grows one tree;
// "Rebuild" builds a tree from scratch over everything accumulated so far, every frame.
void BM_AccumulateInsert(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    const size_t batch = (photons.size() + 9) / 10;
    size_t bytes = 0;
    for (auto _ : state) {
        KdTree tree(kSceneBounds, kLeafSize);
        for (size_t first = 0; first < photons.size(); first += batch)
            tree.insert(std::span<const Photon>(photons).subspan(first, std::min(batch, photons.size() - first)));
        benchmark::DoNotOptimize(tree.nodeCount());
        bytes = tree.memoryBytes();
    }
    setPhotonCounters(state, photons.size(), bytes);
}

void BM_AccumulateRebuild(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    const size_t batch = (photons.size() + 9) / 10;
    for (auto _ : state) {
        KdTree tree(kSceneBounds, kLeafSize);
        for (size_t end = batch; end < photons.size() + batch; end += batch) {
            tree.build(std::span<const Photon>(photons).first(std::min(end, photons.size())));
            benchmark::DoNotOptimize(tree.nodeCount());
        }
    }
    setPhotonCounters(state, photons.size(), 0);
}

void BM_AccumulateRebuildNanoflann(benchmark::State& state) {
    const auto& photons = photonSet(size_t(state.range(0)));
    const size_t batch = (photons.size() + 9) / 10;
    for (auto _ : state) {
        for (size_t end = batch; end < photons.size() + batch; end += batch) {
            std::vector<Photon> sofar(photons.begin(), photons.begin() + std::min(end, photons.size()));
            PhotonCloud cloud{&sofar};
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
    for (int64_t n : kSizes) {
        benchmark::RegisterBenchmark("build/middle", BM_BuildMiddle)->Arg(n)->Unit(kMillisecond);
        benchmark::RegisterBenchmark("build/median", BM_BuildMedian)->Arg(n)->Unit(kMillisecond);
        benchmark::RegisterBenchmark("build/nanoflann", BM_BuildNanoflann)->Arg(n)->Unit(kMillisecond);
        for (int64_t res : {64, 256})
            benchmark::RegisterBenchmark("build/grid", BM_BuildGrid)->Args({n, res})->Unit(kMillisecond);
    }
    for (int64_t n : kSizes) {
        for (int64_t k : kKs) {
            benchmark::RegisterBenchmark("knn/middle", BM_QueryMiddle)->Args({n, k})->Unit(kMillisecond);
            benchmark::RegisterBenchmark("knn/middle-incremental", BM_QueryMiddleIncremental)
                ->Args({n, k})->Unit(kMillisecond);
            benchmark::RegisterBenchmark("knn/median", BM_QueryMedian)->Args({n, k})->Unit(kMillisecond);
            benchmark::RegisterBenchmark("knn/nanoflann", BM_QueryNanoflann)->Args({n, k})->Unit(kMillisecond);
            for (int64_t res : {64, 256})
                benchmark::RegisterBenchmark("knn/grid", BM_QueryGrid)->Args({n, k, res})->Unit(kMillisecond);
        }
    }
    for (int64_t n : kSizes) {
        benchmark::RegisterBenchmark("accumulate10/insert", BM_AccumulateInsert)->Arg(n)->Unit(kMillisecond);
        benchmark::RegisterBenchmark("accumulate10/rebuild", BM_AccumulateRebuild)->Arg(n)->Unit(kMillisecond);
        benchmark::RegisterBenchmark("accumulate10/rebuild-nanoflann", BM_AccumulateRebuildNanoflann)
            ->Arg(n)->Unit(kMillisecond);
    }
}

}  // namespace
}  // namespace rtpm

int main(int argc, char** argv) {
    rtpm::registerAll();
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
