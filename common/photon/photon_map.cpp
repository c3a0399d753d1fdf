// Per-set photon maps: plain or selective (SPT) batch shooting, power normalisation, accumulation.
//
// Power bookkeeping (docs/ARCHITECTURE.md §5.2–§5.3). Every light l with a share P_l of the
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
//
// A batch runs in four stages per light (shootBatch): plan (which Halton indices, with which
// path power: planLight, and on the first SPT batch the classification probe), trace
// (tracePhotons), weight (weightRefinedBoxes, then the next batch's refine set: advanceLight),
// and insert (toStored, PhotonIndex::insert).
#include "common/photon/photon_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/core/check.h"
#include "common/photon/density.h"
#include "common/photon/group_gather.h"
#include "common/photon/spt_grid.h"
#include "common/photon/visible_from.h"

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

float maxChannel(Vec3 v) { return std::max({v.x, v.y, v.z}); }

// SPT cell target of a light with `budget` paths per batch.
uint64_t sptTarget(const PhotonSettings& settings, uint64_t budget) {
    return settings.sptCells > 0 ? settings.sptCells : std::max<uint64_t>(1, budget / 4);
}

// The maps' power unit: the largest initial path power of any light's first batch (the plan is
// the same for every set), rounded down to a power of two. A path's power never grows (mirrors
// and glass reflect at most all of it, Russian roulette divides by the largest channel's
// albedo), so stored values are < 2 units; SPT refinement weights (≥ 1/65), absorption and
// colour only shrink them, and RGB9E5 keeps 2^-9 relative precision down to 2^-20 units
// (photon.cpp) whatever the scene's scale in metres and watts.
float choosePowerUnit(const std::vector<Emitter>& emitters, const PhotonSettings& settings) {
    const std::vector<uint32_t> budget = splitBudget(emitters, settings.photonsPerBatch);
    float largest = 0.0f;
    for (size_t l = 0; l < emitters.size(); ++l) {
        if (budget[l] == 0) continue;
        float paths = static_cast<float>(budget[l]);
        if (settings.selective) {
            const DimLayout dims = dimLayout(emitters[l].kind, settings.diffuseBounces);
            paths = static_cast<float>(makeSptGrid(dims.count, sptTarget(settings, budget[l])).cellCount);
        }
        largest = std::max(largest, maxChannel(emitters[l].flux) / paths);
    }
    if (!(largest > 0.0f) || !std::isfinite(largest)) return 1.0f;
    int exp2 = 0;
    std::frexp(largest, &exp2);  // largest = f · 2^exp2, f in [0.5, 1)
    // Unit and 1/unit stay normal floats (so p / unit is exact and never overflows).
    return std::ldexp(1.0f, std::clamp(exp2 - 1, -100, 100));
}

}  // namespace

/// One light's sequence in one set: where its next batch starts, and (SPT) its box grid and the
/// refine set D the previous batch chose.
struct PhotonMaps::LightSequence {
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

    LightSequence(uint32_t set, const Emitter& e, uint32_t budgetPaths, const PhotonSettings& s)
        : stream(streamOf(set, e)), budget(budgetPaths), dims(dimLayout(e.kind, s.diffuseBounces)) {
        halton = Halton(s.seed, stream);
        if (s.selective && budget > 0) {
            grid = makeSptGrid(dims.count, sptTarget(s, budget));
            dilate = s.sptDilate;
            if (dilate) neighbours = sptNeighbours(grid);
        }
    }

    // The refine set D for the next batch from this batch's outcomes: boxes with a productive
    // member (pilot i of N_g paths, then R refinements of each box in `refined`, in that order),
    // dilated by their face neighbours when enabled.
    std::vector<uint8_t> classify(const std::vector<uint32_t>& stored,
                                  const std::vector<uint32_t>& refined, uint32_t r) const {
        const uint64_t ng = grid.cellCount;
        std::vector<uint8_t> hit(ng, 0);
        for (uint64_t i = 0; i < ng; ++i) hit[i] = stored[i] > 0;
        size_t path = ng;
        for (uint32_t cell : refined)
            for (uint32_t m = 0; m < r; ++m, ++path)
                if (stored[path] > 0) hit[cell] = 1;
        if (!dilate) return hit;
        std::vector<uint8_t> out = hit;
        const size_t fan = 2 * static_cast<size_t>(grid.dims);
        for (uint64_t i = 0; i < ng; ++i) {
            if (!hit[i]) continue;
            for (size_t j = 0; j < fan; ++j) out[neighbours[i * fan + j]] = 1;
        }
        return out;
    }
};

/// What one light traces in one batch (the plan stage's result).
struct PhotonMaps::LightPlan {
    std::vector<uint64_t> indices;  ///< Halton indices, in trace order
    Vec3 powerPerPath{0.0f};        ///< initial power of every path (W, per batch)
    uint64_t pilots = 0;            ///< SPT: N_g (indices[0, N_g) are the pilots); 0 plain
    std::vector<uint32_t> refined;  ///< SPT: boxes of D, in the order their refinements follow
    uint32_t refinements = 0;       ///< SPT: R per box of D
};

struct PhotonMaps::SetState {
    uint32_t set = 0;
    std::optional<PhotonIndex> index;  // created at the first batch after a reset
    PhotonOccupancy occupancy{0.0f};   // of `index`'s photons, radius rMax (with `index`)
    std::optional<KdTree> pass;        // the last progressive pass's photons alone
    uint32_t passBatches = 0;          // batches in `pass`
    std::vector<Photon> pending;       // passes' photons not yet in `index` (flushPasses)
    SetPhotons shot;                   // what the last shootBatch / shootPass traced (takeShot)
    std::vector<Photon> lastBatch;     // the last shootBatch's photons (lastBatch)
    uint32_t lastBatchNumber = 0;      // stats.batches after it inserted them (0: none)
    PhotonSetStats stats;
    std::vector<LightSequence> lights;
    bool capped = false;
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

const PhotonIndex* PhotonMaps::indexOf(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    return s->index ? &*s->index : nullptr;
}

std::vector<Photon> PhotonMaps::photons(uint32_t set) const {
    const PhotonIndex* index = indexOf(set);
    return index ? index->photons() : std::vector<Photon>{};
}

Vec3 PhotonMaps::storedPowerPerBatch(uint32_t set) const {
    const SetState* s = find(set);
    RTPM_CHECK(s != nullptr);
    if (s->stats.batches == 0) return Vec3(0.0f);
    glm::dvec3 sum(0.0);
    for (const Photon& p : photons(set)) sum += glm::dvec3(p.powerRgb());
    return Vec3(sum * (double(powerUnit_) / double(s->stats.batches)));
}

void PhotonMaps::prepare(const EmbreeScene& scene) {
    if (emittersReady_) return;
    emitters_ = buildEmitters(scene);
    const float diag = scene.bounds().diagonal();
    rMax_ = settings_.rMax > 0.0f ? settings_.rMax : 0.02f * (diag > 0.0f ? diag : 1.0f);
    powerUnit_ = choosePowerUnit(emitters_, settings_);
    emittersReady_ = true;
}

void PhotonMaps::probeRefineSet(const EmbreeScene& scene, const TraceSettings& ts,
                                const PhotonSource& source, LightSequence& ls,
                                TraceStats& traced) const {
    const uint64_t ng = ls.grid.cellCount;
    std::vector<uint64_t> indices(ng);
    for (uint64_t i = 0; i < ng; ++i) indices[i] = ls.nextPeriod * ng + i;
    PhotonSource src = source;
    src.powerPerPath = source.emitter->flux / static_cast<float>(ng);
    TraceOutput probe;
    tracePhotons(scene, src, ts, indices, probe);
    traced.add(probe.stats);
    traced.productivePaths -= probe.stats.productivePaths;  // yield counts stored paths
    ls.refine = ls.classify(probe.storedPerPath, {}, 0);
    ls.nextPeriod += 1;
}

PhotonMaps::LightPlan PhotonMaps::planLight(LightSequence& ls, const Emitter& e,
                                            uint64_t budget) const {
    LightPlan plan;
    if (!settings_.selective) {
        plan.indices.resize(ls.budget);
        for (uint32_t i = 0; i < ls.budget; ++i) plan.indices[i] = ls.nextIndex + i;
        ls.nextIndex += ls.budget;
        plan.powerPerPath = e.flux / static_cast<float>(ls.budget);
        return plan;
    }
    const uint64_t ng = ls.grid.cellCount;
    for (uint64_t i = 0; i < ng; ++i)
        if (ls.refine[i]) plan.refined.push_back(static_cast<uint32_t>(i));
    uint32_t r = 0;
    if (!plan.refined.empty()) {
        if (settings_.sptRefinements > 0) {
            r = settings_.sptRefinements;
        } else if (budget > ng) {
            r = static_cast<uint32_t>(
                std::min<uint64_t>(kMaxSptRefinements, (budget - ng) / plan.refined.size()));
        }
    }
    const uint64_t base = ls.nextPeriod * ng;
    plan.indices.resize(ng + plan.refined.size() * r);
    for (uint64_t i = 0; i < ng; ++i) plan.indices[i] = base + i;
    size_t j = ng;
    for (uint32_t cell : plan.refined)
        for (uint32_t m = 1; m <= r; ++m) plan.indices[j++] = base + m * ng + cell;
    // Traced with Φ_l / N_g; weightRefinedBoxes scales the members of refined boxes by 1/(1+R).
    plan.powerPerPath = e.flux / static_cast<float>(ng);
    plan.pilots = ng;
    plan.refinements = r;
    return plan;
}

void PhotonMaps::weightRefinedBoxes(const LightPlan& plan, const LightSequence& ls,
                                    TraceOutput& out) {
    if (plan.pilots == 0 || plan.refinements == 0) return;
    const float memberScale = 1.0f / static_cast<float>(1 + plan.refinements);
    size_t photon = 0;
    for (size_t path = 0; path < plan.indices.size(); ++path) {
        const uint32_t count = out.storedPerPath[path];
        const bool inRefined = path >= plan.pilots || ls.refine[path];
        if (inRefined)
            for (uint32_t q = 0; q < count; ++q) out.photons[photon + q].power *= memberScale;
        photon += count;
    }
    RTPM_CHECK(photon == out.photons.size());
}

void PhotonMaps::advanceLight(const LightPlan& plan, const TraceOutput& out, LightSequence& ls) {
    if (plan.pilots == 0) return;  // plain: planLight already advanced the index
    ls.refine = ls.classify(out.storedPerPath, plan.refined, plan.refinements);
    ls.nextPeriod += 1 + plan.refinements;
}

void PhotonMaps::toStored(const TraceOutput& out, std::vector<Photon>& batch) const {
    batch.reserve(batch.size() + out.photons.size());
    for (const TracedPhoton& p : out.photons)  // exact: powerUnit_ is a power of two
        batch.push_back(Photon::make(p.position, p.power / powerUnit_, p.incoming));
}

void PhotonMaps::shootBatch(const EmbreeScene& scene, uint32_t set) {
    SetState* st = find(set);
    RTPM_CHECK(st != nullptr);
    flushPasses(set);
    if (st->capped) return;
    std::vector<Photon> batch = traceBatch(scene, *st);
    st->shot = SetPhotons{set, 0, {}};
    if (sharesShots() && batch.size() <= shareCap_) st->shot = SetPhotons{set, 1, batch};
    insertBatch(*st, batch);
    st->lastBatch = std::move(batch);
    st->lastBatchNumber = st->stats.batches;
}

std::span<const Photon> PhotonMaps::lastBatch(uint32_t set) const {
    const SetState* st = find(set);
    if (!st || st->lastBatchNumber == 0 || st->lastBatchNumber != st->stats.batches) return {};
    return st->lastBatch;
}

void PhotonMaps::shootPass(const EmbreeScene& scene, uint32_t set, uint32_t batches) {
    SetState* st = find(set);
    RTPM_CHECK(st != nullptr && batches >= 1);
    st->lastBatchNumber = 0;
    std::vector<Photon> batch = traceBatch(scene, *st);
    // The shot handed to the other sets: the whole batches that fit shareCap_.
    uint32_t sharedBatches = batch.size() <= shareCap_ ? 1 : 0;
    size_t sharedPhotons = sharedBatches ? batch.size() : 0;
    for (uint32_t b = 1; b < batches; ++b) {
        std::vector<Photon> more = traceBatch(scene, *st);
        batch.insert(batch.end(), more.begin(), more.end());
        if (sharedBatches == b && batch.size() <= shareCap_) {
            sharedBatches = b + 1;
            sharedPhotons = batch.size();
        }
    }
    st->pass.emplace(scene.bounds(), KdTree::kRadiusLeafSize);
    st->pass->build(batch);
    st->passBatches = batches;
    st->stats.passes += 1;
    if (sharesShots())
        st->shot = SetPhotons{set, sharedBatches, std::vector<Photon>(batch.begin(), batch.begin() + std::ptrdiff_t(sharedPhotons))};
    // Kept for the map, not inserted now: an insertion moves the map's leaf-ordered photon array
    // (O(stored)), which would make a still frame's cost grow with the map. Bounded by the cap.
    const uint64_t cap = settings_.capPhotons;
    if (!st->capped && (cap == 0 || st->stats.photonsStored + st->pending.size() < cap)) {
        st->pending.insert(st->pending.end(), batch.begin(), batch.end());
        st->stats.pendingBatches += batches;
    }
}

void PhotonMaps::flushPasses(uint32_t set) {
    SetState* st = find(set);
    RTPM_CHECK(st != nullptr);
    if (st->stats.pendingBatches == 0) return;
    const uint32_t batches = st->stats.pendingBatches;
    std::vector<Photon> photons = std::move(st->pending);
    st->pending = {};
    st->stats.pendingBatches = 0;
    st->lastBatchNumber = 0;
    insertBatch(*st, photons);
    st->stats.batches += batches - 1;  // insertBatch counted one
}

std::vector<Photon> PhotonMaps::traceBatch(const EmbreeScene& scene, SetState& state) {
    SetState* st = &state;
    const uint32_t set = st->set;
    prepare(scene);
    if (!st->index) {
        st->index.emplace(settings_.tree, scene.bounds());
        st->occupancy = PhotonOccupancy(rMax_);
        const std::vector<uint32_t> budget = splitBudget(emitters_, settings_.photonsPerBatch);
        st->lights.clear();
        for (size_t l = 0; l < emitters_.size(); ++l)
            st->lights.emplace_back(set, emitters_[l], budget[l], settings_);
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
    for (size_t l = 0; l < emitters_.size(); ++l) {
        LightSequence& ls = st->lights[l];
        if (ls.budget == 0 || !causticPossible) continue;
        const Emitter& e = emitters_[l];
        PhotonSource src;
        src.emitter = &e;
        src.halton = &ls.halton;
        src.hashStream = ls.stream;
        src.dims = ls.dims;
        // Plan: the first SPT batch after a reset spends N_g paths on a classification probe.
        uint64_t budget = ls.budget;
        if (settings_.selective && ls.refine.empty()) {
            probeRefineSet(scene, ts, src, ls, traced);
            budget = budget > ls.grid.cellCount ? budget - ls.grid.cellCount : 0;
        }
        const LightPlan plan = planLight(ls, e, budget);
        // Trace.
        src.powerPerPath = plan.powerPerPath;
        TraceOutput out;
        tracePhotons(scene, src, ts, plan.indices, out);
        // Weight, and choose the next batch's refine set from this batch's outcomes.
        weightRefinedBoxes(plan, ls, out);
        advanceLight(plan, out, ls);
        if (plan.pilots > 0) {
            cellsTotal += plan.pilots;
            refinedTotal += plan.refined.size();
            maxR = std::max(maxR, plan.refinements);
        }
        traced.add(out.stats);
        toStored(out, batch);
    }

    stats.pathsTraced += traced.paths;
    stats.productivePaths += traced.productivePaths;
    stats.raysCast += traced.rays;
    stats.anomalies += traced.anomalies;
    stats.spt.cells = cellsTotal;
    stats.spt.refinedCells = refinedTotal;
    stats.spt.refinements = maxR;
    stats.seconds.trace += traced.wallSeconds;
    stats.seconds.sampling += traced.samplingSeconds;
    stats.seconds.rayCast += traced.rayCastSeconds;
    stats.seconds.interaction += traced.interactionSeconds;
    // A scene without lights or without a caustic generator never produces photons.
    if (emitters_.empty() || !causticPossible) st->capped = true;
    return batch;
}

void PhotonMaps::insertBatch(SetState& state, std::span<const Photon> batch) {
    SetState* st = &state;
    PhotonSetStats& stats = st->stats;
    const Clock::time_point t0 = Clock::now();
    st->index->insert(batch, settings_.k, rMax_);
    st->occupancy.insert(batch);
    stats.photonsStored = st->index->size();
    stats.seconds.insert += std::chrono::duration<double>(Clock::now() - t0).count();
    stats.batches += 1;
    if (settings_.capPhotons > 0 &&
        (stats.photonsStored >= settings_.capPhotons ||
         stats.pathsTraced >= kCapPathsPerPhoton * settings_.capPhotons))
        st->capped = true;
}

Vec3 PhotonMaps::radiance(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit,
                          Vec3 normal, Vec3 albedo, GatherHint* hint) const {
    const SetState* st = find(set);
    if (!st || st->stats.batches == 0 || !st->index) return Vec3(0.0f);
    // No photon within rMax: the gather would find nothing (radiance 0), so skip its descent.
    if (!st->occupancy.mayHaveWithin(hit.position)) {
        if (hint) hint->radius2 = 0.0f;
        return Vec3(0.0f);
    }
    thread_local KnnHeap heap;
    const float scale = powerUnit_ / static_cast<float>(st->stats.batches);
    const VisibleFrom visible(settings_.gatherVisibility, scene, hit, normal);
    // The neighbour's r² × kGuessScale as the first bound (group_gather.h says why 1.25).
    const float guess2 = hint ? kGuessScale * hint->radius2 : 0.0f;
    const DensityGather g = st->index->visit([&](const auto& index) {
        return gatherKnn(index, hit.position, normal, settings_.k, rMax_, heap, visible, guess2);
    });
    if (hint) hint->radius2 = g.radius2;
    return causticRadianceFrom(g, albedo, scale);
}

DensityGather PhotonMaps::gatherMap(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit,
                                    Vec3 normal) const {
    const SetState* st = find(set);
    if (!st || st->stats.batches == 0 || !st->index) return {};
    if (!st->occupancy.mayHaveWithin(hit.position)) return {};  // nothing within rMax
    thread_local KnnHeap heap;
    const VisibleFrom visible(settings_.gatherVisibility, scene, hit, normal);
    DensityGather g = st->index->visit([&](const auto& index) {
        return gatherKnn(index, hit.position, normal, settings_.k, rMax_, heap, visible);
    });
    g.power *= powerUnit_ / static_cast<float>(st->stats.batches);
    return g;
}

void PhotonMaps::gatherGroup(const SetState& st, std::span<const CausticQuery> queries,
                             std::span<DensityGather> out, GatherHint* hint) const {
    RTPM_CHECK(out.size() == queries.size());
    // Hits with no photon within rMax get no gather (the occupancy test, as in `radiance`); the
    // others are gathered as one group.
    thread_local GroupGatherScratch scratch;
    thread_local std::vector<GatherQuery> group;
    thread_local std::vector<uint32_t> slot;
    thread_local std::vector<DensityGather> gathers;
    group.clear();
    slot.clear();
    for (size_t i = 0; i < queries.size(); ++i) {
        out[i] = DensityGather{};
        if (!st.occupancy.mayHaveWithin(queries[i].hit->position)) continue;
        group.push_back(GatherQuery{queries[i].hit->position, queries[i].normal});
        slot.push_back(uint32_t(i));
    }
    gathers.resize(group.size());
    const float guess2 = hint ? kGuessScale * hint->radius2 : 0.0f;
    st.index->visit([&](const auto& index) {
        gatherKnnGroup(index, std::span<const GatherQuery>(group), settings_.k, rMax_, guess2, scratch,
                       std::span<DensityGather>(gathers));
    });
    // The next group's guess: the largest r_k² of the gathers that found k photons (one that
    // found fewer searched all of rMax and says nothing about the density nearby). If none
    // found k, the photons are sparse here and the next group searches all of rMax as a group.
    float largest = 0.0f;
    for (size_t j = 0; j < group.size(); ++j) {
        out[slot[j]] = gathers[j];
        if (gathers[j].count == settings_.k) largest = std::max(largest, gathers[j].radius2);
    }
    if (hint && !group.empty()) hint->radius2 = largest > 0.0f ? largest : rMax_ * rMax_;
}

void PhotonMaps::radianceGroup(const EmbreeScene& scene, uint32_t set, std::span<const CausticQuery> queries,
                               std::span<Vec3> out, GatherHint* hint) const {
    RTPM_CHECK(out.size() == queries.size());
    const SetState* st = find(set);
    if (!st || st->stats.batches == 0 || !st->index) {
        std::fill(out.begin(), out.end(), Vec3(0.0f));
        return;
    }
    if (settings_.gatherVisibility) {  // a shadow ray per gathered photon: nothing to share
        CausticEstimator::radianceGroup(scene, set, queries, out, hint);
        return;
    }
    thread_local std::vector<DensityGather> gathers;
    gathers.resize(queries.size());
    gatherGroup(*st, queries, gathers, hint);
    const float scale = powerUnit_ / static_cast<float>(st->stats.batches);
    for (size_t i = 0; i < queries.size(); ++i) out[i] = causticRadianceFrom(gathers[i], queries[i].albedo, scale);
}

void PhotonMaps::gatherMapGroup(const EmbreeScene& scene, uint32_t set, std::span<const CausticQuery> queries,
                                std::span<DensityGather> out, GatherHint* hint) const {
    RTPM_CHECK(out.size() == queries.size());
    const SetState* st = find(set);
    if (!st || st->stats.batches == 0 || !st->index || settings_.gatherVisibility) {
        for (size_t i = 0; i < queries.size(); ++i) out[i] = gatherMap(scene, set, *queries[i].hit, queries[i].normal);
        return;
    }
    gatherGroup(*st, queries, out, hint);
    const float scale = powerUnit_ / static_cast<float>(st->stats.batches);
    for (DensityGather& g : out) g.power *= scale;
}

uint32_t PhotonMaps::passBatches(uint32_t set) const {
    const SetState* st = find(set);
    return st && st->pass ? st->passBatches : 0;
}

const KdTree* PhotonMaps::passTree(uint32_t set) const {
    const SetState* st = find(set);
    return st && st->pass ? &*st->pass : nullptr;
}

SetPhotons PhotonMaps::takeShot(uint32_t set) {
    SetState* st = find(set);
    RTPM_CHECK(st != nullptr);
    SetPhotons shot = std::move(st->shot);
    st->shot = SetPhotons{set, 0, {}};
    // Batches that stored no photon share nothing: the others' passes skip such a shot (as
    // SharedPhotons::build does), and the wire carries a shot's batches only with its photons.
    if (shot.photons.empty()) shot.batches = 0;
    return shot;
}

uint32_t PhotonMaps::gatherMapPhotons(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit,
                                      Vec3 normal, float radius2, std::vector<FoundPhoton>& out) const {
    const SetState* st = find(set);
    if (!st || st->stats.batches == 0 || !st->index) return 0;
    if (!(radius2 > 0.0f) || !st->occupancy.mayHaveWithin(hit.position)) return st->stats.batches;
    const size_t first = out.size();
    const VisibleFrom visible(settings_.gatherVisibility, scene, hit, normal);
    st->index->visit([&](const auto& index) {
        RadiusList<std::decay_t<decltype(index)>, VisibleFrom> list(index, normal, radius2, visible, out);
        index.search(hit.position, list);
    });
    for (size_t i = first; i < out.size(); ++i) out[i].power *= powerUnit_;
    return st->stats.batches;
}

}  // namespace rtpm
