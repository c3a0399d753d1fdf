// The curved-mirror caustic reference (tests/support/ring_mirror.h) checked against an
// independent numerical integration of the mirror mapping.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "tests/support/ring_mirror.h"

namespace rtpm {
namespace {

using testscenes::RingMirror;

// The closed form itself: a facet-by-facet sum of mirrored point lights. Check it against a
// direct numerical integration of the mirror mapping (rays from the light through a fine grid of
// points on each facet, reflected and binned on the floor): the flux that lands in a 0.1 m
// square must equal ∫ E dA over that square from the closed form, within the binning's
// quadrature error (0.5 %).
TEST(RingMirror, ClosedFormMatchesTheIntegratedMirrorMapping) {
    RingMirror rm;
    rm.facets = 90;  // coarse, so the integration below is cheap
    const double x0 = -0.2, z0 = 0.1, side = 0.1;
    // ∫ E dA by a 200 × 200 midpoint rule over the square.
    double closed = 0.0;
    const int n = 200;
    for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b)
            closed += rm.irradiance(x0 + (a + 0.5) * side / n, z0 + (b + 0.5) * side / n);
    closed *= (side / n) * (side / n);
    // Flux through the mirror mapping: the solid angle of each facet, sampled by a 1200 × 1200
    // grid of points on it; each point p carries I · dΩ = I · cos_p dA / |p − L|².
    double mapped = 0.0;
    const Vec3 L = rm.light;
    const int m = 1200;
    for (int f = 0; f < rm.facets; ++f) {
        const Vec3 v0 = rm.edge(f), v1 = rm.edge(f + 1);
        const glm::dvec3 e = glm::dvec3(v1 - v0);
        glm::dvec3 nrm = glm::normalize(glm::dvec3(-e.z, 0.0, e.x));
        if (glm::dot(nrm, -glm::dvec3(v0)) < 0.0) nrm = -nrm;
        const double dA = glm::length(e) * rm.height / double(m) / double(m);
        for (int a = 0; a < m; ++a)
            for (int b = 0; b < m; ++b) {
                const glm::dvec3 p = glm::dvec3(v0) + e * ((a + 0.5) / m) + glm::dvec3(0.0, rm.height * (b + 0.5) / m, 0.0);
                const glm::dvec3 toP = p - glm::dvec3(L);
                const double dist2 = glm::dot(toP, toP);
                const glm::dvec3 dir = toP / std::sqrt(dist2);
                const double cosP = -glm::dot(dir, nrm);
                if (cosP <= 0.0) continue;
                const glm::dvec3 r = dir - 2.0 * glm::dot(dir, nrm) * nrm;
                if (!(r.y < 0.0)) continue;
                const glm::dvec3 hit = p + r * (-p.y / r.y);
                if (hit.x < x0 || hit.x >= x0 + side || hit.z < z0 || hit.z >= z0 + side) continue;
                mapped += rm.reflectance * rm.intensity * cosP * dA / dist2;
            }
    }
    ASSERT_GT(closed, 0.0) << "pick a square the caustic reaches";
    EXPECT_NEAR(mapped / closed, 1.0, 0.005) << "closed " << closed << " W, mapped " << mapped << " W";
}

}  // namespace
}  // namespace rtpm
