// Per-set photon maps: plain or selective (SPT) batch shooting, power normalisation, accumulation.
//
// Power bookkeeping (paper-notes §5.5, §5.7; DESIGN §5). Every light l with a share P_l of the
// batch is estimated on its own:
//  * plain: indices [n_l, n_l + P_l) of its sequence, each path starts with Φ_l / P_l;
//  * SPT: N_g pilots i ∈ [0, N_g) (one per elementary box of the steering dims, offset by whole
//    periods so every batch draws new points in the same boxes). A box is refined when its pilot
//    stored a caustic photon or — with sptDilate — a face neighbour's pilot did. A refined box
//    gets R more members i + m·N_g, m = 1…R (same box, stratified inside it). Each box carries
//    Φ_l / N_g; its n members share it, so every path of a refined box starts with
//    Φ_l / (N_g (1+R)) and an unrefined pilot with Φ_l / N_g (it stored nothing). R is uniform
//    within a batch, so one scale fits all photons of the batch.
// Powers are relative to one batch; the estimate divides by the number of batches.
//
// Why dilation: refining only boxes whose own pilot hit weights a box that is a fraction f
// productive by P(pilot hits) · f = f², losing a share of every partly productive box — the
// caustic's border and, for a small generator, its whole power. Refining the neighbours of
// productive boxes makes the refinement of a border box (almost always) independent of its own
// pilot, so its expected contribution is f again. What remains biased is a productive region
// narrower than a box whose pilot and neighbours' pilots all miss.
#include "common/photon_map.h"

#include <algorithm>
#include <chrono>

#include "common/check.h"
#include "common/density.h"

namespace rtpm {

namespace {

using Clock = std::chrono::steady_clock;

// Hash stream of light `emitter` in set `set`: its Halton rotation and its hashed numbers.
uint64_t streamOf(uint32_t set, const Emitter& e) {
    return hashKeys(set, e.id, static_cast<uint64_t>(e.kind), 0x4c49474854ull);
}

}  // namespace

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
    };
    uint32_t set = 0;
    std::unique_ptr<KdTree> tree;
    PhotonSetStats stats;
    std::vector<LightState> lights;
    bool planned = false;
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

void PhotonMaps::shootBatch(const EmbreeScene& scene, uint32_t set) {
    SetState* st = find(set);
    RTPM_CHECK(st != nullptr);
    if (st->capped) return;
    if (!emittersReady_) {
        emitters_ = buildEmitters(scene);
        const float diag = scene.bounds().diagonal();
        rMax_ = settings_.rMax > 0.0f ? settings_.rMax : 0.02f * (diag > 0.0f ? diag : 1.0f);
        emittersReady_ = true;
    }
    if (!st->planned) {
        st->tree = std::make_unique<KdTree>(scene.bounds());
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
                if (settings_.sptDilate) ls.neighbours = sptNeighbours(ls.grid);
            }
            st->lights.push_back(std::move(ls));
        }
        st->planned = true;
    }

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
        if (ls.budget == 0) continue;
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
            const uint64_t base = ls.nextPeriod * ng;
            indices.resize(ng);
            for (uint64_t i = 0; i < ng; ++i) indices[i] = base + i;
            src.powerPerPath = e.flux / static_cast<float>(ng);
            tracePhotons(scene, src, ts, indices, out);
            // Boxes to refine, in pilot order.
            std::vector<uint32_t> refined;
            const size_t fan = 2 * static_cast<size_t>(ls.grid.dims);
            for (uint64_t i = 0; i < ng; ++i) {
                bool refine = out.productive[i] != 0;
                if (!refine && settings_.sptDilate) {
                    for (size_t j = 0; j < fan && !refine; ++j)
                        refine = out.productive[ls.neighbours[i * fan + j]] != 0;
                }
                if (refine) refined.push_back(static_cast<uint32_t>(i));
            }
            uint32_t r = 0;
            if (!refined.empty()) {
                if (settings_.sptRefinements > 0) {
                    r = settings_.sptRefinements;
                } else if (ls.budget > ng) {
                    r = static_cast<uint32_t>(std::min<uint64_t>(
                        kMaxSptRefinements, (ls.budget - ng) / refined.size()));
                }
            }
            if (r > 0) {
                // The pilots' photons become members of boxes with 1 + R members.
                const float pilotScale = 1.0f / static_cast<float>(1 + r);
                for (TracedPhoton& p : out.photons) p.power *= pilotScale;
                indices.resize(refined.size() * r);
                size_t j = 0;
                for (uint32_t cell : refined)
                    for (uint32_t m = 1; m <= r; ++m) indices[j++] = base + m * ng + cell;
                src.powerPerPath = e.flux / static_cast<float>(ng * (1 + r));
                tracePhotons(scene, src, ts, indices, out);
            }
            ls.nextPeriod += 1 + r;
            cellsTotal += ng;
            refinedTotal += refined.size();
            maxR = std::max(maxR, r);
        }
        traced.add(out.stats);
        batch.reserve(batch.size() + out.photons.size());
        for (const TracedPhoton& p : out.photons)
            batch.push_back(Photon::make(p.position, p.power, p.incoming));
    }

    const Clock::time_point t0 = Clock::now();
    st->tree->insert(batch);
    const double insertSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

    stats.batches += 1;
    stats.pathsTraced += traced.paths;
    stats.productivePaths += traced.productivePaths;
    stats.photonsStored = st->tree->size();
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
    // A scene without lights never produces photons: nothing to accumulate.
    if (emitters_.empty()) st->capped = true;
}

Vec3 PhotonMaps::radiance(uint32_t set, const SurfaceHit& hit, Vec3 normal, Vec3 albedo) const {
    const SetState* st = find(set);
    if (!st || !st->tree || st->stats.batches == 0) return Vec3(0.0f);
    thread_local KnnHeap heap;
    const float scale = 1.0f / static_cast<float>(st->stats.batches);
    return causticRadiance(*st->tree, hit.position, normal, albedo, settings_.k, rMax_, scale, heap);
}

}  // namespace rtpm
