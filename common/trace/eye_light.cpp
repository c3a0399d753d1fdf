// The light at the eye pass's diffuse end points: shadow rays to the punctual lights, stratified
// samples of the emissive triangles and of the world light (paper §4.2).
//
// * Area lights (emissive triangles): the sample budget is N_max = areaLightSamples per triangle
//   with at most kMaxTrianglesSampledEach triangles, else kMaxTrianglesSampledEach·areaLightSamples
//   in total. A shading point takes N = clamp(⌈Ω / kSolidAnglePerSample⌉, 1, N_max) samples,
//   where Ω = π R² / max(d², R²) bounds the solid angle of the emitters' bounding sphere (centre
//   c, radius R; d = |x − c|): a small or far light is nearly a point and one shadow ray resolves
//   it (RING's 10 cm lamp at 2 m: Ω ≈ 0.003 sr, N = 1 instead of 8; HEADLIGHT's filament: 1
//   instead of up to 48), a near, large one keeps the full budget (the Cornell box lamp from its
//   floor: Ω ≈ 0.1 sr, N = 8). Still views refine the estimate over passes (AreaLightSampler,
//   eye_pass.cpp).
//   With N = N_max and few triangles, each triangle gets `areaLightSamples` stratified samples (a
//   Cranley–Patterson rotated Hammersley set); otherwise the N samples pick triangles in
//   proportion to their power (area × radiance sum) through a stratified CDF inversion, so the
//   cost per pixel stays bounded for finely tessellated emitters.
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
#include "common/trace/eye_shading.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/core/halton.h"
#include "common/core/math.h"
#include "common/core/sampling.h"
#include "common/trace/microfacet.h"
#include "common/trace/optics.h"

namespace rtpm {
namespace detail {

namespace {

/// Solid angle (sr) of emitter one shadow sample stands for (a cone of half-angle ≈ 3.2°).
constexpr float kSolidAnglePerSample = 0.01f;
/// World-light directions per diffuse end point and progressive pass.
constexpr int kEnvironmentSamples = 8;

/// `sum` plus the radiance reflected from the world light (file comment), sampled with the
/// rotation `rot`. Precondition: ctx.environment set.
Vec3 environmentLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                      const std::array<float, 3>& rot, Counters& count, Vec3 sum, const PlasticBsdf* coat) {
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
        if (coat) value *= coat->lightShare(glm::dot(wi, n));
        ++count.shadow;
        rays[queued] = Ray{es.offsetOrigin(hit.position, ng, wi), wi, 0.0f, std::numeric_limits<float>::infinity()};
        values[queued++] = value * (1.0f / float(kEnvironmentSamples));
    }
    const uint32_t blocked = queued > 0 ? es.occluded8(rays, queued) : 0u;
    for (int i = 0; i < queued; ++i)
        if (!(blocked & (1u << i))) sum += values[i];
    return sum;
}

}  // namespace

namespace {

/// Light `light` arriving at `position`: its unit direction toward the light `wi`, the irradiance
/// perpendicular to it (W/m², before the cosine) and the shadow ray's end (`target`, unused when
/// `toInfinity`). False when it sends nothing there.
bool punctualIncidence(const Light& light, Vec3 position, Vec3& wi, Vec3& irradiance, Vec3& target,
                       bool& toInfinity) {
    target = Vec3(0.0f);
    toInfinity = false;
    if (light.type == LightType::Directional) {
        wi = -glm::normalize(light.direction);
        irradiance = light.intensity;
        toInfinity = true;
        return true;
    }
    const Vec3 d = light.position - position;
    const float dist2 = glm::dot(d, d);
    if (!(dist2 > 0.0f)) return false;
    wi = d / std::sqrt(dist2);
    irradiance = light.intensity / dist2;
    if (light.type == LightType::Spot) {
        const float att = spotFalloff(light, glm::dot(glm::normalize(light.direction), -wi));
        if (!(att > 0.0f)) return false;
        irradiance *= att;
    }
    target = light.position;
    return true;
}

/// True when the shadow ray from `hit` (lifted along `ng`) toward the light is blocked.
bool shadowed(const Context& ctx, const SurfaceHit& hit, Vec3 ng, Vec3 wi, Vec3 target, bool toInfinity,
              Counters& count) {
    const EmbreeScene& es = ctx.es;
    const Vec3 origin = es.offsetOrigin(hit.position, ng, wi);
    Ray shadow = toInfinity ? Ray{origin, wi, 0.0f, std::numeric_limits<float>::infinity()}
                            : Ray{origin, target - origin, 0.0f, 1.0f};
    ++count.shadow;
    return es.occluded(shadow);
}

}  // namespace

Vec3 punctualLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                   Counters& count, const PlasticBsdf* coat) {
    Vec3 sum(0.0f);
    const Vec3 brdf = albedo * kInvPi;
    if (maxComponent(albedo) <= 0.0f) return sum;

    for (const Light& light : ctx.scene.lights) {
        Vec3 wi;
        Vec3 irradiance;  // W/m² perpendicular to wi, before the cosine
        Vec3 target;
        bool toInfinity;
        if (!punctualIncidence(light, hit.position, wi, irradiance, target, toInfinity)) continue;
        // The light must be on the viewer's side of the true surface, or the offset would put the
        // shadow ray's origin through the surface.
        if (glm::dot(wi, ng) <= 0.0f) continue;
        const float cosS = glm::dot(wi, n);
        if (cosS <= 0.0f) continue;
        if (shadowed(ctx, hit, ng, wi, target, toInfinity, count)) continue;
        if (coat)
            sum += brdf * irradiance * (cosS * coat->lightShare(cosS));
        else
            sum += brdf * irradiance * cosS;
    }
    return sum;
}

Vec3 coatHighlight(const Context& ctx, const SurfaceHit& hit, Vec3 wo, Vec3 ns, Vec3 ng,
                   const PlasticBsdf& coat, Counters& count) {
    Vec3 sum(0.0f);
    if (coat.smooth()) return sum;
    const ShadingFrame frame(ns);
    const Vec3 woLocal = frame.toLocal(wo);
    for (const Light& light : ctx.scene.lights) {
        Vec3 wi, irradiance, target;
        bool toInfinity;
        if (!punctualIncidence(light, hit.position, wi, irradiance, target, toInfinity)) continue;
        if (glm::dot(wi, ng) <= 0.0f) continue;
        const Vec3 wiLocal = frame.toLocal(wi);
        const Vec3 f = coat.coatEval(woLocal, wiLocal);
        if (!(maxComponent(f) > 0.0f)) continue;
        if (shadowed(ctx, hit, ng, wi, target, toInfinity, count)) continue;
        sum += f * irradiance * wiLocal.z;
    }
    return sum;
}

Vec3 glossyHighlight(const Context& ctx, const SurfaceHit& hit, Vec3 wo, Vec3 ns, Vec3 ng, const Material& m,
                     Counters& count) {
    Vec3 sum(0.0f);
    if (ctx.scene.lights.empty()) return sum;
    const float alpha = ggxAlpha(m.roughness);
    const bool conductor = m.type == MaterialType::Mirror;
    // A dielectric's frame has its normal out of the medium (microfacet.h); a conductor's faces
    // the viewer.
    const ShadingFrame frame(conductor ? ns : hit.shadingNormal);
    const Vec3 woLocal = frame.toLocal(wo);
    for (const Light& light : ctx.scene.lights) {
        Vec3 wi, irradiance, target;
        bool toInfinity;
        if (!punctualIncidence(light, hit.position, wi, irradiance, target, toInfinity)) continue;
        if (glm::dot(wi, ng) <= 0.0f) continue;  // behind the surface: only reflection is direct light
        const Vec3 wiLocal = frame.toLocal(wi);
        const Vec3 f = conductor ? roughConductorEval(woLocal, wiLocal, alpha, m.baseColor)
                                 : Vec3(roughDielectricEval(woLocal, wiLocal, alpha, m.ior, Transport::Radiance));
        if (!(maxComponent(f) > 0.0f)) continue;
        if (shadowed(ctx, hit, ng, wi, target, toInfinity, count)) continue;
        sum += f * irradiance * std::abs(wiLocal.z);
    }
    return sum;
}

Vec3 areaLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
               const std::array<float, 3>& rot, Counters& count, Vec3 sum, const PlasticBsdf* coat) {
    const EmbreeScene& es = ctx.es;
    const Vec3 brdf = albedo * kInvPi;
    if (maxComponent(albedo) <= 0.0f) return sum;
    if (ctx.environment) sum = environmentLight(ctx, hit, n, ng, albedo, rot, count, sum, coat);
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
        if (coat) pendingValue[pending] *= coat->lightShare(cosS);
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

Vec3 directLight(const Context& ctx, const SurfaceHit& hit, Vec3 n, Vec3 ng, Vec3 albedo,
                 const std::array<float, 3>& rot, Counters& count, const PlasticBsdf* coat) {
    return areaLight(ctx, hit, n, ng, albedo, rot, count, punctualLight(ctx, hit, n, ng, albedo, count, coat),
                     coat);
}

}  // namespace detail
}  // namespace rtpm
