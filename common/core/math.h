// Vector types and the scalar helpers every stage shares: π, finiteness.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/glm.hpp>

namespace rtpm {

using Vec2 = glm::vec2;
using Vec3 = glm::vec3;
using Mat4 = glm::mat4;

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kInvPi = 1.0f / kPi;

/// True when every component is finite (no NaN, no ±Inf).
inline bool finite(Vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// Largest of the three components.
inline float maxComponent(Vec3 v) { return std::max({v.x, v.y, v.z}); }

/// Luminance of linear Rec. 709 RGB, in double.
inline double luminance(Vec3 c) { return 0.2126 * double(c.x) + 0.7152 * double(c.y) + 0.0722 * double(c.z); }
inline double luminance(const glm::dvec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

}  // namespace rtpm
