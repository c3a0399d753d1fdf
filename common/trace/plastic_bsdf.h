// The glTF metallic-roughness dielectric base (a Plastic material, scene.h): a Lambertian base of
// the base colour under a dielectric specular coat of index kCoatIor, mixed with the glTF metal
// lobe by `metallic`. What the eye pass and the photon tracer ask of it (docs/ARCHITECTURE.md §9).
//
// The model, in the local shading frame of microfacet.h (z the normal, wo and wi pointing away):
// * The coat: a GGX microfacet reflector, α = roughness² (a smooth mirror-like coat at
//   roughness ≤ kSmoothRoughness), of reflectance F(c) = s·(1 − m)·F_d(c) + m·F_s(c) at the
//   microfacet angle c = wo·h: F_d the exact unpolarised dielectric Fresnel of index 1.5 (F0 = 0.04,
//   glTF's default), s the KHR_materials_specular factor, F_s Schlick's with F0 = the base colour
//   (glTF's metal lobe, weighted by metallic m; glTF mixes the two BRDFs by m, and both share one
//   microfacet distribution, so one sampled normal serves both).
// * The base: f_d(wo, wi) = (1 − m) · ρ/π · (1 − s·E(μo)) (1 − s·E(μi)) / (1 − s·E_avg), with E(μ)
//   the dielectric coat's directional albedo (its reflectance integrated over the lobe, Fresnel and
//   masking included) and E_avg = 2∫E(μ)μ dμ: the coupled diffuse of Kelemen and Szirmay-Kalos
//   (2001). It is reciprocal (symmetric in μo, μi), and for a white base (ρ = 1, m = 0) the
//   directional albedo is s·E(μo) + (1 − s·E(μo)) = 1 at every angle: the base gets exactly what the
//   coat does not reflect, averaged over the light's directions, so a white furnace stays at 1 (at
//   ≤ 1 for any base, roughness or metallic). Weighting by 1 − F(μ) instead would be reciprocal too,
//   but a rough coat's albedo is not F(μ) (masking loses energy, off-normal facets see another
//   angle), so the sum would miss 1 both ways.
// * E(μ) for a smooth coat is F_d(μ) itself; for a rough one it is tabulated over (roughness, μ)
//   (32 × 64 points, each a 32 × 32 midpoint quadrature of the visible-normal integral), computed
//   row by row on first use and interpolated linearly; E_avg integrates the interpolant exactly,
//   so the identity above holds for the table as used.
// Still approximated: a single coat interface (no internal reflections between coat and base, no
// tint of the base by the coat, no energy lost by the coat's multiple scattering returned).
#pragma once

#include "common/scene/scene.h"
#include "common/trace/microfacet.h"

namespace rtpm {

/// Index of refraction of the plastic coat: glTF's dielectric F0 = ((1.5 − 1)/(1.5 + 1))² = 0.04.
inline constexpr float kCoatIor = 1.5f;

/// Directional albedo E(μ) of the dielectric coat alone (index kCoatIor, specular factor 1) of glTF
/// perceptual `roughness`, for a direction at cosine `cosTheta` from the normal (clamped to [0, 1]).
/// Smooth (roughness ≤ kSmoothRoughness): the Fresnel reflectance. Thread-safe; the first call for a
/// roughness computes two table rows (about 2 ms), later calls are O(1).
float coatAlbedo(float roughness, float cosTheta);
/// E_avg = 2∫₀¹ E(μ) μ dμ of coatAlbedo's E for `roughness` (the cosine-weighted mean). Same costs.
float coatAverageAlbedo(float roughness);

/// A Plastic material's lobes at a shading point (the file comment's model). Built per hit, O(1)
/// after the table rows exist; pure and thread-safe.
class PlasticBsdf {
public:
    /// Reads roughness, metallic, specular and baseColor (the metal lobe's F0; the base's albedo
    /// comes with each call, as it carries the texture). Precondition: material.type == Plastic.
    explicit PlasticBsdf(const Material& material);

    bool smooth() const { return smooth_; }
    float alpha() const { return alpha_; }
    /// The coat's reflectance at microfacet cosine `cosOM` (per channel): s(1 − m)F_d + m F_s.
    Vec3 coatFresnel(float cosOM) const;
    /// The base's share seen from `cosOut` (the viewer's side): (1 − m)(1 − s·E(cosOut)).
    float viewShare(float cosOut) const;
    /// The base's share of light arriving at `cosIn`: (1 − s·E(cosIn)) / (1 − s·E_avg). Its
    /// cosine-weighted mean over the hemisphere is 1.
    float lightShare(float cosIn) const;
    /// f_d(wo, wi) of the base with albedo `albedo` (0 unless both are above the surface).
    Vec3 diffuseEval(Vec3 wo, Vec3 wi, Vec3 albedo) const;
    /// The rough coat's BRDF coatFresnel(wo·h) D(h) G2 / (4 cos θo cos θi); 0 for a smooth coat (a
    /// delta lobe) or a direction below the surface. Symmetric in wo, wi.
    Vec3 coatEval(Vec3 wo, Vec3 wi) const;
    /// The coat's reflection of `wo` (wo.z > 0): a smooth coat reflects about z with weight
    /// coatFresnel(wo.z); a rough one about a visible normal drawn with `u`, weight
    /// coatFresnel(wo·h) G2/G1(wo). False when the direction falls below the surface.
    bool sampleCoat(Vec3 wo, Vec2 u, BsdfSample& out) const;

    /// Photon lobe probabilities at incidence cosine `cosIn`: the metal lobe m, the dielectric
    /// coat (1 − m)·s·E(cosIn), the base the rest, (1 − m)(1 − s·E(cosIn)).
    float metalChance() const { return metallic_; }
    float coatChance(float cosIn) const;
    /// The dielectric coat's reflection alone (the photon's coat lobe): like sampleCoat with m = 0
    /// and s = 1, the weight divided by E(wo.z) so that its mean over `u` is 1 (its choice with
    /// probability coatChance carries the rest).
    bool sampleDielectricCoat(Vec3 wo, Vec2 u, BsdfSample& out) const;
    /// The metal lobe alone: weight F_s(wo·h) G2/G1 (smooth: F_s(wo.z)).
    bool sampleMetal(Vec3 wo, Vec2 u, BsdfSample& out) const;

private:
    bool sampleWith(Vec3 wo, Vec2 u, int lobe, BsdfSample& out) const;
    float e(float cosTheta) const;

    float roughness_, alpha_, metallic_, specular_;
    bool smooth_;
    Vec3 metalF0_;
    float diffuseNorm_;  // 1 / (1 − s·E_avg)
};

}  // namespace rtpm
