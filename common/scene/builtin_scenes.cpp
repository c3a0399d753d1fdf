// Procedural built-in scenes: surfaces of revolution (lathe), quads and boxes assembled into scenes.
//
// Winding convention everywhere: the geometric normal cross(b − a, c − a) points out of the solid
// (for single-sided surfaces: towards the side that is lit or emits), because dielectrics decide
// "entering" from it. A lathe profile (r, y) traversed with the solid on its left (i.e. closed
// profiles counter-clockwise in the r–y half plane) yields outward normals.
#include "common/scene/builtin_scenes.h"

#include <cmath>
#include <numbers>

#include <glm/gtc/matrix_transform.hpp>

namespace rtpm {

namespace {


// A smooth run of profile points (r ≥ 0, y) revolved about +Y into `mesh`. Points with r = 0
// become a single pole vertex. Normals are analytic (profile normal rotated), so the band is
// smooth inside; consecutive bands meet at a crease with identical vertex positions (watertight).
void addLatheBand(Mesh& mesh, const std::vector<Vec2>& pts, int segments) {
    const size_t K = pts.size();
    // 2-D outward normal of each profile segment: tangent (dr, dy) rotated clockwise → (dy, −dr).
    std::vector<Vec2> segN(K - 1);
    for (size_t k = 0; k + 1 < K; ++k) {
        Vec2 d = pts[k + 1] - pts[k];
        segN[k] = glm::normalize(Vec2(d.y, -d.x));
    }
    std::vector<uint32_t> ringStart(K);
    std::vector<bool> pole(K);
    for (size_t k = 0; k < K; ++k) {
        Vec2 n = k == 0 ? segN[0] : k == K - 1 ? segN[K - 2] : glm::normalize(segN[k - 1] + segN[k]);
        pole[k] = pts[k].x <= 1e-7f;
        ringStart[k] = uint32_t(mesh.positions.size());
        if (pole[k]) {
            mesh.positions.push_back(Vec3(0.0f, pts[k].y, 0.0f));
            mesh.normals.push_back(Vec3(0.0f, n.y >= 0.0f ? 1.0f : -1.0f, 0.0f));
            continue;
        }
        for (int j = 0; j < segments; ++j) {
            float th = 2.0f * kPi * float(j) / float(segments);
            float c = std::cos(th), s = std::sin(th);
            mesh.positions.push_back(Vec3(pts[k].x * c, pts[k].y, pts[k].x * s));
            mesh.normals.push_back(glm::normalize(Vec3(n.x * c, n.y, n.x * s)));
        }
    }
    auto vid = [&](size_t k, int j) {
        return pole[k] ? ringStart[k] : ringStart[k] + uint32_t(j % segments);
    };
    for (size_t k = 0; k + 1 < K; ++k) {
        if (pole[k] && pole[k + 1]) continue;
        for (int j = 0; j < segments; ++j) {
            // Order derived so that the normal is cross(d_profile, d_theta) = outward (see top).
            if (!pole[k]) mesh.indices.insert(mesh.indices.end(), {vid(k, j), vid(k + 1, j), vid(k, j + 1)});
            if (!pole[k + 1])
                mesh.indices.insert(mesh.indices.end(), {vid(k, j + 1), vid(k + 1, j), vid(k + 1, j + 1)});
        }
    }
}

// Points along a straight profile segment from a to b (inclusive), n intervals.
std::vector<Vec2> line(Vec2 a, Vec2 b, int n) {
    std::vector<Vec2> p;
    for (int i = 0; i < n; ++i) p.push_back(glm::mix(a, b, float(i) / float(n)));
    p.push_back(b);  // exactly b: neighbouring bands must share their end points bit for bit
    return p;
}

// Points on the circle (centre c, radius R) in the r–y plane from angle a0 to a1 (radians from +r).
std::vector<Vec2> arc(Vec2 c, float R, float a0, float a1, int n) {
    std::vector<Vec2> p;
    for (int i = 0; i <= n; ++i) {
        float a = a0 + (a1 - a0) * float(i) / float(n);
        p.push_back(c + R * Vec2(std::cos(a), std::sin(a)));
    }
    return p;
}

// Closed sphere: a semicircle profile from the bottom pole to the top pole.
void addSphere(Mesh& mesh, Vec3 centre, float radius, int rings, int segments, bool inward = false) {
    Mesh local;
    addLatheBand(local, arc(Vec2(0.0f), radius, -0.5f * kPi, 0.5f * kPi, rings), segments);
    uint32_t base = uint32_t(mesh.positions.size());
    for (size_t i = 0; i < local.positions.size(); ++i) {
        mesh.positions.push_back(centre + local.positions[i]);
        mesh.normals.push_back(inward ? -local.normals[i] : local.normals[i]);
    }
    for (size_t t = 0; t < local.indices.size(); t += 3) {
        if (inward)
            mesh.indices.insert(mesh.indices.end(),
                                {base + local.indices[t], base + local.indices[t + 2], base + local.indices[t + 1]});
        else
            mesh.indices.insert(mesh.indices.end(),
                                {base + local.indices[t], base + local.indices[t + 1], base + local.indices[t + 2]});
    }
}

// Planar quad a, b, c, d in counter-clockwise order seen from the side its normal points to.
void addQuad(Mesh& mesh, Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
    uint32_t base = uint32_t(mesh.positions.size());
    Vec3 n = glm::normalize(glm::cross(b - a, c - a));
    for (Vec3 p : {a, b, c, d}) {
        mesh.positions.push_back(p);
        mesh.normals.push_back(n);
    }
    mesh.uvs.clear();
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// Axis-aligned box, outward normals, flat faces (4 vertices per face).
void addBox(Mesh& mesh, Vec3 lo, Vec3 hi) {
    Vec3 p[8];
    for (int i = 0; i < 8; ++i) p[i] = Vec3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    addQuad(mesh, p[0], p[4], p[6], p[2]);  // −x
    addQuad(mesh, p[1], p[3], p[7], p[5]);  // +x
    addQuad(mesh, p[0], p[1], p[5], p[4]);  // −y
    addQuad(mesh, p[2], p[6], p[7], p[3]);  // +y
    addQuad(mesh, p[0], p[2], p[3], p[1]);  // −z
    addQuad(mesh, p[4], p[5], p[7], p[6]);  // +z
}

// Bakes an object → world transform into positions and normals.
void transformMesh(Mesh& mesh, const Mat4& m) {
    glm::mat3 nm = glm::transpose(glm::inverse(glm::mat3(m)));
    for (Vec3& p : mesh.positions) p = Vec3(m * glm::vec4(p, 1.0f));
    for (Vec3& n : mesh.normals) n = glm::normalize(nm * n);
}

uint32_t addMaterial(Scene& s, Material m) {
    s.materials.push_back(std::move(m));
    return uint32_t(s.materials.size() - 1);
}

Material diffuse(const std::string& name, Vec3 albedo) {
    Material m;
    m.name = name;
    m.type = MaterialType::Diffuse;
    m.baseColor = albedo;
    return m;
}

Material mirror(const std::string& name, Vec3 reflectance) {
    Material m;
    m.name = name;
    m.type = MaterialType::Mirror;
    m.baseColor = reflectance;
    return m;
}

Material dielectric(const std::string& name, float ior, Vec3 absorption = Vec3(0.0f)) {
    Material m;
    m.name = name;
    m.type = MaterialType::Dielectric;
    m.baseColor = Vec3(1.0f);
    m.ior = ior;
    m.absorption = absorption;
    return m;
}

Material emitter(const std::string& name, Vec3 radiance) {
    Material m = diffuse(name, Vec3(0.0f));
    m.emission = radiance;
    return m;
}

void addMesh(Scene& s, Mesh mesh, const std::string& name, uint32_t material) {
    mesh.name = name;
    mesh.material = material;
    Instance inst;
    inst.name = name;
    inst.mesh = uint32_t(s.meshes.size());
    s.instances.push_back(inst);
    s.meshes.push_back(std::move(mesh));
}

// Horizontal square floor of half-size h at height y, facing +y.
Mesh floorQuad(float h, float y) {
    Mesh m;
    addQuad(m, Vec3(-h, y, h), Vec3(h, y, h), Vec3(h, y, -h), Vec3(-h, y, -h));
    return m;
}

// Square emissive quad of side `size` centred at `centre`, emitting towards `facing`.
Mesh lightQuad(Vec3 centre, Vec3 facing, float size) {
    Vec3 n = glm::normalize(facing);
    Vec3 t = glm::normalize(glm::cross(std::abs(n.y) < 0.9f ? Vec3(0, 1, 0) : Vec3(1, 0, 0), n));
    Vec3 b = glm::cross(n, t);
    float h = 0.5f * size;
    Mesh m;
    // Counter-clockwise around n: (−t−b), (t−b), (t+b), (−t+b) seen from the n side.
    addQuad(m, centre - h * t - h * b, centre + h * t - h * b, centre + h * t + h * b, centre - h * t + h * b);
    return m;
}

}  // namespace

Scene buildRingScene() {
    Scene s;
    s.name = "RING";
    const uint32_t floorMat = addMaterial(s, diffuse("floor", Vec3(0.8f)));
    const uint32_t metal = addMaterial(s, mirror("ring metal", Vec3(0.95f, 0.93f, 0.88f)));
    const uint32_t lamp = addMaterial(s, emitter("lamp", Vec3(4000.0f)));
    addMesh(s, floorQuad(2.0f, 0.0f), "floor", floorMat);

    // Ring band: radius 0.5 m, wall 1 cm, height 0.2 m; closed profile (bottom, outer, top, inner)
    // counter-clockwise, 128 segments → 4 bands · 2 · 128 = 1024 triangles.
    // Lifted 0.1 mm so its bottom face is not coplanar with the floor.
    const float ri = 0.5f, ro = 0.51f, y0 = 0.0001f, h = 0.2f;
    const int seg = 128;
    Mesh ring;
    addLatheBand(ring, line({ri, y0}, {ro, y0}, 1), seg);
    addLatheBand(ring, line({ro, y0}, {ro, h}, 1), seg);
    addLatheBand(ring, line({ro, h}, {ri, h}, 1), seg);
    addLatheBand(ring, line({ri, h}, {ri, y0}, 1), seg);
    addMesh(s, std::move(ring), "ring", metal);

    // Small area light (10 cm) low on the −x side, 24° above the horizon seen from the ring centre,
    // aimed at the far inner wall: light entering over the near rim reflects into the nephroid,
    // whose cusp (R/2 towards the light) lies in the near wall's shadow.
    const Vec3 lampPos(-2.0f, 0.9f, 0.0f);
    addMesh(s, lightQuad(lampPos, Vec3(0.5f, 0.0f, 0.0f) - lampPos, 0.1f), "lamp", lamp);
    // From the lamp's side, so the lamp itself stays out of view.
    s.camera = Camera::lookAt(Vec3(-1.1f, 1.6f, 1.1f), Vec3(-0.05f, 0.0f, 0.0f), Vec3(0, 1, 0), 0.6f);
    return s;
}

Scene buildGlassScene() {
    Scene s;
    s.name = "GLASS";
    const uint32_t table = addMaterial(s, diffuse("table", Vec3(0.8f, 0.78f, 0.74f)));
    const uint32_t glassMat = addMaterial(s, dielectric("glass", 1.5f));
    // Amber cognac: transmittance (0.85, 0.45, 0.15) through 5 cm → σ = −ln(T)/0.05 m.
    const uint32_t cognac = addMaterial(
        s, dielectric("cognac", 1.33f,
                      Vec3(-std::log(0.85f), -std::log(0.45f), -std::log(0.15f)) / 0.05f));
    addMesh(s, floorQuad(0.6f, 0.0f), "table", table);

    // Glass profile (r, y), closed counter-clockwise: foot bottom, foot edge, foot top, stem, bowl
    // outside (sphere R = 5 cm around y = 11.5 cm), lip, bowl inside (2 mm wall) down to the axis.
    const int seg = 80;
    const float yc = 0.115f, R = 0.05f, Ri = 0.048f, yTop = 0.15f, rStem = 0.004f;
    const float aStem = -std::acos(rStem / R);
    const float aTopOut = std::asin((yTop - yc) / R), aTopIn = std::asin((yTop - yc) / Ri);
    // Bands share their end points exactly (taken from the neighbouring band), so the
    // surface stays watertight despite rounding in the trigonometry.
    const std::vector<Vec2> outside = arc({0.0f, yc}, R, aStem, aTopOut, 40);
    std::vector<Vec2> inside = arc({0.0f, yc}, Ri, aTopIn, -0.5f * kPi, 48);
    inside.front().y = outside.back().y;  // flat lip
    Mesh glass;
    addLatheBand(glass, line({0.0f, 0.0f}, {0.04f, 0.0f}, 4), seg);
    addLatheBand(glass, line({0.04f, 0.0f}, {0.04f, 0.004f}, 1), seg);
    addLatheBand(glass, line({0.04f, 0.004f}, {rStem, 0.007f}, 6), seg);
    addLatheBand(glass, line({rStem, 0.007f}, outside.front(), 6), seg);
    addLatheBand(glass, outside, seg);
    addLatheBand(glass, line(outside.back(), inside.front(), 1), seg);
    addLatheBand(glass, inside, seg);
    // Lifted 0.1 mm (with the liquid below) so the foot's bottom face is not coplanar with the
    // table: a ray reaching both at one distance would hit either, depending on BVH order.
    const Mat4 lift = glm::translate(Mat4(1.0f), Vec3(0.0f, 0.0001f, 0.0f));
    transformMesh(glass, lift);
    addMesh(s, std::move(glass), "cognac glass", glassMat);

    // Liquid up to y = 10 cm, 0.2 mm inside the bowl's inner wall: coincident glass/liquid
    // surfaces would make the side of every hit ambiguous, a thin air gap does not.
    const float Rl = Ri - 0.0002f, yLevel = 0.10f;
    const float aLevel = std::asin((yLevel - yc) / Rl);
    Mesh liquid;
    const std::vector<Vec2> wetted = arc({0.0f, yc}, Rl, -0.5f * kPi, aLevel, 24);
    addLatheBand(liquid, wetted, seg);
    addLatheBand(liquid, line(wetted.back(), {0.0f, wetted.back().y}, 6), seg);
    transformMesh(liquid, lift);
    addMesh(s, std::move(liquid), "cognac", cognac);

    Light l;
    l.name = "lamp";
    l.type = LightType::Point;
    l.position = Vec3(-0.3f, 0.32f, -0.08f);
    l.intensity = Vec3(4.0f);
    s.lights.push_back(l);
    s.camera = Camera::lookAt(Vec3(0.12f, 0.26f, 0.42f), Vec3(0.05f, 0.05f, 0.0f), Vec3(0, 1, 0), 0.6f);
    return s;
}

Scene buildEggScene() {
    Scene s;
    s.name = "EGG";
    const uint32_t floorMat = addMaterial(s, diffuse("floor", Vec3(0.8f)));
    const uint32_t glassMat = addMaterial(s, dielectric("glass egg", 1.5f));
    addMesh(s, floorQuad(0.75f, 0.0f), "floor", floorMat);

    // Egg profile: y = a(1 − cos t), r = b sin t (1 + 0.18 cos t), t ∈ [0, π]: blunt end down,
    // 12 cm tall; 32 profile steps × 64 segments (poles are fans) = 3968 triangles.
    const float a = 0.06f, b = 0.042f;
    std::vector<Vec2> prof;
    for (int i = 0; i <= 32; ++i) {
        float t = kPi * float(i) / 32.0f;
        float r = (i == 0 || i == 32) ? 0.0f : b * std::sin(t) * (1.0f + 0.18f * std::cos(t));
        prof.push_back(Vec2(r, a * (1.0f - std::cos(t))));
    }
    Mesh egg;
    addLatheBand(egg, prof, 64);
    addMesh(s, std::move(egg), "egg", glassMat);

    Light l;
    l.name = "lamp";
    l.type = LightType::Point;
    l.position = Vec3(-0.25f, 0.45f, -0.1f);
    l.intensity = Vec3(5.0f);
    s.lights.push_back(l);
    s.camera = Camera::lookAt(Vec3(0.2f, 0.3f, 0.45f), Vec3(0.04f, 0.04f, 0.0f), Vec3(0, 1, 0), 0.6f);
    return s;
}

Scene buildHeadlightScene() {
    Scene s;
    s.name = "HEADLIGHT";
    const uint32_t wallMat = addMaterial(s, diffuse("wall", Vec3(0.8f)));
    const uint32_t chrome = addMaterial(s, mirror("reflector", Vec3(0.9f)));
    const uint32_t glassMat = addMaterial(s, dielectric("glass", 1.5f));
    // Filament: 4 × 1.5 × 1.5 mm box, area 2.85e-5 m²; flux = π · L · A ≈ 90 W at L = 1e6.
    const uint32_t filamentMat = addMaterial(s, emitter("filament", Vec3(1.0e6f, 0.85e6f, 0.6e6f)));

    // The lamp is built about +Y (lathe axis) and turned so that it shines along +Z.
    const Mat4 toZ = glm::rotate(Mat4(1.0f), 0.5f * kPi, Vec3(1, 0, 0));  // +Y → +Z

    // Parabolic reflector y = r²/(4f) − f, focus at the origin, f = 2.5 cm, from the bulb hole
    // (r = 1.4 cm) to the rim (r = 9 cm): 140 rings × 256 segments × 2 = 71.7k triangles. Its
    // normals face the focus (the lit side): the profile runs outwards, the surface below its left.
    const float f = 0.025f;
    std::vector<Vec2> para;
    for (int i = 0; i <= 140; ++i) {
        float r = 0.014f + (0.09f - 0.014f) * float(i) / 140.0f;
        para.push_back(Vec2(r, r * r / (4.0f * f) - f));
    }
    // Walked inwards (rim → hole), the focus side is on the profile's left → normals face the axis.
    Mesh reflector;
    std::vector<Vec2> paraRev(para.rbegin(), para.rend());
    addLatheBand(reflector, paraRev, 256);
    transformMesh(reflector, toZ);
    addMesh(s, std::move(reflector), "reflector", chrome);

    // Bulb: glass shell, outer radius 12 mm, inner 11 mm, centred at the focus; the inner
    // sphere's normals point into the hollow (out of the glass). 64 × 128 × 2 each.
    Mesh bulb;
    addSphere(bulb, Vec3(0.0f), 0.012f, 64, 128);
    addSphere(bulb, Vec3(0.0f), 0.011f, 64, 128, /*inward=*/true);
    transformMesh(bulb, toZ);
    addMesh(s, std::move(bulb), "bulb", glassMat);

    Mesh filament;
    addBox(filament, Vec3(-0.00075f, -0.00075f, -0.002f), Vec3(0.00075f, 0.00075f, 0.002f));
    addMesh(s, std::move(filament), "filament", filamentMat);

    // Front cover: slightly curved glass disc (radius 10 cm, 5 mm thick, surfaces of curvature
    // radius 0.6 m) in front of the rim: front cap, back cap, rim, closed counter-clockwise.
    const float Rc = 0.6f, rc = 0.1f, t = 0.005f, y0 = 0.07f;
    auto sag = [&](float r) { return std::sqrt(Rc * Rc - r * r) - Rc; };
    std::vector<Vec2> back, front;
    for (int i = 0; i <= 48; ++i) {
        float r = rc * float(i) / 48.0f;
        back.push_back(Vec2(r, y0 + sag(r)));
        front.push_back(Vec2(rc - r, y0 + t + sag(rc - r)));
    }
    Mesh cover;
    addLatheBand(cover, back, 256);
    front.front().x = back.back().x;
    addLatheBand(cover, line(back.back(), front.front(), 1), 256);
    addLatheBand(cover, front, 256);
    transformMesh(cover, toZ);
    addMesh(s, std::move(cover), "front glass", glassMat);

    // Wall 3 m ahead, 4 m × 3 m, facing the lamp.
    Mesh wall;
    addQuad(wall, Vec3(2.0f, -1.5f, 3.0f), Vec3(-2.0f, -1.5f, 3.0f), Vec3(-2.0f, 1.5f, 3.0f),
            Vec3(2.0f, 1.5f, 3.0f));
    addMesh(s, std::move(wall), "wall", wallMat);

    s.camera = Camera::lookAt(Vec3(0.9f, 0.45f, -0.5f), Vec3(0.0f, 0.0f, 1.8f), Vec3(0, 1, 0), 0.9f);
    return s;
}

Scene buildCornellScene() {
    Scene s;
    s.name = "CORNELL";
    const uint32_t white = addMaterial(s, diffuse("white", Vec3(0.725f, 0.71f, 0.68f)));
    const uint32_t red = addMaterial(s, diffuse("red", Vec3(0.63f, 0.065f, 0.05f)));
    const uint32_t green = addMaterial(s, diffuse("green", Vec3(0.14f, 0.45f, 0.091f)));
    const uint32_t glassMat = addMaterial(s, dielectric("glass", 1.5f));
    const uint32_t mirrorMat = addMaterial(s, mirror("mirror", Vec3(0.95f)));
    const uint32_t lamp = addMaterial(s, emitter("ceiling lamp", Vec3(17.0f, 12.0f, 4.0f)));

    // Box x ∈ [−0.5, 0.5], y ∈ [0, 1], z ∈ [−0.5, 0.5], open towards +z; walls face inwards.
    Mesh m;
    addQuad(m, Vec3(-0.5f, 0, 0.5f), Vec3(0.5f, 0, 0.5f), Vec3(0.5f, 0, -0.5f), Vec3(-0.5f, 0, -0.5f));
    addMesh(s, m, "floor", white);
    m = Mesh();
    addQuad(m, Vec3(-0.5f, 1, -0.5f), Vec3(0.5f, 1, -0.5f), Vec3(0.5f, 1, 0.5f), Vec3(-0.5f, 1, 0.5f));
    addMesh(s, m, "ceiling", white);
    m = Mesh();
    addQuad(m, Vec3(-0.5f, 0, -0.5f), Vec3(0.5f, 0, -0.5f), Vec3(0.5f, 1, -0.5f), Vec3(-0.5f, 1, -0.5f));
    addMesh(s, m, "back wall", white);
    m = Mesh();
    addQuad(m, Vec3(-0.5f, 0, 0.5f), Vec3(-0.5f, 0, -0.5f), Vec3(-0.5f, 1, -0.5f), Vec3(-0.5f, 1, 0.5f));
    addMesh(s, m, "left wall", red);
    m = Mesh();
    addQuad(m, Vec3(0.5f, 0, -0.5f), Vec3(0.5f, 0, 0.5f), Vec3(0.5f, 1, 0.5f), Vec3(0.5f, 1, -0.5f));
    addMesh(s, m, "right wall", green);
    // Lamp 1 mm below the ceiling, facing down.
    addMesh(s, lightQuad(Vec3(0.0f, 0.999f, 0.0f), Vec3(0, -1, 0), 0.25f), "ceiling lamp", lamp);

    Mesh glassSphere;
    addSphere(glassSphere, Vec3(0.22f, 0.17f, 0.1f), 0.17f, 48, 96);
    addMesh(s, std::move(glassSphere), "glass sphere", glassMat);
    Mesh mirrorSphere;
    addSphere(mirrorSphere, Vec3(-0.22f, 0.17f, -0.15f), 0.17f, 48, 96);
    addMesh(s, std::move(mirrorSphere), "mirror sphere", mirrorMat);

    s.camera = Camera::lookAt(Vec3(0.0f, 0.5f, 1.9f), Vec3(0.0f, 0.5f, 0.0f), Vec3(0, 1, 0), 0.7f);
    return s;
}

Scene buildBuiltinScene(const std::string& name) {
    if (name == "RING") return buildRingScene();
    if (name == "GLASS") return buildGlassScene();
    if (name == "EGG") return buildEggScene();
    if (name == "HEADLIGHT") return buildHeadlightScene();
    if (name == "CORNELL") return buildCornellScene();
    throw SceneError(name, "scene", "unknown built-in scene");
}

}  // namespace rtpm
