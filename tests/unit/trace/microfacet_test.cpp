// Tests of the GGX BSDFs against quadrature of their own formulas and against physics: visible
// normals integrate to one, energy never grows (white furnace), reciprocity, the samplers' density
// equals the evaluated pdf (χ² test), and the smooth limit keeps R + T = 1.
#include "common/trace/microfacet.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "common/core/halton.h"
#include "common/trace/optics.h"

namespace rtpm {
namespace {

float rnd(uint64_t stream, uint64_t i, uint64_t dim) { return hashToUnit(hashKeys(0x6d66, stream, i, dim)); }

Vec3 direction(float cosTheta, float phi) {
    const float s = std::sqrt(std::max(0.0f, 1.0f - cosTheta * cosTheta));
    return Vec3(s * std::cos(phi), s * std::sin(phi), cosTheta);
}

// ∫ g(w) dω over cos θ ∈ [zLo, zHi], φ ∈ [0, 2π), midpoint rule on an nz × nphi grid in (cos θ, φ)
// (dω = d cos θ dφ): exact for the solid angle, converging as the grid refines.
template <typename F>
double integrateSphere(F g, double zLo, double zHi, int nz, int nphi) {
    double sum = 0.0;
    const double dz = (zHi - zLo) / nz, dphi = 2.0 * M_PI / nphi;
    for (int i = 0; i < nz; ++i) {
        const double z = zLo + (i + 0.5) * dz;
        for (int j = 0; j < nphi; ++j) sum += g(direction(float(z), float((j + 0.5) * dphi)));
    }
    return sum * dz * dphi;
}

// In θ rather than cos θ: fine near the pole, where narrow lobes of small α sit.
template <typename F>
double integrateHemisphereTheta(F g, int ntheta, int nphi) {
    double sum = 0.0;
    const double dt = 0.5 * M_PI / ntheta, dphi = 2.0 * M_PI / nphi;
    for (int i = 0; i < ntheta; ++i) {
        const double t = (i + 0.5) * dt;
        for (int j = 0; j < nphi; ++j)
            sum += g(direction(float(std::cos(t)), float((j + 0.5) * dphi))) * std::sin(t);
    }
    return sum * dt * dphi;
}

// Upper tail probability of a χ² statistic with `dof` degrees of freedom (Wilson–Hilferty's
// normal approximation, accurate to a few percent in p for dof ≥ 10).
double chiSquareTail(double x, int dof) {
    const double k = dof;
    const double z = (std::cbrt(x / k) - (1.0 - 2.0 / (9.0 * k))) / std::sqrt(2.0 / (9.0 * k));
    return 0.5 * std::erfc(z / std::sqrt(2.0));
}

TEST(Microfacet, NormalsAndVisibleNormalsIntegrateToOne) {
    // ∫ D(m) cos θm dω = 1 (projected area) and ∫ D_wo(m) dω = 1 for every wo (Heitz 2014 eq. 38):
    // checks D, Λ and G1 together, independently of any sampler.
    for (float alpha : {0.05f, 0.2f, 0.5f, 1.0f}) {
        const Ggx g{alpha};
        EXPECT_NEAR(integrateHemisphereTheta([&](Vec3 m) { return g.d(m) * m.z; }, 4000, 64), 1.0, 2e-3)
            << alpha;
        for (float cosO : {1.0f, 0.7f, 0.3f, 0.05f, -0.5f}) {
            const Vec3 wo = direction(cosO, 0.4f);
            EXPECT_NEAR(integrateHemisphereTheta([&](Vec3 m) { return g.visibleNormalPdf(wo, m); }, 4000, 256),
                        1.0, 3e-3)
                << "alpha " << alpha << " cos " << cosO;
        }
    }
}

// A white (F0 = 1) GGX conductor loses energy only to the bounces between microfacets that a
// single-scattering model leaves out. Stated bounds: nothing is lost in the smooth limit; a few
// percent at roughness ≤ 0.3 away from grazing (Kulla and Conty 2017 report the same); the loss
// grows with roughness at every angle; at α = 1 and normal incidence the albedo is exactly
// 1 − ln 2 = 0.307 (D = 1/π, visible normals cosine-distributed, G2 = cos 2θm / cos² θm:
// ∫ over θm < π/4 gives 2 [c² − ln c] from 1/√2 to 1).
TEST(Microfacet, WhiteFurnaceConductorLosesOnlyMultipleScattering) {
    const std::vector<float> roughnesses = {0.1f, 0.3f, 0.5f, 0.7f, 1.0f};
    const std::vector<float> cosines = {1.0f, 0.8f, 0.5f, 0.2f, 0.05f};
    std::vector<double> previousLoss(cosines.size(), 0.0);
    for (float roughness : roughnesses) {
        const float alpha = ggxAlpha(roughness);
        for (size_t c = 0; c < cosines.size(); ++c) {
            const float cosO = cosines[c];
            const Vec3 wo = direction(cosO, 1.1f);
            const int n = 40000;
            double sum = 0.0, sum2 = 0.0;
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                const double w = roughConductorSample(wo, alpha, Vec3(1.0f), Vec2(rnd(1, i, 0), rnd(1, i, 1)), s)
                                     ? double(s.weight.x)
                                     : 0.0;
                EXPECT_LE(w, 1.0 + 1e-5);
                sum += w;
                sum2 += w * w;
            }
            const double mean = sum / n;
            const double sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
            if (roughness >= 0.3f && cosO >= 0.2f) {
                // The albedo by quadrature of f cos θi, independent of the sampler (a lobe of
                // roughness 0.1, or one at grazing view, is too narrow for the grid).
                const double quad = integrateHemisphereTheta(
                    [&](Vec3 wi) { return roughConductorEval(wo, wi, alpha, Vec3(1.0f)).x * wi.z; }, 3000, 512);
                EXPECT_LE(quad, 1.0 + 2e-3) << "roughness " << roughness << " cos " << cosO;
                EXPECT_NEAR(mean, quad, 4.0 * sd + 3e-3) << "roughness " << roughness << " cos " << cosO;
            }
            const double loss = 1.0 - mean;
            EXPECT_GE(loss, -1e-6);
            if (roughness <= 0.3f && cosO >= 0.5f) {
                EXPECT_LT(loss, 0.03) << roughness << " " << cosO;
            }
            if (cosO >= 0.2f) {  // at grazing view a narrow lobe is masked more than a wide one
                EXPECT_GE(loss, previousLoss[c] - 4.0 * sd) << roughness << " " << cosO;
            }
            previousLoss[c] = loss;
            if (roughness == 1.0f && cosO == 1.0f) {
                EXPECT_NEAR(mean, 1.0 - std::log(2.0), 4.0 * sd);
            }
        }
    }
    // The smooth limit loses nothing.
    BsdfSample s;
    ASSERT_TRUE(roughConductorSample(direction(0.6f, 0.0f), ggxAlpha(0.0101f), Vec3(1.0f), Vec2(0.3f, 0.7f), s));
    EXPECT_NEAR(s.weight.x, 1.0f, 1e-4f);
}

TEST(Microfacet, WhiteFurnaceDielectricReflectsPlusTransmitsAtMostOne) {
    for (float eta : {1.33f, 1.5f, 2.4f}) {
        for (float roughness : {0.3f, 0.6f, 1.0f}) {
            const float alpha = ggxAlpha(roughness);
            for (float cosO : {0.9f, 0.4f, 0.1f, -0.3f, -0.8f}) {
                const Vec3 wo = direction(cosO, 0.3f);
                const double quad = integrateSphere(
                    [&](Vec3 wi) {
                        return roughDielectricEval(wo, wi, alpha, eta, Transport::Importance) * std::abs(wi.z);
                    },
                    -1.0, 1.0, 2000, 256);
                EXPECT_LE(quad, 1.0 + 5e-3) << eta << " " << roughness << " " << cosO;
                const int n = 40000;
                double sum = 0.0, sum2 = 0.0;
                for (int i = 0; i < n; ++i) {
                    BsdfSample s;
                    const double w = roughDielectricSample(wo, alpha, eta, rnd(2, i, 0),
                                                           Vec2(rnd(2, i, 1), rnd(2, i, 2)), s)
                                         ? double(s.weight.x)
                                         : 0.0;
                    EXPECT_LE(w, 1.0 + 1e-5);
                    sum += w;
                    sum2 += w * w;
                }
                const double mean = sum / n;
                const double sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
                EXPECT_LE(mean, 1.0 + 1e-6);
                // The quadrature is coarse where a lobe is narrow: 1 % of slack.
                EXPECT_NEAR(mean, quad, 4.0 * sd + 1e-2) << eta << " " << roughness << " " << cosO;
            }
        }
    }
}

TEST(Microfacet, NearlySmoothDielectricIsLosslessWithFresnelSplit) {
    // Roughness just above kSmoothRoughness: R + T = 1 within Monte Carlo tolerance, and the
    // reflected share is the smooth interface's Fresnel reflectance.
    const float alpha = ggxAlpha(0.02f);
    for (float eta : {1.33f, 1.5f}) {
        for (float cosO : {0.95f, 0.5f, 0.15f, -0.9f, -0.6f}) {
            const Vec3 wo = direction(cosO, 2.0f);
            const int n = 20000;
            double total = 0.0, reflected = 0.0;
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                if (!roughDielectricSample(wo, alpha, eta, rnd(3, i, 0), Vec2(rnd(3, i, 1), rnd(3, i, 2)), s)) continue;
                total += s.weight.x;
                if (!s.transmitted) reflected += s.weight.x;
            }
            EXPECT_NEAR(total / n, 1.0, 2e-3) << eta << " " << cosO;
            const float f = fresnelDielectric(cosO, 1.0f, eta);
            // Binomial standard deviation of the reflected share, 5σ plus the lobe's own spread.
            const double sd = std::sqrt(double(f) * (1.0 - f) / n);
            EXPECT_NEAR(reflected / n, f, 5.0 * sd + 2e-3) << eta << " " << cosO;
        }
    }
}

TEST(Microfacet, SplitAtOneMicrofacetHasTheSamplersExpectedWeights) {
    // The eye pass's split (both lobes at one visible normal) and the photons' random choice
    // estimate the same reflected and transmitted energy.
    for (float cosO : {0.8f, 0.3f, -0.6f}) {
        const Vec3 wo = direction(cosO, 0.5f);
        const float alpha = ggxAlpha(0.5f), eta = 1.5f;
        const int n = 40000;
        double splitR = 0.0, splitT = 0.0, sampleR = 0.0, sampleT = 0.0;
        for (int i = 0; i < n; ++i) {
            BsdfSample r, t, s;
            const Vec2 u(rnd(30, i, 0), rnd(30, i, 1));
            const int lobes = roughDielectricSplit(wo, alpha, eta, u, r, t);
            if (lobes & 1) splitR += r.weight.x;
            if (lobes & 2) splitT += t.weight.x;
            if (roughDielectricSample(wo, alpha, eta, rnd(31, i, 2), Vec2(rnd(31, i, 0), rnd(31, i, 1)), s))
                (s.transmitted ? sampleT : sampleR) += s.weight.x;
        }
        EXPECT_NEAR(splitR / n, sampleR / n, 0.01) << cosO;
        EXPECT_NEAR(splitT / n, sampleT / n, 0.01) << cosO;
        if (cosO > 0.0f) EXPECT_GT(splitT / n, 0.3) << cosO;  // inside, beyond the critical angle, little passes
    }
}

TEST(Microfacet, ReflectionIsReciprocalAndTransmissionGeneralisedReciprocal) {
    int transmissions = 0;
    for (int i = 0; i < 2000; ++i) {
        const float alpha = ggxAlpha(0.05f + 0.95f * rnd(4, i, 0));
        const Vec3 a = direction(2.0f * rnd(4, i, 1) - 1.0f, 2.0f * kPi * rnd(4, i, 2));
        const Vec3 b = direction(2.0f * rnd(4, i, 3) - 1.0f, 2.0f * kPi * rnd(4, i, 4));
        const Vec3 f0(0.9f, 0.6f, 0.3f);
        const Vec3 fab = roughConductorEval(a, b, alpha, f0), fba = roughConductorEval(b, a, alpha, f0);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(fab[c], fba[c], 1e-4f * std::max(1.0f, fab[c])) << i;
        const float eta = 1.5f;
        const float dab = roughDielectricEval(a, b, alpha, eta, Transport::Radiance);
        const float dba = roughDielectricEval(b, a, alpha, eta, Transport::Radiance);
        if (a.z * b.z > 0.0f) {
            EXPECT_NEAR(dab, dba, 1e-4f * std::max(1.0f, dab)) << i;
        } else {
            // f(wo, wi) / η_o² = f(wi, wo) / η_i², η the index on each direction's side.
            const float etaA = a.z > 0.0f ? 1.0f : eta, etaB = b.z > 0.0f ? 1.0f : eta;
            EXPECT_NEAR(dab / (etaA * etaA), dba / (etaB * etaB), 2e-4f * std::max(1.0f, dab)) << i;
            if (dab > 1e-3f) ++transmissions;
        }
    }
    EXPECT_GT(transmissions, 100);  // the transmission branch was really exercised
}

// Samples `n` directions with `sample`, bins them on the sphere in (cos θ, φ) and compares with
// the counts `pdf` predicts (each bin's integral by a 40 × 40 midpoint rule: a
// rough dielectric's transmission at grazing view peaks near the horizon, where 12 × 12 was off by
// 5 %), plus one bin for
// failed samples (1 − ∫ pdf). Returns the χ² tail probability.
template <typename Sample, typename Pdf>
double chiSquareOfSampler(Sample sample, Pdf pdf, int n) {
    constexpr int kZ = 24, kPhi = 24, kSub = 40;
    std::vector<double> observed(kZ * kPhi + 1, 0.0), expected(kZ * kPhi + 1, 0.0);
    for (int i = 0; i < n; ++i) {
        Vec3 w;
        if (!sample(i, w)) {
            observed.back() += 1.0;
            continue;
        }
        const int iz = std::clamp(int((w.z + 1.0f) * 0.5f * kZ), 0, kZ - 1);
        double phi = std::atan2(double(w.y), double(w.x));
        if (phi < 0.0) phi += 2.0 * M_PI;
        const int ip = std::clamp(int(phi / (2.0 * M_PI) * kPhi), 0, kPhi - 1);
        observed[size_t(iz * kPhi + ip)] += 1.0;
    }
    double total = 0.0;
    for (int iz = 0; iz < kZ; ++iz)
        for (int ip = 0; ip < kPhi; ++ip) {
            double s = 0.0;
            const double dz = 2.0 / kZ / kSub, dp = 2.0 * M_PI / kPhi / kSub;
            for (int a = 0; a < kSub; ++a)
                for (int b = 0; b < kSub; ++b)
                    s += pdf(direction(float(-1.0 + iz * 2.0 / kZ + (a + 0.5) * dz),
                                       float(ip * 2.0 * M_PI / kPhi + (b + 0.5) * dp)));
            expected[size_t(iz * kPhi + ip)] = s * dz * dp * n;
            total += s * dz * dp;
        }
    expected.back() = std::max(0.0, 1.0 - total) * n;
    // Bins expecting fewer than 5 samples are pooled (the χ² approximation needs it).
    double chi2 = 0.0, poolObs = 0.0, poolExp = 0.0;
    int dof = -1;
    for (size_t i = 0; i < expected.size(); ++i) {
        if (expected[i] < 5.0) {
            poolObs += observed[i];
            poolExp += expected[i];
            continue;
        }
        chi2 += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
        ++dof;
    }
    if (poolExp > 0.0) {
        chi2 += (poolObs - poolExp) * (poolObs - poolExp) / std::max(poolExp, 1.0);
        ++dof;
    }
    return chiSquareTail(chi2, std::max(dof, 1));
}

TEST(Microfacet, SampledDirectionsFollowTheEvaluatedPdf) {
    // α = 0.01 overall, Šidák-corrected over the configurations (Mitsuba 3's χ² test).
    struct Case {
        bool dielectric;
        float roughness, cosO;
    };
    const std::vector<Case> cases = {{false, 0.5f, 0.9f}, {false, 0.7f, 0.3f}, {false, 1.0f, 0.6f},
                                     {true, 0.6f, 0.8f},  {true, 0.8f, -0.5f}, {true, 1.0f, 0.2f}, {false, 1.0f, 0.2f}, {true, 1.0f, 0.5f}, {true, 0.7f, 0.2f}, {true, 1.0f, -0.2f}};
    const double level = 1.0 - std::pow(1.0 - 0.01, 1.0 / double(cases.size()));
    for (size_t c = 0; c < cases.size(); ++c) {
        const Case k = cases[c];
        const float alpha = ggxAlpha(k.roughness), eta = 1.5f;
        const Vec3 wo = direction(k.cosO, 0.7f);
        auto sample = [&](int i, Vec3& w) {
            BsdfSample s;
            const bool ok = k.dielectric
                                ? roughDielectricSample(wo, alpha, eta, rnd(5 + c, i, 0), Vec2(rnd(5 + c, i, 1), rnd(5 + c, i, 2)), s)
                                : roughConductorSample(wo, alpha, Vec3(1.0f), Vec2(rnd(5 + c, i, 1), rnd(5 + c, i, 2)), s);
            if (!ok) return false;
            // The sampler's own pdf must be the evaluated one.
            const float pdf = k.dielectric ? roughDielectricPdf(wo, s.wi, alpha, eta) : roughConductorPdf(wo, s.wi, alpha);
            EXPECT_NEAR(s.pdf, pdf, 1e-3f * std::max(1.0f, pdf)) << c;
            w = s.wi;
            return true;
        };
        auto pdf = [&](Vec3 wi) {
            return double(k.dielectric ? roughDielectricPdf(wo, wi, alpha, eta) : roughConductorPdf(wo, wi, alpha));
        };
        const double p = chiSquareOfSampler(sample, pdf, 200000);
        EXPECT_GT(p, level) << "case " << c;
    }
}

TEST(Microfacet, ChiSquareDetectsAWrongPdf) {
    // The χ² test itself can fail: a sampler of α = 0.5 judged against the pdf of α = 0.6.
    const Vec3 wo = direction(0.8f, 0.2f);
    auto sample = [&](int i, Vec3& w) {
        BsdfSample s;
        if (!roughConductorSample(wo, ggxAlpha(0.5f), Vec3(1.0f), Vec2(rnd(20, i, 0), rnd(20, i, 1)), s)) return false;
        w = s.wi;
        return true;
    };
    auto pdf = [&](Vec3 wi) { return double(roughConductorPdf(wo, wi, ggxAlpha(0.6f))); };
    EXPECT_LT(chiSquareOfSampler(sample, pdf, 200000), 1e-6);
}

}  // namespace
}  // namespace rtpm
