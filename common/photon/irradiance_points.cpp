// Irradiance points: a bounded subset of a photon map's photons with their k-NN irradiance.
#include "common/photon/irradiance_points.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/check.h"
#include "common/photon/density.h"
#include "common/photon/knn.h"
#include "common/photon/visible_from.h"

namespace rtpm {

struct IrradiancePoints::SetPoints {
    uint32_t set = 0;
    bool built = false;
    uint32_t batches = 0;          ///< the map's batch count when built
    uint64_t photons = 0;          ///< the map's photon count when built
    uint32_t heldBatches = 0;      ///< the batches the points' flux holds (built + added)
    uint64_t heldPhotons = 0;      ///< the map's photon count then
    float rMax2 = 0.0f;            ///< the map's gather radius², the lookup's bound
    KdTree tree;                   ///< one entry per point; its power word is the point's id
    /// What a lookup reads of a point, per point id, in one place: where it answers (m², its
    /// k-NN disc at its photon or wider), whether its irradiance (W/m², one batch's flux per unit area)
    /// is above 0, and its inverse per channel (1/max(10⁻³⁰, E)) for the harmonic mean,
    /// computed once when it changes rather than at every lookup (RING's orbit: the lookups are
    /// a quarter of a frame).
    struct Answer {
        glm::dvec3 inverse{0.0};
        float radius2 = 0.0f;
        bool lit = false;
    };
    std::vector<Answer> answers;
    /// Sets what a lookup reads of point i's irradiance `v`.
    void setIrradiance(size_t i, Vec3 v) {
        answers[i].lit = v.x > 0.0f || v.y > 0.0f || v.z > 0.0f;
        answers[i].inverse = glm::dvec3(1.0 / std::max(1e-30, double(v.x)), 1.0 / std::max(1e-30, double(v.y)),
                                        1.0 / std::max(1e-30, double(v.z)));
    }
    // Per point id, for adding later batches (addBatch): where it lies, the normal it faces, its
    // estimate's disc (r_k² at the build; 0: none) and the flux within it, W summed over the held
    // batches.
    std::vector<Vec3> position, normal;
    std::vector<float> disc2;
    std::vector<Vec3> flux;
    /// Per point id: the flux within the disc of half its estimate's area (kInnerArea), W summed
    /// over the held batches.
    std::vector<Vec3> innerFlux;
    /// Per point id: Σ of the squared luminance of the photons' powers within its disc, W²
    /// summed over the held batches: the variance of the difference between the inner disc's
    /// flux and the ring's around it (sharpness).
    std::vector<float> squares;
};

namespace {

/// The area of a point's inner disc relative to its estimate's disc.
constexpr float kInnerArea = 0.5f;
/// A point's inner disc and the ring around it (the same area) differing by less than kSharpFrom
/// standard deviations of their photon noise leave its estimate to the whole disc; by kSharpAt or
/// more, to the inner one; linear between (sharpness).
constexpr float kSharpFrom = 0.5f, kSharpAt = 1.5f;

/// What a point sums of the photons within its disc (r²) and within its inner disc (inner2): at
/// the build over the map's photons, later over each batch's.
struct DiscSums {
    float inner2;
    Vec3 flux{0.0f}, innerFlux{0.0f};
    float squares = 0.0f;  ///< Σ of the photons' squared power luminances
    void add(float dist2, Vec3 power) {
        flux += power;
        squares += float(luminance(power) * luminance(power));
        if (dist2 < inner2) innerFlux += power;
    }
};

/// The share of a point's estimate its inner disc takes from the build on: where the inner disc
/// and the ring around it hold different flux beyond their noise (the point lies on a gradient,
/// which the whole disc blurs); none where they agree (a smooth caustic, whose noise the whole
/// disc halves). `squares`: Σ of the squared luminances of the photons' powers in the whole disc,
/// the variance of the inner flux minus the ring's.
float sharpness(Vec3 flux, Vec3 innerFlux, float squares) {
    if (!(squares > 0.0f)) return 0.0f;
    const float z = float(std::abs(luminance(innerFlux) - luminance(flux - innerFlux)) / std::sqrt(double(squares)));
    return std::clamp((z - kSharpFrom) / (kSharpAt - kSharpFrom), 0.0f, 1.0f);
}

/// A point's irradiance from its fluxes over `held` batches, its estimate's disc being the map's
/// k-NN disc at its photon when it held `built` batches: the k-NN disc of held batches has about
/// built/held of the area, and a kernel's blur grows with its area, so the estimate blends the
/// whole disc (weight 1 − a) and the inner one (weight a) to that area: a = (1 − built/held) /
/// (1 − kInnerArea), 0 at the build, 1 once the map doubled (where the points are rebuilt); or
/// the point's sharpness where that is more.
Vec3 blendedIrradiance(Vec3 flux, Vec3 innerFlux, float squares, float disc2, uint32_t built, uint32_t held) {
    const float a = std::max(sharpness(flux, innerFlux, squares),
                             std::clamp((1.0f - float(built) / float(held)) / (1.0f - kInnerArea), 0.0f, 1.0f));
    const float whole = 1.0f / (kPi * disc2 * float(held));
    return flux * ((1.0f - a) * whole) + innerFlux * (a * whole / kInnerArea);
}

/// A k-NN result set over the points that keeps only points facing the query's normal (the
/// density gather's front/back rule: a point's `incoming` is its normal reversed) and counts the
/// points offered to it.
class FacingPoints {
public:
    FacingPoints(KnnHeap& heap, const KdTree& tree, Vec3 normal) : inner_(heap, tree, normal) {}
    float worstDist2() const { return inner_.worstDist2(); }
    void add(float dist2, uint32_t index) {
        ++offered;
        inner_.add(dist2, index);
    }
    uint64_t offered = 0;

private:
    FrontFacingKnn<KdTree> inner_;
};

}  // namespace

IrradiancePoints::IrradiancePoints(std::vector<uint32_t> sets) : sets_(std::move(sets)) {
    for (uint32_t s : sets_) {
        points_.push_back(std::make_unique<SetPoints>());
        points_.back()->set = s;
    }
}

IrradiancePoints::~IrradiancePoints() = default;

const IrradiancePoints::SetPoints* IrradiancePoints::find(uint32_t set) const {
    for (const auto& p : points_)
        if (p->set == set) return p.get();
    return nullptr;
}

void IrradiancePoints::invalidate() {
    for (auto& p : points_) p->built = false;
}

size_t IrradiancePoints::pointCount(uint32_t set) const {
    const SetPoints* p = find(set);
    return p && p->built ? p->answers.size() : 0;
}

void IrradiancePoints::update(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set) {
    SetPoints* sp = nullptr;
    for (auto& p : points_)
        if (p->set == set) sp = p.get();
    RTPM_CHECK(sp != nullptr);
    const PhotonSetStats& stats = maps.stats(set);
    if (sp->built) {
        // A map reset or replaced since the points last took in its photons.
        const bool changed = stats.batches < sp->heldBatches ||
                             (stats.batches == sp->heldBatches && stats.photonsStored != sp->heldPhotons);
        if (!changed && !needsRebuild(sp->batches, sp->photons, stats.batches, stats.photonsStored, set)) {
            if (stats.batches == sp->heldBatches + 1) addBatch(*sp, maps, set);
            return;
        }
    }
    sp->built = true;
    sp->batches = sp->heldBatches = stats.batches;
    sp->photons = sp->heldPhotons = stats.photonsStored;
    sp->rMax2 = maps.gatherRadius() * maps.gatherRadius();
    sp->answers.clear();
    sp->position.clear();
    sp->normal.clear();
    sp->disc2.clear();
    sp->flux.clear();
    sp->innerFlux.clear();
    sp->squares.clear();
    const PhotonIndex* index = maps.indexOf(set);
    const size_t n = index ? index->size() : 0;
    if (stats.batches == 0 || n == 0) {
        sp->tree = KdTree(scene.bounds());
        return;
    }
    const size_t stride = std::max<size_t>(kPointStride, (n + kMaxPoints - 1) / kMaxPoints);
    const size_t count = n / stride;
    std::vector<Photon> at(count);
    index->visit([&](const auto& idx) {
        for (size_t i = 0; i < count; ++i) at[i] = idx.photon(uint32_t(i * stride + stride / 2));
    });

    // Per point: the surface normal under its photon (a ray of ±δ along the photon's direction;
    // -direction if it misses), then the map's k-NN gather there. Points go in groups of 8
    // consecutive ones (neighbours in leaf order share their search: gatherMapGroup), the hint
    // runs through fixed blocks of groups, so the result does not depend on the thread count.
    std::vector<SurfaceHit> hits(count);
    std::vector<Vec3> normals(count);
    sp->answers.assign(count, SetPoints::Answer{});
    sp->position.resize(count);
    sp->normal.resize(count);
    sp->disc2.assign(count, 0.0f);
    sp->flux.assign(count, Vec3(0.0f));
    sp->innerFlux.assign(count, Vec3(0.0f));
    sp->squares.assign(count, 0.0f);
    const float delta = 1e-4f * scene.bounds().diagonal();
    // A point answers within its estimate's disc, widened once the stride leaves fewer than
    // kLookupPoints points in a disc (k photons hold about k / stride points): the disc then
    // reaches kLookupPoints points' worth of area, so the discs still cover the caustic.
    const float reach = std::max(1.0f, float(kLookupPoints * stride) / float(std::max(1u, maps.settings().k)));
    constexpr size_t kGroup = 8, kBlock = 64 * kGroup;
    tbb::parallel_for(size_t(0), (count + kBlock - 1) / kBlock, [&](size_t block) {
        const size_t end = std::min(count, (block + 1) * kBlock);
        for (size_t i = block * kBlock; i < end; ++i) {
            const Vec3 d = at[i].incomingDir();
            SurfaceHit h;
            Vec3 nrm = -d;
            if (scene.intersect(Ray{at[i].position - delta * d, d, 0.0f, 2.0f * delta}, h)) {
                const bool flip = glm::dot(h.geometricNormal, d) > 0.0f;
                nrm = flip ? -h.shadingNormal : h.shadingNormal;
                if (!(glm::dot(nrm, d) < 0.0f)) nrm = flip ? -h.geometricNormal : h.geometricNormal;
            }
            h.position = at[i].position;
            h.geometricNormal = nrm;
            h.shadingNormal = nrm;
            hits[i] = h;
            normals[i] = nrm;
            sp->position[i] = at[i].position;
            sp->normal[i] = nrm;
        }
        thread_local std::vector<FoundPhoton> inDisc;
        CausticQuery queries[kGroup];
        DensityGather gathers[kGroup];
        GatherHint hint;
        for (size_t g0 = block * kBlock; g0 < end; g0 += kGroup) {
            const size_t m = std::min(kGroup, end - g0);
            for (size_t i = 0; i < m; ++i) queries[i] = CausticQuery{&hits[g0 + i], normals[g0 + i], Vec3(1.0f)};
            maps.gatherMapGroup(scene, set, std::span(queries, m), std::span(gathers, m), &hint);
            for (size_t i = 0; i < m; ++i)
                if (gathers[i].radius2 > 0.0f) {
                    const float disc2 = gathers[i].radius2;
                    sp->answers[g0 + i].radius2 = gathers[i].radius2 * reach;
                    sp->disc2[g0 + i] = disc2;
                    inDisc.clear();
                    maps.gatherMapPhotons(scene, set, hits[g0 + i], normals[g0 + i], disc2, inDisc);
                    DiscSums sums{kInnerArea * disc2};
                    for (const FoundPhoton& f : inDisc) sums.add(f.dist2, f.power);
                    sp->flux[g0 + i] = sums.flux;
                    sp->innerFlux[g0 + i] = sums.innerFlux;
                    sp->squares[g0 + i] = sums.squares;
                    sp->setIrradiance(g0 + i, blendedIrradiance(sums.flux, sums.innerFlux, sums.squares, disc2,
                                                                stats.batches, stats.batches));
                }
        }
    });
    gathers_ += count;

    // The points' tree: position, the normal reversed as the incoming direction (so the gather's
    // front-facing rule applies unchanged) and the point's id in the power word.
    for (size_t i = 0; i < count; ++i) {
        at[i].incoming = encodeOctahedral(-normals[i]);
        at[i].power = uint32_t(i);
    }
    sp->tree = KdTree(scene.bounds());
    sp->tree.build(at);
}

void IrradiancePoints::addBatch(SetPoints& sp, const PhotonMaps& maps, uint32_t set) {
    const std::span<const Photon> batch = maps.lastBatch(set);
    // Without the batch's photons (it came as flushed passes) or with a visibility test (which
    // the points' build applies with the scene at each point), the points keep the batches they
    // hold: their estimate stays a correct one of fewer photons until the next rebuild.
    if (batch.empty() || maps.settings().gatherVisibility) return;
    KdTree tree(sp.tree.bounds());
    tree.build(batch);
    const float unit = maps.powerUnit();
    sp.heldBatches += 1;
    sp.heldPhotons = maps.stats(set).photonsStored;
    // Each point on its own: the sums do not depend on the thread count.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, sp.flux.size(), 256), [&](const auto& range) {
        for (size_t i = range.begin(); i < range.end(); ++i) {
            const float r2 = sp.disc2[i];
            if (!(r2 > 0.0f)) continue;
            struct Within {
                const KdTree& tree;
                Vec3 normal;
                float r2;
                DiscSums& sums;
                float worstDist2() const { return r2; }
                void add(float d2, uint32_t j) {
                    if (keptWithin<KdTree, VisibleFrom>(tree, j, d2, r2, normal, nullptr))
                        sums.add(d2, decodeRgb9e5(tree.photonPower(j)));
                }
            };
            DiscSums added{kInnerArea * r2};
            Within within{tree, sp.normal[i], r2, added};
            tree.search(sp.position[i], within);
            sp.flux[i] += added.flux * unit;
            sp.innerFlux[i] += added.innerFlux * unit;
            sp.squares[i] += added.squares * unit * unit;
            sp.setIrradiance(i, blendedIrradiance(sp.flux[i], sp.innerFlux[i], sp.squares[i], r2, sp.batches,
                                                  sp.heldBatches));
        }
    });
}

Vec3 IrradiancePoints::lookup(const SetPoints& sp, Vec3 position, Vec3 normal, Vec3 albedo,
                              uint64_t& offered, GatherHint* hint) {
    if (sp.answers.empty()) return Vec3(0.0f);
    // The previous query's kLookupPoints points face this one too when its normal is the same
    // (a flat receiver's), so they lie within their farthest distance plus the step: its nearest
    // points do as well, and a search bounded there finds the same points as one bounded by rMax
    // (the bound widened by a relative 1e-4, far beyond the float rounding of the distances).
    // The bound prunes the tree's far cells from the start; an orbiting camera's frames look up
    // every eye hit (RING at 640×480: 28 % of a client's time in this search).
    float bound2 = sp.rMax2;
    if (hint && hint->lastReach >= 0.0f && normal == hint->lastNormal) {
        const float reach = hint->lastReach + glm::distance(position, hint->lastPosition);
        bound2 = std::min(bound2, reach * reach * 1.0001f);
    }
    thread_local KnnHeap heap;
    heap.reset(kLookupPoints, bound2);
    FacingPoints result(heap, sp.tree, normal);
    sp.tree.search(position, result);
    offered += result.offered;
    if (hint) {
        hint->lastPosition = position;
        hint->lastNormal = normal;
        hint->lastReach = heap.entries().size() == kLookupPoints ? std::sqrt(heap.worstDist2()) : -1.0f;
    }
    // Of the nearest points, those whose disc holds the query, each weighed by how deep inside
    // its disc the query lies (1 − d²/r², the Epanechnikov kernel of the point's own disc: a point
    // whose disc barely reaches the query says little about it; equal weights blurred the curved
    // mirror's moving caustic by up to 2 % more at frames 2–31). Points lie where photons do, with
    // a density ∝ their irradiance: the harmonic mean weights each by the area it stands for
    // (∝ 1/E), where the plain mean would lean towards the brighter side of a gradient (on the
    // curved mirror by +30 % of the caustic's energy after one frame, +70 % after 32).
    glm::dvec3 inverse(0.0);
    double weights = 0.0;
    for (const KnnEntry& e : heap.entries()) {
        const uint32_t id = sp.tree.photonPower(e.index);
        const SetPoints::Answer& a = sp.answers[id];
        if (!(e.dist2 < a.radius2) || !a.lit) continue;
        const double w = 1.0 - double(e.dist2) / double(a.radius2);
        inverse += w * a.inverse;
        weights += w;
    }
    if (!(weights > 0.0)) return Vec3(0.0f);
    return albedo * kInvPi * Vec3(glm::dvec3(weights) / inverse);
}

Vec3 IrradiancePoints::radiance(const EmbreeScene&, uint32_t set, const SurfaceHit& hit, Vec3 normal,
                                Vec3 albedo, GatherHint* hint) const {
    const SetPoints* sp = find(set);
    lookups_.fetch_add(1, std::memory_order_relaxed);
    if (!sp || !sp->built) return Vec3(0.0f);
    uint64_t offered = 0;
    const Vec3 v = lookup(*sp, hit.position, normal, albedo, offered, hint);
    candidates_.fetch_add(offered, std::memory_order_relaxed);
    return v;
}

void IrradiancePoints::radianceGroup(const EmbreeScene&, uint32_t set, std::span<const CausticQuery> queries,
                                     std::span<Vec3> out, GatherHint* hint) const {
    RTPM_CHECK(out.size() == queries.size());
    const SetPoints* sp = find(set);
    lookups_.fetch_add(queries.size(), std::memory_order_relaxed);
    uint64_t offered = 0;
    for (size_t i = 0; i < queries.size(); ++i)
        out[i] = sp && sp->built
                     ? lookup(*sp, queries[i].hit->position, queries[i].normal, queries[i].albedo, offered, hint)
                     : Vec3(0.0f);
    candidates_.fetch_add(offered, std::memory_order_relaxed);
}

IrradiancePointCounts IrradiancePoints::counts() const {
    return IrradiancePointCounts{gathers_.load(), lookups_.load(), candidates_.load()};
}

void IrradiancePoints::resetCounters() {
    gathers_ = 0;
    lookups_ = 0;
    candidates_ = 0;
}

}  // namespace rtpm
