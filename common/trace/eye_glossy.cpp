// The eye pass's glossy vertices: what arrives at a rough mirror or dielectric, estimated from
// sampled visible microfacet normals and the split trees traced on from them.
//
// * Glossy materials (a Mirror or Dielectric rougher than kSmoothRoughness, common/trace/
//   microfacet.h) end the pixel's split path: what arrives at a glossy vertex is estimated from
//   EyeSettings::glossySamples visible microfacet normals (stratified in the first number). At each, a
//   conductor reflects and a dielectric splits into both lobes with weights F·G2/G1 and
//   (1 − F)·G2/G1, which in the smooth limit is the smooth dielectric's Fresnel split above; the
//   branches then go on as a split tree like the pixel's own (further glossy vertices take one
//   microfacet each). Point, spot and sun lights, which no sampled direction meets, add their
//   highlight at every glossy vertex by a shadow ray (glossyHighlight; for a dielectric its
//   reflection lobe). Numbers come from the pixel's hashed rotation at the vertex and the pass,
//   never from threads. In record mode (the progressive estimator) the glossy vertex is recorded
//   with the direct light of its restart samples, and each pass draws one fresh normal (the
//   rotation advanced along the R3 sequence, as for area lights) and re-traces its tree, so a
//   still view's glossy reflections converge as the passes' running mean (a pass then costs
//   about one eye pass over the glossy pixels). The caustic seen through a glossy vertex
//   is refined at the end points the restart's samples reached (recorded for their caustic only),
//   so it converges in photons but keeps those directions; with the knn estimator it is looked up
//   at each frame's end points and box-filtered as every caustic is.
#include "common/trace/eye_shading.h"

#include <algorithm>
#include <array>
#include <cstring>

#include "common/core/halton.h"
#include "common/core/math.h"
#include "common/core/sampling.h"
#include "common/trace/microfacet.h"
#include "common/trace/optics.h"

namespace rtpm {
namespace detail {

namespace {

constexpr int kGlossyStackSize = 32;

/// One glossyTree call's state: its numbers, its branches still to trace and its sums.
struct GlossyWalk {
    const Context& ctx;
    uint32_t set;
    GlossyCaustic caustic;
    Counters& count;
    std::vector<EyeHit>* record;
    const EyeHit* base;
    float share;     // 1 / samples: throughputs are per sample, the mean is taken at the end points
    uint64_t key;    // hashed from the rotation and the pass
    PathState* stack;  // kGlossyStackSize entries
    uint64_t counter = 0;
    int top = 0;
    GlossyRadiance out;
};

/// The walk's next number in [0, 1).
float nextUniform(GlossyWalk& w) { return hashToUnit(splitMix64(w.key ^ splitMix64(++w.counter))); }

/// Queues the branch leaving `h` along `next`, unless its throughput is pruned or the stack is full.
void pushBranch(GlossyWalk& w, const SurfaceHit& h, Vec3 hng, Vec3 next, Vec3 throughput, int d) {
    if (maxComponent(throughput) < kMinThroughput) return;
    if (w.top == kGlossyStackSize) {
        ++w.count.stackOverflow;
        return;
    }
    w.stack[w.top++] = PathState{Ray{w.ctx.es.offsetOrigin(h.position, hng, next), next}, throughput, d};
}

/// Scatters at glossy `h` with the visible normal drawn by `u`: one branch for a conductor,
/// up to two for a dielectric. A direction on the wrong side of the true surface is dropped.
void scatterGlossy(GlossyWalk& w, const SurfaceHit& h, Vec3 rdir, Vec3 hng, Vec3 hns, Vec2 u, Vec3 throughput,
                   int d) {
    const Material& m = w.ctx.scene.materials[h.material];
    const Vec3 wo = -glm::normalize(rdir);
    if (m.type == MaterialType::Plastic) {
        const ShadingFrame frame(hns);
        BsdfSample s;
        if (!PlasticBsdf(m).sampleCoat(frame.toLocal(wo), u, s)) return;
        const Vec3 next = glm::normalize(frame.toWorld(s.wi));
        if (glm::dot(next, hng) > 0.0f) pushBranch(w, h, hng, next, throughput * s.weight, d);
        return;
    }
    if (m.type == MaterialType::Mirror) {
        const ShadingFrame frame(hns);
        BsdfSample s;
        if (!roughConductorSample(frame.toLocal(wo), ggxAlpha(m.roughness), m.baseColor, u, s)) return;
        const Vec3 next = glm::normalize(frame.toWorld(s.wi));
        if (glm::dot(next, hng) > 0.0f) pushBranch(w, h, hng, next, throughput * s.weight, d);
        return;
    }
    // The dielectric's frame has its normal out of the medium (the convention of optics.h).
    const ShadingFrame frame(h.shadingNormal);
    BsdfSample r, t;
    const int lobes = roughDielectricSplit(frame.toLocal(wo), ggxAlpha(m.roughness), m.ior, u, r, t);
    if (lobes & 1) {
        const Vec3 next = glm::normalize(frame.toWorld(r.wi));
        if (glm::dot(next, hng) > 0.0f) pushBranch(w, h, hng, next, throughput * r.weight, d);
    }
    if (lobes & 2) {
        const Vec3 next = glm::normalize(frame.toWorld(t.wi));
        if (glm::dot(next, hng) < 0.0f) pushBranch(w, h, hng, next, throughput * t.weight, d);
    }
}

/// A diffuse end point `h` of material `m` reached with `throughput` (per sample): its direct light,
/// and its caustic looked up or recorded as the walk asks. `coat`: a plastic's base (eye_shading.h).
void glossyEndPoint(GlossyWalk& w, const SurfaceHit& h, const Material& m, Vec3 hns, Vec3 hng, Vec3 throughput,
                    const PlasticBsdf* coat = nullptr) {
    const EmbreeScene& es = w.ctx.es;
    const Vec3 albedo = baseColorAt(m, w.ctx.scene.textures, h.uv);
    const std::array<float, 3> r{nextUniform(w), nextUniform(w), nextUniform(w)};
    w.out.direct += (throughput * w.share) * directLight(w.ctx, h, hns, hng, albedo, r, w.count, coat);
    if (w.caustic == GlossyCaustic::Lookup && w.ctx.caustics) {
        w.out.caustic += (throughput * w.share) * w.ctx.caustics->radiance(es, w.set, h, hns, albedo);
    } else if (w.caustic == GlossyCaustic::Record) {
        EyeHit& e = w.record->emplace_back();
        e.hit = h;
        e.normal = hns;
        e.geometricNormal = hng;
        e.albedo = albedo;
        e.throughput = w.base->throughput * (throughput * w.share);
        e.pixel = w.base->pixel;
        e.set = w.base->set;
        e.kind = EyeHit::Kind::CausticOnly;
    }
}

/// Follows `path` to its end; smooth dielectric splits queue their reflected branch.
void traceGlossyBranch(GlossyWalk& w, PathState path) {
    const EmbreeScene& es = w.ctx.es;
    const Scene& scene = w.ctx.scene;
    for (;;) {
        SurfaceHit h;
        ++w.count.secondary;
        if (!es.intersect(path.ray, h)) {
            if (w.ctx.environment)
                w.out.direct += (path.throughput * w.share) * w.ctx.environment->radiance(glm::normalize(path.ray.dir));
            break;
        }
        const Material& m = scene.materials[h.material];
        const Vec3 rdir = path.ray.dir;
        const float cosGeo = glm::dot(rdir, h.geometricNormal);
        if (m.type == MaterialType::Dielectric && cosGeo > 0.0f && m.absorption != Vec3(0.0f))
            path.throughput *= beerLambert(m.absorption, h.t * glm::length(rdir));
        if (m.isEmissive() && cosGeo < 0.0f)
            w.out.direct += (path.throughput * w.share) *
                          (m.emissiveTexture >= 0 ? emissionAt(m, scene.textures, h.uv) : m.emission);
        const Vec3 hng = cosGeo > 0.0f ? -h.geometricNormal : h.geometricNormal;
        const Vec3 hns = cosGeo > 0.0f ? -h.shadingNormal : h.shadingNormal;
        if (m.type == MaterialType::Diffuse) {
            if (m.unlit)
                w.out.direct += (path.throughput * w.share) * baseColorAt(m, scene.textures, h.uv);
            else
                glossyEndPoint(w, h, m, hns, hng, path.throughput);
            break;
        }
        if (m.type == MaterialType::Plastic) {
            // As shadePixel: the base ends here, the coat goes on (reflected, or one microfacet).
            const PlasticBsdf coat(m);
            const Vec3 wo = -glm::normalize(rdir);
            const float cosO = std::clamp(glm::dot(wo, hns), 0.0f, 1.0f);
            glossyEndPoint(w, h, m, hns, hng, path.throughput * coat.viewShare(cosO), &coat);
            if (path.depth >= w.ctx.settings.maxDepth) break;
            if (!coat.smooth()) {
                w.out.direct += (path.throughput * w.share) * coatHighlight(w.ctx, h, wo, hns, hng, coat, w.count);
                const float u0 = nextUniform(w);
                scatterGlossy(w, h, rdir, hng, hns, Vec2(u0, nextUniform(w)), path.throughput, path.depth + 1);
                break;
            }
            Vec3 r = glm::normalize(reflect(rdir, hns));
            if (glm::dot(r, hng) <= 0.0f) r = glm::normalize(reflect(rdir, hng));
            path.throughput *= coat.coatFresnel(cosO);
            path.ray = Ray{es.offsetOrigin(h.position, hng, r), r};
            ++path.depth;
            if (maxComponent(path.throughput) < kMinThroughput) break;
            continue;
        }
        if (m.isPartlyDiffuse()) {
            glossyEndPoint(w, h, m, hns, hng, path.throughput * (1.0f - m.transmission));
            path.throughput *= m.transmission;
            if (maxComponent(path.throughput) < kMinThroughput) break;
        }
        if (path.depth >= w.ctx.settings.maxDepth) break;
        if (m.isGlossy()) {
            w.out.direct += (path.throughput * w.share) * glossyHighlight(w.ctx, h, -glm::normalize(rdir), hns, hng, m,
                                                                          w.count);
            const float u0 = nextUniform(w);
            scatterGlossy(w, h, rdir, hng, hns, Vec2(u0, nextUniform(w)), path.throughput, path.depth + 1);
            break;
        }
        if (m.type == MaterialType::Mirror) {
            Vec3 r = glm::normalize(reflect(rdir, hns));
            if (glm::dot(r, hng) <= 0.0f) r = glm::normalize(reflect(rdir, hng));
            path.throughput *= m.baseColor;
            path.ray = Ray{es.offsetOrigin(h.position, hng, r), r};
            ++path.depth;
            if (maxComponent(path.throughput) < kMinThroughput) break;
            continue;
        }
        // Smooth dielectric: both branches, weighted by Fresnel (as shadePixel).
        const DielectricInterface side = dielectricInterface(rdir, h.geometricNormal, m.ior);
        const float cosI = std::clamp(-glm::dot(rdir, hns), 0.0f, 1.0f);
        Vec3 t;
        const bool canRefract = refract(rdir, hns, side.etaI / side.etaT, t) && glm::dot(t, hng) < 0.0f;
        const float fr = canRefract ? fresnelDielectric(cosI, side.etaI, side.etaT) : 1.0f;
        Vec3 r = glm::normalize(reflect(rdir, hns));
        if (glm::dot(r, hng) <= 0.0f) r = glm::normalize(reflect(rdir, hng));
        pushBranch(w, h, hng, r, path.throughput * fr, path.depth + 1);
        if (!canRefract) break;
        path.throughput *= 1.0f - fr;
        path.ray = Ray{es.offsetOrigin(h.position, hng, t), t};
        ++path.depth;
        if (maxComponent(path.throughput) < kMinThroughput) break;
    }
}

}  // namespace

GlossyRadiance glossyTree(const Context& ctx, uint32_t set, const SurfaceHit& hit, Vec3 dir, Vec3 ng,
                          Vec3 ns, int depth, const std::array<float, 3>& rot, uint32_t pass, int samples,
                          GlossyCaustic caustic, Counters& count, std::vector<EyeHit>* record,
                          const EyeHit* base) {
    uint32_t b0, b1;
    std::memcpy(&b0, &rot[0], 4);
    std::memcpy(&b1, &rot[1], 4);
    const uint64_t key = splitMix64((uint64_t(b0) << 32 | b1) ^ splitMix64(0x676c6f7373ull + pass));
    PathState stack[kGlossyStackSize];
    GlossyWalk w{ctx, set, caustic, count, record, base, 1.0f / float(samples), key, stack, 0, 0, {}};
    const Material& m = ctx.scene.materials[hit.material];
    // The punctual lights' highlight, once per vertex.
    if (m.type == MaterialType::Plastic)
        w.out.direct += coatHighlight(ctx, hit, -glm::normalize(dir), ns, ng, PlasticBsdf(m), count);
    else
        w.out.direct += glossyHighlight(ctx, hit, -glm::normalize(dir), ns, ng, m, count);
    // Throughputs are per sample (so branches are pruned as in shadePixel); the mean over the
    // samples is taken at the end points.
    for (int k = 0; k < samples; ++k) {
        const Vec2 u((float(k) + rot[0]) * w.share, wrap01(rot[1] + 0.618034f * float(k)));
        scatterGlossy(w, hit, dir, ng, ns, u, Vec3(1.0f), depth + 1);
    }
    while (w.top > 0) traceGlossyBranch(w, w.stack[--w.top]);
    return w.out;
}

}  // namespace detail
}  // namespace rtpm
