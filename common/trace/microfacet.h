// GGX microfacet BSDFs of rough metals and rough glass, with visible-normal sampling: what the eye
// pass and the photon tracer do at a glossy surface (docs/ARCHITECTURE.md §5, §6).
//
// Every function works in a local shading frame: z is the macro-surface normal, unit directions
// point away from the surface (pbrt's convention: `wo` toward the viewer or where the photon came
// from, `wi` the other direction). For a dielectric, +z points out of the medium (index `eta`
// inside, 1 outside) and either direction may lie below.
// Sources: GGX/Trowbridge–Reitz distribution with the height-correlated Smith masking-shadowing
// (Heitz 2014, "Understanding the masking-shadowing function", eqs. 72, 99); sampling of the
// visible normals (Heitz 2018, "Sampling the GGX distribution of visible normals"); rough
// dielectric reflection and transmission (Walter, Marschner, Li, Torrance 2007, eqs. 20–21, 38–41,
// as pbrt-v4's DielectricBxDF writes them); the conductor's Fresnel by Schlick with F0 = the glTF
// base colour, as glTF's metal BRDF defines it.
#pragma once

#include "common/core/math.h"

namespace rtpm {

/// GGX α from glTF perceptual roughness (glTF: α = roughness²; above kSmoothRoughness, scene.h), clamped to [1e-4, 1] so that D and
/// its sampling stay finite in float. Pure, O(1).
float ggxAlpha(float roughness);

/// The isotropic GGX distribution of microfacet normals of roughness `alpha` (local frame).
struct Ggx {
    float alpha;
    /// D(m): microfacet normal density per unit projected area (sr⁻¹); 0 for m.z ≤ 0.
    float d(Vec3 m) const;
    /// Smith Λ(w) (symmetric in w.z's sign).
    float lambda(Vec3 w) const;
    /// Smith masking G1(w) = 1 / (1 + Λ(w)).
    float g1(Vec3 w) const { return 1.0f / (1.0f + lambda(w)); }
    /// Height-correlated masking-shadowing G2(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi)).
    float g2(Vec3 wo, Vec3 wi) const { return 1.0f / (1.0f + lambda(wo) + lambda(wi)); }
    /// A normal m (m.z ≥ 0) drawn from the normals visible from `wo` (any side: a wo below the
    /// surface draws as from −wo), D_wo(m) = G1(wo) max(0, |wo·m|) D(m) / |wo.z|, from two
    /// uniform numbers in [0, 1). Heitz 2018's inversion: stratification of `u` is kept.
    Vec3 sampleVisibleNormal(Vec3 wo, Vec2 u) const;
    /// D_wo(m), the density of sampleVisibleNormal (sr⁻¹ over m).
    float visibleNormalPdf(Vec3 wo, Vec3 m) const;
};

/// Schlick's Fresnel F0 + (1 − F0)(1 − cosθ)⁵ per channel, cosθ clamped to [0, 1].
Vec3 fresnelSchlick(Vec3 f0, float cosTheta);

/// One sampled direction of a BSDF. `weight` = f·|cos θi| / pdf, what the path's throughput or the
/// photon's power is multiplied by (for transmission, flux form: see roughDielectricSample).
struct BsdfSample {
    Vec3 wi{0.0f};
    Vec3 weight{0.0f};
    float pdf = 0.0f;
    bool transmitted = false;
};

/// Rough conductor BRDF f(wo, wi) = F(wo·m) D(m) G2 / (4 cos θo cos θi), m the half vector, F
/// Schlick's with F0 = `f0`. 0 unless both directions are above the surface. Symmetric in wo, wi.
Vec3 roughConductorEval(Vec3 wo, Vec3 wi, float alpha, Vec3 f0);
/// Density over wi (sr⁻¹) of roughConductorSample: D_wo(m) / (4 |wo·m|).
float roughConductorPdf(Vec3 wo, Vec3 wi, float alpha);
/// Reflects `wo` (wo.z > 0) about a visible normal drawn with `u`; weight F(wo·m) G2/G1(wo) ≤ F.
/// False (nothing sampled: the path ends) when the reflection falls below the surface.
bool roughConductorSample(Vec3 wo, float alpha, Vec3 f0, Vec2 u, BsdfSample& out);

/// How a transmitted direction's value is counted. Radiance: f as the rendering equation uses it
/// (transmission scaled by (η_o/η_i)², η on the side of wo and wi). Importance: without that
/// factor, the form whose integral over wi is what a photon's power keeps (Veach 1997 §5.2).
enum class Transport : uint8_t { Radiance, Importance };

/// Rough dielectric BSDF (Walter et al. 2007): reflection F D G2 / (4 |cos θo cos θi|) when wo
/// and wi are on one side, transmission (1 − F) D G2 |wi·m||wo·m| / ((wi·m + wo·m/η')² |cos θi cos θo|)
/// across, with m the generalised half vector and η' the index ratio of wi's side to wo's
/// (divided by η'² in Radiance mode). `eta` = index inside (+z outside). Generalised reciprocity
/// in Radiance mode: f(wo, wi) / η_o² = f(wi, wo) / η_i².
float roughDielectricEval(Vec3 wo, Vec3 wi, float alpha, float eta, Transport mode);
/// Density over wi (sr⁻¹) of roughDielectricSample.
float roughDielectricPdf(Vec3 wo, Vec3 wi, float alpha, float eta);
/// Draws a visible normal m with `u`, then reflects with probability F(wo·m) (`uChoice` < F) or
/// refracts; weight G2/G1(wo) ≤ 1 in Importance form for both (the choice is the Fresnel weight).
/// A Radiance-mode path would divide a transmission's weight by η'²; the eye pass leaves it out
/// as it does for smooth glass (an eye path that enters a medium leaves it through as many
/// interfaces, and the factors cancel). False when the sampled direction is not on the side the
/// choice requires (a microfacet facing away).
bool roughDielectricSample(Vec3 wo, float alpha, float eta, float uChoice, Vec2 u, BsdfSample& out);

/// Both lobes of a rough dielectric at one visible normal drawn with `u`: `reflected` with weight
/// F(wo·m) G2/G1(wo), `transmitted` with (1 − F) G2/G1(wo) (Importance form). Each is set only when
/// it exists on its side (bit 0: reflected, bit 1: transmitted; 0 = nothing). Their expected sum
/// is roughDielectricSample's expected weight, with less variance: an eye path that splits here
/// is, in the smooth limit, the smooth dielectric's deterministic Fresnel split.
int roughDielectricSplit(Vec3 wo, float alpha, float eta, Vec2 u, BsdfSample& reflected,
                         BsdfSample& transmitted);

/// The local frame of a unit normal `n`: world = x·t + y·b + z·n (Duff et al. 2017, continuous
/// except at n.z = −1).
struct ShadingFrame {
    Vec3 t, b, n;
    explicit ShadingFrame(Vec3 normal);
    Vec3 toLocal(Vec3 v) const { return Vec3(glm::dot(v, t), glm::dot(v, b), glm::dot(v, n)); }
    Vec3 toWorld(Vec3 v) const { return v.x * t + v.y * b + v.z * n; }
};

}  // namespace rtpm
