// GGX microfacet BSDFs: distribution, masking, visible-normal sampling, rough conductor and rough
// dielectric (microfacet.h gives the sources).
#include "common/trace/microfacet.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/trace/optics.h"

namespace rtpm {

namespace {

float sqr(float x) { return x * x; }

// Reflection of `w` (pointing away from the surface) about the unit normal `m`.
Vec3 reflectAbout(Vec3 w, Vec3 m) { return -w + 2.0f * glm::dot(w, m) * m; }

// Refraction of `w` (pointing away from the surface, on either side) through a surface of unit
// normal `m` (m.z ≥ 0) and index `eta` below it, pbrt-v4's Refract: false under total internal
// reflection; `etap` receives the index ratio of the far side to w's side.
bool refractAbout(Vec3 w, Vec3 m, float eta, float& etap, Vec3& out) {
    float cosI = glm::dot(m, w);
    if (cosI < 0.0f) {
        eta = 1.0f / eta;
        cosI = -cosI;
        m = -m;
    }
    const float sin2I = std::max(0.0f, 1.0f - cosI * cosI);
    const float sin2T = sin2I / (eta * eta);
    if (sin2T >= 1.0f) return false;
    const float cosT = std::sqrt(std::max(0.0f, 1.0f - sin2T));
    out = glm::normalize(-w / eta + (cosI / eta - cosT) * m);
    etap = eta;
    return true;
}

// The generalised half vector of a dielectric pair (Walter et al. 2007 eq. 16), facing +z, and
// the index ratio η' of wi's side to wo's; false when it does not exist or a facet faces away.
bool dielectricHalfVector(Vec3 wo, Vec3 wi, float eta, Vec3& m, float& etap) {
    const float co = wo.z, ci = wi.z;
    if (co == 0.0f || ci == 0.0f) return false;
    const bool reflect = co * ci > 0.0f;
    etap = reflect ? 1.0f : (co > 0.0f ? eta : 1.0f / eta);
    m = wi * etap + wo;
    const float len2 = glm::dot(m, m);
    if (!(len2 > 0.0f)) return false;
    m /= std::sqrt(len2);
    if (m.z < 0.0f) m = -m;
    // Back-facing microfacets contribute nothing.
    return !(glm::dot(m, wi) * ci < 0.0f || glm::dot(m, wo) * co < 0.0f);
}

}  // namespace

float ggxAlpha(float roughness) {
    return std::clamp(roughness * roughness, 1e-4f, 1.0f);
}

float Ggx::d(Vec3 m) const {
    if (m.z <= 0.0f) return 0.0f;
    const float a2 = alpha * alpha;
    const float t = m.z * m.z * (a2 - 1.0f) + 1.0f;
    return a2 / (kPi * t * t);
}

float Ggx::lambda(Vec3 w) const {
    const float cos2 = w.z * w.z;
    if (!(cos2 > 0.0f)) return std::numeric_limits<float>::infinity();
    const float tan2 = std::max(0.0f, 1.0f - cos2) / cos2;
    return 0.5f * (std::sqrt(1.0f + alpha * alpha * tan2) - 1.0f);
}

Vec3 Ggx::sampleVisibleNormal(Vec3 wo, Vec2 u) const {
    // Heitz 2018, listing 1: stretch to the hemisphere configuration, sample the projected
    // half-disc, unstretch.
    Vec3 vh = glm::normalize(Vec3(alpha * wo.x, alpha * wo.y, wo.z));
    if (vh.z < 0.0f) vh = -vh;
    const float lensq = vh.x * vh.x + vh.y * vh.y;
    const Vec3 t1 = lensq > 0.0f ? Vec3(-vh.y, vh.x, 0.0f) / std::sqrt(lensq) : Vec3(1.0f, 0.0f, 0.0f);
    const Vec3 t2 = glm::cross(vh, t1);
    const float r = std::sqrt(u.x);
    const float phi = 2.0f * kPi * u.y;
    const float p1 = r * std::cos(phi);
    float p2 = r * std::sin(phi);
    const float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * std::sqrt(std::max(0.0f, 1.0f - p1 * p1)) + s * p2;
    const Vec3 nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0f, 1.0f - p1 * p1 - p2 * p2)) * vh;
    return glm::normalize(Vec3(alpha * nh.x, alpha * nh.y, std::max(1e-6f, nh.z)));
}

float Ggx::visibleNormalPdf(Vec3 wo, Vec3 m) const {
    const float cosO = wo.z;
    if (cosO == 0.0f) return 0.0f;
    const float cosOM = glm::dot(wo, m);
    if (cosOM * cosO <= 0.0f) return 0.0f;
    return g1(wo) * std::abs(cosOM) * d(m) / std::abs(cosO);
}

Vec3 fresnelSchlick(Vec3 f0, float cosTheta) {
    const float c = 1.0f - std::clamp(cosTheta, 0.0f, 1.0f);
    const float c2 = c * c;
    return f0 + (Vec3(1.0f) - f0) * (c2 * c2 * c);
}

Vec3 roughConductorEval(Vec3 wo, Vec3 wi, float alpha, Vec3 f0) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return Vec3(0.0f);
    const Vec3 m = glm::normalize(wo + wi);
    const Ggx g{alpha};
    return fresnelSchlick(f0, glm::dot(wo, m)) * (g.d(m) * g.g2(wo, wi) / (4.0f * wo.z * wi.z));
}

float roughConductorPdf(Vec3 wo, Vec3 wi, float alpha) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return 0.0f;
    const Vec3 m = glm::normalize(wo + wi);
    const float cosOM = glm::dot(wo, m);
    if (!(cosOM > 0.0f)) return 0.0f;
    return Ggx{alpha}.visibleNormalPdf(wo, m) / (4.0f * cosOM);
}

bool roughConductorSample(Vec3 wo, float alpha, Vec3 f0, Vec2 u, BsdfSample& out) {
    if (!(wo.z > 0.0f)) return false;
    const Ggx g{alpha};
    const Vec3 m = g.sampleVisibleNormal(wo, u);
    const float cosOM = glm::dot(wo, m);
    if (!(cosOM > 0.0f)) return false;
    const Vec3 wi = reflectAbout(wo, m);
    if (!(wi.z > 0.0f)) return false;
    out.wi = wi;
    out.pdf = g.visibleNormalPdf(wo, m) / (4.0f * cosOM);
    // f·cos θi / pdf = F D G2 / (4 cos θo) / (G1 D cos(wo, m) / cos θo / (4 cos(wo, m))) = F G2 / G1.
    out.weight = fresnelSchlick(f0, cosOM) * (g.g2(wo, wi) / g.g1(wo));
    out.transmitted = false;
    return out.pdf > 0.0f;
}

float roughDielectricEval(Vec3 wo, Vec3 wi, float alpha, float eta, Transport mode) {
    Vec3 m;
    float etap;
    if (!dielectricHalfVector(wo, wi, eta, m, etap)) return 0.0f;
    const Ggx g{alpha};
    const float f = fresnelDielectric(glm::dot(wo, m), 1.0f, eta);
    const float ci = wi.z, co = wo.z;
    if (ci * co > 0.0f) return g.d(m) * g.g2(wo, wi) * f / std::abs(4.0f * ci * co);
    const float denom = sqr(glm::dot(wi, m) + glm::dot(wo, m) / etap) * ci * co;
    float ft = g.d(m) * (1.0f - f) * g.g2(wo, wi) * std::abs(glm::dot(wi, m) * glm::dot(wo, m) / denom);
    if (mode == Transport::Radiance) ft /= etap * etap;
    return ft;
}

float roughDielectricPdf(Vec3 wo, Vec3 wi, float alpha, float eta) {
    Vec3 m;
    float etap;
    if (!dielectricHalfVector(wo, wi, eta, m, etap)) return 0.0f;
    const Ggx g{alpha};
    const float r = fresnelDielectric(glm::dot(wo, m), 1.0f, eta);
    if (wi.z * wo.z > 0.0f) return g.visibleNormalPdf(wo, m) / (4.0f * std::abs(glm::dot(wo, m))) * r;
    const float dmdwi = std::abs(glm::dot(wi, m)) / sqr(glm::dot(wi, m) + glm::dot(wo, m) / etap);
    return g.visibleNormalPdf(wo, m) * dmdwi * (1.0f - r);
}

bool roughDielectricSample(Vec3 wo, float alpha, float eta, float uChoice, Vec2 u, BsdfSample& out) {
    if (wo.z == 0.0f) return false;
    const Ggx g{alpha};
    const Vec3 m = g.sampleVisibleNormal(wo, u);
    const float cosOM = glm::dot(wo, m);
    if (cosOM * wo.z <= 0.0f) return false;
    const float r = fresnelDielectric(cosOM, 1.0f, eta);
    const float dwo = g.visibleNormalPdf(wo, m);
    if (uChoice < r) {
        const Vec3 wi = reflectAbout(wo, m);
        if (wi.z * wo.z <= 0.0f) return false;
        out.wi = wi;
        out.pdf = dwo / (4.0f * std::abs(cosOM)) * r;
        out.transmitted = false;
    } else {
        float etap;
        Vec3 wi;
        if (!refractAbout(wo, m, eta, etap, wi) || wi.z * wo.z >= 0.0f) return false;
        out.wi = wi;
        out.pdf = dwo * std::abs(glm::dot(wi, m)) / sqr(glm::dot(wi, m) + cosOM / etap) * (1.0f - r);
        out.transmitted = true;
    }
    // f·|cos θi| / pdf in Importance form: the Fresnel factor cancels against the choice, the
    // Jacobians against each other, and G2 / G1(wo) is left (pbrt-v4, DielectricBxDF::Sample_f).
    out.weight = Vec3(g.g2(wo, out.wi) / g.g1(wo));
    return out.pdf > 0.0f;
}

int roughDielectricSplit(Vec3 wo, float alpha, float eta, Vec2 u, BsdfSample& reflected,
                         BsdfSample& transmitted) {
    if (wo.z == 0.0f) return 0;
    const Ggx g{alpha};
    const Vec3 m = g.sampleVisibleNormal(wo, u);
    const float cosOM = glm::dot(wo, m);
    if (cosOM * wo.z <= 0.0f) return 0;
    const float r = fresnelDielectric(cosOM, 1.0f, eta);
    const float g1 = g.g1(wo);
    int out = 0;
    const Vec3 wr = reflectAbout(wo, m);
    if (wr.z * wo.z > 0.0f && r > 0.0f) {
        reflected.wi = wr;
        reflected.weight = Vec3(r * g.g2(wo, wr) / g1);
        reflected.pdf = 0.0f;  // a split, not a sample
        reflected.transmitted = false;
        out |= 1;
    }
    float etap;
    Vec3 wt;
    if (r < 1.0f && refractAbout(wo, m, eta, etap, wt) && wt.z * wo.z < 0.0f) {
        transmitted.wi = wt;
        transmitted.weight = Vec3((1.0f - r) * g.g2(wo, wt) / g1);
        transmitted.pdf = 0.0f;
        transmitted.transmitted = true;
        out |= 2;
    }
    return out;
}

ShadingFrame::ShadingFrame(Vec3 normal) : n(normal) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float bb = n.x * n.y * a;
    t = Vec3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    b = Vec3(bb, sign + n.y * n.y * a, -n.y);
}

}  // namespace rtpm
