// The world light: radiance arriving from infinitely far away, uniform or from an equirectangular
// map, and the importance sampling of it that the eye pass and the photon tracer share.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/core/math.h"

namespace rtpm {

struct Texture;

/// Largest equirectangular map, in texels: 4096 × 2048 (100 MB of float RGB, sent to every client).
constexpr uint64_t kMaxEnvironmentTexels = uint64_t(4096) * 2048;

/// A direction drawn from an Environment: unit `direction` toward the sky (light arrives along
/// −direction), the radiance from there and the solid-angle density it was drawn with.
struct EnvironmentSample {
    Vec3 direction{0.0f, 1.0f, 0.0f};
    Vec3 radiance{0.0f};  ///< W/(m²·sr)
    float pdf = 0.0f;     ///< per steradian; 0 when nothing was drawn (an empty environment)
};

/// Radiance L(ω) from the direction ω at infinity, in the scene's world frame (glTF: +Y up).
///
/// Map mapping (Blender's equirectangular world texture with default vector, Y up as in glTF):
/// u = atan2(ω.z, ω.x)/(2π) + 1/2 across the width (the image centre looks along +X), v = θ/π
/// down the height with θ the angle from +Y (row 0 is the zenith). Each texel is constant over its
/// patch of sphere (no filtering), so that radiance() and pdf() describe the same function.
///
/// Sampling (map): a texel is chosen with probability ∝ Σ_rgb L_texel · Ω_texel, Ω_texel its exact
/// solid angle (2π/W)(cos θ_top − cos θ_bottom) — the sin θ weighting integrated over the row —
/// then a point uniform in φ and cos θ within it, so the density per steradian is constant on a
/// texel (P_texel / Ω_texel) and L/pdf has the same Σ_rgb for every sample. The two numbers steer
/// the row (u.x) and the column (u.y) continuously: stratification carries over.
/// Uniform environments are sampled uniformly over the sphere (pdf 1/4π).
/// Immutable once built; thread-safe to read.
class Environment {
public:
    /// No world light: radiance 0 everywhere, empty() true.
    Environment() = default;
    /// Constant radiance from every direction. Precondition: finite, ≥ 0.
    static Environment uniform(Vec3 radiance);
    /// Equirectangular map of radiance (linear RGB, W/(m²·sr)); builds the sampling tables.
    /// Precondition (checked by validateEnvironmentMap): width = 2·height, texels finite ≥ 0.
    /// Cost O(texels), memory 2 doubles per texel.
    static Environment fromMap(const Texture& map);

    /// True when no direction carries light (no environment, black colour or an all-black map).
    bool empty() const { return !(integral_.x > 0.0f || integral_.y > 0.0f || integral_.z > 0.0f); }
    bool hasMap() const { return width_ > 0; }
    Vec3 uniformRadiance() const { return uniform_; }
    int width() const { return width_; }
    int height() const { return height_; }
    /// The map's texels, row-major from the top, RGB (empty without a map).
    const std::vector<float>& texels() const { return rgb_; }

    /// L(ω) for unit `direction`. Pure, O(1).
    Vec3 radiance(Vec3 direction) const;
    /// Draws a direction from (u.x, u.y) ∈ [0, 1)². O(log W + log H).
    EnvironmentSample sample(Vec2 u) const;
    /// The density sample() draws unit `direction` with, per steradian. O(1).
    float pdf(Vec3 direction) const;
    /// ∫ L dω over the sphere per channel (W/m²): the irradiance a disc facing every way at once
    /// would collect, and with πR² the flux crossing a disc of radius R (photon emission).
    Vec3 integral() const { return integral_; }

    /// Texel coordinates (u, v) ∈ [0, 1]² of unit `direction`, and back (the patch centre's
    /// direction for u, v at texel centres). Pure.
    static Vec2 uvOf(Vec3 direction);
    static Vec3 directionOf(Vec2 uv);

private:
    size_t texelOf(Vec3 direction) const;
    Vec3 uniform_{0.0f};
    int width_ = 0, height_ = 0;
    std::vector<float> rgb_;
    std::vector<double> rowCdf_;  ///< height_ entries, last 1
    std::vector<double> colCdf_;  ///< per row width_ entries, last of each non-empty row 1
    double weightSum_ = 0.0;      ///< Σ Σ_rgb L·Ω over texels
    Vec3 integral_{0.0f};
};

/// Throws SceneError{file, "environment", …} unless `map` can be an Environment: width = 2·height
/// (equirectangular), at most kMaxEnvironmentTexels, every value finite and ≥ 0 (the first bad
/// texel is named by column and row).
void validateEnvironmentMap(const Texture& map, const std::string& file);

}  // namespace rtpm
