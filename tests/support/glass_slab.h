// The glass-slab caustic scene and its closed-form reference: a refracted caustic.
//
// A point light of intensity I sits at height h above the top face of a horizontal slab of index
// n and thickness t (no absorption), whose bottom face is g above a diffuse floor. A photon leaving
// at angle θ from the downward axis refracts to θ' (sin θ = n sin θ'), crosses the slab and leaves
// at θ again. If it crosses the slab 2k+1 times (k internal reflection pairs) it lands at
//     ρ_k(θ) = (h + g)·tan θ + (2k+1)·t·tan θ'
// carrying the fraction T_k(θ) = (1 − F(θ))²·F(θ)^{2k} (F: unpolarised Fresnel reflectance, the
// same inside and outside by reciprocity). Flux I·T_k·sinθ dθ dφ lands on the floor area ρ dρ dφ, so
//     E(ρ) = Σ_k I·T_k(θ_k)·sin θ_k / (ρ · dρ_k/dθ)    with ρ_k(θ_k) = ρ,
// and at the axis (θ → 0, ρ_k ≈ c_k·θ) the virtual-source form
//     E(0) = I·(1 − R₀)²·Σ_k R₀^{2k} / c_k²,   c_k = h + g + (2k+1)·t/n,   R₀ = ((n−1)/(n+1))².
// The k ≥ 1 terms add R₀² ≈ 0.16 % for n = 1.5; the sum is taken to k = 5 (remainder < 1e-13).
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "common/scene/scene.h"
#include "tests/support/progressive_run.h"
#include "tests/support/test_scenes.h"

namespace rtpm::testscenes {

inline double fresnelUnpolarised(double cosI, double n) {
    const double sinT2 = (1.0 - cosI * cosI) / (n * n);
    const double cosT = std::sqrt(std::max(0.0, 1.0 - sinT2));
    const double rs = (cosI - n * cosT) / (cosI + n * cosT);
    const double rp = (n * cosI - cosT) / (n * cosI + cosT);
    return 0.5 * (rs * rs + rp * rp);
}

struct Slab {
    double h, g, t, n, intensity;
};

/// Where a photon leaving the light at θ from the downward axis lands after 2k+1 crossings.
inline double slabLanding(const Slab& s, int k, double theta) {
    const double thetaIn = std::asin(std::sin(theta) / s.n);
    return (s.h + s.g) * std::tan(theta) + (2.0 * k + 1.0) * s.t * std::tan(thetaIn);
}

/// E(ρ) (W/m²) on the floor at distance ρ from the point under the light.
inline double slabIrradiance(const Slab& s, double rho) {
    constexpr double pi = std::numbers::pi;
    double e = 0.0;
    for (int k = 0; k <= 5; ++k) {
        const double passes = 2.0 * k + 1.0;
        if (rho <= 0.0) {
            const double r0 = std::pow((s.n - 1.0) / (s.n + 1.0), 2.0);
            const double c = s.h + s.g + passes * s.t / s.n;
            e += s.intensity * (1.0 - r0) * (1.0 - r0) * std::pow(r0, 2.0 * k) / (c * c);
            continue;
        }
        double lo = 0.0, hi = pi / 2 - 1e-9;
        for (int it = 0; it < 64; ++it) {  // the bracket is below one ulp of θ after 55
            const double mid = 0.5 * (lo + hi);
            (slabLanding(s, k, mid) < rho ? lo : hi) = mid;
        }
        const double theta = 0.5 * (lo + hi);
        const double thetaIn = std::asin(std::sin(theta) / s.n);
        const double dRho = (s.h + s.g) / std::pow(std::cos(theta), 2.0) +
                            passes * s.t * std::cos(theta) / (s.n * std::pow(std::cos(thetaIn), 3.0));
        const double f = fresnelUnpolarised(std::cos(theta), s.n);
        const double transmitted = (1.0 - f) * (1.0 - f) * std::pow(f, 2.0 * k);
        e += s.intensity * transmitted * std::sin(theta) / (rho * dRho);
    }
    return e;
}

/// The slab above a floor, seen from below the slab: the camera hangs between the slab's bottom
/// face and the floor, looking straight down, so its rays meet only the floor (no glass on the
/// eye path) and the reference is ρ_f/π · E(ρ) per pixel.
struct GlassSlab {
    Slab geometry{0.5, 0.3, 0.2, 1.5, 3.0};
    double floorAlbedo = 0.8;
    /// Half-width of the slab (m). Its side faces reflect (total internal reflection) the light
    /// that reaches them back under the slab: at 3 m that light lands beyond |x| = 1.3 m, out
    /// of view (a 1 m slab put 10 % more light into the view than the infinite slab's E).
    double slabHalf = 3.0;
    /// Half-width of the floor (m): the view and a margin; the photons landing farther away
    /// would only cost storage.
    double floorHalf = 1.5;
    /// The view (4:3) spans |x| ≤ 0.5, |z| ≤ 0.375 of the floor, where E falls to 0.62 of E(0).
    Vec3 cameraEye{0.0f, 0.25f, 0.0f};
    float yfov = 1.9655874464f;  ///< 2·atan(1.5): ±0.375 m of floor vertically at 0.25 m

    Vec3 lightPosition() const { return Vec3(0.0f, float(geometry.g + geometry.t + geometry.h), 0.0f); }

    /// The scene (materials: 0 floor, 1 glass).
    Scene scene() const {
        Scene s;
        s.name = "GLASS_SLAB";
        const float w = float(slabHalf), f = float(floorHalf);
        const uint32_t floorMat = addMaterial(s, MaterialType::Diffuse, Vec3(float(floorAlbedo)));
        const uint32_t glass = addMaterial(s, MaterialType::Dielectric, Vec3(1.0f), float(geometry.n));
        addMesh(s, quad(Vec3(0.0f), Vec3(0.0f, 0.0f, f), Vec3(f, 0.0f, 0.0f), floorMat));
        addMesh(s, box(Vec3(-w, float(geometry.g), -w), Vec3(w, float(geometry.g + geometry.t), w), glass));
        addPointLight(s, lightPosition(), Vec3(float(geometry.intensity)));
        s.camera = Camera::lookAt(cameraEye, Vec3(cameraEye.x, 0.0f, cameraEye.z), Vec3(0.0f, 0.0f, -1.0f), yfov);
        return s;
    }

    double irradiance(double x, double z) const { return slabIrradiance(geometry, std::hypot(x, z)); }

    /// Reference caustic radiance per pixel (every pixel sees the floor). E is smooth at the
    /// pixel scale (its relative curvature over a 6 mm pixel is below 1e-4), so the default
    /// takes each pixel's centre; `samples` > 1 averages a grid inside the pixel as the
    /// sharp-edged scenes do.
    CausticReference reference(int width, int height, int samples = 1) const {
        return floorReference(
            *scene().camera, width, height, samples, floorAlbedo,
            [this](double x, double z) { return irradiance(x, z); },
            [](const glm::dvec3&, const glm::dvec3&) { return true; });
    }

    /// The caustic flux (W) onto the floor rectangle |x| ≤ xHalf, |z| ≤ zHalf, integrated over
    /// the light's directions instead of the floor: a midpoint rule in (θ, φ) over `steps` ×
    /// `steps` cells (θ up to the rectangle's corner), each cell adding I · T_k(θ) sinθ dθ dφ
    /// for every k whose landing point ρ_k(θ)(cos φ, sin φ) lies in the rectangle. It uses the
    /// landing map only, not its Jacobian dρ/dθ, so it checks slabIrradiance independently.
    double fluxOnto(double xHalf, double zHalf, int steps = 4000) const {
        constexpr double pi = std::numbers::pi;
        const Slab& s = geometry;
        const double corner = std::hypot(xHalf, zHalf);
        double thetaMax = 0.0, hi = pi / 2 - 1e-9;  // direct landing ρ_0(θ) = corner
        for (int it = 0; it < 200; ++it) {
            const double mid = 0.5 * (thetaMax + hi);
            (slabLanding(s, 0, mid) < corner ? thetaMax : hi) = mid;
        }
        thetaMax = hi;
        const double dTheta = thetaMax / steps, dPhi = 2.0 * pi / steps;
        std::vector<double> cosPhi(static_cast<size_t>(steps)), sinPhi(static_cast<size_t>(steps));
        for (int b = 0; b < steps; ++b) {
            cosPhi[size_t(b)] = std::cos((b + 0.5) * dPhi);
            sinPhi[size_t(b)] = std::sin((b + 0.5) * dPhi);
        }
        double flux = 0.0;
        for (int a = 0; a < steps; ++a) {
            const double theta = (a + 0.5) * dTheta;
            const double f = fresnelUnpolarised(std::cos(theta), s.n);
            for (int k = 0; k <= 2; ++k) {
                const double rho = slabLanding(s, k, theta);
                const double weight = s.intensity * (1.0 - f) * (1.0 - f) * std::pow(f, 2.0 * k) *
                                      std::sin(theta) * dTheta * dPhi;
                for (size_t b = 0; b < cosPhi.size(); ++b)
                    if (std::abs(rho * cosPhi[b]) <= xHalf && std::abs(rho * sinPhi[b]) <= zHalf) flux += weight;
            }
        }
        return flux;
    }
};

}  // namespace rtpm::testscenes
