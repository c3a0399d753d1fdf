// ProgressiveSet: photons binned into a radius ladder per eye hit; the disc shown is chosen per
// frame by the intersection-of-confidence-intervals rule (progressive.h).
#include "common/render/progressive.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "common/core/check.h"
#include "common/core/math.h"
#include "common/photon/group_gather.h"

namespace rtpm {

namespace {

// A caustic value's relative noise in 64ths, as the wire carries it: how far the master's filter
// may see it differ from a neighbour's before it reads an edge there (0 for a black value).
uint8_t relativeNoise64ths(double noise, double value) {
    const double rel = noise / value;
    return value > 0.0 && std::isfinite(rel) ? uint8_t(std::lround(std::clamp(rel * 64.0, 0.0, 255.0))) : 0;
}

// kBinRatio2^j for every ring.
const std::array<double, kRadiusBins> kDiscScale = [] {
    std::array<double, kRadiusBins> a{};
    for (int j = 0; j < kRadiusBins; ++j) a[size_t(j)] = std::pow(kBinRatio2, double(j));
    return a;
}();

// r_j² of ring j's outer disc.
double disc2(double outer2, int j) { return outer2 * kDiscScale[size_t(j)]; }

// The photons of one gather, reused per thread.
thread_local std::vector<FoundPhoton> found;

// The blur of a disc relative to its estimate e (n photons), from the step to the disc just
// inside it (e', n'; Choice::drift), whose area is rho × this disc's (kBinRatio2 between whole
// rings), with the step's own noise taken out in quadrature: for Poisson counts
// Var(e − e')/e² = (n'(1/rho − 1)² + n − n')/n². A step of less than half a ring's (the walk's
// start disc lay near the next ring's edge) says nothing it could be divided up by: 0.
double drift(double e, double n, double inner, double innerN, double rho) {
    if (!(1.0 - rho >= 0.5 * (1.0 - kBinRatio2))) return 0.0;
    const double step = (e - inner) / e;
    const double a = 1.0 / rho - 1.0;
    const double noise = (innerN * a * a + (n - innerN)) / (n * n);
    return std::sqrt(std::max(0.0, step * step - noise)) / (1.0 - rho);
}

// The number of equal-power photons whose estimate is as noisy as that of photons of luminance
// sum `sum` and sum of squared luminances `sum2`: (Σw)² / Σw². Photons of one power count as
// themselves; a disc holding one heavy photon among many light ones (an SPT pilot that hit
// outside the refined boxes carries up to 1 + R times a refined path's power) counts far fewer,
// so the rule does not take it for a precise small disc.
double effectiveCount(double sum, double sum2, double count) {
    return sum2 > 0.0 ? sum * sum / sum2 : count;
}

// The squared distance of offset `o` in the metric of a hit's discs (ProgressiveSet::Shape):
// |o|²/a + (a − 1/a)(o·u)², whose disc of radius r is the ellipse with semi-axes r/√a across u
// and r√a along the surface, of the circle's area.
inline float metricDist2(Vec3 o, Vec3 u, float a) {
    const float t = dot(o, u);
    return dot(o, o) / a + (a - 1.0f / a) * t * t;
}

// An orthonormal pair in the plane of unit normal n (the moments' axes).
void tangentBasis(Vec3 n, Vec3& t1, Vec3& t2) {
    t1 = glm::normalize(std::abs(n.x) > 0.9f ? glm::cross(n, Vec3(0, 1, 0)) : glm::cross(n, Vec3(1, 0, 0)));
    t2 = glm::cross(n, t1);
}

// One search's sums of photon offsets in the tangent plane (Shape's moments), in double.
struct MomentSums {
    double n = 0.0, s1 = 0.0, s2 = 0.0, s11 = 0.0, s12 = 0.0, s22 = 0.0;
    void add(Vec3 o, Vec3 t1, Vec3 t2) {
        const double a = dot(o, t1), b = dot(o, t2);
        n += 1.0;
        s1 += a;
        s2 += b;
        s11 += a * a;
        s12 += a * b;
        s22 += b * b;
    }
};

// Adds `m` to the shape's moments and decides the shape once they hold kShapePhotons photons:
// the covariance of the offsets has eigenvalues λ₁ ≥ λ₂; where λ₁/λ₂ ≥ kAspectMin the discs
// become ellipses of aspect min(kAspectMax, (λ₁/λ₂)^kAspectPower) whose long axis is λ₁'s.
void addMoments(ProgressiveSet::Shape& shape, const MomentSums& m, Vec3 normal) {
    if (shape.decided) return;
    shape.n += float(m.n);
    shape.s1 += float(m.s1);
    shape.s2 += float(m.s2);
    shape.s11 += float(m.s11);
    shape.s12 += float(m.s12);
    shape.s22 += float(m.s22);
    if (!(double(shape.n) >= kShapePhotons)) return;
    shape.decided = true;
    const double c = shape.n, m1 = shape.s1 / c, m2 = shape.s2 / c;
    const double c11 = shape.s11 / c - m1 * m1, c12 = shape.s12 / c - m1 * m2, c22 = shape.s22 / c - m2 * m2;
    const double mid = 0.5 * (c11 + c22), half = std::sqrt(0.25 * (c11 - c22) * (c11 - c22) + c12 * c12);
    const double big = mid + half, small = mid - half;
    // Coincident photons say nothing of a direction: a circle. (Their spread in the float sums
    // is rounding, up to about 1e-5 of their mean squared offset.)
    if (!(big > 1e-4 * (shape.s11 + shape.s22) / c)) return;
    const double ratio = small > 0.0 ? big / small : std::numeric_limits<double>::infinity();
    if (!(ratio >= kAspectMin)) return;
    Vec3 t1, t2;
    tangentBasis(normal, t1, t2);
    const double theta = 0.5 * std::atan2(2.0 * c12, c11 - c22);  // λ₁'s axis from t1
    shape.across = glm::normalize(float(-std::sin(theta)) * t1 + float(std::cos(theta)) * t2);
    shape.aspect = float(std::min(kAspectMax, std::pow(ratio, kAspectPower)));
}

// Adds rings `active` … kRadiusBins − 1 of `from` to `to`.
void addRings(ProgressiveSet::Rings& to, const ProgressiveSet::Rings& from, int active) {
    for (int j = active; j < kRadiusBins; ++j) {
        for (int c = 0; c < 3; ++c) to.power[size_t(3 * j + c)] += from.power[size_t(3 * j + c)];
        to.count[size_t(j)] += from.count[size_t(j)];
        to.power2[size_t(j)] += from.power2[size_t(j)];
    }
}

// The ellipse a shaped hit bins within (Shape), searched as `slabs` spheres, one per slab of its
// long axis: a sphere's search keeps the photons within the ellipse (metric distance² below
// `limit2`, the active disc's r²) that lie in its own slab, so none is binned twice.
struct Ellipse {
    Vec3 x, across, axis;  // centre, short axis, long axis (unit)
    float aspect, limit2;
    float along;           // the long semi-axis, r√a
    int slabs, slab;
    // The slab of offset o (0 … slabs − 1).
    int slabOf(Vec3 o) const {
        return std::clamp(int(std::floor((dot(o, axis) + along) * float(slabs) / (2.0f * along))), 0, slabs - 1);
    }
};

// One hit's binning of one pass (ProgressiveSet::bin): the photons are summed per ring here
// first, then added to the ring totals (addTo), so the totals take one addition per pass, not per
// photon, and float sums stay accurate over many passes. A photon's ring is the number of inner
// discs it lies inside (r_{j+1}² ≤ d² < r_j²): 19 comparisons with the discs' exact squared
// radii, which the compiler vectorises (a log2 per photon cost more, and rounded at the ring
// boundaries).
class PassRings {
public:
    PassRings(float outer2, float powerUnit) : inverseUnit_(1.0f / powerUnit) {
        inner2_[0] = 0.0f;  // unused: every photon lies inside the outer disc
        for (int j = 1; j < kRadiusBins; ++j) inner2_[j] = float(disc2(outer2, j));
    }
    /// A photon at squared distance `dist2` with power `power` (W, one batch).
    void add(float dist2, Vec3 power) {
        int j = 0;
        for (int i = 1; i < kRadiusBins; ++i) j += dist2 < inner2_[i] ? 1 : 0;
        local_.power[3 * j] += power.x;
        local_.power[3 * j + 1] += power.y;
        local_.power[3 * j + 2] += power.z;
        local_.count[j] += 1.0f;
        // Squares in units² stay far from float's range.
        const float w = (0.2126f * power.x + 0.7152f * power.y + 0.0722f * power.z) * inverseUnit_;
        local_.power2[j] += w * w;
    }
    /// Adds rings `active` … kRadiusBins − 1 to `rings` (photons in rings outside are left out).
    void addTo(ProgressiveSet::Rings& rings, int active) const { addRings(rings, local_, active); }

private:
    alignas(32) float inner2_[kRadiusBins];
    float inverseUnit_;
    ProgressiveSet::Rings local_;
};

// A radius search's result set that bins the photons it finds (density.h keptWithin: strictly
// within sqrt(radius2), front-facing, visible if `visible` is given) straight into PassRings, in
// the order the search finds them: what RadiusList would list, without the list between.
class BinFound {
public:
    BinFound(const KdTree& tree, uint32_t ownSet, Vec3 normal, float radius2, float powerUnit,
             const VisibleFrom* visible, PassRings& rings, const Ellipse* ellipse, MomentSums* moments, Vec3 x)
        : tree_(tree), tagged_(tree.tagged()), ownSet_(ownSet), normal_(normal), radius2_(radius2),
          powerUnit_(powerUnit), visible_(visible), rings_(rings), ellipse_(ellipse), moments_(moments), x_(x) {
        if (moments_) tangentBasis(normal_, t1_, t2_);
    }
    float worstDist2() const { return radius2_; }
    void add(float dist2, uint32_t i) {
        if (tagged_ && tree_.photonTag(i) == ownSet_) return;  // the set's own photons, binned before
        float ringDist2 = dist2;
        if (ellipse_) {
            const Vec3 o = tree_.photonPosition(i) - ellipse_->x;
            ringDist2 = metricDist2(o, ellipse_->across, ellipse_->aspect);
            if (!(ringDist2 < ellipse_->limit2) || (ellipse_->slabs > 1 && ellipse_->slabOf(o) != ellipse_->slab)) return;
        }
        if (!keptWithin(tree_, i, dist2, radius2_, normal_, visible_)) return;
        rings_.add(ringDist2, decodeRgb9e5(tree_.photonPower(i)) * powerUnit_);
        if (moments_) moments_->add(tree_.photonPosition(i) - x_, t1_, t2_);
    }

private:
    const KdTree& tree_;
    bool tagged_;
    uint32_t ownSet_;
    Vec3 normal_;
    float radius2_;
    float powerUnit_;
    const VisibleFrom* visible_;
    PassRings& rings_;
    const Ellipse* ellipse_;
    MomentSums* moments_;
    Vec3 x_;
    Vec3 t1_{0.0f}, t2_{0.0f};
};
static_assert(ResultSet<BinFound>);

// The world distance between neighbouring pixels of the image at a set's pixel p (of `pixels`,
// `cols` a row; set neighbours are M apart): from its first hit to the next pixel's in its row or
// column, the nearer; infinite without hits.
double pixelFootprint(const EyeRecords& records, size_t p, size_t pixels, size_t cols, int m) {
    double best = std::numeric_limits<double>::infinity();
    if (records.firstHit[p] == records.firstHit[p + 1]) return best;
    const Vec3 x = records.hits[records.firstHit[p]].hit.position;
    for (size_t q : {p + 1, p + cols}) {
        if (q >= pixels || (q == p + 1 && q % cols == 0)) continue;
        if (records.firstHit[q] == records.firstHit[q + 1]) continue;
        best = std::min(best, double(glm::length(records.hits[records.firstHit[q]].hit.position - x)));
    }
    return best / double(m);
}

}  // namespace

void ProgressiveSet::choose(const Rings& rings, int active, double gamma, const double (&noiseScale)[2],
                            double maxCount, Choice (&out)[2], double powerUnit) {
    // E_j ∝ P_j / kBinRatio2^j (the common factor π R₀² B cancels in every comparison), and
    // σ_j ≈ E_j / √n_j. The walk starts at the disc holding exactly kMinPhotons (a disc with
    // fewer says too little about its noise to be compared), then takes whole rings.
    glm::dvec3 power(0.0);
    double count = 0.0, power2 = 0.0;  // photons, Σ of their squared luminances
    double lo[2], hi[2];
    bool open[2] = {true, true}, any = false;
    for (int i = 0; i < 2; ++i) {
        lo[i] = -std::numeric_limits<double>::infinity();
        hi[i] = std::numeric_limits<double>::infinity();
        out[i] = Choice{active, kDiscScale[size_t(active)], glm::dvec3(0.0), 0.0};
    }
    double previous = 0.0, previousCount = 0.0;  // E and effective n of the last disc walked
    double previousScale = 1.0;                  // and its area (Choice::scale)
    double previousDrift = 0.0;                  // and its blur (Choice::drift)
    // The disc holding exactly `target` photons inside ring j, the ring's photons taken as spread
    // evenly over its area (where the walk starts and where the cap ends it).
    struct Partial {
        double inner, scale;  // disc j+1's area and this disc's, relative to the outer disc
        glm::dvec3 power;
        double effective, e, sd;
    };
    auto partial = [&](int j, const glm::dvec3& ring, double target) {
        const double a = (target - count) / double(rings.count[j]);
        Partial d;
        d.inner = kDiscScale[size_t(j + 1)];
        d.scale = d.inner + a * (kDiscScale[size_t(j)] - d.inner);
        d.power = power + a * ring;
        d.effective = effectiveCount(luminance(d.power) / powerUnit, power2 + a * double(rings.power2[j]), target);
        d.e = luminance(d.power) / d.scale;
        d.sd = d.effective > 0.0 ? d.e / std::sqrt(d.effective) : 0.0;
        return d;
    };
    for (int j = kRadiusBins - 1; j >= active && (open[0] || open[1]); --j) {
        const double scale = 1.0 / kDiscScale[size_t(j)];
        const glm::dvec3 ring(rings.power[3 * j], rings.power[3 * j + 1], rings.power[3 * j + 2]);
        if (!any && count + rings.count[j] >= kMinPhotons && count < kMinPhotons && j + 1 < kRadiusBins) {
            // The walk starts at the disc holding exactly kMinPhotons, within ring j (its photons
            // taken as spread evenly over the ring's area, as where the cap ends the walk): a
            // start at whole rings jumped from ring to ring as a pixel moved away from a bright
            // edge, and drew concentric rings around GLASS's spot and in EGG's shadow.
            const Partial d = partial(j, ring, kMinPhotons);
            for (int i = 0; i < 2; ++i) {
                lo[i] = d.e - gamma * noiseScale[i] * d.sd;
                hi[i] = d.e + gamma * noiseScale[i] * d.sd;
                out[i] = Choice{j + 1, d.scale, d.power, double(kMinPhotons), 0.0, d.effective};
            }
            previous = d.e;
            previousCount = d.effective;
            previousScale = d.scale;
            any = true;
        }
        if (any && count + rings.count[j] > maxCount) {
            // The cap ends the walk inside ring j: the disc holding exactly maxCount photons, the
            // ring's photons taken as spread evenly over its area, if the rule still admits it.
            const Partial d = partial(j, ring, maxCount);
            for (int i = 0; i < 2 && maxCount > count; ++i) {
                if (!open[i]) continue;
                if (std::max(lo[i], d.e - gamma * noiseScale[i] * d.sd) > std::min(hi[i], d.e + gamma * noiseScale[i] * d.sd))
                    continue;
                // Its blur: the inner disc's, grown with the area (a kernel's bias grows as r²).
                out[i] = Choice{j + 1, d.scale, d.power, maxCount, previousDrift * d.scale / d.inner, d.effective, true};
            }
            break;
        }
        power += ring;
        count += rings.count[j];
        power2 += rings.power2[j];
        if (!any && count < kMinPhotons && j > active) continue;
        const double n = effectiveCount(luminance(power) / powerUnit, power2, count);
        const double e = luminance(power) * scale;
        const double sd = n > 0.0 ? e / std::sqrt(n) : 0.0;
        const double rho = previousScale / kDiscScale[size_t(j)];
        const double blur = any && e > 0.0 ? drift(e, n, previous, previousCount, rho) : 0.0;
        for (int i = 0; i < 2; ++i) {
            if (!open[i]) continue;
            const double lo2 = std::max(lo[i], e - gamma * noiseScale[i] * sd);
            const double hi2 = std::min(hi[i], e + gamma * noiseScale[i] * sd);
            if (any && lo2 > hi2) {
                open[i] = false;
                continue;
            }
            lo[i] = lo2;
            hi[i] = hi2;
            out[i] = Choice{j, kDiscScale[size_t(j)], power, count, blur, n};
        }
        previous = e;
        previousCount = n;
        previousScale = kDiscScale[size_t(j)];
        previousDrift = blur;
        any = true;
    }
}

void ProgressiveSet::bin(Rings& rings, float outer2, int active, std::span<const FoundPhoton> photons,
                         float powerUnit) {
    PassRings local(outer2, powerUnit);
    for (const FoundPhoton& p : photons) local.add(p.dist2, p.power);
    local.addTo(rings, active);
}

void ProgressiveSet::binWithin(Rings& rings, float outer2, int active, std::span<const KdTree* const> trees,
                               uint32_t set, Vec3 x, Vec3 normal, float radius2, float treeUnit, float powerUnit,
                               const VisibleFrom* visible, Shape* shape) {
    PassRings local(outer2, powerUnit);
    MomentSums moments;
    MomentSums* collect = shape && !shape->decided ? &moments : nullptr;
    if (radius2 > 0.0f && shape && shape->aspect != 1.0f) {
        // The ellipse of semi-axes L = r√a along and r/√a across as n spheres over slabs of its
        // long axis, each of radius² (L/n)² + r²/a: n π r² (a/n² + 1/a) in all, 2.5 π r² for
        // n = a/2 against a π r² for one sphere of radius L.
        Ellipse e{x, shape->across, glm::cross(normal, shape->across), shape->aspect, radius2,
                  std::sqrt(radius2 * shape->aspect), std::max(1, int(std::lround(0.5f * shape->aspect))), 0};
        const float half = e.along / float(e.slabs);
        const float sphere2 = e.slabs == 1 ? radius2 * e.aspect : (half * half + radius2 / e.aspect) * (1.0f + 1e-4f);
        for (e.slab = 0; e.slab < e.slabs; ++e.slab) {
            const Vec3 centre = e.slabs == 1 ? x : x + e.axis * (-e.along + (2.0f * float(e.slab) + 1.0f) * half);
            for (const KdTree* tree : trees) {
                if (tree->empty()) continue;
                BinFound found(*tree, set, normal, sphere2, treeUnit, visible, local, &e, collect, x);
                tree->search(centre, found);
            }
        }
    } else if (radius2 > 0.0f) {
        for (const KdTree* tree : trees) {
            if (tree->empty()) continue;
            BinFound found(*tree, set, normal, radius2, treeUnit, visible, local, nullptr, collect, x);
            tree->search(x, found);
        }
    }
    local.addTo(rings, active);
    if (collect) addMoments(*shape, moments, normal);
}

void ProgressiveSet::restart(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set,
                             const Camera& camera, EyeRecords records, std::span<PixelRadiance> out) {
    RTPM_CHECK(records.firstHit.size() == out.size() + 1);
    records_ = std::move(records);
    camera_ = camera;
    passes_ = 0;
    areaSets_ = 0;
    batches_ = double(maps.stats(set).batches);
    rule_.gamma = maps.settings().progressiveGamma;
    rule_.k = maps.settings().k;
    rule_.pathsPerBatch = maps.settings().photonsPerBatch;
    rule_.powerUnit = maps.powerUnit();
    fixedDirect_.resize(out.size());
    for (size_t p = 0; p < out.size(); ++p) fixedDirect_[p] = out[p].direct;
    state_.assign(records_.hits.size(), HitState{});
    const float rMax2 = maps.gatherRadius() * maps.gatherRadius();
    // The ladder's outer disc has kOuterArea × the area of the map's k-NN disc. Then the map's
    // photons within it fill the rings, or only those within the narrowest whole disc `inner`
    // that holds more than the cap's photons: the walk then ends inside it and the rings outside
    // are never read, now or later (a capped disc only narrows; kActiveMargin), so they stay
    // inactive, and the passes gather no farther.
    const double capPhotons = std::max<double>(maxDiscPhotons(rule_.k, batches_ * double(rule_.pathsPerBatch)), kMinPhotons);
    // The cap's photons, √batches × k, fill about √batches × the k-NN disc: the first disc tried
    // has at least that area, the second twice that (a disc whose photons fell short of the cap),
    // then the whole ladder. Trying the smaller disc first cut the curved mirror's restart by
    // a sixth (198 against 230 ms on one thread; the same image: only rings the walk never
    // reads are left out).
    const double capArea = std::sqrt(std::max(1.0, batches_));
    constexpr double kCapAreaTries[] = {1.0, 2.0};
    // The narrowest whole disc of at least `area` × the k-NN disc (0: none, the ladder's outer).
    auto discOver = [&](const HitState& s, const DensityGather& g, double area) {
        int inner = 0;
        if (g.count >= rule_.k && g.radius2 > 0.0f)
            while (inner + 1 < kRadiusBins && disc2(s.outer2, inner + 1) >= area * double(g.radius2)) ++inner;
        return inner;
    };
    // One radius search per hit gives both the k-NN disc and the photons binned
    // (PhotonMaps::gatherMapKnnWithin: r_k from the photons found), within kGuessScale × the
    // first disc the hit before tried; the guess runs through a fixed block of hits, so neither
    // the searches nor the image depend on the thread count. The same image as a k-NN search
    // followed by a radius search, in 150 instead of 198 ms on the curved mirror's first frame on
    // one thread (RING 330 → 300 ms, GLASS 821 → 753 ms).
    constexpr size_t kBlock = 512;
    const size_t hitCount = records_.hits.size();
    tbb::parallel_for(size_t(0), (hitCount + kBlock - 1) / kBlock, [&](size_t block) {
        float guess2 = 0.0f;  // 0: all of rMax
        const size_t end = std::min(hitCount, (block + 1) * kBlock);
        for (size_t h = block * kBlock; h < end; ++h) {
            const EyeHit& e = records_.hits[h];
            HitState& s = state_[h];
            s.areaSum = glm::dvec3(e.areaDirect);
            float reach2 = guess2;  // `found` holds every photon strictly within it
            const DensityGather g = maps.gatherMapKnnWithin(scene, set, e.hit, e.normal, reach2, found);
            s.outer2 = g.radius2 > 0.0f ? std::min(rMax2, kOuterArea * g.radius2) : rMax2;
            // Just beyond, so that a photon at exactly that distance falls inside the ladder.
            s.outer2 = std::nextafter(s.outer2, std::numeric_limits<float>::infinity());
            const int first = discOver(s, g, kCapAreaTries[0] * capArea);
            // A hit whose k-NN disc reached rMax leaves the guess as it was: the next one may lie
            // in the caustic again, and a search of all of rMax there costs more than a failed guess.
            if (first > 0) guess2 = kGuessScale * float(disc2(s.outer2, first));
            // Where the k-NN disc held its k photons: the discs above, narrowest first. `found`
            // may hold photons beyond the disc tried: they fall in rings below `active`, which
            // bin leaves out, so the rings get exactly what a search of that disc would give.
            // Makes `found` hold every photon strictly within sqrt(r2), searching only beyond reach.
            auto cover = [&](float r2) {
                if (r2 <= reach2) return;
                found.clear();
                maps.gatherMapPhotons(scene, set, e.hit, e.normal, r2, found);
                reach2 = r2;
            };
            // Bins `found` from ring `active` on. The photons within the active disc first add to
            // the hit's shape moments; where that decides an ellipse, the rings get the photons
            // within the ellipses instead.
            auto binShaped = [&] {
                const float r2 = float(disc2(s.outer2, s.active));
                MomentSums m;
                Vec3 t1, t2;
                tangentBasis(e.normal, t1, t2);
                for (const FoundPhoton& p : found)
                    if (p.dist2 < r2) m.add(p.position - e.hit.position, t1, t2);
                addMoments(s.shape, m, e.normal);
                if (s.shape.aspect != 1.0f) {
                    cover(r2 * s.shape.aspect);
                    for (FoundPhoton& p : found)
                        p.dist2 = metricDist2(p.position - e.hit.position, s.shape.across, s.shape.aspect);
                    std::erase_if(found, [r2](const FoundPhoton& p) { return !(p.dist2 < r2); });
                }
                bin(s.rings, s.outer2, s.active, found, float(rule_.powerUnit));
            };
            bool capped = false;
            int tried = 0;
            for (double factor : kCapAreaTries) {
                const int inner = discOver(s, g, factor * capArea);
                if (inner == tried) continue;  // 0: none; else the disc just tried
                tried = inner;
                const float r2 = float(disc2(s.outer2, inner));
                cover(r2);
                const auto held = std::count_if(found.begin(), found.end(), [r2](const FoundPhoton& p) { return p.dist2 < r2; });
                if (double(held) > capPhotons) {
                    s.active = inner;
                    binShaped();
                    capped = true;
                    break;
                }
            }
            if (capped) continue;
            // The whole ladder (active 0): nothing beyond its outer disc may be binned.
            cover(s.outer2);
            const float outer2 = s.outer2;
            std::erase_if(found, [outer2](const FoundPhoton& p) { return !(p.dist2 < outer2); });
            reach2 = std::min(reach2, outer2);
            binShaped();
        }
    });
    valid_ = true;
    uint64_t nonFinite = 0;
    compose(out, nonFinite);
}

void ProgressiveSet::pass(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set,
                          std::span<const SharedPhotons* const> shared,
                          const AreaLightSampler& areaLights, std::span<PixelRadiance> out, uint64_t& shadowRays,
                          uint64_t& nonFinite) {
    RTPM_CHECK(valid_ && out.size() + 1 == records_.firstHit.size());
    ++passes_;
    const bool sampleArea = !areaLights.empty();
    if (sampleArea) ++areaSets_;
    std::atomic<uint64_t> rays{0};
    const bool visibility = maps.settings().gatherVisibility;
    const float unit = maps.powerUnit();
    // The trees a hit searches: the pass's, then (a sharing hit's) each shared frame's tree of
    // every set's shot, where the search leaves this set's own out; and each frame's other sets'
    // batches.
    std::vector<const KdTree*> trees;
    if (const KdTree* own = maps.passTree(set)) trees.push_back(own);
    const size_t ownTrees = trees.size();
    std::vector<uint32_t> sharedBatches;
    for (const SharedPhotons* frame : shared) {
        sharedBatches.push_back(frame->batchesExcept(set));
        trees.push_back(&frame->tree());
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, records_.hits.size()), [&](const auto& range) {
        uint64_t localRays = 0;
        for (size_t h = range.begin(); h < range.end(); ++h) {
            const EyeHit& e = records_.hits[h];
            HitState& s = state_[h];
            const float r2 = float(disc2(s.outer2, s.active));
            // Its own photons, then (a sharing hit) the other sets', binned as the searches find
            // them.
            if (s.sharing)
                for (uint32_t b : sharedBatches) s.shared += float(b);
            const VisibleFrom visible(visibility, scene, e.hit, e.normal);
            const auto searched = std::span(trees).first(s.sharing ? trees.size() : ownTrees);
            auto binInto = [&](Rings& rings) {
                binWithin(rings, s.outer2, s.active, searched, set, e.hit.position, e.normal, r2, unit,
                          float(rule_.powerUnit), visibility ? &visible : nullptr, &s.shape);
            };
            if (s.shape.decided) {
                binInto(s.rings);
            } else {
                // The pass's photons add to the shape's moments first; where they decide an
                // ellipse, the pass bins its photons within the ellipses.
                Rings fresh;
                binInto(fresh);
                if (s.shape.aspect != 1.0f)
                    binInto(s.rings);
                else
                    addRings(s.rings, fresh, s.active);
            }
            if (sampleArea) s.areaSum += glm::dvec3(areaLights.sample(e, areaSets_, localRays));
        }
        rays += localRays;
    });
    batches_ += double(maps.passBatches(set));
    shadowRays += rays;
    compose(out, nonFinite);
}

void ProgressiveSet::skip(std::span<PixelRadiance> out) {
    RTPM_CHECK(valid_ && out.size() == shown_.size());
    ++passes_;
    std::copy(shown_.begin(), shown_.end(), out.begin());
}

void ProgressiveSet::compose(std::span<PixelRadiance> out, uint64_t& nonFinite) {
    const double samples = double(areaSets_) + 1.0;  // area-light sample sets per hit
    const double filterNoise = std::sqrt(rule_.filterShare);
    std::atomic<uint64_t> bad{0};
    std::vector<float> sigma(out.size(), 0.0f);
    ownWeights_.assign(out.size(), 0);
    noise_.assign(out.size(), 0);
    const size_t cols = size_t(std::max(image_.columns, 1));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size()), [&](const auto& range) {
        for (size_t p = range.begin(); p < range.end(); ++p) {
            glm::dvec3 direct(fixedDirect_[p]);
            glm::dvec3 caustic(0.0), own(0.0);
            double sd = 0.0, ownSd = 0.0;
            double noise = 0.0, ownNoise = 0.0;  // Poisson noise alone, of the values as sent
            double radius = 0.0;
            // The first hit's aspect: neighbours' ellipses lie at other angles, so the noise the
            // master's filter allows (noise_) grows with it (else a dotted halo around GLASS's spot).
            double aspect = 1.0;
            bool capped = false;  // the cap, not a change in density, ended the shown disc's walk
            for (uint32_t h = records_.firstHit[p]; h < records_.firstHit[p + 1]; ++h) {
                const EyeHit& e = records_.hits[h];
                HitState& s = state_[h];
                const glm::dvec3 throughput(e.throughput);
                direct += throughput * (s.areaSum / samples);
                // The set's own batches and the other sets' this hit binned (pass).
                const double batches = batches_ + double(s.shared);
                if (!(batches > 0.0) || !(s.outer2 > 0.0f)) continue;
                // Shared photons are common to the sets the filter averages (setFilterShare).
                const double share = s.shared > 0.0f ? 1.0 - (1.0 - rule_.filterShare) * batches_ / batches : rule_.filterShare;
                const double noiseScale = std::sqrt(share);
                const double scales[2] = {noiseScale, 1.0};
                Choice c[2];
                const double paths = batches * double(rule_.pathsPerBatch);
                choose(s.rings, s.active, earlyGamma(rule_.gamma, paths), scales, maxDiscPhotons(rule_.k, paths), c, rule_.powerUnit);
                const glm::dvec3 weight = throughput * glm::dvec3(e.albedo) / double(kPi);
                for (int i = 0; i < (image_.f > 1 ? 2 : 1); ++i) {
                    const double area = kPi * double(s.outer2) * c[i].scale * batches;
                    const glm::dvec3 value = weight * (c[i].power / area);
                    // Noise and the blur the rule saw, added in quadrature.
                    const double rel = c[i].effective > 0.0 ? 1.0 / c[i].effective + c[i].drift * c[i].drift : 0.0;
                    const double sdv = luminance(value) * std::sqrt(rel);
                    const double poisson = c[i].effective > 0.0 ? luminance(value) / std::sqrt(c[i].effective) : 0.0;
                    if (i == 0) {
                        caustic += value;
                        // The shown filter average: neighbours' shared photons sit at other
                        // points of their discs, so their noise still averages out.
                        sd += sdv * filterNoise;
                        noise += poisson;
                    } else {
                        own += value;
                        ownSd += sdv;
                        ownNoise += poisson;
                    }
                }
                if (h == records_.firstHit[p]) {
                    // An ellipse's blur is its short semi-axis's.
                    aspect = double(s.shape.aspect);
                    radius = std::sqrt(double(s.outer2) * c[0].scale / aspect);
                    capped = c[0].capped;
                }
                const Choice& shown = c[0];
                // Rings far outside the shown disc are no longer gathered; none outside the ring
                // of a capped one (kActiveMargin).
                s.active = std::max(s.active, shown.capped ? shown.disc - 1 : shown.disc - kActiveMargin);
            }
            if (image_.f > 1 && radius > 0.0) {
                const double half = 0.5 * double(image_.f) * pixelFootprint(records_, p, out.size(), cols, image_.m);
                const double t = radius / half;
                // In 255ths, as the wire carries it, so one process and a cluster agree.
                const double full = capped ? kOwnFullCapped : kOwnFull, none = capped ? kOwnNoneCapped : kOwnNone;
                const uint8_t w255 = uint8_t(std::lround(std::clamp((none - t) / (none - full), 0.0, 1.0) * 255.0));
                const double w = double(w255) / 255.0;
                ownWeights_[p] = w255;
                caustic = w * own + (1.0 - w) * caustic;
                sd = w * ownSd + (1.0 - w) * sd;
                noise = w * ownNoise + (1.0 - w) * noise;
            }
            noise_[p] = relativeNoise64ths(noise * aspect, luminance(caustic));
            // A pixel whose disc is narrower than the filter's window shows (some of) its own
            // estimate: from the next pass on its hits bin the other sets' photons too. One
            // that the filter alone shows has every set's photons through it already.
            const bool share = image_.f <= 1 || ownWeights_[p] > 0;
            for (uint32_t h = records_.firstHit[p]; h < records_.firstHit[p + 1]; ++h)
                state_[h].sharing = state_[h].sharing || share;
            PixelRadiance& px = out[p];
            px.direct = Vec3(direct);
            px.caustic = Vec3(caustic);
            sigma[p] = float(sd);
            if (!finite(px.direct)) {
                px.direct = Vec3(0.0f);
                ++bad;
            }
            if (!finite(px.caustic)) {
                px.caustic = Vec3(0.0f);
                sigma[p] = 0.0f;
                ++bad;
            }
        }
    });
    nonFinite += bad;
    shown_.assign(out.begin(), out.end());
    // The caustic region as the error metrics define it: pixels above 5 % of the 99th percentile.
    std::vector<float> lum(out.size());
    for (size_t p = 0; p < out.size(); ++p) lum[p] = float(luminance(out[p].caustic));
    error_ = CausticErrorSums{};
    error_.batches = batches_;
    if (lum.empty()) return;
    std::vector<float> sorted = lum;
    const size_t k99 = std::min(sorted.size() - 1, size_t(0.99 * double(sorted.size())));
    std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(k99), sorted.end());
    const float threshold = 0.05f * sorted[k99];
    if (!(threshold > 0.0f)) return;
    for (size_t p = 0; p < out.size(); ++p)
        if (lum[p] > threshold) {
            error_.sigma += double(sigma[p]);
            error_.radiance += double(lum[p]);
            ++error_.pixels;
        }
}

}  // namespace rtpm
