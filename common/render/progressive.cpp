// ProgressiveSet: restart from the accumulated map's k-NN gather, then SPPM passes per eye hit.
#include "common/render/progressive.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>

#include "common/core/check.h"
#include "common/core/math.h"

namespace rtpm {

void ProgressiveSet::restart(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set,
                             const Camera& camera, EyeRecords records, std::span<PixelRadiance> out) {
    RTPM_CHECK(records.firstHit.size() == out.size() + 1);
    records_ = std::move(records);
    camera_ = camera;
    passes_ = 0;
    alpha_ = maps.settings().progressiveAlpha;
    batches0_ = maps.stats(set).batches;
    fixedDirect_.resize(out.size());
    for (size_t p = 0; p < out.size(); ++p) fixedDirect_[p] = out[p].direct;
    state_.assign(records_.hits.size(), HitState{});
    const double rMax2 = double(maps.gatherRadius()) * double(maps.gatherRadius());
    // Hits in groups of 8 consecutive ones (neighbouring pixels) share their k-NN search
    // (PhotonMaps::gatherMapGroup); the hint runs through a fixed block of groups, so neither the
    // groups nor the hints depend on the thread count.
    constexpr size_t kGroup = 8, kBlock = 64 * kGroup;
    const size_t hitCount = records_.hits.size();
    tbb::parallel_for(size_t(0), (hitCount + kBlock - 1) / kBlock, [&](size_t block) {
        CausticQuery queries[kGroup];
        DensityGather gathers[kGroup];
        GatherHint hint;
        const size_t end = std::min(hitCount, (block + 1) * kBlock);
        for (size_t h0 = block * kBlock; h0 < end; h0 += kGroup) {
            const size_t n = std::min(kGroup, end - h0);
            for (size_t i = 0; i < n; ++i) {
                const EyeHit& e = records_.hits[h0 + i];
                queries[i] = CausticQuery{&e.hit, e.normal, e.albedo};
            }
            maps.gatherMapGroup(scene, set, std::span(queries, n), std::span(gathers, n), &hint);
            for (size_t i = 0; i < n; ++i) {
                const DensityGather& g = gathers[i];
                HitState& s = state_[h0 + i];
                s.areaSum = glm::dvec3(records_.hits[h0 + i].areaDirect);
                if (g.radius2 > 0.0f && finite(g.power)) {
                    s.radius2 = g.radius2;
                    s.count = double(g.count) * kRestartCountShare;
                    s.flux = glm::dvec3(g.power) * double(batches0_);
                } else {
                    s.radius2 = rMax2;
                }
            }
        }
    });
    valid_ = true;
    uint64_t nonFinite = 0;
    compose(out, nonFinite);
}

void ProgressiveSet::pass(const EmbreeScene& scene, const PhotonMaps& maps, uint32_t set,
                          const AreaLightSampler& areaLights, std::span<PixelRadiance> out,
                          uint64_t& shadowRays, uint64_t& nonFinite) {
    RTPM_CHECK(valid_ && out.size() + 1 == records_.firstHit.size());
    ++passes_;
    const bool sampleArea = !areaLights.empty();
    std::atomic<uint64_t> rays{0};
    const double alpha = alpha_;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, records_.hits.size()), [&](const auto& range) {
        uint64_t localRays = 0;
        for (size_t h = range.begin(); h < range.end(); ++h) {
            const EyeHit& e = records_.hits[h];
            HitState& s = state_[h];
            const PassGather g = maps.gatherPass(scene, set, e.hit, e.normal, float(s.radius2));
            if (g.count > 0 && finite(g.power)) {
                const double m = g.count;
                const double ratio = (s.count + alpha * m) / (s.count + m);
                s.radius2 *= ratio;
                s.count += alpha * m;
                s.flux = (s.flux + glm::dvec3(g.power)) * ratio;
            }
            if (sampleArea) s.areaSum += glm::dvec3(areaLights.sample(e, passes_, localRays));
        }
        rays += localRays;
    });
    shadowRays += rays;
    compose(out, nonFinite);
}

void ProgressiveSet::compose(std::span<PixelRadiance> out, uint64_t& nonFinite) const {
    const double samples = double(passes_) + 1.0;      // area-light sample sets per hit
    const double batches = double(batches0_) + double(passes_);
    std::atomic<uint64_t> bad{0};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size()), [&](const auto& range) {
        for (size_t p = range.begin(); p < range.end(); ++p) {
            glm::dvec3 direct(fixedDirect_[p]);
            glm::dvec3 caustic(0.0);
            for (uint32_t h = records_.firstHit[p]; h < records_.firstHit[p + 1]; ++h) {
                const EyeHit& e = records_.hits[h];
                const HitState& s = state_[h];
                const glm::dvec3 throughput(e.throughput);
                direct += throughput * (s.areaSum / samples);
                if (batches > 0.0 && s.radius2 > 0.0)
                    caustic += throughput * glm::dvec3(e.albedo) *
                               (s.flux / (double(kPi) * double(kPi) * s.radius2 * batches));
            }
            PixelRadiance& px = out[p];
            px.direct = Vec3(direct);
            px.caustic = Vec3(caustic);
            if (!finite(px.direct)) {
                px.direct = Vec3(0.0f);
                ++bad;
            }
            if (!finite(px.caustic)) {
                px.caustic = Vec3(0.0f);
                ++bad;
            }
        }
    });
    nonFinite += bad;
}

}  // namespace rtpm
