// Per-set photon maps: plain or selective (SPT) batch shooting, power normalisation, accumulation.
//
// Power bookkeeping (paper-notes §5.5, §5.7; DESIGN §5). Every light l with a share P_l of the
// batch is estimated on its own, and every photon carries its own power (W, relative to one
// batch; the estimate divides by the number of batches; stored divided by the maps' power unit,
// a power of two near the largest path power, so the RGB9E5 code's fixed range is relative to
// the scene's photon powers rather than to 1 W):
//  * plain: indices [n_l, n_l + P_l) of its sequence, each path starts with Φ_l / P_l.
//  * SPT: the steering dims are cut into N_g = Π b_d^{k_d} elementary boxes; indices i and
//    i + m·N_g share a box. A batch traces one pilot per box (i + p·N_g, p = the batch's first
//    period, so every batch draws new points in the same boxes) and R refinements
//    i + (p+m)·N_g, m = 1…R, in each box of the refine set D. Each box carries Φ_l / N_g, shared
//    by its members: a path in a box of D starts with Φ_l / (N_g (1+R)), a pilot of a box outside
//    D with Φ_l / N_g (the plain estimate of that box).
//
// Unbiasedness. The classic rule "refine the boxes whose own pilot hit" weights a box that is a
// fraction f productive by P(pilot hits) · f = f²: it loses the caustic's borders and most of a
// generator smaller than a box (measured: −4 % of an indirect caustic). Here D is decided before
// the batch, from the *previous* batch's outcomes (every box with a productive pilot or
// refinement, plus — sptDilate — its face neighbours in box space). D is then independent of the
// batch's own points, every box is estimated by an equal-weight average of stratified points in
// it, and E[estimate] is the box's true caustic power for every box, in or out of D. D only
// steers where the paths go (the variance), never the mean. The first batch after a reset has no
// previous batch: it traces one extra pilot period for classification only (not stored).
#include "common/photon/photon_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/core/check.h"
#include "common/photon/density.h"

namespace rtpm {

namespace {

using Clock = std::chrono::steady_clock;

// Hash stream of light `emitter` in set `set`: its Halton rotation and its hashed numbers.
uint64_t streamOf(uint32_t set, const Emitter& e) {
    return hashKeys(set, e.id, static_cast<uint64_t>(e.kind), 0x4c49474854ull);
}

// True if some instance uses a mirror or dielectric: only then can a path store a caustic photon.
bool hasCausticGenerator(const Scene& s) {
    for (const Instance& inst : s.instances) {
        if (inst.mesh >= s.meshes.size()) continue;
        const uint32_t m = s.meshes[inst.mesh].material;
        if (m < s.materials.size() && s.materials[m].isSpecular()) return true;
    }
    return false;
}

// The photons of `old` followed by `batch`: the input of a from-scratch rebuild.
template <class Index>
std::vector<Photon> withBatch(const Index* old, const std::vector<Photon>& batch) {
    std::vector<Photon> all;
    all.reserve((old ? old->size() : 0) + batch.size());
    if (old) all.insert(all.end(), old->photons().begin(), old->photons().end());
    all.insert(all.end(), batch.begin(), batch.end());
    return all;
}

float maxChannel(Vec3 v) { return std::max({v.x, v.y, v.z}); }

}  // namespace

uint32_t gridResolution(uint64_t photons, Vec3 extent, uint32_t k, float rMax) {
    const double maxExtent = std::max({double(extent.x), double(extent.y), double(extent.z)});
    if (!(maxExtent > 0.0) || !std::isfinite(maxExtent)) return 1;
    double res = 1.0;
    if (rMax > 0.0f) res = std::max(res, std::ceil(maxExtent / double(rMax)));
    if (k > 0) res = std::max(res, std::ceil(std::sqrt(double(photons) / double(k))));
    uint32_t r = static_cast<uint32_t>(std::min(res, double(PhotonGrid::kMaxResolution)));
    const double maxCells = std::max(2.0 * double(photons), 4096.0);
    // Cell count as PhotonGrid::build computes it: ceil(side / cell) per axis, at least 1.
    const auto cells = [&](uint32_t n) {
        const double cell = maxExtent / double(n);
        double c = 1.0;
        for (int a = 0; a < 3; ++a) c *= std::clamp(std::ceil(double(extent[a]) / cell), 1.0, double(n));
        return c;
    };
    while (r > 1 && cells(r) > maxCells) --r;
    return r;
}

struct PhotonMaps::SetState {
    struct LightState {
        Halton halton{0, 0};
        uint64_t stream = 0;
        uint32_t budget = 0;
        DimLayout dims;
        SptGrid grid;
        std::vector<uint32_t> neighbours;
        uint64_t nextIndex = 0;   // plain: first index of the next batch
        uint64_t nextPeriod = 0;  // SPT: first period (in units of N_g) of the next batch
        std::vector<uint8_t> refine;  // SPT: the refine set D for the next batch, per box
        bool dilate = true;
    };
    uint32_t set = 0;
    // The one index of settings.tree; the others stay null.
    std::unique_ptr<KdTree> tree;
    std::unique_ptr<MedianKdTree> median;
    std::unique_ptr<PhotonGrid> grid;
    PhotonSetStats stats;
    std::vector<LightState> lights;
    bool planned = false;
    bool capped = false;

    // The refine set D for the next batch from this batch's outcomes: boxes with a productive
    // member (pilot i of N_g paths, then R refinements of each box in `refined`, in that order),
    // dilated by their face neighbours when enabled.
    static std::vector<uint8_t> classify(const LightState& ls, const std::vector<uint32_t>& stored,
                                         const std::vector<uint32_t>& refined, uint32_t r) {
        const uint64_t ng = ls.grid.cellCount;
        std::vector<uint8_t> hit(ng, 0);
        for (uint64_t i = 0; i < ng; ++i) hit[i] = stored[i] > 0;
        size_t path = ng;
        for (uint32_t cell : refined)
            for (uint32_t m = 0; m < r; ++m, ++path)
                if (stored[path] > 0) hit[cell] = 1;
        if (!ls.dilate) return hit;
        std::vector<uint8_t> out = hit;
        const size_t fan = 2 * static_cast<size_t>(ls.grid.dims);
        for (uint64_t i = 0; i < ng; ++i) {
            if (!hit[i]) continue;
            for (size_t j = 0; j < fan; ++j) out[ls.neighbours[i * fan + j]] = 1;
        }
        return out;
    }
};

PhotonMaps::PhotonMaps(const PhotonSettings& settings, std::vector<uint32_t> ownedSets)
    : settings_(settings), ownedSets_(std::move(ownedSets)) {
    for (uint32_t s : ownedSets_) {
        auto st = std::make_unique<SetState>();
        st->set = s;
        sets_.push_back(std::move(st));
    }
}

PhotonMaps::~PhotonMaps() = default;

PhotonMaps::SetState* PhotonMaps::find(uint32_t set) {
    for (auto& s : sets_)
        if (s->set == set) return s.get();
    return nullptr;
}

const PhotonMaps::SetState* PhotonMaps::find(uint32_t set) const {
    for (const auto& s : sets_)
        if (s->set == set) return s.get();
    return nullptr;
}

void PhotonMaps::reset() {
    for (auto& s : sets_) {
        const uint32_t id = s->set;
        *s = SetState{};
        s->set = id;
    }
    emitters_.clear();
    emittersReady_ = false;
    powerUnit_ = 1.0f;
}

bool PhotonMaps::capped(uint32_t set) const {
    const SetState* s = find(set);
    return s && s->capped;
}

bool PhotonMaps::walkthrough() const {
    if (sets_.empty()) return false;
    for (const auto& s : sets_)
        if (!s->capped) return false;
    return true;
}

const PhotonSetStats& PhotonMaps::stats(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    return s->stats;
}

const KdTree* PhotonMaps::tree(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    return s->tree.get();
}

const MedianKdTree* PhotonMaps::medianTree(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    return s->median.get();
}

const PhotonGrid* PhotonMaps::grid(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    return s->grid.get();
}

std::vector<Photon> PhotonMaps::photons(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    std::vector<Photon> out;
    if (s->tree) out.assign(s->tree->photons().begin(), s->tree->photons().end());
    if (s->median) out.assign(s->median->photons().begin(), s->median->photons().end());
    if (s->grid) out.assign(s->grid->photons().begin(), s->grid->photons().end());
    return out;
}

Vec3 PhotonMaps::storedPowerPerBatch(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    if (s->stats.batches == 0) return Vec3(0.0f);
    glm::dvec3 sum(0.0);
    for (const Photon& p : photons(set)) sum += glm::dvec3(p.powerRgb());
    return Vec3(sum * (double(powerUnit_) / double(s->stats.batches)));
}

void PhotonMaps::shootBatch(const EmbreeScene& scene, uint32_t set) {
    SetState* st = find(set);
    RTPM_CHECK(st != nullptr);
    scene_ = &scene;
    if (st->capped) return;
    if (!emittersReady_) {
        emitters_ = buildEmitters(scene);
        const float diag = scene.bounds().diagonal();
        rMax_ = settings_.rMax > 0.0f ? settings_.rMax : 0.02f * (diag > 0.0f ? diag : 1.0f);
        // The power unit: the largest initial path power of the first batch (the plan below is
        // the same for every set), rounded down to a power of two. A path's power never grows
        // (mirrors and glass reflect at most all of it, Russian roulette divides by the largest
        // channel's albedo), so stored values are < 2 units; SPT refinement weights (≥ 1/65),
        // absorption and colour only shrink them, and RGB9E5 keeps 2^-9 relative precision
        // down to 2^-20 units (photon.cpp) whatever the scene's scale in metres and watts.
        const std::vector<uint32_t> budget = splitBudget(emitters_, settings_.photonsPerBatch);
        float largest = 0.0f;
        for (size_t l = 0; l < emitters_.size(); ++l) {
            if (budget[l] == 0) continue;
            float paths = static_cast<float>(budget[l]);
            if (settings_.selective) {
                const DimLayout dims = dimLayout(emitters_[l].kind, settings_.diffuseBounces);
                const uint64_t target = settings_.sptCells > 0 ? settings_.sptCells
                                                               : std::max<uint64_t>(1, budget[l] / 4);
                paths = static_cast<float>(makeSptGrid(dims.count, target).cellCount);
            }
            largest = std::max(largest, maxChannel(emitters_[l].flux) / paths);
        }
        powerUnit_ = 1.0f;
        if (largest > 0.0f && std::isfinite(largest)) {
            int exp2 = 0;
            std::frexp(largest, &exp2);  // largest = f · 2^exp2, f in [0.5, 1)
            // Unit and 1/unit stay normal floats (so p / unit is exact and never overflows).
            powerUnit_ = std::ldexp(1.0f, std::clamp(exp2 - 1, -100, 100));
        }
        emittersReady_ = true;
    }
    if (!st->planned) {
        switch (settings_.tree) {
            case PhotonTree::MiddleSplit: st->tree = std::make_unique<KdTree>(scene.bounds()); break;
            case PhotonTree::MedianBalanced: st->median = std::make_unique<MedianKdTree>(); break;
            case PhotonTree::UniformGrid: st->grid = std::make_unique<PhotonGrid>(); break;
        }
        const std::vector<uint32_t> budget = splitBudget(emitters_, settings_.photonsPerBatch);
        st->lights.clear();
        for (size_t l = 0; l < emitters_.size(); ++l) {
            SetState::LightState ls;
            ls.stream = streamOf(set, emitters_[l]);
            ls.halton = Halton(settings_.seed, ls.stream);
            ls.budget = budget[l];
            ls.dims = dimLayout(emitters_[l].kind, settings_.diffuseBounces);
            if (settings_.selective && ls.budget > 0) {
                const uint64_t target = settings_.sptCells > 0 ? settings_.sptCells
                                                               : std::max<uint64_t>(1, ls.budget / 4);
                ls.grid = makeSptGrid(ls.dims.count, target);
                ls.dilate = settings_.sptDilate;
                if (ls.dilate) ls.neighbours = sptNeighbours(ls.grid);
            }
            st->lights.push_back(std::move(ls));
        }
        st->planned = true;
    }

    // Without a mirror or dielectric no path can store a photon: the batch traces nothing and the
    // set goes to walkthrough (below), instead of tracing its budget every frame up to the cap.
    const bool causticPossible = hasCausticGenerator(scene.scene());

    TraceSettings ts;
    ts.diffuseBounces = settings_.diffuseBounces;
    ts.maxDepth = settings_.maxDepth;
    ts.seed = settings_.seed;

    PhotonSetStats& stats = st->stats;
    TraceStats traced;
    std::vector<Photon> batch;
    uint64_t cellsTotal = 0, refinedTotal = 0;
    uint32_t maxR = 0;
    std::vector<uint64_t> indices;
    for (size_t l = 0; l < emitters_.size(); ++l) {
        SetState::LightState& ls = st->lights[l];
        if (ls.budget == 0 || !causticPossible) continue;
        const Emitter& e = emitters_[l];
        PhotonSource src;
        src.emitter = &e;
        src.halton = &ls.halton;
        src.hashStream = ls.stream;
        src.dims = ls.dims;
        TraceOutput out;
        if (!settings_.selective) {
            indices.resize(ls.budget);
            for (uint32_t i = 0; i < ls.budget; ++i) indices[i] = ls.nextIndex + i;
            ls.nextIndex += ls.budget;
            src.powerPerPath = e.flux / static_cast<float>(ls.budget);
            tracePhotons(scene, src, ts, indices, out);
        } else {
            const uint64_t ng = ls.grid.cellCount;
            uint64_t budget = ls.budget;
            if (ls.refine.empty()) {
                // First batch: classify with a pilot period of its own (not stored).
                indices.resize(ng);
                for (uint64_t i = 0; i < ng; ++i) indices[i] = ls.nextPeriod * ng + i;
                src.powerPerPath = e.flux / static_cast<float>(ng);
                TraceOutput probe;
                tracePhotons(scene, src, ts, indices, probe);
                traced.add(probe.stats);
                traced.productivePaths -= probe.stats.productivePaths;  // yield counts stored paths
                ls.refine = SetState::classify(ls, probe.storedPerPath, {}, 0);
                ls.nextPeriod += 1;
                budget = budget > ng ? budget - ng : 0;
            }
            std::vector<uint32_t> refined;
            for (uint64_t i = 0; i < ng; ++i)
                if (ls.refine[i]) refined.push_back(static_cast<uint32_t>(i));
            uint32_t r = 0;
            if (!refined.empty()) {
                if (settings_.sptRefinements > 0) {
                    r = settings_.sptRefinements;
                } else if (budget > ng) {
                    r = static_cast<uint32_t>(
                        std::min<uint64_t>(kMaxSptRefinements, (budget - ng) / refined.size()));
                }
            }
            const uint64_t base = ls.nextPeriod * ng;
            indices.resize(ng + refined.size() * r);
            for (uint64_t i = 0; i < ng; ++i) indices[i] = base + i;
            size_t j = ng;
            for (uint32_t cell : refined)
                for (uint32_t m = 1; m <= r; ++m) indices[j++] = base + m * ng + cell;
            // Trace with Φ_l / N_g, then scale the members of refined boxes by 1 / (1+R).
            src.powerPerPath = e.flux / static_cast<float>(ng);
            tracePhotons(scene, src, ts, indices, out);
            const float memberScale = 1.0f / static_cast<float>(1 + r);
            size_t photon = 0;
            for (size_t path = 0; path < indices.size(); ++path) {
                const uint32_t count = out.storedPerPath[path];
                const bool inRefined = path >= ng || ls.refine[path];
                if (inRefined && r > 0)
                    for (uint32_t q = 0; q < count; ++q) out.photons[photon + q].power *= memberScale;
                photon += count;
            }
            RTPM_CHECK(photon == out.photons.size());
            ls.refine = SetState::classify(ls, out.storedPerPath, refined, r);
            ls.nextPeriod += 1 + r;
            cellsTotal += ng;
            refinedTotal += refined.size();
            maxR = std::max(maxR, r);
        }
        traced.add(out.stats);
        batch.reserve(batch.size() + out.photons.size());
        for (const TracedPhoton& p : out.photons)  // exact: powerUnit_ is a power of two
            batch.push_back(Photon::make(p.position, p.power / powerUnit_, p.incoming));
    }

    const Clock::time_point t0 = Clock::now();
    switch (settings_.tree) {
        case PhotonTree::MiddleSplit:
            st->tree->insert(batch);
            stats.photonsStored = st->tree->size();
            break;
        case PhotonTree::MedianBalanced: {
            const std::vector<Photon> all = withBatch(st->median.get(), batch);
            st->median->build(all);
            stats.photonsStored = st->median->size();
            break;
        }
        case PhotonTree::UniformGrid: {
            const std::vector<Photon> all = withBatch(st->grid.get(), batch);
            Bounds b;
            for (const Photon& p : all) b.extend(p.position);
            const uint32_t res = all.empty() ? 1 : gridResolution(all.size(), b.extent(), settings_.k, rMax_);
            st->grid = std::make_unique<PhotonGrid>(res);
            st->grid->build(all);
            stats.photonsStored = st->grid->size();
            break;
        }
    }
    const double insertSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

    stats.batches += 1;
    stats.pathsTraced += traced.paths;
    stats.productivePaths += traced.productivePaths;
    stats.raysCast += traced.rays;
    stats.anomalies += traced.anomalies;
    stats.sptCells = cellsTotal;
    stats.sptRefinedCells = refinedTotal;
    stats.sptRefinements = maxR;
    stats.traceSeconds += traced.wallSeconds;
    stats.samplingSeconds += traced.samplingSeconds;
    stats.rayCastSeconds += traced.rayCastSeconds;
    stats.interactionSeconds += traced.interactionSeconds;
    stats.insertSeconds += insertSeconds;

    if (settings_.capPhotons > 0 &&
        (stats.photonsStored >= settings_.capPhotons ||
         stats.pathsTraced >= kCapPathsPerPhoton * settings_.capPhotons))
        st->capped = true;
    // A scene without lights or without a caustic generator never produces photons.
    if (emitters_.empty() || !causticPossible) st->capped = true;
}

Vec3 PhotonMaps::radiance(uint32_t set, const SurfaceHit& hit, Vec3 normal, Vec3 albedo) const {
    const SetState* st = find(set);
    if (!st || st->stats.batches == 0) return Vec3(0.0f);
    thread_local KnnHeap heap;
    const float scale = powerUnit_ / static_cast<float>(st->stats.batches);
    const auto estimate = [&](const auto& index) {
        if (!settings_.gatherVisibility || !scene_)
            return causticRadiance(index, hit.position, normal, albedo, settings_.k, rMax_, scale, heap);
        // Both ends are lifted off their surfaces by the same distance: x along its normal, the
        // photon back along the direction it arrived from (the side of the surface it lies on).
        // A ray between two points of one plane then runs parallel to it, and a photon on the
        // lit face of a zero-thickness wall is seen from the lit side only.
        const Vec3 origin = scene_->offsetOrigin(hit.position, hit.geometricNormal, normal);
        const float lift = glm::length(origin - hit.position);
        const auto visible = [&](const Photon& photon) {
            Ray ray;
            ray.origin = origin;
            ray.dir = photon.position - lift * photon.incomingDir() - origin;
            ray.tMax = 1.0f;
            return glm::dot(ray.dir, ray.dir) == 0.0f || !scene_->occluded(ray);
        };
        return causticRadianceIf(index, hit.position, normal, albedo, settings_.k, rMax_, scale, heap, visible);
    };
    if (st->tree) return estimate(*st->tree);
    if (st->median) return estimate(*st->median);
    if (st->grid) return estimate(*st->grid);
    return Vec3(0.0f);
}

}  // namespace rtpm
