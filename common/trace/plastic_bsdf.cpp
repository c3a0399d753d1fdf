// The plastic BSDF: the coat's albedo table, the coupled diffuse base and the coat's sampling
// (plastic_bsdf.h gives the model and its sources).
#include "common/trace/plastic_bsdf.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

#include "common/core/check.h"
#include "common/trace/optics.h"

namespace rtpm {

namespace {

constexpr int kRoughnessRows = 32;  // roughness i / 31
constexpr int kCosColumns = 64;     // μ = j / 63
constexpr int kQuadrature = 32;     // midpoint samples per axis of the visible-normal square

struct CoatTable {
    std::array<std::once_flag, kRoughnessRows> once;
    std::array<std::array<float, kCosColumns>, kRoughnessRows> albedo{};
    std::array<float, kRoughnessRows> average{};
};

CoatTable& coatTable() {
    static CoatTable table;
    return table;
}

float fresnelCoat(float cosTheta) { return fresnelDielectric(std::clamp(cosTheta, 0.0f, 1.0f), 1.0f, kCoatIor); }

// 2∫ E μ dμ of the piecewise-linear interpolant through (j/63, e[j]), exactly.
float averageOfRow(const std::array<float, kCosColumns>& e) {
    double sum = 0.0;
    const double h = 1.0 / (kCosColumns - 1);
    for (int j = 0; j + 1 < kCosColumns; ++j) {
        const double a = j * h, b = (j + 1) * h;
        const double ea = e[size_t(j)], eb = e[size_t(j) + 1];
        sum += ea * (b * b - a * a) / 2.0 + (eb - ea) / h * ((b * b * b - a * a * a) / 3.0 - a * (b * b - a * a) / 2.0);
    }
    return float(2.0 * sum);
}

// Row i: E(μ) = ∫ F_d(wo·h) G2/G1(wo) over the visible normals h of wo (reflections below the
// surface count 0), by the midpoint rule on the visible-normal square.
void fillRow(CoatTable& t, int i) {
    const Ggx g{ggxAlpha(float(i) / float(kRoughnessRows - 1))};
    for (int j = 0; j < kCosColumns; ++j) {
        const float mu = std::max(1e-4f, float(j) / float(kCosColumns - 1));
        const Vec3 wo(std::sqrt(std::max(0.0f, 1.0f - mu * mu)), 0.0f, mu);
        double sum = 0.0;
        for (int a = 0; a < kQuadrature; ++a)
            for (int b = 0; b < kQuadrature; ++b) {
                const Vec2 u((float(a) + 0.5f) / kQuadrature, (float(b) + 0.5f) / kQuadrature);
                const Vec3 h = g.sampleVisibleNormal(wo, u);
                const float cosOH = glm::dot(wo, h);
                if (!(cosOH > 0.0f)) continue;
                const Vec3 wi = 2.0f * cosOH * h - wo;
                if (!(wi.z > 0.0f)) continue;
                sum += double(fresnelCoat(cosOH)) * double(g.g2(wo, wi) / g.g1(wo));
            }
        t.albedo[size_t(i)][size_t(j)] = float(sum / (kQuadrature * kQuadrature));
    }
    t.average[size_t(i)] = averageOfRow(t.albedo[size_t(i)]);
}

const CoatTable& rowsFor(int i0, int i1) {
    CoatTable& t = coatTable();
    std::call_once(t.once[size_t(i0)], fillRow, std::ref(t), i0);
    std::call_once(t.once[size_t(i1)], fillRow, std::ref(t), i1);
    return t;
}

// The rows around `roughness` and the weight of the upper one.
void rowPosition(float roughness, int& i0, int& i1, float& w) {
    const float x = std::clamp(roughness, 0.0f, 1.0f) * float(kRoughnessRows - 1);
    i0 = std::min(int(x), kRoughnessRows - 2);
    i1 = i0 + 1;
    w = x - float(i0);
}

float smoothAverage() {
    // 2∫ F_d(μ) μ dμ by the midpoint rule on 4096 intervals (F_d is smooth but steep near μ = 0).
    static const float average = [] {
        constexpr int n = 4096;
        double s = 0.0;
        for (int k = 0; k < n; ++k) {
            const double mu = (k + 0.5) / n;
            s += double(fresnelCoat(float(mu))) * mu;
        }
        return float(2.0 * s / n);
    }();
    return average;
}

}  // namespace

float coatAlbedo(float roughness, float cosTheta) {
    const float mu = std::clamp(cosTheta, 0.0f, 1.0f);
    if (roughness <= kSmoothRoughness) return fresnelCoat(mu);
    int i0, i1;
    float w;
    rowPosition(roughness, i0, i1, w);
    const CoatTable& t = rowsFor(i0, i1);
    const float x = mu * float(kCosColumns - 1);
    const int j0 = std::min(int(x), kCosColumns - 2);
    const float v = x - float(j0);
    auto row = [&](int i) {
        const auto& r = t.albedo[size_t(i)];
        return r[size_t(j0)] + v * (r[size_t(j0) + 1] - r[size_t(j0)]);
    };
    return row(i0) + w * (row(i1) - row(i0));
}

float coatAverageAlbedo(float roughness) {
    if (roughness <= kSmoothRoughness) return smoothAverage();
    int i0, i1;
    float w;
    rowPosition(roughness, i0, i1, w);
    const CoatTable& t = rowsFor(i0, i1);
    return t.average[size_t(i0)] + w * (t.average[size_t(i1)] - t.average[size_t(i0)]);
}

PlasticBsdf::PlasticBsdf(const Material& m)
    : roughness_(m.roughness),
      alpha_(ggxAlpha(m.roughness)),
      metallic_(std::clamp(m.metallic, 0.0f, 1.0f)),
      specular_(std::clamp(m.specular, 0.0f, 1.0f)),
      smooth_(m.roughness <= kSmoothRoughness),
      metalF0_(m.baseColor) {
    RTPM_DCHECK(m.type == MaterialType::Plastic);
    diffuseNorm_ = 1.0f / (1.0f - specular_ * coatAverageAlbedo(roughness_));
}

float PlasticBsdf::e(float cosTheta) const { return coatAlbedo(roughness_, cosTheta); }

Vec3 PlasticBsdf::coatFresnel(float cosOM) const {
    Vec3 f((specular_ * (1.0f - metallic_)) * fresnelCoat(cosOM));
    if (metallic_ > 0.0f) f += metallic_ * fresnelSchlick(metalF0_, cosOM);
    return f;
}

float PlasticBsdf::viewShare(float cosOut) const { return (1.0f - metallic_) * (1.0f - specular_ * e(cosOut)); }

float PlasticBsdf::lightShare(float cosIn) const { return (1.0f - specular_ * e(cosIn)) * diffuseNorm_; }

Vec3 PlasticBsdf::diffuseEval(Vec3 wo, Vec3 wi, Vec3 albedo) const {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return Vec3(0.0f);
    return albedo * (kInvPi * viewShare(wo.z) * lightShare(wi.z));
}

Vec3 PlasticBsdf::coatEval(Vec3 wo, Vec3 wi) const {
    if (smooth_ || wo.z <= 0.0f || wi.z <= 0.0f) return Vec3(0.0f);
    const Vec3 h = glm::normalize(wo + wi);
    const Ggx g{alpha_};
    return coatFresnel(glm::dot(wo, h)) * (g.d(h) * g.g2(wo, wi) / (4.0f * wo.z * wi.z));
}

float PlasticBsdf::coatChance(float cosIn) const { return (1.0f - metallic_) * specular_ * e(cosIn); }

// Lobe 0: the whole coat (coatFresnel); 1: the dielectric coat over its albedo; 2: the metal.
bool PlasticBsdf::sampleWith(Vec3 wo, Vec2 u, int lobe, BsdfSample& out) const {
    if (!(wo.z > 0.0f)) return false;
    auto fresnel = [&](float c) {
        if (lobe == 0) return coatFresnel(c);
        if (lobe == 1) return Vec3(fresnelCoat(c) / std::max(e(wo.z), 1e-6f));
        return fresnelSchlick(metalF0_, c);
    };
    if (smooth_) {
        out.wi = Vec3(-wo.x, -wo.y, wo.z);
        out.pdf = 0.0f;  // a delta lobe
        out.weight = lobe == 1 ? Vec3(1.0f) : fresnel(wo.z);
        out.transmitted = false;
        return true;
    }
    const Ggx g{alpha_};
    const Vec3 h = g.sampleVisibleNormal(wo, u);
    const float cosOH = glm::dot(wo, h);
    if (!(cosOH > 0.0f)) return false;
    const Vec3 wi = 2.0f * cosOH * h - wo;
    if (!(wi.z > 0.0f)) return false;
    out.wi = wi;
    out.pdf = g.visibleNormalPdf(wo, h) / (4.0f * cosOH);
    // f·cos θi / pdf = F G2 / G1, as for the rough conductor (microfacet.cpp).
    out.weight = fresnel(cosOH) * (g.g2(wo, wi) / g.g1(wo));
    out.transmitted = false;
    return out.pdf > 0.0f;
}

bool PlasticBsdf::sampleCoat(Vec3 wo, Vec2 u, BsdfSample& out) const { return sampleWith(wo, u, 0, out); }

bool PlasticBsdf::sampleDielectricCoat(Vec3 wo, Vec2 u, BsdfSample& out) const {
    return sampleWith(wo, u, 1, out);
}

bool PlasticBsdf::sampleMetal(Vec3 wo, Vec2 u, BsdfSample& out) const { return sampleWith(wo, u, 2, out); }

}  // namespace rtpm
