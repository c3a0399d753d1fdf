// Smooth-surface optics shared by the eye pass and the photon tracer: Fresnel, reflection,
// refraction and Beer–Lambert absorption.
#pragma once

#include <algorithm>
#include <cmath>

#include "common/scene/scene.h"

namespace rtpm {

/// Exact unpolarized Fresnel reflectance of a smooth dielectric interface (average of the s and p
/// reflectances, e.g. Born & Wolf §1.5; pbrt-v4 FrDielectric).
/// `cosThetaI` is the cosine between the reversed incident direction and the normal on the
/// incident side, in [0, 1]; a negative value means the ray arrives from the other side, and the
/// indices are swapped. `etaI` is the index of the incident medium, `etaT` of the other one.
/// Returns 1 under total internal reflection. Pure, thread-safe, O(1).
inline float fresnelDielectric(float cosThetaI, float etaI, float etaT) {
    cosThetaI = std::clamp(cosThetaI, -1.0f, 1.0f);
    if (cosThetaI < 0.0f) {
        std::swap(etaI, etaT);
        cosThetaI = -cosThetaI;
    }
    const float sinThetaI = std::sqrt(std::max(0.0f, 1.0f - cosThetaI * cosThetaI));
    const float sinThetaT = etaI / etaT * sinThetaI;
    if (sinThetaT >= 1.0f) return 1.0f;  // total internal reflection
    const float cosThetaT = std::sqrt(std::max(0.0f, 1.0f - sinThetaT * sinThetaT));
    const float rs = (etaI * cosThetaI - etaT * cosThetaT) / (etaI * cosThetaI + etaT * cosThetaT);
    const float rp = (etaT * cosThetaI - etaI * cosThetaT) / (etaT * cosThetaI + etaI * cosThetaT);
    return std::clamp(0.5f * (rs * rs + rp * rp), 0.0f, 1.0f);
}

/// Mirror reflection of the travel direction `dir` about the unit normal `n` (either side).
/// |result| = |dir|.
inline Vec3 reflect(Vec3 dir, Vec3 n) { return dir - 2.0f * glm::dot(dir, n) * n; }

/// Refraction of the unit travel direction `dir` through a surface with unit normal `n` facing the
/// incident side (dot(dir, n) <= 0), with `eta` = etaI / etaT (Snell: etaI sinθi = etaT sinθt).
/// Writes the unit transmitted direction to `out` and returns true, or returns false under total
/// internal reflection (`out` untouched).
inline bool refract(Vec3 dir, Vec3 n, float eta, Vec3& out) {
    const float cosI = std::min(1.0f, -glm::dot(dir, n));
    const float sin2T = eta * eta * std::max(0.0f, 1.0f - cosI * cosI);
    if (sin2T >= 1.0f) return false;
    const float cosT = std::sqrt(1.0f - sin2T);
    out = glm::normalize(eta * dir + (eta * cosI - cosT) * n);
    return true;
}

/// Fraction of light transmitted through `distance` metres of a medium with absorption
/// coefficient `sigma` (per metre, per channel): exp(−σ·d).
inline Vec3 beerLambert(Vec3 sigma, float distance) {
    return Vec3(std::exp(-sigma.x * distance), std::exp(-sigma.y * distance),
                std::exp(-sigma.z * distance));
}

/// The two sides of a dielectric surface as seen by a ray travelling along `dir`.
/// Convention: the geometric normal points out of the medium (material ior inside, 1 outside).
struct DielectricInterface {
    Vec3 normal;     ///< unit normal facing the incident side (dot(dir, normal) <= 0)
    float cosI;      ///< cosine of the incidence angle, [0, 1]
    float etaI;      ///< index on the incident side
    float etaT;      ///< index on the transmitted side
    bool entering;   ///< true when the ray enters the medium (arrives from the front face)
};

/// Classifies a hit on a dielectric of index `ior` by the sign of dot(dir, geometricNormal).
/// `dir` unit travel direction, `normal` unit (geometric or shading) normal of the hit.
inline DielectricInterface dielectricInterface(Vec3 dir, Vec3 normal, float ior) {
    const float c = glm::dot(dir, normal);
    DielectricInterface s;
    s.entering = c < 0.0f;
    s.normal = s.entering ? normal : -normal;
    s.cosI = std::min(1.0f, std::abs(c));
    s.etaI = s.entering ? 1.0f : ior;
    s.etaT = s.entering ? ior : 1.0f;
    return s;
}

}  // namespace rtpm
