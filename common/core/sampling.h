// Direction sampling shared by the shading stages: an orthonormal basis and cosine-weighted
// hemisphere directions.
#pragma once

#include <cmath>

#include "common/core/math.h"

namespace rtpm {

/// Orthonormal t, b around unit n (Duff et al. 2017, branchless, continuous except at n.z = −1).
inline void orthonormalBasis(Vec3 n, Vec3& t, Vec3& b) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float bb = n.x * n.y * a;
    t = Vec3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    b = Vec3(bb, sign + n.y * n.y * a, -n.y);
}

/// Cosine-weighted unit direction about unit n from (u0, u1) ∈ [0, 1)² (Malley: the uniform disc
/// lifted to the hemisphere); density cosθ/π per steradian. Pure.
inline Vec3 cosineHemisphere(Vec3 n, float u0, float u1) {
    const float r = std::sqrt(u0);
    const float phi = 2.0f * kPi * u1;
    const float z = std::sqrt(std::max(0.0f, 1.0f - u0));
    Vec3 t, b;
    orthonormalBasis(n, t, b);
    return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + z * n);
}

}  // namespace rtpm
