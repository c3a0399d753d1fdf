// Photon emission (point, spot, directional, area, environment) and path tracing that keeps
// caustic photons.
#include "common/photon/photon_tracer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/core/check.h"
#include "common/trace/microfacet.h"
#include "common/trace/optics.h"
#include "common/trace/plastic_bsdf.h"

namespace rtpm {
namespace {

constexpr double kPiD = std::numbers::pi;

// Purposes of hashed random numbers (the fifth hash key), so two uses at one bounce never share.
enum Purpose : uint64_t {
    kFresnelChoice = 1, kRoulette = 2, kBounceU = 3, kBounceV = 4, kLobeChoice = 5, kGlossyU = 6, kGlossyV = 7
};


// Orthonormal basis around unit n (Duff et al. 2017, branchless and continuous except at n.z = -1).
void basis(Vec3 n, Vec3& t, Vec3& b) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float bb = n.x * n.y * a;
    t = Vec3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    b = Vec3(bb, sign + n.y * n.y * a, -n.y);
}

// Cosine-weighted direction about unit n (Malley: uniform disc lifted to the hemisphere).
Vec3 cosineDirection(Vec3 n, float u0, float u1) {
    const float r = std::sqrt(u0);
    const float phi = 2.0f * kPi * u1;
    const float z = std::sqrt(std::max(0.0f, 1.0f - u0));
    Vec3 t, b;
    basis(n, t, b);
    return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + z * n);
}

// Concentric square-to-disc mapping (Shirley–Chiu): stratification of (u0, u1) is kept.
Vec2 concentricDisc(float u0, float u1) {
    const float a = 2.0f * u0 - 1.0f;
    const float b = 2.0f * u1 - 1.0f;
    if (a == 0.0f && b == 0.0f) return Vec2(0.0f);
    float r, phi;
    if (std::abs(a) > std::abs(b)) {
        r = a;
        phi = (kPi / 4.0f) * (b / a);
    } else {
        r = b;
        phi = (kPi / 2.0f) - (kPi / 4.0f) * (a / b);
    }
    return Vec2(r * std::cos(phi), r * std::sin(phi));
}

float channelSum(Vec3 v) { return v.x + v.y + v.z; }

}  // namespace

Vec3 lightFlux(const Light& light, const Bounds& bounds) {
    switch (light.type) {
        case LightType::Point:
            return 4.0f * kPi * light.intensity;
        case LightType::Spot:
            return spotSolidAngle(light) * light.intensity;
        case LightType::Directional: {
            const float r = 0.5f * bounds.diagonal();
            return kPi * r * r * light.intensity;
        }
    }
    return Vec3(0.0f);
}

std::vector<Emitter> buildEmitters(const EmbreeScene& scene) {
    std::vector<Emitter> out;
    const Bounds& bounds = scene.bounds();
    const std::vector<Light>& lights = scene.scene().lights;
    for (uint32_t i = 0; i < lights.size(); ++i) {
        const Light& l = lights[i];
        Emitter e;
        e.id = i;
        e.flux = lightFlux(l, bounds);
        if (!finite(e.flux) || !(channelSum(e.flux) > 0.0f)) continue;
        if (l.intensity.x < 0.0f || l.intensity.y < 0.0f || l.intensity.z < 0.0f) continue;
        e.position = l.position;
        const float axisLen = glm::length(l.direction);
        e.axis = axisLen > 0.0f && std::isfinite(axisLen) ? l.direction / axisLen : Vec3(0, -1, 0);
        switch (l.type) {
            case LightType::Point:
                e.kind = EmitterKind::Point;
                break;
            case LightType::Spot: {
                e.kind = EmitterKind::Spot;
                const SpotShape s = spotShape(l);
                e.cosOuter = static_cast<float>(s.cosOuter);
                e.falloffScale = static_cast<float>(s.scale);
                break;
            }
            case LightType::Directional: {
                e.kind = EmitterKind::Directional;
                // The disc is the bounding sphere's cross-section, placed just outside the sphere
                // on the side the light comes from, so every scene point is reachable.
                const float r = 0.5f * bounds.diagonal();
                e.discRadius = r;
                e.discCentre = bounds.centre() - e.axis * (r * 1.001f + scene.epsilon());
                basis(e.axis, e.tangent, e.bitangent);
                break;
            }
        }
        out.push_back(std::move(e));
    }
    // Area lights: one emitter per distinct radiance, so every photon of a group carries the same
    // power and the group's emitted power sums to π·L·ΣA exactly.
    const std::vector<EmissiveTriangle>& tris = scene.emissiveTriangles();
    const size_t firstArea = out.size();
    std::vector<double> areaSum;
    std::vector<uint8_t> textured;         // per area group
    std::vector<glm::dvec3> texturedFlux;  // per area group: Σ A_t L_t (textured groups)
    for (uint32_t t = 0; t < tris.size(); ++t) {
        const EmissiveTriangle& tri = tris[t];
        if (!(tri.area > 0.0f) || !std::isfinite(tri.area) || !finite(tri.radiance) ||
            !finite(tri.normal) || !(channelSum(tri.radiance) > 0.0f))
            continue;
        size_t g = firstArea;
        if (tri.textured) {
            while (g < out.size() && !(textured[g - firstArea] && out[g].material == tri.material)) ++g;
        } else {
            while (g < out.size() && (textured[g - firstArea] || out[g].radiance != tri.radiance)) ++g;
        }
        if (g == out.size()) {
            Emitter e;
            e.kind = EmitterKind::Area;
            e.id = static_cast<uint32_t>(g - firstArea);
            e.radiance = tri.radiance;
            e.material = tri.material;
            out.push_back(std::move(e));
            areaSum.push_back(0.0);
            textured.push_back(tri.textured ? 1 : 0);
            texturedFlux.emplace_back(0.0);
        }
        Emitter& e = out[g];
        double& sum = areaSum[g - firstArea];
        if (tri.textured) {
            // Weight area × Σ_rgb L; the flux is accumulated per channel in double.
            sum += double(tri.area) * double(channelSum(tri.radiance));
            texturedFlux[g - firstArea] += glm::dvec3(tri.radiance) * double(tri.area);
            e.colour.push_back(tri.radiance);  // turned into the power factor below
        } else {
            sum += tri.area;
        }
        e.triangles.push_back(t);
        e.cdf.push_back(sum);
    }
    const size_t lastArea = out.size();
    const Environment& env = scene.scene().environment;
    if (!env.empty()) {
        Emitter e;
        e.kind = EmitterKind::Environment;
        const float r = 0.5f * bounds.diagonal();
        e.discRadius = r;
        e.discCentre = bounds.centre();
        e.flux = kPi * r * r * env.integral();
        if (finite(e.flux) && channelSum(e.flux) > 0.0f) out.push_back(std::move(e));
    }
    for (size_t g = firstArea; g < lastArea; ++g) {
        Emitter& e = out[g];
        const double total = areaSum[g - firstArea];
        for (double& c : e.cdf) c /= total;
        e.cdf.back() = 1.0;
        if (!textured[g - firstArea]) {
            e.flux = static_cast<float>(kPiD * total) * e.radiance;
            continue;
        }
        // Φ = π Σ A_t L_t. Triangle t is chosen with p_t = A_t s_t / W (s_t = Σ_rgb L_t,
        // W = Σ A_t s_t) and its photon carries Φ/N ⊙ k_t with k_t = (L_t / s_t) ⊘ (Φ / Σ_rgb Φ):
        // E[power] = Σ p_t Φ/N ⊙ k_t = Φ/N, and Σ_rgb of every photon's power is Σ_rgb Φ / N.
        const glm::dvec3 flux = kPiD * texturedFlux[g - firstArea];
        const double fluxSum = flux.x + flux.y + flux.z;
        e.flux = Vec3(flux);
        for (Vec3& c : e.colour) {
            const double s = double(channelSum(c));
            Vec3 k(0.0f);
            for (int ch = 0; ch < 3; ++ch)
                if (flux[ch] > 0.0) k[ch] = float(double(c[ch]) / s * fluxSum / flux[ch]);
            c = k;
        }
    }
    return out;
}

std::vector<uint32_t> splitBudget(std::span<const Emitter> emitters, uint32_t total) {
    const size_t n = emitters.size();
    std::vector<uint32_t> out(n, 0);
    if (n == 0 || total == 0) return out;
    // One path for every emitter first (a light with a photon budget of 0 would lose its flux),
    // the rest by largest remainder on Σ_rgb flux.
    uint32_t rest = total;
    if (total >= n) {
        for (uint32_t& c : out) c = 1;
        rest -= static_cast<uint32_t>(n);
    }
    double sum = 0.0;
    for (const Emitter& e : emitters) sum += channelSum(e.flux);
    if (!(sum > 0.0)) return out;
    std::vector<double> remainder(n);
    uint32_t given = 0;
    for (size_t i = 0; i < n; ++i) {
        const double share = rest * (channelSum(emitters[i].flux) / sum);
        const uint32_t whole = static_cast<uint32_t>(std::floor(share));
        out[i] += whole;
        given += whole;
        remainder[i] = share - whole;
    }
    std::vector<size_t> order(n);
    for (size_t i = 0; i < n; ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return remainder[a] > remainder[b]; });
    for (size_t j = 0; given < rest; ++j, ++given) ++out[order[j % n]];
    return out;
}

DimLayout dimLayout(EmitterKind kind, uint32_t diffuseBounces) {
    DimLayout d;
    d.direction = 0;
    int next = 2;
    if (kind == EmitterKind::Area || kind == EmitterKind::Environment) {
        d.point = next;
        next += 2;
    }
    if (diffuseBounces > 0) {
        d.bounce = next;
        next += 2;
    }
    d.count = next;
    return d;
}

EmittedRay sampleEmission(const Emitter& e, const EmbreeScene& scene, Vec2 uDir, Vec2 uPoint) {
    EmittedRay r;
    switch (e.kind) {
        case EmitterKind::Point: {
            const float z = 1.0f - 2.0f * uDir.x;
            const float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
            const float phi = 2.0f * kPi * uDir.y;
            r.origin = e.position;
            r.dir = Vec3(s * std::cos(phi), s * std::sin(phi), z);
            break;
        }
        case EmitterKind::Spot: {
            // cosθ from the exact inverse CDF of the falloff a(cosθ) on [cosO, 1]: the ramp
            // (a = ((c − cosO)s)², CDF ∝ s²(c − cosO)³/3) then the flat top (a = 1).
            const double cosO = e.cosOuter;
            const double s = e.falloffScale;
            const double c1 = std::min(1.0, cosO + 1.0 / s);
            const double w = c1 - cosO;
            const double ramp = s * s * w * w * w / 3.0;
            const double target = uDir.x * (ramp + (1.0 - c1));
            double c = target < ramp ? cosO + std::cbrt(3.0 * target / (s * s)) : c1 + (target - ramp);
            c = std::clamp(c, -1.0, 1.0);
            const float cosT = static_cast<float>(c);
            const float sinT = std::sqrt(std::max(0.0f, 1.0f - cosT * cosT));
            const float phi = 2.0f * kPi * uDir.y;
            Vec3 t, b;
            basis(e.axis, t, b);
            r.origin = e.position;
            r.dir = glm::normalize(sinT * std::cos(phi) * t + sinT * std::sin(phi) * b + cosT * e.axis);
            break;
        }
        case EmitterKind::Directional: {
            const Vec2 d = concentricDisc(uDir.x, uDir.y) * e.discRadius;
            r.origin = e.discCentre + d.x * e.tangent + d.y * e.bitangent;
            r.dir = e.axis;
            break;
        }
        case EmitterKind::Area: {
            // Triangle ∝ area by uPoint.x, then uPoint.x is stretched back to [0, 1) within the
            // chosen triangle's CDF slot, so both numbers still steer the point continuously.
            const auto it = std::upper_bound(e.cdf.begin(), e.cdf.end(), static_cast<double>(uPoint.x));
            const size_t t = std::min<size_t>(static_cast<size_t>(it - e.cdf.begin()), e.cdf.size() - 1);
            const double lo = t == 0 ? 0.0 : e.cdf[t - 1];
            const double width = e.cdf[t] - lo;
            float u0 = width > 0.0 ? static_cast<float>((uPoint.x - lo) / width) : 0.5f;
            u0 = std::clamp(u0, 0.0f, kOneMinusEpsilon);
            const EmissiveTriangle& tri = scene.emissiveTriangles()[e.triangles[t]];
            const float su = std::sqrt(u0);
            const float b0 = 1.0f - su;
            const float b1 = uPoint.y * su;
            r.origin = b0 * tri.p0 + b1 * tri.p1 + (1.0f - b0 - b1) * tri.p2;
            r.normal = tri.normal;
            r.dir = cosineDirection(tri.normal, uDir.x, uDir.y);
            if (!e.colour.empty()) r.powerScale = e.colour[t];
            break;
        }
        case EmitterKind::Environment: {
            const Environment& env = scene.scene().environment;
            const EnvironmentSample s = env.sample(uDir);
            r.dir = -s.direction;
            Vec3 t, b;
            basis(r.dir, t, b);
            const Vec2 d = concentricDisc(uPoint.x, uPoint.y) * e.discRadius;
            r.origin = e.discCentre + s.direction * (e.discRadius * 1.001f + scene.epsilon()) + d.x * t + d.y * b;
            const Vec3 integral = env.integral();
            r.powerScale = Vec3(0.0f);
            if (s.pdf > 0.0f)
                for (int c = 0; c < 3; ++c)
                    if (integral[c] > 0.0f) r.powerScale[c] = s.radiance[c] / (s.pdf * integral[c]);
            break;
        }
    }
    return r;
}

void TraceStats::add(const TraceStats& o) {
    paths += o.paths;
    productivePaths += o.productivePaths;
    stored += o.stored;
    rays += o.rays;
    anomalies += o.anomalies;
    wallSeconds += o.wallSeconds;
    samplingSeconds += o.samplingSeconds;
    rayCastSeconds += o.rayCastSeconds;
    interactionSeconds += o.interactionSeconds;
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
}

/// One photon path: what it reads, where its photons go, and what it carries between bounces.
struct PhotonWalk {
    const Scene& model;
    const PhotonSource& src;
    const TraceSettings& ts;
    uint64_t index;
    std::vector<TracedPhoton>& out;
    Vec3 power;
    bool specularSinceDiffuse = false;
    uint32_t diffuseCount = 0;
    int stored = 0;
};

/// The path's hashed number for `purpose` at bounce `bounce`.
float hashed(const PhotonWalk& w, uint32_t bounce, uint64_t purpose) {
    return hashToUnit(hashKeys(w.ts.seed, w.src.hashStream, w.index, bounce, purpose));
}

/// The emitted ray of path `index`, its power in `power`: direction (and point) from the source's
/// Halton dims.
Ray emitPhoton(const EmbreeScene& scene, const PhotonSource& src, uint64_t index, Vec3& power) {
    const Emitter& e = *src.emitter;
    const Halton& h = *src.halton;
    const Vec2 uDir(h.sample(src.dims.direction, index), h.sample(src.dims.direction + 1, index));
    Vec2 uPoint(0.0f);
    if (src.dims.point >= 0)
        uPoint = Vec2(h.sample(src.dims.point, index), h.sample(src.dims.point + 1, index));
    const EmittedRay em = sampleEmission(e, scene, uDir, uPoint);
    Ray ray;
    ray.dir = em.dir;
    ray.origin = e.kind == EmitterKind::Area ? scene.offsetOrigin(em.origin, em.normal, em.dir)
                                             : em.origin;
    power = src.powerPerPath;
    if (!e.colour.empty() || e.kind == EmitterKind::Environment) power *= em.powerScale;
    return ray;
}

/// The mirror lobe at a hit (arriving along `dir`, normals facing it): the next direction, 0
/// when the photon is absorbed.
Vec3 scatterMirror(PhotonWalk& w, const Material& mat, Vec3 dir, Vec3 ns, Vec3 ng, uint32_t depth) {
    if (mat.isGlossy()) {
        // GGX conductor: a direction from the normals visible to the photon, power ×
        // F G2/G1 (≤ 1, so no roulette is needed). A direction below the true surface
        // (a shading normal far from it) absorbs the photon.
        const ShadingFrame frame(ns);
        BsdfSample s;
        if (!roughConductorSample(frame.toLocal(-dir), ggxAlpha(mat.roughness), mat.baseColor,
                                  Vec2(hashed(w, depth, kGlossyU), hashed(w, depth, kGlossyV)), s))
            return Vec3(0.0f);
        Vec3 next = glm::normalize(frame.toWorld(s.wi));
        if (glm::dot(next, ng) <= 0.0f) next = Vec3(0.0f);
        w.power *= s.weight;
        w.specularSinceDiffuse = true;
        return next;
    }
    Vec3 next = reflect(dir, ns);
    // A shading normal can send the reflection below the surface; use the true one.
    if (glm::dot(next, ng) <= 0.0f) next = reflect(dir, ng);
    w.power *= mat.baseColor;
    w.specularSinceDiffuse = true;
    return next;
}

/// The dielectric lobe at `hit` (`attenuated`: the absorption inside was already applied): the
/// next direction, 0 when the photon is absorbed.
Vec3 scatterDielectric(PhotonWalk& w, const SurfaceHit& hit, const Material& mat, Vec3 dir, Vec3 ns,
                       Vec3 ng, uint32_t depth, bool attenuated) {
    const DielectricInterface side = dielectricInterface(dir, hit.geometricNormal, mat.ior);
    // A back-face hit ends a segment that ran inside this medium.
    if (!side.entering && !attenuated) w.power *= beerLambert(mat.absorption, hit.t);
    Vec3 next;
    if (mat.isGlossy()) {
        // GGX rough dielectric in the frame of the outward shading normal: reflection
        // or refraction about a visible microfacet normal, chosen by its Fresnel
        // reflectance, power × G2/G1 (the Importance form: flux is not scaled by η²).
        // A direction on the wrong side of the true surface absorbs the photon.
        const ShadingFrame frame(hit.shadingNormal);
        BsdfSample s;
        if (!roughDielectricSample(frame.toLocal(-dir), ggxAlpha(mat.roughness), mat.ior,
                                   hashed(w, depth, kFresnelChoice),
                                   Vec2(hashed(w, depth, kGlossyU), hashed(w, depth, kGlossyV)), s))
            return Vec3(0.0f);
        next = glm::normalize(frame.toWorld(s.wi));
        if ((glm::dot(next, ng) > 0.0f) == s.transmitted) next = Vec3(0.0f);
        w.power *= s.weight;
        w.specularSinceDiffuse = true;
        return next;
    }
    const float f = fresnelDielectric(side.cosI, side.etaI, side.etaT);
    if (hashed(w, depth, kFresnelChoice) < f ||
        !refract(dir, ns, side.etaI / side.etaT, next)) {
        next = reflect(dir, ns);
        if (glm::dot(next, ng) <= 0.0f) next = reflect(dir, ng);
    } else if (glm::dot(next, ng) >= 0.0f) {
        // Shading normal bent the refraction back out: refract about the true one.
        if (!refract(dir, ng, side.etaI / side.etaT, next)) next = reflect(dir, ng);
    }
    w.specularSinceDiffuse = true;
    return next;
}

/// The diffuse lobe at `hit`: stores a caustic photon (unless `storedHere` on arrival), then ends
/// the path or bounces (Russian roulette on the albedo, cosine-weighted; a plastic's base, `coat`,
/// weights the bounce by the base's share of its direction). Returns false for an anomaly (a
/// non-finite power to store), else true with `next` 0 when the path ends.
bool scatterDiffuse(PhotonWalk& w, const SurfaceHit& hit, const Material& mat, Vec3 dir, Vec3 ns, Vec3 ng,
                    uint32_t depth, bool storedHere, Vec3& next, const PlasticBsdf* coat = nullptr) {
    if (w.specularSinceDiffuse && !storedHere) {
        if (!finite(w.power)) return false;
        w.out.push_back(TracedPhoton{hit.position, w.power, dir});
        ++w.stored;
    }
    if (w.diffuseCount >= w.ts.diffuseBounces) {
        next = Vec3(0.0f);
        return true;
    }
    const Vec3 albedo = baseColorAt(mat, w.model.textures, hit.uv);
    const float survive = std::min(1.0f, std::max({albedo.x, albedo.y, albedo.z}));
    if (!(survive > 0.0f) || hashed(w, depth, kRoulette) >= survive) {
        next = Vec3(0.0f);
        return true;
    }
    w.power *= albedo / survive;
    float u0, u1;
    if (w.diffuseCount == 0 && w.src.dims.bounce >= 0) {
        u0 = w.src.halton->sample(w.src.dims.bounce, w.index);
        u1 = w.src.halton->sample(w.src.dims.bounce + 1, w.index);
    } else {
        u0 = hashed(w, depth, kBounceU);
        u1 = hashed(w, depth, kBounceV);
    }
    next = cosineDirection(ns, u0, u1);
    if (glm::dot(next, ng) <= 0.0f) next = cosineDirection(ng, u0, u1);
    if (coat) w.power *= coat->lightShare(glm::dot(next, ns));
    ++w.diffuseCount;
    w.specularSinceDiffuse = false;
    return true;
}

/// A plastic at `hit` (plastic_bsdf.h): its base is a diffuse receiver, so a caustic photon is stored
/// on arrival, × lightShare (the incoming side's factor; the viewer's is the eye pass's). One lobe
/// is then chosen by the photon's hashed number: metal (probability m), the dielectric coat
/// ((1 − m)·s·E(cos θ)) or the base (a Lambertian bounce), each weighted by its share over its
/// probability, as for a partly transmissive dielectric (a smooth coat keeps the power exactly).
/// Returns false for an anomaly, else true with `next` 0 when absorbed.
bool scatterPlastic(PhotonWalk& w, const SurfaceHit& hit, const Material& mat, Vec3 dir, Vec3 ns, Vec3 ng,
                    uint32_t depth, Vec3& next) {
    const PlasticBsdf bsdf(mat);
    const float cosIn = std::clamp(-glm::dot(dir, ns), 0.0f, 1.0f);
    bool storedHere = false;
    if (w.specularSinceDiffuse) {
        const Vec3 power = w.power * bsdf.lightShare(cosIn);
        if (!finite(power)) return false;
        w.out.push_back(TracedPhoton{hit.position, power, dir});
        ++w.stored;
        storedHere = true;
    }
    const float u = hashed(w, depth, kLobeChoice);
    const float metal = bsdf.metalChance();
    if (u >= metal + bsdf.coatChance(cosIn))
        return scatterDiffuse(w, hit, mat, dir, ns, ng, depth, storedHere, next, &bsdf);
    const ShadingFrame frame(ns);
    BsdfSample s;
    const Vec2 uv(hashed(w, depth, kGlossyU), hashed(w, depth, kGlossyV));
    const bool sampled = u < metal ? bsdf.sampleMetal(frame.toLocal(-dir), uv, s)
                                   : bsdf.sampleDielectricCoat(frame.toLocal(-dir), uv, s);
    next = Vec3(0.0f);
    if (!sampled) return true;
    if (bsdf.smooth()) {
        // As a mirror: about the shading normal, or the true one if that goes below the surface.
        next = reflect(dir, ns);
        if (glm::dot(next, ng) <= 0.0f) next = reflect(dir, ng);
    } else {
        next = glm::normalize(frame.toWorld(s.wi));
        if (glm::dot(next, ng) <= 0.0f) next = Vec3(0.0f);  // below the true surface: absorbed
    }
    w.power *= s.weight;
    w.specularSinceDiffuse = true;
    return true;
}

}  // namespace

int tracePhotonPath(const EmbreeScene& scene, const PhotonSource& src, const TraceSettings& ts,
                    uint64_t index, std::vector<TracedPhoton>& out, TraceStats& stats, bool timed) {
    RTPM_DCHECK(src.emitter && src.halton);
    const Scene& model = scene.scene();
    const size_t outStart = out.size();
    Clock::time_point tStart, tMark;
    if (timed) tStart = Clock::now();

    PhotonWalk w{model, src, ts, index, out, Vec3(0.0f)};
    Ray ray = emitPhoton(scene, src, index, w.power);
    if (timed) {
        tMark = Clock::now();
        stats.samplingSeconds += seconds(tStart, tMark);
    }

    bool anomaly = !finite(ray.origin) || !finite(ray.dir) || !finite(w.power);
    for (uint32_t depth = 0; depth < ts.maxDepth && !anomaly; ++depth) {
        SurfaceHit hit;
        ++stats.rays;
        bool found;
        if (timed) {
            const Clock::time_point t0 = Clock::now();
            found = scene.intersect(ray, hit);
            stats.rayCastSeconds += seconds(t0, Clock::now());
        } else {
            found = scene.intersect(ray, hit);
        }
        if (!found) break;
        if (!finite(hit.position) || !finite(hit.geometricNormal) || !finite(hit.shadingNormal)) {
            anomaly = true;
            break;
        }
        const Vec3 dir = ray.dir;  // unit throughout
        // Normals facing the side the photon arrives from.
        const Vec3 ng = glm::dot(dir, hit.geometricNormal) <= 0.0f ? hit.geometricNormal
                                                                    : -hit.geometricNormal;
        Vec3 ns = glm::dot(hit.shadingNormal, ng) >= 0.0f ? hit.shadingNormal : -hit.shadingNormal;
        if (!(glm::dot(ns, ns) > 0.5f)) ns = ng;
        if (!(glm::dot(ng, ng) > 0.5f)) break;  // degenerate triangle: no usable side
        if (hit.material >= model.materials.size()) break;
        const Material& mat = model.materials[hit.material];
        if (mat.type == MaterialType::Diffuse && mat.unlit) break;  // unlit: absorbs, stores nothing
        // A partly transmissive dielectric (transmission t < 1) is a surface the photon map must
        // know the incident flux on (the eye pass weights its estimate by the Lambertian share
        // 1 − t): a caustic photon is stored on arrival, whatever lobe it takes next. The lobe is
        // then chosen with probability t (dielectric) or 1 − t (Lambertian) from the photon's
        // hashed numbers, and the power is kept: the choice is the weight.
        MaterialType lobe = mat.type;
        bool storedHere = false, attenuated = false;
        if (mat.isPartlyDiffuse()) {
            if (glm::dot(dir, hit.geometricNormal) > 0.0f) {
                w.power *= beerLambert(mat.absorption, hit.t);  // the segment ran inside the medium
                attenuated = true;
            }
            if (w.specularSinceDiffuse) {
                if (!finite(w.power)) {
                    anomaly = true;
                    break;
                }
                out.push_back(TracedPhoton{hit.position, w.power, dir});
                ++w.stored;
                storedHere = true;
            }
            if (hashed(w, depth, kLobeChoice) >= mat.transmission) lobe = MaterialType::Diffuse;
        }
        Vec3 next;
        switch (lobe) {
            case MaterialType::Mirror:
                next = scatterMirror(w, mat, dir, ns, ng, depth);
                break;
            case MaterialType::Dielectric:
                next = scatterDielectric(w, hit, mat, dir, ns, ng, depth, attenuated);
                break;
            case MaterialType::Diffuse:
                anomaly = !scatterDiffuse(w, hit, mat, dir, ns, ng, depth, storedHere, next);
                break;
            case MaterialType::Plastic:
                anomaly = !scatterPlastic(w, hit, mat, dir, ns, ng, depth, next);
                break;
        }
        if (anomaly) break;
        if (next == Vec3(0.0f)) break;
        if (!finite(w.power) || !finite(next)) {
            anomaly = true;
            break;
        }
        if (!(w.power.x > 0.0f || w.power.y > 0.0f || w.power.z > 0.0f)) break;
        ray.origin = scene.offsetOrigin(hit.position, hit.geometricNormal, next);
        ray.dir = next;
        ray.tMin = 0.0f;
        ray.tMax = 1e30f;
    }
    ++stats.paths;
    if (anomaly) {
        out.resize(outStart);
        ++stats.anomalies;
        return -1;
    }
    if (w.stored > 0) ++stats.productivePaths;
    stats.stored += static_cast<uint64_t>(w.stored);
    return w.stored;
}

void tracePhotons(const EmbreeScene& scene, const PhotonSource& source, const TraceSettings& ts,
                  std::span<const uint64_t> indices, TraceOutput& out) {
    // Fixed-size chunks, each with its own buffer, concatenated in chunk order: the output is
    // the same for any thread count or schedule.
    constexpr size_t kChunk = 256;
    const size_t n = indices.size();
    const size_t chunks = (n + kChunk - 1) / kChunk;
    struct ChunkResult {
        std::vector<TracedPhoton> photons;
        std::vector<uint32_t> storedPerPath;
        TraceStats stats;          // counters of every path
        TraceStats timedStats;     // phase times of the timed sample paths
        double timedTotal = 0.0;   // their total time
    };
    std::vector<ChunkResult> results(chunks);
    const Clock::time_point start = Clock::now();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t c = r.begin(); c != r.end(); ++c) {
            ChunkResult& res = results[c];
            const size_t lo = c * kChunk;
            const size_t hi = std::min(n, lo + kChunk);
            res.storedPerPath.resize(hi - lo);
            for (size_t j = lo; j < hi; ++j) {
                const uint64_t index = indices[j];
                const bool timed = index % kTimedPathStride == 0;
                int stored;
                if (timed) {
                    TraceStats t;
                    const Clock::time_point t0 = Clock::now();
                    stored = tracePhotonPath(scene, source, ts, index, res.photons, t, true);
                    res.timedTotal += seconds(t0, Clock::now());
                    res.timedStats.samplingSeconds += t.samplingSeconds;
                    res.timedStats.rayCastSeconds += t.rayCastSeconds;
                    t.samplingSeconds = t.rayCastSeconds = t.interactionSeconds = 0.0;
                    res.stats.add(t);
                } else {
                    stored = tracePhotonPath(scene, source, ts, index, res.photons, res.stats, false);
                }
                res.storedPerPath[j - lo] = stored > 0 ? static_cast<uint32_t>(stored) : 0;
            }
        }
    });
    const double wall = seconds(start, Clock::now());

    TraceStats total;
    TraceStats timed;
    double timedTotal = 0.0;
    size_t photonCount = out.photons.size();
    for (const ChunkResult& res : results) photonCount += res.photons.size();
    out.photons.reserve(photonCount);
    out.storedPerPath.reserve(out.storedPerPath.size() + n);
    for (ChunkResult& res : results) {
        out.photons.insert(out.photons.end(), res.photons.begin(), res.photons.end());
        out.storedPerPath.insert(out.storedPerPath.end(), res.storedPerPath.begin(), res.storedPerPath.end());
        total.add(res.stats);
        timed.add(res.timedStats);
        timedTotal += res.timedTotal;
    }
    // Table 3 split: the timed paths' phase fractions applied to the measured wall time.
    total.wallSeconds = wall;
    if (timedTotal > 0.0) {
        const double fs = std::min(1.0, timed.samplingSeconds / timedTotal);
        const double fr = std::min(1.0 - fs, timed.rayCastSeconds / timedTotal);
        total.samplingSeconds = wall * fs;
        total.rayCastSeconds = wall * fr;
        total.interactionSeconds = wall * (1.0 - fs - fr);
    } else {
        total.interactionSeconds = wall;
    }
    out.stats.add(total);
}

}  // namespace rtpm
