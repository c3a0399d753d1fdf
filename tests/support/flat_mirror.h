// The flat-mirror caustic scene and its closed-form reference: a sharp-edged caustic.
//
// A rectangular mirror (reflectance R) stands upright in the plane x = 0, facing +x, spanning
// bottom ≤ y ≤ top and |z| ≤ a, above a diffuse floor y = 0 (albedo ρ_f). A point light of
// intensity I at L = (l_x, l_y, l_z), l_x > 0 and l_y > top, lights it; the camera looks straight
// down at the floor in front of the mirror.
//
// Reference (no photon estimator): a plane mirror reflects the light of the light's mirror image
// L' = (−l_x, l_y, l_z), restricted to the rays that cross the mirror rectangle. At a floor point
// x the caustic irradiance is therefore exactly
//     E(x) = R · I · cosθ / d²    if the segment L' → x crosses the rectangle, else 0,
//     d = |x − L'|, cosθ = l_y / d (the floor faces up),
// for single reflections (L S D paths; render with `--photon-depth 2 --diffuse-bounces 0`). The
// lit region is the rectangle's shadow cast from L' onto the floor, a trapezoid whose four edges
// are all sharp (the mirror's bottom edge is above the floor). Every reflected ray goes down
// (l_y > top) and meets nothing but the floor, so the caustic's flux on the floor is R · I · Ω,
// Ω the solid angle of the rectangle seen from L (solidAngle(): an independent check of the
// reference image's total). The caustic radiance seen from above is L_c(x) = ρ_f/π · E(x).
#pragma once

#include <cmath>
#include <vector>

#include "common/scene/scene.h"
#include "tests/support/progressive_run.h"
#include "tests/support/test_scenes.h"

namespace rtpm::testscenes {

struct FlatMirror {
    double reflectance = 0.9;  ///< R of the mirror
    double floorAlbedo = 0.8;  ///< ρ_f
    double intensity = 3.0;    ///< I (W/sr)
    // Dimensions are binary fractions, so the float scene and the double reference agree exactly.
    double halfWidth = 0.3125;  ///< a (m)
    double bottom = 0.25;       ///< lower edge above the floor (m)
    double top = 0.625;         ///< upper edge (m)
    Vec3 light{0.625f, 1.25f, 0.0625f};
    /// The lit trapezoid spans 0.156 ≤ x ≤ 0.625 and −0.69 ≤ z ≤ 0.56; the camera's view (4:3)
    /// spans −0.225 ≤ x ≤ 0.975 (top of the image: +x) and |z| ≤ 0.8 (right: +z).
    Vec3 cameraEye{0.375f, 3.0f, 0.0f};
    float yfov = 0.3947911197f;  ///< 2·atan(0.2): ±0.6 m of floor vertically at 3 m

    /// The scene (materials: 0 floor, 1 mirror).
    Scene scene() const {
        Scene s;
        s.name = "FLAT_MIRROR";
        const uint32_t floorMat = addMaterial(s, MaterialType::Diffuse, Vec3(float(floorAlbedo)));
        const uint32_t mirrorMat = addMaterial(s, MaterialType::Mirror, Vec3(float(reflectance)));
        addMesh(s, quad(Vec3(0.0f), Vec3(0.0f, 0.0f, 3.0f), Vec3(3.0f, 0.0f, 0.0f), floorMat));
        const float halfHeight = float(0.5 * (top - bottom));
        addMesh(s, quad(Vec3(0.0f, float(0.5 * (top + bottom)), 0.0f), Vec3(0.0f, halfHeight, 0.0f),
                        Vec3(0.0f, 0.0f, float(halfWidth)), mirrorMat));
        addPointLight(s, light, Vec3(float(intensity)));
        const Vec3 target(cameraEye.x, 0.0f, cameraEye.z);
        s.camera = Camera::lookAt(cameraEye, target, Vec3(1.0f, 0.0f, 0.0f), yfov);
        return s;
    }

    /// Exact single-reflection caustic irradiance (W/m²) at floor point (x, 0, z).
    double irradiance(double x, double z) const {
        const double lx = light.x, ly = light.y, lz = light.z;
        if (!(x > 0.0)) return 0.0;  // behind the mirror or in its plane
        // Where the segment from L' = (−l_x, l_y, l_z) to (x, 0, z) crosses x = 0.
        const double t = lx / (lx + x);
        const double py = ly * (1.0 - t), pz = lz + t * (z - lz);
        if (py < bottom || py > top || std::abs(pz) > halfWidth) return 0.0;
        const double dx = x + lx, dz = z - lz;
        const double d2 = dx * dx + ly * ly + dz * dz;
        return reflectance * intensity * (ly / std::sqrt(d2)) / d2;
    }

    /// Solid angle (sr) of the mirror rectangle seen from the light, in closed form: for a
    /// rectangle u₁ ≤ u ≤ u₂, v₁ ≤ v ≤ v₂ in a plane at distance D, coordinates from the foot of
    /// the perpendicular, Ω = F(u₂,v₂) − F(u₁,v₂) − F(u₂,v₁) + F(u₁,v₁) with
    /// F(u, v) = atan(u v / (D √(u² + v² + D²))).
    double solidAngle() const {
        const double dist = light.x;
        auto f = [&](double u, double v) { return std::atan(u * v / (dist * std::sqrt(u * u + v * v + dist * dist))); };
        const double u1 = bottom - light.y, u2 = top - light.y;
        const double v1 = -halfWidth - light.z, v2 = halfWidth - light.z;
        return f(u2, v2) - f(u1, v2) - f(u2, v1) + f(u1, v1);
    }

    /// Whether a camera ray from `o` along `d` reaches the floor without meeting the mirror.
    bool floorVisible(const glm::dvec3& o, const glm::dvec3& d) const {
        if (d.x == 0.0) return true;
        const double t = -o.x / d.x;
        if (!(t > 0.0)) return true;
        const double y = o.y + t * d.y, z = o.z + t * d.z;
        return y < bottom || y > top || std::abs(z) > halfWidth;
    }

    /// Reference caustic radiance per pixel, `samples` × `samples` floor points per pixel (the
    /// edges' pixels get their covered fraction); pixels that see any of the mirror are not
    /// compared.
    CausticReference reference(int width, int height, int samples = 8) const {
        return floorReference(
            *scene().camera, width, height, samples, floorAlbedo,
            [this](double x, double z) { return irradiance(x, z); },
            [this](const glm::dvec3& o, const glm::dvec3& d) { return floorVisible(o, d); });
    }
};

}  // namespace rtpm::testscenes
