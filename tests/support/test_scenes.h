// Small hand-built scenes for the accuracy and hard-case tests: quads, boxes, materials, lights.
#pragma once

#include <string>
#include <utility>

#include "common/scene/scene.h"

namespace rtpm::testscenes {

/// Quad centred at `centre` spanning ±uAxis, ±vAxis; counter-clockwise (front face) seen from
/// the side cross(uAxis, vAxis) points to. No vertex normals: the geometric normal shades.
inline Mesh quad(Vec3 centre, Vec3 uAxis, Vec3 vAxis, uint32_t material) {
    Mesh m;
    m.name = "quad";
    m.positions = {centre - uAxis - vAxis, centre + uAxis - vAxis, centre + uAxis + vAxis,
                   centre - uAxis + vAxis};
    m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    m.indices = {0, 1, 2, 0, 2, 3};
    m.material = material;
    return m;
}

/// Closed axis-aligned box, every face wound outward (geometric normals point out of the solid).
inline Mesh box(Vec3 lo, Vec3 hi, uint32_t material) {
    Mesh m;
    m.name = "box";
    m.material = material;
    for (int i = 0; i < 8; ++i)
        m.positions.push_back(Vec3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z));
    const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
    const Vec3 c = 0.5f * (lo + hi);
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        const Vec3 p0 = m.positions[m.indices[t]], p1 = m.positions[m.indices[t + 1]],
                   p2 = m.positions[m.indices[t + 2]];
        if (glm::dot(glm::cross(p1 - p0, p2 - p0), (p0 + p1 + p2) / 3.0f - c) < 0.0f)
            std::swap(m.indices[t + 1], m.indices[t + 2]);
    }
    return m;
}

/// Appends `mesh` with an identity instance.
inline void addMesh(Scene& s, Mesh mesh) {
    s.instances.push_back(
        Instance{"instance " + std::to_string(s.meshes.size()), uint32_t(s.meshes.size()), Mat4(1.0f)});
    s.meshes.push_back(std::move(mesh));
}

/// Appends a material and returns its index.
inline uint32_t addMaterial(Scene& s, MaterialType type, Vec3 baseColor, float ior = 1.5f) {
    Material m;
    m.name = "material " + std::to_string(s.materials.size());
    m.type = type;
    m.baseColor = baseColor;
    m.ior = ior;
    s.materials.push_back(m);
    return uint32_t(s.materials.size() - 1);
}

/// Appends a point light of radiant intensity `intensity` W/sr.
inline void addPointLight(Scene& s, Vec3 position, Vec3 intensity) {
    Light l;
    l.name = "light " + std::to_string(s.lights.size());
    l.type = LightType::Point;
    l.position = position;
    l.intensity = intensity;
    s.lights.push_back(l);
}

/// One diffuse floor quad (material "floor"), a glass quad 0.5 m above it (material "glass",
/// instances "floor" and "glass"), a point light at (0, 2, 0) with intensity 5 W/sr and a camera:
/// the smallest scene every edit kind (camera, light, material, transform) applies to.
inline Scene floorAndGlassBox() {
    Scene s;
    s.name = "small";
    Material floor;
    floor.name = "floor";
    Material glass;
    glass.name = "glass";
    glass.type = MaterialType::Dielectric;
    s.materials = {floor, glass};
    Mesh quad;
    quad.positions = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
    quad.indices = {0, 1, 2, 0, 2, 3};
    Mesh box = quad;
    box.material = 1;
    for (Vec3& p : box.positions) p.y = 0.5f;
    s.meshes = {quad, box};
    s.instances = {Instance{"floor", 0, Mat4(1.0f)}, Instance{"glass", 1, Mat4(1.0f)}};
    Light l;
    l.position = Vec3(0, 2, 0);
    l.intensity = Vec3(5.0f);
    s.lights = {l};
    s.camera = Camera::lookAt(Vec3(0, 1, 3), Vec3(0), Vec3(0, 1, 0), 0.8f);
    s.validate("small");
    return s;
}

}  // namespace rtpm::testscenes
