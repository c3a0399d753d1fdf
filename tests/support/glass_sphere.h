// The glass-sphere caustic scene and its reference: a ball lens focusing a spot light onto a
// floor, the light refracted twice (and reflected inside any number of times), with the outer
// reflection too, every path a caustic path (L S+ D).
//
// The light sits on the sphere's vertical axis, so every light path stays in the plane holding
// the axis and its first direction: the reference traces each path exactly in that plane (the
// sphere as a circle; Snell's law and the unpolarised Fresnel reflectance at each interface, each
// path split into its reflected and refracted branch down to a throughput of 1e-7) for a midpoint
// rule over the angle θ from the downward axis, and bins where each lands by its distance ρ from
// the point under the light. A direction carries I·sinθ·dθ·2π of flux (the ring of directions
// at θ), landing on the circle of radius ρ; a pixel's flux is the sum, over the radial bins, of
// a bin's flux times the share of its annulus inside the pixel's floor rectangle (closed form:
// the area of a disc cut by a rectangle). Nothing of the renderer is used: no photon map, no
// kernel, no ray tracer; only the sphere is a perfect one, where the scene's is a fine mesh with
// interpolated normals.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "common/scene/scene.h"
#include "tests/support/glass_slab.h"
#include "tests/support/progressive_run.h"
#include "tests/support/test_scenes.h"

namespace rtpm::testscenes {

/// A UV sphere of `segments` × `rings` quads with unit vertex normals pointing out.
inline Mesh uvSphere(Vec3 centre, float radius, int segments, int rings, uint32_t material) {
    Mesh m;
    m.name = "sphere";
    m.material = material;
    for (int j = 0; j <= rings; ++j) {
        const double v = std::numbers::pi * double(j) / rings;
        for (int i = 0; i <= segments; ++i) {
            const double u = 2.0 * std::numbers::pi * double(i) / segments;
            const Vec3 n(float(std::sin(v) * std::cos(u)), float(std::cos(v)), float(std::sin(v) * std::sin(u)));
            m.positions.push_back(centre + radius * n);
            m.normals.push_back(glm::normalize(n));
        }
    }
    const auto at = [&](int i, int j) { return uint32_t(j * (segments + 1) + i); };
    for (int j = 0; j < rings; ++j)
        for (int i = 0; i < segments; ++i) {
            const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
            // Counter-clockwise seen from outside: (a, c, b) and (a, d, c) with v growing downwards.
            if (j > 0) m.indices.insert(m.indices.end(), {a, b, c});
            if (j < rings - 1) m.indices.insert(m.indices.end(), {a, c, d});
        }
    return m;
}

namespace sphere_detail {

/// Area of {0 ≤ u ≤ x, 0 ≤ v ≤ z, u² + v² ≤ r²} for x, z ≥ 0.
inline double cornerArea(double x, double z, double r) {
    if (x * x + z * z <= r * r) return x * z;
    const auto f = [r](double a) { return 0.5 * (a * std::sqrt(std::max(0.0, r * r - a * a)) + r * r * std::asin(a / r)); };
    const double a = std::min(x, r);
    const double uStar = std::sqrt(std::max(0.0, r * r - z * z));
    if (a <= uStar) return z * a;
    return z * uStar + f(a) - f(uStar);
}

/// Area of the disc of radius r about the origin inside [x0, x1] × [z0, z1].
inline double discInRect(double x0, double x1, double z0, double z1, double r) {
    const auto g = [r](double x, double z) {
        const double s = (x < 0.0 ? -1.0 : 1.0) * (z < 0.0 ? -1.0 : 1.0);
        return s * cornerArea(std::abs(x), std::abs(z), r);
    };
    return g(x1, z1) - g(x0, z1) - g(x1, z0) + g(x0, z0);
}

struct V2 {
    double x, y;
};
inline V2 operator+(V2 a, V2 b) { return {a.x + b.x, a.y + b.y}; }
inline V2 operator-(V2 a, V2 b) { return {a.x - b.x, a.y - b.y}; }
inline V2 operator*(double s, V2 a) { return {s * a.x, s * a.y}; }
inline double dot(V2 a, V2 b) { return a.x * b.x + a.y * b.y; }

}  // namespace sphere_detail

/// A glass ball (index n, radius R, centre at height yc above the floor y = 0) under a spot light
/// at height yl on its axis whose cone just covers the ball; a camera between the ball and the
/// floor looks straight down, so it sees only the floor.
struct GlassSphere {
    double radius = 0.2, centreHeight = 0.5, n = 1.5, lightHeight = 1.5, intensity = 3.0;
    double floorAlbedo = 0.8;
    double floorHalf = 1.5;
    Vec3 cameraEye{0.0f, 0.2f, 0.0f};
    float yfov = 1.9655874464f;  ///< 2·atan(1.5): ±0.3 m of floor vertically at 0.2 m
    int segments = 512, rings = 256;
    /// Ray segments of a photon path (PhotonSettings::maxDepth's default): the reference drops the
    /// light that a path of more segments would bring, as the photon tracer does.
    int maxSegments = 16;

    /// Half-angle of the ball seen from the light.
    double ballAngle() const { return std::asin(radius / (lightHeight - centreHeight)); }

    Scene scene() const {
        Scene s;
        s.name = "GLASS_SPHERE";
        const float f = float(floorHalf);
        const uint32_t floorMat = addMaterial(s, MaterialType::Diffuse, Vec3(float(floorAlbedo)));
        const uint32_t glass = addMaterial(s, MaterialType::Dielectric, Vec3(1.0f), float(n));
        addMesh(s, quad(Vec3(0.0f), Vec3(0.0f, 0.0f, f), Vec3(f, 0.0f, 0.0f), floorMat));
        addMesh(s, uvSphere(Vec3(0.0f, float(centreHeight), 0.0f), float(radius), segments, rings, glass));
        // Full intensity over the ball (the falloff reaches 1 at 0.001 in cos θ inside the outer
        // cone, about 0.005 rad), nothing far beyond it.
        Light l;
        l.name = "spot";
        l.type = LightType::Spot;
        l.position = Vec3(0.0f, float(lightHeight), 0.0f);
        l.direction = Vec3(0.0f, -1.0f, 0.0f);
        l.intensity = Vec3(float(intensity));
        l.outerConeAngle = float(ballAngle() + 0.02);
        l.innerConeAngle = float(ballAngle() + 0.015);
        s.lights.push_back(l);
        s.camera = camera();
        return s;
    }

    Camera camera() const {
        return Camera::lookAt(cameraEye, Vec3(cameraEye.x, 0.0f, cameraEye.z), Vec3(0.0f, 0.0f, -1.0f), yfov);
    }

    /// Flux landing per radial bin of width `binWidth` out to `maxRho` (W), from `steps` midpoint
    /// directions over the ball's cone.
    std::vector<double> radialFlux(double binWidth, double maxRho, int steps) const {
        using namespace sphere_detail;
        std::vector<double> bins(size_t(maxRho / binWidth) + 1, 0.0);
        const V2 light{0.0, lightHeight}, centre{0.0, centreHeight};
        const double alpha = ballAngle(), dTheta = alpha / steps;
        struct Branch {
            V2 p, d;
            double w;
            bool inside;
            int segments;  // ray segments traced before this one
        };
        std::vector<Branch> stack;
        for (int a = 0; a < steps; ++a) {
            const double theta = (a + 0.5) * dTheta;
            const double flux = intensity * std::sin(theta) * dTheta * 2.0 * std::numbers::pi;
            stack.assign(1, Branch{light, {std::sin(theta), -std::cos(theta)}, flux, false, 0});
            while (!stack.empty()) {
                const Branch b = stack.back();
                stack.pop_back();
                // Where the ray meets the circle: outside, the nearer root (none: it lands);
                // inside, the farther one.
                const V2 oc = b.p - centre;
                const double bq = dot(oc, b.d), cq = dot(oc, oc) - radius * radius, disc = bq * bq - cq;
                double t = -1.0;
                if (b.inside) t = -bq + std::sqrt(std::max(0.0, disc));
                else if (disc > 0.0) t = -bq - std::sqrt(disc);
                if (!b.inside && !(t > 1e-12)) {
                    if (b.d.y < 0.0) {
                        const double x = b.p.x + (-b.p.y / b.d.y) * b.d.x;
                        const size_t bin = size_t(std::abs(x) / binWidth);
                        if (bin < bins.size()) bins[bin] += b.w;
                    }
                    continue;
                }
                // The photon tracer's path length (PhotonSettings::maxDepth): the segment ending
                // here is its last one, and the path ends without landing.
                if (b.segments + 1 >= maxSegments) continue;
                const V2 hit = b.p + t * b.d;
                V2 normal = (1.0 / radius) * (hit - centre);  // outward
                if (b.inside) normal = -1.0 * normal;          // facing the ray's side
                const double cosI = std::clamp(-dot(b.d, normal), 0.0, 1.0);
                const double eta = b.inside ? 1.0 / n : n;  // n_t / n_i
                const double fr = fresnelUnpolarised(cosI, eta);
                const V2 refl = b.d + 2.0 * cosI * normal;
                if (b.w * fr > 1e-7 * flux) stack.push_back(Branch{hit, refl, b.w * fr, b.inside, b.segments + 1});
                const double sinT2 = (1.0 - cosI * cosI) / (eta * eta);
                if (sinT2 < 1.0 && b.w * (1.0 - fr) > 1e-7 * flux) {
                    const double cosT = std::sqrt(1.0 - sinT2);
                    const V2 refr = (1.0 / eta) * b.d + (cosI / eta - cosT) * normal;
                    stack.push_back(Branch{hit, refr, b.w * (1.0 - fr), !b.inside, b.segments + 1});
                }
            }
        }
        return bins;
    }

    /// Reference caustic radiance per pixel: ρ_f/π × the pixel's flux over its floor area.
    CausticReference reference(int width, int height) const {
        const Camera cam = camera();
        const Camera::PixelRays rays = cam.pixelRays(width, height);
        const double h = cam.position.y;
        // Floor x of image column edge i, floor z of row edge j (right = +x, up = −z here).
        const auto edgeX = [&](double i) { return (2.0 * i / width - 1.0) * double(rays.halfW) * h * double(rays.right.x); };
        const auto edgeZ = [&](double j) { return (1.0 - 2.0 * j / height) * double(rays.halfH) * h * double(rays.up.z); };
        const double maxRho = std::hypot(edgeX(0), edgeZ(0)) + 0.01;
        constexpr double kBin = 2e-5;
        const std::vector<double> flux = radialFlux(kBin, maxRho, 400000);
        CausticReference ref;
        ref.rgb.assign(size_t(width) * size_t(height) * 3, 0.0f);
        ref.mask.assign(size_t(width) * size_t(height), 1);
        for (int j = 0; j < height; ++j)
            for (int i = 0; i < width; ++i) {
                const double xa = edgeX(i), xb = edgeX(i + 1), za = edgeZ(j), zb = edgeZ(j + 1);
                const double x0 = std::min(xa, xb), x1 = std::max(xa, xb), z0 = std::min(za, zb), z1 = std::max(za, zb);
                const double nearX = std::max(0.0, std::max(x0, -x1)), nearZ = std::max(0.0, std::max(z0, -z1));
                const double rMin = std::hypot(nearX, nearZ);
                const double rMax = std::hypot(std::max(std::abs(x0), std::abs(x1)), std::max(std::abs(z0), std::abs(z1)));
                double sum = 0.0;
                double inner = sphere_detail::discInRect(x0, x1, z0, z1, std::floor(rMin / kBin) * kBin);
                for (size_t b = size_t(rMin / kBin); b < flux.size() && double(b) * kBin < rMax; ++b) {
                    const double r0 = double(b) * kBin, r1 = r0 + kBin;
                    const double outer = sphere_detail::discInRect(x0, x1, z0, z1, r1);
                    sum += flux[b] * (outer - inner) / (std::numbers::pi * (r1 * r1 - r0 * r0));
                    inner = outer;
                }
                const double l = floorAlbedo / std::numbers::pi * sum / ((x1 - x0) * (z1 - z0));
                const size_t p = size_t(j) * size_t(width) + size_t(i);
                ref.rgb[3 * p] = ref.rgb[3 * p + 1] = ref.rgb[3 * p + 2] = float(l);
            }
        return ref;
    }
};

}  // namespace rtpm::testscenes
