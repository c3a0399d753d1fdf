// The eye pass: per pixel, a primary ray, deterministic splitting along specular chains, and at
// each diffuse end point direct light by shadow rays plus the caustic estimate (paper §4.2).
//
// Choices the paper leaves open (docs/ARCHITECTURE.md §11):
// * Dielectrics split the path deterministically: both the reflected (×F) and the refracted
//   (×(1−F)) branch are traced with a small explicit stack, branches whose throughput falls below
//   kMinThroughput are dropped. One pixel is then noise-free through glass and the image does not
//   depend on any random choice. Refraction does not scale radiance by (ηt/ηi)²: an eye path that
//   enters a dielectric leaves it again through as many interfaces, so the factors cancel.
// * A moving camera's frames sample the splits instead (renderSet's sampleSeed): both branches
//   while each carries at least kSplitThroughput of the pixel (the first surfaces a viewer
//   sees), below that one branch chosen by its Fresnel share, weighted by the inverse of its
//   probability; the branches that exist and their pruning are the deterministic tree's, so the
//   mean over seeds is the deterministic image. On GLASS (640×480) a frame then casts about a
//   tenth of the secondary rays (tests/bench/RESULTS.md).
// * Beer–Lambert: a segment that ends on the back face of a dielectric (dot(dir, Ng) > 0) ran
//   inside that dielectric, and is attenuated by its absorption over the segment length. Nested
//   media are modelled as separate closed surfaces (liquid inside glass), each handled this way.
// * Shadow rays are blocked by every surface, dielectrics included: light focused or refracted by
//   glass is caustic light and comes from the photon map, never from the direct term.
// * Area lights (emissive triangles): the sample budget is N_max = areaLightSamples per triangle
//   with at most kMaxTrianglesSampledEach triangles, else kMaxTrianglesSampledEach·areaLightSamples
//   in total. A shading point takes N = clamp(⌈Ω / kSolidAnglePerSample⌉, 1, N_max) samples,
//   where Ω = π R² / max(d², R²) bounds the solid angle of the emitters' bounding sphere (centre
//   c, radius R; d = |x − c|): a small or far light is nearly a point and one shadow ray resolves
//   it (RING's 10 cm lamp at 2 m: Ω ≈ 0.003 sr, N = 1 instead of 8; HEADLIGHT's filament: 1
//   instead of up to 48), a near, large one keeps the full budget (the Cornell box lamp from its
//   floor: Ω ≈ 0.1 sr, N = 8). Still views refine the estimate over passes (AreaLightSampler).
//   With N = N_max and few triangles, each triangle gets `areaLightSamples` stratified samples (a
//   Cranley–Patterson rotated Hammersley set); otherwise the N samples pick triangles in
//   proportion to their power (area × radiance sum) through a stratified CDF inversion, so the
//   cost per pixel stays bounded for finely tessellated emitters.
// * Sample rotations are hashed from the pixel's image coordinates and the path vertex number,
//   never from thread or set order: the image is identical for any thread count or set split.
// * Mirrors reflect with baseColor (no texture); diffuse albedo is baseColor × texture(uv).
// * A partly transmissive dielectric (transmission t < 1) is split deterministically like a
//   Fresnel split: the Lambertian share (1 − t) is shaded at the hit (direct light and caustic
//   estimate, albedo baseColor × texture), the dielectric share t continues through the Fresnel
//   split below. The photon tracer makes the same choice stochastically (photon_tracer.cpp).
// * Unlit materials (KHR_materials_unlit) return baseColor × texture and end the path.
// * Glossy materials (a Mirror or Dielectric rougher than kSmoothRoughness, common/trace/
//   microfacet.h) end the pixel's split path: what arrives at a glossy vertex is estimated from
//   kGlossySamples visible microfacet normals (stratified in the first number). At each, a
//   conductor reflects and a dielectric splits into both lobes with weights F·G2/G1 and
//   (1 − F)·G2/G1, which in the smooth limit is the smooth dielectric's Fresnel split above; the
//   branches then go on as a split tree like the pixel's own (further glossy vertices take one
//   microfacet each). Numbers come from the pixel's hashed rotation at the vertex and the pass,
//   never from threads. In record mode (the progressive estimator) the glossy vertex is recorded
//   with the direct light of its restart samples, and each pass draws one fresh normal (the
//   rotation advanced along the R3 sequence, as for area lights) and re-traces its tree, so a
//   still view's glossy reflections converge as the passes' running mean (a pass then costs
//   about one eye pass over the glossy pixels). The caustic seen through a glossy vertex
//   is refined at the end points the restart's samples reached (recorded for their caustic only),
//   so it converges in photons but keeps those directions; with the knn estimator it is looked up
//   at each frame's end points and box-filtered as every caustic is.
// * The world light (Scene::environment): a ray that leaves the scene — from the camera, a mirror
//   or glass — returns its radiance. A diffuse end point takes kEnvironmentSamples directions by
//   plain light sampling (no MIS: a Lambertian point has no lobe worth sampling instead), each with
//   a shadow ray to infinity: a uniform sky cosine-weighted about the shading normal (every
//   unoccluded sample then carries exactly albedo × L), a map from its piecewise-constant
//   distribution (Environment::sample). The samples are stratified like the area lights'
//   (Hammersley, rotated per pixel and per progressive pass), and count as area-light light:
//   EyeHit::areaDirect holds them and AreaLightSampler refines them over still frames. Light the
//   environment sends through glass or off mirrors onto a diffuse surface is caustic light, from
//   the photon map (the environment shoots photons, photon_tracer.cpp), as for every light.
#include "common/trace/eye_pass.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "common/core/check.h"
#include "common/trace/microfacet.h"
#include "common/trace/optics.h"
#include "common/core/halton.h"
#include "common/core/math.h"
#include "common/core/sampling.h"

namespace rtpm {

namespace {

constexpr float kMinThroughput = 1e-3f;
/// Sampled splits (renderSet's sampleSeed): a dielectric split is traced both ways while each
/// branch carries at least this share of the pixel, else one branch is chosen at random.
constexpr float kSplitThroughput = 0.25f;
constexpr int kMaxTrianglesSampledEach = 16;
/// Solid angle (sr) of emitter one shadow sample stands for (a cone of half-angle ≈ 3.2°).
constexpr float kSolidAnglePerSample = 0.01f;
constexpr int kStackSize = 64;
/// BSDF samples per glossy vertex in an eye pass; a progressive pass adds one more (it re-traces
/// the glossy pixels' trees, where a smooth scene's pass traces no eye ray at all).
constexpr int kGlossySamples = 4;
/// World-light directions per diffuse end point and progressive pass.
constexpr int kEnvironmentSamples = 8;


float wrap01(float x) {
    x -= std::floor(x);
    return x < 1.0f ? x : 0.0f;
}

/// Per-renderSet data shared by all pixels (read-only inside the parallel loop).
struct Context {
    const EmbreeScene& es;
    const Scene& scene;
    const EyeSettings& settings;
    const CausticEstimator* caustics;
    int set;
    uint64_t sampleSeed;      // 0: deterministic splitting; else sampled splits (renderSet)
    int areaSamples;
    bool sampleEach;          // few triangles: at the full budget each gets areaSamples samples
    int maxAreaSamples;       // N_max, the budget at the full solid angle
    std::vector<float> cdf;   // power-proportional selection: cumulative, last = 1
    Vec3 emitterCentre{0.0f}; // bounding sphere of the emissive triangles
    float emitterRadius2 = 0.0f;
    const Environment* environment = nullptr;  // null when the scene has no world light
};

struct Counters {
    uint64_t primary = 0, secondary = 0, shadow = 0, nonFinite = 0, stackOverflow = 0, sampledSplits = 0;
};

Context makeContext(const EmbreeScene& scene, const EyeSettings& settings,
                    const CausticEstimator* caustics, int set) {
    Context ctx{scene, scene.scene(), settings, caustics, set, 0, std::max(1, settings.areaLightSamples),
                true, 0, {}};
    const auto& tris = scene.emissiveTriangles();
    ctx.sampleEach = int(tris.size()) <= kMaxTrianglesSampledEach;
    ctx.maxAreaSamples = ctx.areaSamples * (ctx.sampleEach ? int(tris.size()) : kMaxTrianglesSampledEach);
    if (!ctx.scene.environment.empty()) ctx.environment = &ctx.scene.environment;
    if (!tris.empty()) {
        Bounds b;
        for (const EmissiveTriangle& e : tris) {
            b.extend(e.p0);
            b.extend(e.p1);
            b.extend(e.p2);
        }
        ctx.emitterCentre = 0.5f * (b.lo + b.hi);
        const Vec3 half = 0.5f * (b.hi - b.lo);
        ctx.emitterRadius2 = glm::dot(half, half);
        if (!std::isfinite(ctx.emitterRadius2)) ctx.emitterRadius2 = std::numeric_limits<float>::infinity();
        ctx.cdf.resize(tris.size());
        double acc = 0.0;
        for (size_t i = 0; i < tris.size(); ++i) {
            const Vec3 rad = tris[i].radiance;
            const double power = double(tris[i].area) * double(std::max(0.0f, rad.x + rad.y + rad.z));
            acc += std::isfinite(power) ? power : 0.0;
            ctx.cdf[i] = float(acc);
        }
        for (float& c : ctx.cdf) c = acc > 0.0 ? float(c / acc) : 1.0f;
        ctx.cdf.back() = 1.0f;
    }
    return ctx;
}

/// Radiance reflected toward the viewer by a Lambertian point from the punctual lights (shadow
/// rays). `n` shading normal and `ng` geometric normal, both facing the viewer.
Vec3 punctualLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                   Counters& count) {
    const EmbreeScene& es = ctx.es;
    Vec3 sum(0.0f);
    const Vec3 brdf = albedo * kInvPi;
    if (maxComponent(albedo) <= 0.0f) return sum;

    for (const Light& light : ctx.scene.lights) {
        Vec3 wi;
        Vec3 irradiance;  // W/m² perpendicular to wi, before the cosine
        Vec3 target(0.0f);
        bool toInfinity = false;
        if (light.type == LightType::Directional) {
            wi = -glm::normalize(light.direction);
            irradiance = light.intensity;
            toInfinity = true;
        } else {
            const Vec3 d = light.position - hit.position;
            const float dist2 = glm::dot(d, d);
            if (!(dist2 > 0.0f)) continue;
            wi = d / std::sqrt(dist2);
            irradiance = light.intensity / dist2;
            if (light.type == LightType::Spot) {
                const float att = spotFalloff(light, glm::dot(glm::normalize(light.direction), -wi));
                if (!(att > 0.0f)) continue;
                irradiance *= att;
            }
            target = light.position;
        }
        // The light must be on the viewer's side of the true surface, or the offset would put the
        // shadow ray's origin through the surface.
        if (glm::dot(wi, ng) <= 0.0f) continue;
        const float cosS = glm::dot(wi, n);
        if (cosS <= 0.0f) continue;
        const Vec3 origin = es.offsetOrigin(hit.position, ng, wi);
        Ray shadow = toInfinity ? Ray{origin, wi, 0.0f, std::numeric_limits<float>::infinity()}
                                : Ray{origin, target - origin, 0.0f, 1.0f};
        ++count.shadow;
        if (es.occluded(shadow)) continue;
        sum += brdf * irradiance * cosS;
    }
    return sum;
}

/// `sum` plus the radiance reflected from the world light (file comment), sampled with the
/// rotation `rot`. Precondition: ctx.environment set.
Vec3 environmentLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                      const std::array<float, 3>& rot, Counters& count, Vec3 sum) {
    const EmbreeScene& es = ctx.es;
    const Environment& env = *ctx.environment;
    const bool uniform = !env.hasMap();
    Ray rays[kEnvironmentSamples];
    Vec3 values[kEnvironmentSamples];
    int queued = 0;
    for (int k = 0; k < kEnvironmentSamples; ++k) {
        const float u0 = wrap01((float(k) + 0.5f) / float(kEnvironmentSamples) + rot[2]);
        const float u1 = wrap01(static_cast<float>(radicalInverseBase2(uint64_t(k))) + rot[1]);
        Vec3 wi, value;
        if (uniform) {
            // Cosine-weighted: brdf · L · cos / (cos/π) = albedo · L.
            wi = cosineHemisphere(n, u0, u1);
            value = albedo * env.uniformRadiance();
        } else {
            const EnvironmentSample e = env.sample(Vec2(u0, u1));
            wi = e.direction;
            const float cosS = glm::dot(wi, n);
            if (!(e.pdf > 0.0f) || cosS <= 0.0f) continue;
            value = albedo * kInvPi * e.radiance * (cosS / e.pdf);
        }
        if (glm::dot(wi, ng) <= 0.0f) continue;
        ++count.shadow;
        rays[queued] = Ray{es.offsetOrigin(hit.position, ng, wi), wi, 0.0f, std::numeric_limits<float>::infinity()};
        values[queued++] = value * (1.0f / float(kEnvironmentSamples));
    }
    const uint32_t blocked = queued > 0 ? es.occluded8(rays, queued) : 0u;
    for (int i = 0; i < queued; ++i)
        if (!(blocked & (1u << i))) sum += values[i];
    return sum;
}

/// `sum` plus the radiance reflected from the world light and the emissive triangles, sampled with
/// the Cranley–Patterson rotation `rot` (the pixel's, advanced per progressive pass).
Vec3 areaLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
               const std::array<float, 3>& rot, Counters& count, Vec3 sum) {
    const EmbreeScene& es = ctx.es;
    const Vec3 brdf = albedo * kInvPi;
    if (maxComponent(albedo) <= 0.0f) return sum;
    if (ctx.environment) sum = environmentLight(ctx, hit, n, ng, albedo, rot, count, sum);
    const auto& tris = es.emissiveTriangles();
    if (tris.empty()) return sum;
    // Shadow rays toward the emitters go to Embree in packets of 8 (one origin, one small light:
    // coherent); contributions are added in sample order, so the sum is the one of single rays.
    Ray pendingRay[8];
    Vec3 pendingValue[8];
    int pending = 0;
    auto flush = [&] {
        const uint32_t blocked = es.occluded8(pendingRay, pending);
        for (int i = 0; i < pending; ++i)
            if (!(blocked & (1u << i))) sum += pendingValue[i];
        pending = 0;
    };
    auto sampleTriangle = [&](const EmissiveTriangle& e, float u1, float u2, float weight) {
        // Uniform point on the triangle (Turk's square-root parametrisation).
        const float su = std::sqrt(u1);
        const Vec3 q = (1.0f - su) * e.p0 + (su * (1.0f - u2)) * e.p1 + (su * u2) * e.p2;
        const Vec3 d = q - hit.position;
        const float dist2 = glm::dot(d, d);
        if (!(dist2 > 0.0f)) return;
        const Vec3 wi = d / std::sqrt(dist2);
        const float cosL = -glm::dot(wi, e.normal);
        if (cosL <= 0.0f || glm::dot(wi, ng) <= 0.0f) return;
        const float cosS = glm::dot(wi, n);
        if (cosS <= 0.0f) return;
        const Vec3 origin = es.offsetOrigin(hit.position, ng, wi);
        const Vec3 end = es.offsetOrigin(q, e.normal, -wi);
        ++count.shadow;
        pendingRay[pending] = Ray{origin, end - origin, 0.0f, 1.0f};
        pendingValue[pending] = brdf * e.radiance * (cosS * cosL / dist2 * weight);
        if (++pending == 8) flush();
    };

    // N from the solid angle the emitters' bounding sphere subtends (file comment); a point
    // inside the sphere (or a degenerate one) keeps the full budget.
    int budget = ctx.maxAreaSamples;
    {
        const Vec3 dc = hit.position - ctx.emitterCentre;
        const float d2 = glm::dot(dc, dc);
        if (d2 > ctx.emitterRadius2 && std::isfinite(d2)) {
            const float omega = kPi * ctx.emitterRadius2 / d2;
            budget = std::clamp(int(std::ceil(omega / kSolidAnglePerSample)), 1, ctx.maxAreaSamples);
        }
    }
    if (ctx.sampleEach && budget == ctx.maxAreaSamples) {
        const int ns = ctx.areaSamples;
        for (const EmissiveTriangle& e : tris) {
            const float weight = e.area / float(ns);
            for (int k = 0; k < ns; ++k)
                sampleTriangle(e, wrap01((float(k) + 0.5f) / float(ns) + rot[0]),
                               wrap01(static_cast<float>(radicalInverseBase2(uint64_t(k))) + rot[1]), weight);
        }
    } else {
        const int ns = budget;
        for (int k = 0; k < ns; ++k) {
            const float uSel = wrap01((float(k) + 0.5f) / float(ns) + rot[0]);
            const size_t t = std::min<size_t>(
                size_t(std::upper_bound(ctx.cdf.begin(), ctx.cdf.end(), uSel) - ctx.cdf.begin()),
                tris.size() - 1);
            const float p = ctx.cdf[t] - (t > 0 ? ctx.cdf[t - 1] : 0.0f);
            if (!(p > 0.0f)) continue;
            sampleTriangle(tris[t], wrap01(static_cast<float>(radicalInverseBase2(uint64_t(k))) + rot[1]),
                           wrap01(radicalInverseBase3f(uint32_t(k)) + rot[2]),
                           tris[t].area / (p * float(ns)));
        }
    }
    if (pending > 0) flush();
    return sum;
}

/// Direct light from every light: punctual first, then the area samples added to that sum (the
/// order the image has always been computed in).
Vec3 directLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                 const std::array<float, 3>& rot, Counters& count) {
    return areaLight(ctx, hit, n, ng, albedo, rot, count, punctualLight(ctx, hit, n, ng, albedo, count));
}

struct PathState {
    Ray ray;
    Vec3 throughput;  ///< of the deterministic splitting's branch: decides what is pruned
    int depth;
    float weight = 1.0f;  ///< 1 / the probability of the branches chosen at random so far
};

/// What arrives at a glossy vertex, times the throughput from it: direct light (and emission met
/// on the way) and, when looked up, the caustic estimate at the diffuse end points.
struct GlossyRadiance {
    Vec3 direct{0.0f};
    Vec3 caustic{0.0f};
};

/// Where the caustic of a glossy tree's diffuse end points goes.
enum class GlossyCaustic : uint8_t {
    Lookup,  ///< asked of ctx.caustics (if any) into GlossyRadiance::caustic
    Record,  ///< each end point appended to `record` as an EyeHit::Kind::CausticOnly hit
    Skip,    ///< not estimated (a progressive pass: the recorded end points refine it)
};

constexpr int kGlossyStackSize = 32;

/// The paths on from glossy vertex `hit` of material index hit.material (arriving along `dir`,
/// `ng` and `ns` facing the viewer, at specular depth `depth`; file comment). `samples`
/// visible normals, stratified in their first number and advanced per pass; each scatters the
/// path: a conductor reflects about it, a dielectric splits into both lobes about it (the smooth
/// dielectric's Fresnel split in the limit). Further on, the tree splits at dielectrics (smooth
/// ones about the normal, glossy ones about one sampled microfacet) and follows mirrors and
/// conductors, as shadePixel does, down to the diffuse end points' direct light. Numbers after
/// the first vertex are hashed from the rotation, the pass and a counter. With Record, `base`
/// gives the recorded end points' pixel, set and the throughput before the vertex.
GlossyRadiance glossyTree(const Context& ctx, uint32_t set, const SurfaceHit& hit, Vec3 dir, Vec3 ng,
                          Vec3 ns, int depth, const std::array<float, 3>& rot, uint32_t pass, int samples,
                          GlossyCaustic caustic, Counters& count, std::vector<EyeHit>* record = nullptr,
                          const EyeHit* base = nullptr) {
    const EmbreeScene& es = ctx.es;
    const Scene& scene = ctx.scene;
    GlossyRadiance out;
    uint32_t b0, b1;
    std::memcpy(&b0, &rot[0], 4);
    std::memcpy(&b1, &rot[1], 4);
    const uint64_t key = splitMix64((uint64_t(b0) << 32 | b1) ^ splitMix64(0x676c6f7373ull + pass));
    uint64_t counter = 0;
    auto uniform = [&] { return hashToUnit(splitMix64(key ^ splitMix64(++counter))); };
    PathState stack[kGlossyStackSize];
    int top = 0;
    auto push = [&](const SurfaceHit& h, Vec3 hng, Vec3 next, Vec3 throughput, int d) {
        if (maxComponent(throughput) < kMinThroughput) return;
        if (top == kGlossyStackSize) {
            ++count.stackOverflow;
            return;
        }
        stack[top++] = PathState{Ray{es.offsetOrigin(h.position, hng, next), next}, throughput, d};
    };
    // Scatters at glossy `h` with the visible normal drawn by `u`: one branch for a conductor,
    // up to two for a dielectric. A direction on the wrong side of the true surface is dropped.
    auto scatter = [&](const SurfaceHit& h, Vec3 rdir, Vec3 hng, Vec3 hns, Vec2 u, Vec3 throughput, int d) {
        const Material& m = scene.materials[h.material];
        const Vec3 wo = -glm::normalize(rdir);
        if (m.type == MaterialType::Mirror) {
            const ShadingFrame frame(hns);
            BsdfSample s;
            if (!roughConductorSample(frame.toLocal(wo), ggxAlpha(m.roughness), m.baseColor, u, s)) return;
            const Vec3 next = glm::normalize(frame.toWorld(s.wi));
            if (glm::dot(next, hng) > 0.0f) push(h, hng, next, throughput * s.weight, d);
            return;
        }
        // The dielectric's frame has its normal out of the medium (the convention of optics.h).
        const ShadingFrame frame(h.shadingNormal);
        BsdfSample r, t;
        const int lobes = roughDielectricSplit(frame.toLocal(wo), ggxAlpha(m.roughness), m.ior, u, r, t);
        if (lobes & 1) {
            const Vec3 next = glm::normalize(frame.toWorld(r.wi));
            if (glm::dot(next, hng) > 0.0f) push(h, hng, next, throughput * r.weight, d);
        }
        if (lobes & 2) {
            const Vec3 next = glm::normalize(frame.toWorld(t.wi));
            if (glm::dot(next, hng) < 0.0f) push(h, hng, next, throughput * t.weight, d);
        }
    };
    // Throughputs are per sample (so branches are pruned as in shadePixel); the mean over the
    // samples is taken at the end points.
    const float share = 1.0f / float(samples);
    for (int k = 0; k < samples; ++k) {
        const Vec2 u((float(k) + rot[0]) * share, wrap01(rot[1] + 0.618034f * float(k)));
        scatter(hit, dir, ng, ns, u, Vec3(1.0f), depth + 1);
    }
    while (top > 0) {
        PathState path = stack[--top];
        for (;;) {
            SurfaceHit h;
            ++count.secondary;
            if (!es.intersect(path.ray, h)) {
                if (ctx.environment)
                    out.direct += (path.throughput * share) * ctx.environment->radiance(glm::normalize(path.ray.dir));
                break;
            }
            const Material& m = scene.materials[h.material];
            const Vec3 rdir = path.ray.dir;
            const float cosGeo = glm::dot(rdir, h.geometricNormal);
            if (m.type == MaterialType::Dielectric && cosGeo > 0.0f && m.absorption != Vec3(0.0f))
                path.throughput *= beerLambert(m.absorption, h.t * glm::length(rdir));
            if (m.isEmissive() && cosGeo < 0.0f)
                out.direct += (path.throughput * share) *
                              (m.emissiveTexture >= 0 ? emissionAt(m, scene.textures, h.uv) : m.emission);
            const Vec3 hng = cosGeo > 0.0f ? -h.geometricNormal : h.geometricNormal;
            const Vec3 hns = cosGeo > 0.0f ? -h.shadingNormal : h.shadingNormal;
            auto endPoint = [&](Vec3 throughput) {
                const Vec3 albedo = baseColorAt(m, scene.textures, h.uv);
                const std::array<float, 3> r{uniform(), uniform(), uniform()};
                out.direct += (throughput * share) * directLight(ctx, h, hns, hng, albedo, r, count);
                if (caustic == GlossyCaustic::Lookup && ctx.caustics) {
                    out.caustic += (throughput * share) * ctx.caustics->radiance(es, set, h, hns, albedo);
                } else if (caustic == GlossyCaustic::Record) {
                    EyeHit& e = record->emplace_back();
                    e.hit = h;
                    e.normal = hns;
                    e.geometricNormal = hng;
                    e.albedo = albedo;
                    e.throughput = base->throughput * (throughput * share);
                    e.pixel = base->pixel;
                    e.set = base->set;
                    e.kind = EyeHit::Kind::CausticOnly;
                }
            };
            if (m.type == MaterialType::Diffuse) {
                if (m.unlit)
                    out.direct += (path.throughput * share) * baseColorAt(m, scene.textures, h.uv);
                else
                    endPoint(path.throughput);
                break;
            }
            if (m.isPartlyDiffuse()) {
                endPoint(path.throughput * (1.0f - m.transmission));
                path.throughput *= m.transmission;
                if (maxComponent(path.throughput) < kMinThroughput) break;
            }
            if (path.depth >= ctx.settings.maxDepth) break;
            if (m.isGlossy()) {
                const float u0 = uniform();
                scatter(h, rdir, hng, hns, Vec2(u0, uniform()), path.throughput, path.depth + 1);
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
            push(h, hng, r, path.throughput * fr, path.depth + 1);
            if (!canRefract) break;
            path.throughput *= 1.0f - fr;
            path.ray = Ray{es.offsetOrigin(h.position, hng, t), t};
            ++path.depth;
            if (maxComponent(path.throughput) < kMinThroughput) break;
        }
    }
    return out;
}

/// A caustic lookup a pixel of the packet asks for: shadePixel queues them, renderSet answers a
/// packet's lookups as one group (CausticEstimator::radianceGroup) and adds throughput × radiance
/// to the pixel's caustic in queue order.
struct CausticRequest {
    SurfaceHit hit;
    Vec3 normal;
    Vec3 albedo;
    Vec3 throughput;
    int lane;
};

/// `stack` is kStackSize entries of scratch owned by the calling task: constructing the split
/// stack per pixel (64 rays with their default values) cost more than a typical pixel's shading.
/// With `hits` (record mode) the diffuse end points are appended to it (pixel index `pixel`),
/// the pixel's direct value leaves out their area-light term (EyeHit::areaDirect holds it) and
/// no caustic is looked up. Otherwise, with an estimator, each diffuse end point queues its
/// caustic lookup in `requests` (tagged `lane`); the returned caustic is 0 until renderSet adds
/// the answers.
/// The primary ray is traced by the caller (renderSet: 8 neighbouring pixels per Embree packet):
/// `firstHit` is what it hit, null for a miss.
PixelRadiance shadePixel(const Context& ctx, int x, int y, const Ray& primaryRay,
                         const SurfaceHit* firstHit, PathState* stack, Counters& count,
                         std::vector<CausticRequest>& requests, int lane,
                         std::vector<EyeHit>* hits = nullptr, uint32_t pixel = 0) {
    const EmbreeScene& es = ctx.es;
    const Scene& scene = ctx.scene;
    PixelRadiance result;
    int top = 0;
    stack[top++] = PathState{primaryRay, Vec3(1.0f), 0};
    const uint64_t pixelKey = (uint64_t(uint32_t(y)) << 32) | uint32_t(x);
    uint32_t diffuseVertex = 0;
    uint32_t glossyVertex = 0;
    uint32_t split = 0;  // dielectric splits so far: the key of a sampled split's random number
    bool primary = true;

    while (top > 0) {
        PathState path = stack[--top];
        for (;;) {  // follow one branch; dielectric splits push the reflected branch
            SurfaceHit hit;
            if (primary) {
                ++count.primary;
                primary = false;
                if (!firstHit) {
                    if (ctx.environment) result.direct += ctx.environment->radiance(glm::normalize(path.ray.dir));
                    break;
                }
                hit = *firstHit;
            } else {
                ++count.secondary;
                if (!es.intersect(path.ray, hit)) {
                    if (ctx.environment)
                        result.direct += path.throughput * path.weight *
                                         ctx.environment->radiance(glm::normalize(path.ray.dir));
                    break;
                }
            }
            const Material& mat = scene.materials[hit.material];
            const Vec3 dir = path.ray.dir;
            const float cosGeo = glm::dot(dir, hit.geometricNormal);

            // A clear medium (σ = 0) attenuates by exp(−0) = 1 exactly: skip the three exp calls.
            if (mat.type == MaterialType::Dielectric && cosGeo > 0.0f && mat.absorption != Vec3(0.0f))
                path.throughput *= beerLambert(mat.absorption, hit.t * glm::length(dir));
            if (mat.isEmissive() && cosGeo < 0.0f)
                result.direct += path.throughput * path.weight * (mat.emissiveTexture >= 0
                                                        ? emissionAt(mat, scene.textures, hit.uv)
                                                        : mat.emission);

            // Normals facing the viewer.
            const Vec3 ng = cosGeo > 0.0f ? -hit.geometricNormal : hit.geometricNormal;
            const Vec3 ns = cosGeo > 0.0f ? -hit.shadingNormal : hit.shadingNormal;

            // Lambertian end point (or the Lambertian share of a partly transmissive dielectric,
            // weighted by `throughput`): direct light by shadow rays plus the caustic estimate.
            auto shadeDiffuse = [&](Vec3 throughput) {
                const Vec3 albedo = baseColorAt(mat, scene.textures, hit.uv);
                const uint64_t h = splitMix64(pixelKey ^ splitMix64(diffuseVertex++));
                const std::array<float, 3> rot{hashToUnit(h), hashToUnit(splitMix64(h + 1)), hashToUnit(splitMix64(h + 2))};
                if (hits) {  // progressive: keep the record; the caustic comes from the passes
                    EyeHit& e = hits->emplace_back();
                    e.hit = hit;
                    e.normal = ns;
                    e.geometricNormal = ng;
                    e.albedo = albedo;
                    e.throughput = throughput;
                    e.rotation = rot;
                    e.pixel = pixel;
                    result.direct += throughput * punctualLight(ctx, hit, ns, ng, albedo, count);
                    e.areaDirect = areaLight(ctx, hit, ns, ng, albedo, rot, count, Vec3(0.0f));
                    if (!finite(e.areaDirect)) {
                        e.areaDirect = Vec3(0.0f);
                        ++count.nonFinite;
                    }
                    return;
                }
                result.direct += throughput * directLight(ctx, hit, ns, ng, albedo, rot, count);
                if (ctx.caustics) requests.push_back(CausticRequest{hit, ns, albedo, throughput, lane});
            };

            if (mat.type == MaterialType::Diffuse) {
                if (mat.unlit)
                    result.direct += path.throughput * path.weight * baseColorAt(mat, scene.textures, hit.uv);
                else
                    shadeDiffuse(path.throughput * path.weight);
                break;
            }
            if (mat.isPartlyDiffuse()) {
                // Deterministic split of a partly transmissive material: the Lambertian share
                // (1 − t) ends here, the dielectric share t continues below.
                shadeDiffuse(path.throughput * path.weight * (1.0f - mat.transmission));
                path.throughput *= mat.transmission;
                if (maxComponent(path.throughput) < kMinThroughput) break;
            }
            if (path.depth >= ctx.settings.maxDepth) break;

            if (mat.isGlossy()) {
                // A glossy vertex ends the split path; what arrives here is sampled (file comment).
                const uint64_t h = splitMix64(pixelKey ^ splitMix64(0x676c6f7373ull + glossyVertex++));
                const std::array<float, 3> rot{hashToUnit(h), hashToUnit(splitMix64(h + 1)), hashToUnit(splitMix64(h + 2))};
                if (hits) {
                    // The end points' caustic hits first, then the glossy vertex (its direct light
                    // refined per pass): a pixel's first hit stays a diffuse one where it has one.
                    EyeHit vertex;
                    vertex.hit = hit;
                    vertex.normal = ns;
                    vertex.geometricNormal = ng;
                    vertex.throughput = path.throughput;
                    vertex.rotation = rot;
                    vertex.pixel = pixel;
                    vertex.wo = -glm::normalize(dir);
                    vertex.set = uint16_t(ctx.set);
                    vertex.depth = uint16_t(path.depth);
                    vertex.kind = EyeHit::Kind::Glossy;
                    vertex.areaDirect = glossyTree(ctx, uint32_t(ctx.set), hit, dir, ng, ns, path.depth, rot, 0,
                                                   kGlossySamples, GlossyCaustic::Record, count, hits, &vertex).direct;
                    if (!finite(vertex.areaDirect)) {
                        vertex.areaDirect = Vec3(0.0f);
                        ++count.nonFinite;
                    }
                    hits->push_back(vertex);
                } else {
                    const GlossyRadiance g = glossyTree(ctx, uint32_t(ctx.set), hit, dir, ng, ns, path.depth, rot, 0,
                                                        kGlossySamples, GlossyCaustic::Lookup, count);
                    result.direct += path.throughput * path.weight * g.direct;
                    result.caustic += path.throughput * path.weight * g.caustic;
                }
                break;
            }

            if (mat.type == MaterialType::Mirror) {
                // Reflect about the shading normal; if that sends the ray into the surface (strong
                // normal interpolation at grazing angles) use the geometric normal instead.
                Vec3 r = glm::normalize(reflect(dir, ns));
                if (glm::dot(r, ng) <= 0.0f) r = glm::normalize(reflect(dir, ng));
                path.throughput *= mat.baseColor;
                path.ray = Ray{es.offsetOrigin(hit.position, ng, r), r};
                ++path.depth;
                if (maxComponent(path.throughput) < kMinThroughput) break;
                continue;
            }

            // Dielectric: the side is decided by the geometric normal, the angles by the shading one.
            const DielectricInterface side = dielectricInterface(dir, hit.geometricNormal, mat.ior);
            const Vec3 nFace = ns;  // faces the incident side
            const float cosI = std::clamp(-glm::dot(dir, nFace), 0.0f, 1.0f);
            Vec3 t;
            const bool canRefract = refract(dir, nFace, side.etaI / side.etaT, t) &&
                                    glm::dot(t, ng) < 0.0f;
            const float fr = canRefract ? fresnelDielectric(cosI, side.etaI, side.etaT) : 1.0f;
            Vec3 r = glm::normalize(reflect(dir, nFace));
            if (glm::dot(r, ng) <= 0.0f) r = glm::normalize(reflect(dir, ng));
            const Vec3 reflThroughput = path.throughput * fr;
            const Vec3 transThroughput = path.throughput * (1.0f - fr);
            const int depth = path.depth + 1;
            const bool keepRefl = maxComponent(reflThroughput) >= kMinThroughput;
            const bool keepTrans = canRefract && maxComponent(transThroughput) >= kMinThroughput;
            if (keepRefl && keepTrans) {
                // Sampled splits (a moving camera's frames): a split whose weaker branch would
                // carry less than kSplitThroughput of the pixel traces one branch, reflection
                // with probability F, weighted by 1/F or 1/(1 − F). The branches kept and their
                // throughputs are the deterministic tree's, so the expectation is its image.
                if (ctx.sampleSeed != 0 &&
                    std::min(maxComponent(reflThroughput), maxComponent(transThroughput)) * path.weight <
                        kSplitThroughput) {
                    ++count.sampledSplits;
                    const float u = hashToUnit(hashKeys(ctx.sampleSeed, pixelKey, split++));
                    path = u < fr ? PathState{Ray{es.offsetOrigin(hit.position, ng, r), r}, reflThroughput, depth,
                                              path.weight / fr}
                                  : PathState{Ray{es.offsetOrigin(hit.position, ng, t), t}, transThroughput, depth,
                                              path.weight / (1.0f - fr)};
                    continue;
                }
                if (top < kStackSize)
                    stack[top++] = PathState{Ray{es.offsetOrigin(hit.position, ng, r), r}, reflThroughput, depth,
                                             path.weight};
                else
                    ++count.stackOverflow;
            }
            if (keepTrans) {
                path = PathState{Ray{es.offsetOrigin(hit.position, ng, t), t}, transThroughput, depth, path.weight};
                continue;
            }
            if (keepRefl) {
                path = PathState{Ray{es.offsetOrigin(hit.position, ng, r), r}, reflThroughput, depth, path.weight};
                continue;
            }
            break;
        }
    }
    if (!finite(result.direct)) {
        result.direct = Vec3(0.0f);
        ++count.nonFinite;
    }
    return result;
}

}  // namespace

void renderSet(const EmbreeScene& scene, const Camera& camera, const EyeSettings& settings,
               const Interleave& pattern, int set, const CausticEstimator* caustics,
               std::span<PixelRadiance> out, EyeStats* stats, EyeRecords* records, uint64_t sampleSeed) {
    RTPM_CHECK(set >= 0 && set < pattern.setCount());
    RTPM_CHECK(out.size() == size_t(pattern.pixelCount(set)));
    Context context = makeContext(scene, settings, caustics, set);
    context.sampleSeed = sampleSeed;
    const Context& ctx = context;
    const int rows = pattern.setRows(set);
    const int cols = pattern.setColumns(set);
    // Record mode: each row's hits go to their own vector, concatenated in row order afterwards,
    // so the record order does not depend on the thread count.
    std::vector<std::vector<EyeHit>> rowHits(records ? size_t(rows) : 0);
    std::atomic<uint64_t> primary{0}, secondary{0}, shadow{0}, nonFinite{0}, overflow{0}, sampled{0};
    const Camera::PixelRays pixelRays = camera.pixelRays(pattern.width, pattern.height);
    tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& range) {
        Counters count;
        std::vector<PathState> stack(kStackSize);
        Ray rays[8];
        SurfaceHit firstHits[8];
        std::vector<CausticRequest> requests;
        std::vector<CausticQuery> queries;
        std::vector<Vec3> answers;
        for (int r = range.begin(); r < range.end(); ++r) {
            GatherHint hint;  // per row: what a pixel's neighbours hint does not depend on threads
            for (int c0 = 0; c0 < cols; c0 += 8) {
                // Primary rays of 8 neighbouring pixels of the row as one coherent Embree packet.
                const int lanes = std::min(8, cols - c0);
                for (int l = 0; l < lanes; ++l) {
                    const int n = r * cols + c0 + l;
                    rays[l] = Ray{camera.position,
                                  pixelRays.direction(pattern.pixelX(set, n), pattern.pixelY(set, n))};
                }
                const uint32_t hitMask = ctx.es.intersect8(rays, lanes, firstHits);
                requests.clear();
                for (int l = 0; l < lanes; ++l) {
                    const int n = r * cols + c0 + l;
                    out[size_t(n)] = shadePixel(ctx, pattern.pixelX(set, n), pattern.pixelY(set, n), rays[l],
                                                (hitMask >> l) & 1u ? &firstHits[l] : nullptr, stack.data(),
                                                count, requests, l, records ? &rowHits[size_t(r)] : nullptr,
                                                uint32_t(n));
                }
                // The packet's caustic lookups as one group (neighbouring hits share their search).
                if (!requests.empty()) {
                    queries.resize(requests.size());
                    answers.resize(requests.size());
                    for (size_t i = 0; i < requests.size(); ++i)
                        queries[i] = CausticQuery{&requests[i].hit, requests[i].normal, requests[i].albedo};
                    ctx.caustics->radianceGroup(ctx.es, uint32_t(ctx.set), queries, answers, &hint);
                    for (size_t i = 0; i < requests.size(); ++i)
                        out[size_t(r * cols + c0 + requests[i].lane)].caustic += requests[i].throughput * answers[i];
                    for (int l = 0; l < lanes; ++l) {
                        Vec3& caustic = out[size_t(r * cols + c0 + l)].caustic;
                        if (!finite(caustic)) {
                            caustic = Vec3(0.0f);
                            ++count.nonFinite;
                        }
                    }
                }
            }
        }
        primary += count.primary;
        secondary += count.secondary;
        shadow += count.shadow;
        nonFinite += count.nonFinite;
        overflow += count.stackOverflow;
        sampled += count.sampledSplits;
    });
    if (records) {
        records->hits.clear();
        for (const auto& row : rowHits) records->hits.insert(records->hits.end(), row.begin(), row.end());
        records->firstHit.assign(out.size() + 1, 0);
        for (const EyeHit& e : records->hits) ++records->firstHit[e.pixel + 1];
        for (size_t i = 1; i < records->firstHit.size(); ++i) records->firstHit[i] += records->firstHit[i - 1];
    }
    if (stats) {
        stats->primaryRays += primary;
        stats->secondaryRays += secondary;
        stats->shadowRays += shadow;
        stats->nonFinite += nonFinite;
        stats->stackOverflows += overflow;
        stats->sampledSplits += sampled;
    }
}

struct AreaLightSampler::Impl {
    Context ctx;
    bool glossy;  // the scene has a glossy material
};

AreaLightSampler::AreaLightSampler(const EmbreeScene& scene, const EyeSettings& settings)
    : impl_(std::make_unique<Impl>(Impl{makeContext(scene, settings, nullptr, 0),
                                        std::any_of(scene.scene().materials.begin(), scene.scene().materials.end(),
                                                    [](const Material& m) { return m.isGlossy(); })})) {}

AreaLightSampler::~AreaLightSampler() = default;

bool AreaLightSampler::empty() const {
    return impl_->ctx.es.emissiveTriangles().empty() && !impl_->glossy && !impl_->ctx.environment;
}

Vec3 AreaLightSampler::sample(const EyeHit& e, uint32_t pass, uint64_t& shadowRays) const {
    // Pass p rotates the pixel's rotation by p steps of the R3 sequence (Roberts 2018: the
    // generalised golden ratio φ₃ = 1.2207…, steps 1/φ₃, 1/φ₃², 1/φ₃³), so successive passes
    // stratify each other's samples; pass 0 is the eye pass's own rotation.
    constexpr double kStep[3] = {0.8191725133961645, 0.6710436067037893, 0.5497004779019703};
    std::array<float, 3> rot = e.rotation;
    for (int d = 0; d < 3; ++d) {
        const double shifted = double(rot[d]) + double(pass) * kStep[d];
        rot[d] = wrap01(float(shifted - std::floor(shifted)));
    }
    Counters count;
    Vec3 v(0.0f);
    if (e.kind == EyeHit::Kind::Glossy) {
        v = glossyTree(impl_->ctx, e.set, e.hit, -e.wo, e.geometricNormal, e.normal, int(e.depth), rot, pass, 1,
                       GlossyCaustic::Skip, count).direct;
    } else if (e.kind == EyeHit::Kind::EndPoint) {
        v = areaLight(impl_->ctx, e.hit, e.normal, e.geometricNormal, e.albedo, rot, count, Vec3(0.0f));
    }
    shadowRays += count.shadow;
    return finite(v) ? v : Vec3(0.0f);
}

}  // namespace rtpm
