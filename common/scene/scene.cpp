// Scene model helpers: bounds, texture lookup, camera rays and validation.
#include "common/scene/scene.h"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <numbers>
#include <string>

namespace rtpm {

namespace {


bool finiteMatrix(const Mat4& m) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r])) return false;
    return true;
}


}  // namespace

Vec3 Texture::sample(Vec2 uv) const {
    // Repeat wrapping, texel centres at half-integers, bilinear.
    float x = (uv.x - std::floor(uv.x)) * float(width) - 0.5f;
    float y = (uv.y - std::floor(uv.y)) * float(height) - 0.5f;
    if (!std::isfinite(x) || !std::isfinite(y)) return Vec3(0.0f);
    float fx = std::floor(x), fy = std::floor(y);
    float tx = x - fx, ty = y - fy;
    auto wrap = [](int v, int n) { return ((v % n) + n) % n; };
    int x0 = wrap(int(fx), width), x1 = wrap(int(fx) + 1, width);
    int y0 = wrap(int(fy), height), y1 = wrap(int(fy) + 1, height);
    auto texel = [&](int xi, int yi) {
        const float* p = &rgb[(size_t(yi) * size_t(width) + size_t(xi)) * 3];
        return Vec3(p[0], p[1], p[2]);
    };
    return (1 - ty) * ((1 - tx) * texel(x0, y0) + tx * texel(x1, y0)) +
           ty * ((1 - tx) * texel(x0, y1) + tx * texel(x1, y1));
}

Vec3 Texture::meanOverTriangle(Vec2 a, Vec2 b, Vec2 c) const {
    // Footprint: the longest edge in texels sets the subdivision (4 sub-triangle rows per texel).
    const Vec2 size{float(width), float(height)};
    const float edge = std::max({glm::length((b - a) * size), glm::length((c - b) * size),
                                 glm::length((a - c) * size)});
    const int n = std::isfinite(edge) ? std::clamp(int(std::ceil(4.0f * edge)), 2, 32) : 2;
    // The n² sub-triangles of a regular subdivision have equal area: their centroids weigh the same.
    // In barycentric steps of 1/n, "up" triangles have centroids (i + 1/3, j + 1/3)/n and "down"
    // ones (i + 2/3, j + 2/3)/n.
    Vec3 sum(0.0f);
    int count = 0;
    const float inv = 1.0f / float(n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; i + j < n; ++j) {
            for (int down = 0; down < 2; ++down) {
                if (down && i + j + 2 > n) continue;
                const float off = down ? 2.0f / 3.0f : 1.0f / 3.0f;
                const float u = (float(i) + off) * inv, v = (float(j) + off) * inv;
                sum += sample(a + u * (b - a) + v * (c - a));
                ++count;
            }
        }
    return sum / float(std::max(count, 1));
}

Vec2 TextureTransform::apply(Vec2 uv) const {
    // KHR_texture_transform: translation · rotation · scale, rotation matrix [c s; −s c] in the
    // extension's row-major notation (a positive angle turns uv counter-clockwise).
    const float c = std::cos(rotation), s = std::sin(rotation);
    const Vec2 scaled = uv * scale;
    return Vec2(c * scaled.x + s * scaled.y, -s * scaled.x + c * scaled.y) + offset;
}

const char* materialTypeName(MaterialType type) {
    switch (type) {
        case MaterialType::Mirror: return "mirror";
        case MaterialType::Dielectric: return "dielectric";
        case MaterialType::Plastic: return "plastic";
        case MaterialType::Diffuse: break;
    }
    return "diffuse";
}

Vec3 baseColorAt(const Material& material, const std::vector<Texture>& textures, Vec2 uv) {
    Vec3 albedo = material.baseColor;
    if (material.baseColorTexture >= 0 && size_t(material.baseColorTexture) < textures.size()) {
        const Texture& tex = textures[size_t(material.baseColorTexture)];
        if (tex.width > 0 && tex.height > 0) {
            if (!material.baseColorTransform.isIdentity()) uv = material.baseColorTransform.apply(uv);
            albedo *= tex.sample(uv);
        }
    }
    return albedo;
}

Vec3 emissionAt(const Material& material, const std::vector<Texture>& textures, Vec2 uv) {
    Vec3 e = material.emission;
    if (material.emissiveTexture >= 0 && size_t(material.emissiveTexture) < textures.size()) {
        const Texture& tex = textures[size_t(material.emissiveTexture)];
        if (tex.width > 0 && tex.height > 0) e *= tex.sample(uv);
    }
    return e;
}

Camera Camera::lookAt(Vec3 eye, Vec3 target, Vec3 upHint, float yfovRadians) {
    Camera c;
    c.position = eye;
    c.forward = glm::normalize(target - eye);
    Vec3 right = glm::cross(c.forward, upHint);
    if (glm::length(right) < 1e-6f) right = glm::cross(c.forward, Vec3(1, 0, 0));
    if (glm::length(right) < 1e-6f) right = glm::cross(c.forward, Vec3(0, 0, 1));
    right = glm::normalize(right);
    c.up = glm::normalize(glm::cross(right, c.forward));
    c.yfov = yfovRadians;
    return c;
}

Vec3 Camera::rayDirection(int i, int j, int width, int height) const {
    return pixelRays(width, height).direction(i, j);
}

Camera::PixelRays Camera::pixelRays(int width, int height) const {
    // Image plane at distance 1: half height tan(yfov/2), aspect from the image size.
    const float halfH = std::tan(0.5f * yfov);
    const float halfW = halfH * float(width) / float(height);
    return PixelRays{forward, glm::cross(forward, up), up, halfW, halfH, float(width), float(height)};
}

Vec3 Camera::PixelRays::direction(int i, int j) const {
    const float sx = (2.0f * (float(i) + 0.5f) / width - 1.0f) * halfW;
    const float sy = (1.0f - 2.0f * (float(j) + 0.5f) / height) * halfH;
    return glm::normalize(forward + sx * right + sy * up);
}

Bounds Scene::bounds() const {
    Bounds b;
    for (const Instance& inst : instances) {
        if (inst.mesh >= meshes.size()) continue;
        for (Vec3 p : meshes[inst.mesh].positions) b.extend(Vec3(inst.transform * glm::vec4(p, 1.0f)));
    }
    for (const Light& l : lights)
        if (l.type != LightType::Directional) b.extend(l.position);
    return b;
}

size_t Scene::triangleCount() const {
    size_t n = 0;
    for (const Instance& inst : instances)
        if (inst.mesh < meshes.size()) n += meshes[inst.mesh].triangleCount();
    return n;
}

void validateMesh(const Mesh& m, const std::string& fileName, const std::string& el) {
    if (m.indices.size() % 3 != 0)
        throw SceneError(fileName, el, "index count " + std::to_string(m.indices.size()) + " not a multiple of 3");
    for (uint32_t idx : m.indices)
        if (idx >= m.positions.size())
            throw SceneError(fileName, el, "vertex index " + std::to_string(idx) + " out of range (" +
                                               std::to_string(m.positions.size()) + " vertices)");
    for (Vec3 p : m.positions)
        if (!finite(p)) throw SceneError(fileName, el, "non-finite vertex position");
}

namespace {

bool withinWorld(Vec3 p) {
    return finite(p) && std::abs(p.x) <= kMaxWorldCoordinate && std::abs(p.y) <= kMaxWorldCoordinate &&
           std::abs(p.z) <= kMaxWorldCoordinate;
}

bool inRange(Vec3 v, float lo, float hi) {
    return finite(v) && glm::all(glm::greaterThanEqual(v, Vec3(lo))) && glm::all(glm::lessThanEqual(v, Vec3(hi)));
}

std::string num(float v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", double(v));
    return buf;
}

}  // namespace

Bounds meshBounds(const Mesh& mesh) {
    Bounds b;
    for (Vec3 p : mesh.positions) b.extend(p);
    return b;
}

void validateLight(const Light& l, const std::string& fileName, const std::string& el) {
    if (!finite(l.position) || !finite(l.direction) || !finite(l.intensity))
        throw SceneError(fileName, el, "non-finite value");
    if (l.type != LightType::Directional && !withinWorld(l.position))
        throw SceneError(fileName, el, "position beyond " + num(kMaxWorldCoordinate) + " m");
    if (glm::any(glm::lessThan(l.intensity, Vec3(0.0f)))) throw SceneError(fileName, el, "negative intensity");
    if (!inRange(l.intensity, 0.0f, kMaxRadiantValue))
        throw SceneError(fileName, el, "intensity above " + num(kMaxRadiantValue));
    if (l.type != LightType::Point && std::abs(glm::length(l.direction) - 1.0f) > 1e-3f)
        throw SceneError(fileName, el, "direction is not a unit vector");
    if (l.type == LightType::Spot &&
        !(l.innerConeAngle >= 0.0f && l.innerConeAngle < l.outerConeAngle && l.outerConeAngle <= 1.5707964f))
        throw SceneError(fileName, el, "spot cone angles must satisfy 0 <= inner < outer <= pi/2");
}

void validateMaterial(const Material& m, size_t textureCount, const std::string& fileName,
                      const std::string& el) {
    if (!finite(m.baseColor) || !finite(m.emission) || !finite(m.absorption) || !std::isfinite(m.ior) ||
        !std::isfinite(m.roughness))
        throw SceneError(fileName, el, "non-finite value");
    if (!(m.roughness >= 0.0f && m.roughness <= 1.0f))
        throw SceneError(fileName, el, "roughness " + std::to_string(m.roughness) + " outside [0, 1]");
    if (glm::any(glm::lessThan(m.emission, Vec3(0.0f))) || glm::any(glm::lessThan(m.absorption, Vec3(0.0f))))
        throw SceneError(fileName, el, "negative emission or absorption");
    if (!inRange(m.emission, 0.0f, kMaxRadiantValue))
        throw SceneError(fileName, el, "emission above " + num(kMaxRadiantValue));
    if (!inRange(m.absorption, 0.0f, kMaxAbsorption))
        throw SceneError(fileName, el, "absorption above " + num(kMaxAbsorption) + " per metre");
    if (!(m.metallic >= 0.0f && m.metallic <= 1.0f))
        throw SceneError(fileName, el, "metallic " + std::to_string(m.metallic) + " outside [0, 1]");
    if (!(m.specular >= 0.0f && m.specular <= 1.0f))
        throw SceneError(fileName, el, "specular " + std::to_string(m.specular) + " outside [0, 1]");
    if (m.type == MaterialType::Dielectric && !(m.ior >= 1.0f && m.ior <= 4.0f))
        throw SceneError(fileName, el, "ior " + std::to_string(m.ior) + " outside [1, 4]");
    if ((m.baseColorTexture >= 0 && size_t(m.baseColorTexture) >= textureCount) ||
        (m.emissiveTexture >= 0 && size_t(m.emissiveTexture) >= textureCount))
        throw SceneError(fileName, el, "texture index out of range");
    const TextureTransform& tt = m.baseColorTransform;
    if (!finite(Vec3(tt.offset, tt.rotation)) || !finite(Vec3(tt.scale, 0.0f)))
        throw SceneError(fileName, el, "non-finite texture transform");
    if (!(m.transmission > 0.0f && m.transmission <= 1.0f))
        throw SceneError(fileName, el, "transmission " + std::to_string(m.transmission) + " outside (0, 1]");
}

void validateInstanceTransform(const Mat4& t, const Bounds& box, const std::string& fileName,
                               const std::string& el) {
    if (!finiteMatrix(t)) throw SceneError(fileName, el, "non-finite transform");
    if (std::abs(t[0][3]) > 1e-6f || std::abs(t[1][3]) > 1e-6f || std::abs(t[2][3]) > 1e-6f ||
        std::abs(t[3][3] - 1.0f) > 1e-6f)
        throw SceneError(fileName, el, "transform is not affine (last row must be 0 0 0 1)");
    const glm::mat3 lin(t);
    for (int c = 0; c < 3; ++c) {
        const float len = glm::length(lin[c]);
        if (!(len >= kMinTransformScale && len <= kMaxTransformScale))
            throw SceneError(fileName, el, "transform scales an axis by " + num(len) + " (allowed " +
                                               num(kMinTransformScale) + " to " + num(kMaxTransformScale) + ")");
    }
    // Invertible: |det| against the product of the column lengths (1 for a rotation).
    const double det = double(glm::determinant(lin));
    const double scale = double(glm::length(lin[0])) * glm::length(lin[1]) * glm::length(lin[2]);
    if (!(std::abs(det) > 1e-6 * scale))
        throw SceneError(fileName, el, "transform flattens the object (its linear part is singular)");
    if (!box.empty())
        for (int k = 0; k < 8; ++k) {
            const Vec3 corner((k & 1) ? box.hi.x : box.lo.x, (k & 2) ? box.hi.y : box.lo.y,
                              (k & 4) ? box.hi.z : box.lo.z);
            if (!withinWorld(Vec3(t * glm::vec4(corner, 1.0f))))
                throw SceneError(fileName, el, "transform places the object beyond " +
                                                   num(kMaxWorldCoordinate) + " m");
        }
}

void validateCamera(const Camera& c, const std::string& fileName, const std::string& el) {
    if (!finite(c.position) || !finite(c.forward) || !finite(c.up) || !std::isfinite(c.yfov))
        throw SceneError(fileName, el, "non-finite value");
    if (!withinWorld(c.position))
        throw SceneError(fileName, el, "position beyond " + num(kMaxWorldCoordinate) + " m");
    const float fl = glm::length(c.forward), ul = glm::length(c.up);
    if (!(fl > 1e-6f) || !(ul > 1e-6f)) throw SceneError(fileName, el, "forward and up must be non-zero");
    if (!(glm::length(glm::cross(c.forward, c.up)) > 1e-6f * fl * ul))
        throw SceneError(fileName, el, "up is parallel to forward");
    if (!(c.yfov > 1e-4f && c.yfov < 3.1f)) throw SceneError(fileName, el, "yfov outside (0, pi)");
}

void Scene::validate(const std::string& fileName) const {
    std::vector<Bounds> boxes(meshes.size());
    for (size_t mi = 0; mi < meshes.size(); ++mi) {
        const Mesh& m = meshes[mi];
        std::string el = "mesh " + std::to_string(mi) + " (" + m.name + ")";
        validateMesh(m, fileName, el);
        if (!m.normals.empty() && m.normals.size() != m.positions.size())
            throw SceneError(fileName, el, "normal count differs from vertex count");
        for (Vec3 n : m.normals)
            if (!finite(n)) throw SceneError(fileName, el, "non-finite vertex normal");
        if (!m.uvs.empty() && m.uvs.size() != m.positions.size())
            throw SceneError(fileName, el, "uv count differs from vertex count");
        if (m.material >= materials.size()) throw SceneError(fileName, el, "material index out of range");
        boxes[mi] = meshBounds(m);
    }
    for (size_t ii = 0; ii < instances.size(); ++ii) {
        std::string el = "instance " + std::to_string(ii) + " (" + instances[ii].name + ")";
        if (instances[ii].mesh >= meshes.size()) throw SceneError(fileName, el, "mesh index out of range");
        validateInstanceTransform(instances[ii].transform, boxes[instances[ii].mesh], fileName, el);
    }
    for (size_t mi = 0; mi < materials.size(); ++mi)
        validateMaterial(materials[mi], textures.size(), fileName,
                         "material " + std::to_string(mi) + " (" + materials[mi].name + ")");
    for (size_t li = 0; li < lights.size(); ++li)
        validateLight(lights[li], fileName, "light " + std::to_string(li) + " (" + lights[li].name + ")");
    if (camera) validateCamera(*camera, fileName);
    for (size_t ti = 0; ti < textures.size(); ++ti) {
        const Texture& t = textures[ti];
        if (t.width <= 0 || t.height <= 0 || t.rgb.size() != size_t(t.width) * size_t(t.height) * 3)
            throw SceneError(fileName, "texture " + std::to_string(ti) + " (" + t.name + ")", "bad size");
    }
}

SpotShape spotShape(const Light& light) {
    SpotShape s;
    s.cosOuter = std::cos(static_cast<double>(light.outerConeAngle));
    const double cosInner = std::cos(static_cast<double>(light.innerConeAngle));
    s.scale = 1.0 / std::max(0.001, cosInner - s.cosOuter);
    s.c1 = std::min(1.0, s.cosOuter + 1.0 / s.scale);
    const double w = s.c1 - s.cosOuter;
    s.ramp = s.scale * s.scale * w * w * w / 3.0;
    s.flat = 1.0 - s.c1;
    return s;
}

float spotFalloff(const Light& light, float cosTheta) {
    const SpotShape s = spotShape(light);
    const double a = std::clamp((static_cast<double>(cosTheta) - s.cosOuter) * s.scale, 0.0, 1.0);
    return static_cast<float>(a * a);
}

float spotSolidAngle(const Light& light) {
    const SpotShape s = spotShape(light);
    return static_cast<float>(2.0 * std::numbers::pi * (s.ramp + s.flat));
}

}  // namespace rtpm
