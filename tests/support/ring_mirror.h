// The ring-mirror caustic scene and its closed-form reference: the issue-9 curved-mirror case.
//
// A ring of N flat mirror facets (a tessellated cylinder, radius a, height h, standing on the
// floor y = 0), a point light inside it above the rim, a diffuse floor (albedo ρ_f) and a camera
// straight above the centre looking down. The caustic on the floor inside the ring is the
// nephroid-like envelope of the facets' reflections, with curved fold lines and cusps.
//
// Reference (no photon estimator): a flat facet f is a plane mirror, so the light it reflects is
// that of the light's mirror image L'_f, restricted to the rays that cross the facet. At a floor
// point x inside the ring the caustic irradiance is exactly
//     E(x) = Σ_f  R · I · cosθ_f / d_f²   over facets f whose quad the segment L'_f → x crosses,
//     d_f = |x − L'_f|,  cosθ_f = L'_f.y / d_f (the floor faces up),
// for single reflections (L S D paths). Render with photon paths of at most 2 segments and no
// diffuse bounce (`--photon-depth 2 --diffuse-bounces 0`) so rtpm computes the same light
// transport: a second wall bounce needs a third segment. Every segment from a point inside the
// cylinder to its wall stays inside it (radius along a segment is convex), so nothing occludes
// these paths. The caustic radiance seen from above is L_c(x) = ρ_f/π · E(x).
#pragma once

#include <cmath>
#include <numbers>
#include <vector>

#include "common/scene/scene.h"
#include "tests/support/test_scenes.h"

namespace rtpm::testscenes {

struct RingMirror {
    int facets = 720;            ///< N
    double radius = 1.0;         ///< a (m)
    double height = 0.35;        ///< h (m)
    double reflectance = 0.9;    ///< R of the mirror
    double floorAlbedo = 0.8;    ///< ρ_f
    double intensity = 3.0;      ///< I (W/sr)
    Vec3 light{0.55f, 0.9f, 0.0f};
    Vec3 cameraEye{0.0f, 4.0f, 0.0f};
    float yfov = 0.537f;         ///< covers |z| ≤ 1.1 m of the floor at 4 m
    /// true: the facets carry the cylinder's radial vertex normals, so the mirror reflects as a
    /// smooth cylinder (rtpm reflects about the interpolated normal) and the reference is
    /// smoothIrradiance; false: flat facets and the facet-by-facet irradiance(). Flat facets make
    /// the caustic a sum of facet-sized patches whose edges fall at pixel scale (a moiré no
    /// estimator with a gather radius above a pixel resolves), so accuracy figures use smooth.
    bool smooth = true;
    /// Pixels compared: floor points within this fraction of the radius (wall not in the way).
    double maskFraction = 0.97;

    /// The scene (materials: 0 floor, 1 mirror; camera straight down, +z at the image bottom).
    Scene scene() const {
        Scene s;
        s.name = "RING_MIRROR";
        const uint32_t floorMat = addMaterial(s, MaterialType::Diffuse, Vec3(float(floorAlbedo)));
        const uint32_t mirrorMat = addMaterial(s, MaterialType::Mirror, Vec3(float(reflectance)));
        addMesh(s, quad(Vec3(0.0f), Vec3(0.0f, 0.0f, 3.0f), Vec3(3.0f, 0.0f, 0.0f), floorMat));
        Mesh ring;
        ring.name = "ring";
        ring.material = mirrorMat;
        for (int i = 0; i <= facets; ++i) {
            const double phi = 2.0 * std::numbers::pi * double(i % facets) / double(facets);
            const float x = float(radius * std::cos(phi)), z = float(radius * std::sin(phi));
            ring.positions.push_back(Vec3(x, 0.0f, z));
            ring.positions.push_back(Vec3(x, float(height), z));
            if (smooth) {
                const Vec3 inward(float(-std::cos(phi)), 0.0f, float(-std::sin(phi)));
                ring.normals.push_back(inward);
                ring.normals.push_back(inward);
            }
        }
        for (uint32_t i = 0; i < uint32_t(facets); ++i) {
            const uint32_t b0 = 2 * i, t0 = b0 + 1, b1 = b0 + 2, t1 = b0 + 3;
            ring.indices.insert(ring.indices.end(), {b0, t0, b1, b1, t0, t1});
        }
        addMesh(s, std::move(ring));
        addPointLight(s, light, Vec3(float(intensity)));
        s.camera = Camera::lookAt(cameraEye, Vec3(0.0f), Vec3(0.0f, 0.0f, -1.0f), yfov);
        return s;
    }

    /// Bottom vertex of facet edge i (as scene() places it, in float).
    Vec3 edge(int i) const {
        const double phi = 2.0 * std::numbers::pi * double(i % facets) / double(facets);
        return Vec3(float(radius * std::cos(phi)), 0.0f, float(radius * std::sin(phi)));
    }

    /// Exact single-reflection caustic irradiance (W/m²) at floor point (x, 0, z) inside the
    /// ring. O(N).
    double irradiance(double x, double z) const {
        double e = 0.0;
        const double lx = light.x, ly = light.y, lz = light.z;
        for (int f = 0; f < facets; ++f) {
            const Vec3 v0 = edge(f), v1 = edge(f + 1);
            const double ex = double(v1.x) - v0.x, ez = double(v1.z) - v0.z;
            const double len = std::hypot(ex, ez);
            double nx = -ez / len, nz = ex / len;  // horizontal normal of the facet plane
            const double toCentre = -(nx * v0.x + nz * v0.z);
            if (toCentre < 0.0) nx = -nx, nz = -nz;  // point it inward
            const double sl = (lx - v0.x) * nx + (lz - v0.z) * nz;  // light's side distance
            const double sx = (x - v0.x) * nx + (z - v0.z) * nz;
            if (!(sl > 0.0) || !(sx > 0.0)) continue;
            const double ix = lx - 2.0 * sl * nx, iz = lz - 2.0 * sl * nz, iy = ly;  // image L'
            // Where the segment L' → x crosses the facet plane: side distance −sl at L', sx at x.
            const double t = sl / (sl + sx);
            const double px = ix + t * (x - ix), py = iy + t * (0.0 - iy), pz = iz + t * (z - iz);
            if (py < 0.0 || py > height) continue;
            const double u = ((px - v0.x) * ex + (pz - v0.z) * ez) / (len * len);
            if (u < 0.0 || u >= 1.0) continue;
            const double dx = x - ix, dy = iy, dz = z - iz;
            const double d2 = dx * dx + dy * dy + dz * dz;
            e += reflectance * intensity * (dy / std::sqrt(d2)) / d2;
        }
        return e;
    }

    /// Exact single-reflection caustic irradiance (W/m²) at floor point (x, 0, z) inside a smooth
    /// cylindrical mirror (radius a, height h), by the mirror mapping: the reflection points P on
    /// the cylinder are the roots in φ of "P lies on the segment from the light's mirror image in
    /// P's tangent plane to x" (scanned at `scan` angles, refined by bisection), and each adds
    ///     R · I · dΩ/dA = R · I · (a |d·n| / |P − L|²) / |det ∂x/∂(φ, y)|
    /// (dΩ = a |d·n| dφ dy / |P − L|² at the light; the floor Jacobian of the reflected ray by
    /// central differences). Infinite on the fold lines (det → 0), integrable. O(scan).
    double smoothIrradiance(double x, double z, int scan = 2048) const {
        const double lx = light.x, ly = light.y, lz = light.z;
        // Horizontal cross product (P − L') × (X − L') as a function of φ: zero when P lies on
        // the line from the light's image L' to X.
        auto image = [&](double phi, double& ix, double& iz) {
            const double nx = -std::cos(phi), nz = -std::sin(phi);  // inward normal
            const double px = radius * std::cos(phi), pz = radius * std::sin(phi);
            const double s = (lx - px) * nx + (lz - pz) * nz;  // light's distance from the plane
            ix = lx - 2.0 * s * nx;
            iz = lz - 2.0 * s * nz;
        };
        auto g = [&](double phi) {
            double ix, iz;
            image(phi, ix, iz);
            const double px = radius * std::cos(phi), pz = radius * std::sin(phi);
            return (px - ix) * (z - iz) - (pz - iz) * (x - ix);
        };
        // Floor point of the ray from the light reflected at (φ, y); false if it does not go down.
        auto land = [&](double phi, double y, double& fx, double& fz) {
            const double nx = -std::cos(phi), nz = -std::sin(phi);
            const double px = radius * std::cos(phi), pz = radius * std::sin(phi);
            double dx = px - lx, dy = y - ly, dz = pz - lz;
            const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
            dx /= len, dy /= len, dz /= len;
            const double dn = dx * nx + dz * nz;
            const double rx = dx - 2.0 * dn * nx, rz = dz - 2.0 * dn * nz, ry = dy;
            if (!(ry < 0.0)) return false;
            const double t = -y / ry;
            fx = px + t * rx;
            fz = pz + t * rz;
            return true;
        };
        const double twoPi = 2.0 * std::numbers::pi;
        double e = 0.0;
        double prevPhi = 0.0, prevG = g(0.0);
        for (int i = 1; i <= scan; ++i) {
            const double phi = twoPi * double(i) / double(scan);
            const double gi = g(phi);
            if ((prevG < 0.0) != (gi < 0.0)) {
                double lo = prevPhi, hi = phi, glo = prevG;
                for (int it = 0; it < 60; ++it) {
                    const double mid = 0.5 * (lo + hi), gm = g(mid);
                    if ((gm < 0.0) == (glo < 0.0)) lo = mid, glo = gm;
                    else hi = mid;
                }
                const double root = 0.5 * (lo + hi);
                double ix, iz;
                image(root, ix, iz);
                const double px = radius * std::cos(root), pz = radius * std::sin(root);
                const double seg = std::hypot(x - ix, z - iz);
                const double toP = std::hypot(px - ix, pz - iz);
                const bool sameSide = (px - ix) * (x - ix) + (pz - iz) * (z - iz) > 0.0;
                const bool lightInside = (lx - px) * -std::cos(root) + (lz - pz) * -std::sin(root) > 0.0;
                if (sameSide && lightInside && seg > 0.0 && toP < seg) {
                    const double y = ly * (1.0 - toP / seg);  // height where L' → X crosses
                    if (y >= 0.0 && y <= height) {
                        const double hp = 1e-6, hy = 1e-6;
                        double ax, az, bx, bz, cx, cz, dx, dz;
                        if (land(root + hp, y, ax, az) && land(root - hp, y, bx, bz) &&
                            land(root, y + hy, cx, cz) && land(root, y - hy, dx, dz)) {
                            const double j11 = (ax - bx) / (2 * hp), j21 = (az - bz) / (2 * hp);
                            const double j12 = (cx - dx) / (2 * hy), j22 = (cz - dz) / (2 * hy);
                            const double det = std::abs(j11 * j22 - j12 * j21);
                            const double vx = px - lx, vy = y - ly, vz = pz - lz;
                            const double d2 = vx * vx + vy * vy + vz * vz;
                            const double cosP = std::abs(vx * -std::cos(root) + vz * -std::sin(root)) / std::sqrt(d2);
                            if (det > 0.0) e += reflectance * intensity * (radius * cosP / d2) / det;
                        }
                    }
                }
            }
            prevPhi = phi;
            prevG = gi;
        }
        return e;
    }

    /// Floor point seen through the centre of pixel (i, j) of a width × height image, and
    /// whether the comparison may use it: the ray reaches the floor inside the ring without
    /// touching the wall (floor radius ≤ maskFraction · a; the ray's radius grows linearly from 0).
    bool floorPoint(const Camera& cam, int i, int j, int imageWidth, int imageHeight, double& x, double& z) const {
        const Vec3 d = cam.rayDirection(i, j, imageWidth, imageHeight);
        if (!(d.y < 0.0f)) return false;
        const double t = -double(cam.position.y) / double(d.y);
        x = double(cam.position.x) + t * double(d.x);
        z = double(cam.position.z) + t * double(d.z);
        return std::hypot(x, z) <= maskFraction * radius;
    }

    /// Reference caustic radiance per pixel (RGB, row-major, W/(m²·sr)) and the mask of pixels
    /// that may be compared (inside the ring, wall not in the way).
    void referenceImage(int width, int imageHeight, std::vector<float>& rgb, std::vector<uint8_t>& mask) const {
        const Scene s = scene();
        rgb.assign(size_t(width) * size_t(imageHeight) * 3, 0.0f);
        mask.assign(size_t(width) * size_t(imageHeight), 0);
        for (int j = 0; j < imageHeight; ++j)
            for (int i = 0; i < width; ++i) {
                double x = 0.0, z = 0.0;
                const size_t p = size_t(j) * size_t(width) + size_t(i);
                if (!floorPoint(*s.camera, i, j, width, imageHeight, x, z)) continue;
                mask[p] = 1;
                const float l = float(floorAlbedo / std::numbers::pi *
                                      (smooth ? smoothIrradiance(x, z) : irradiance(x, z)));
                rgb[3 * p] = rgb[3 * p + 1] = rgb[3 * p + 2] = l;
            }
    }
};

}  // namespace rtpm::testscenes
