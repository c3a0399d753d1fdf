// The scene model shared by every process: meshes, instances, materials, lights, camera.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/core/math.h"
#include "common/scene/environment.h"

namespace rtpm {

/// A scene file, setting or edit that cannot be used. `file` and `element` name the place.
struct SceneError : std::runtime_error {
    SceneError(std::string fileName, std::string elementName, const std::string& message)
        : std::runtime_error(fileName + ": " + elementName + ": " + message),
          file(std::move(fileName)),
          element(std::move(elementName)) {}
    std::string file;
    std::string element;
};

/// Axis-aligned box in world space (metres). Empty when lo > hi.
struct Bounds {
    Vec3 lo{1e30f};
    Vec3 hi{-1e30f};
    void extend(Vec3 p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    bool empty() const { return lo.x > hi.x; }
    Vec3 extent() const { return empty() ? Vec3(0.0f) : hi - lo; }
    Vec3 centre() const { return 0.5f * (lo + hi); }
    float diagonal() const { return glm::length(extent()); }
};

/// Linear RGB texture, row 0 at the top (glTF/image convention, uv (0,0) = top-left).
struct Texture {
    std::string name;
    int width = 0;
    int height = 0;
    std::vector<float> rgb;  // width * height * 3, linear (sRGB decoded on load)
    /// Bilinear lookup with repeat wrapping. Precondition: width, height > 0.
    Vec3 sample(Vec2 uv) const;
    /// Mean of sample() over the uv-space triangle (a, b, c): the average over the centroids of
    /// a regular n×n subdivision, n from the triangle's footprint in texels (4 per texel along
    /// the longest edge, 2 ≤ n ≤ 32), so its error is that of the midpoint rule at sub-texel spacing.
    /// Precondition: width, height > 0. Cost O(n²) ≤ 1024 lookups.
    Vec3 meanOverTriangle(Vec2 a, Vec2 b, Vec2 c) const;
};

enum class MaterialType : uint8_t {
    Diffuse,     ///< Lambertian, albedo baseColor (times texture)
    Mirror,      ///< metal: perfect specular reflector of reflectance baseColor, or with roughness
                 ///< a GGX conductor with Schlick Fresnel F0 = baseColor
    Dielectric,  ///< glass/liquid: exact Fresnel, refraction, Beer–Lambert inside; with roughness
                 ///< a GGX rough dielectric (Walter et al. 2007)
    Plastic,     ///< glTF's dielectric base (metallicFactor < 0.99): a Lambertian base of albedo
                 ///< baseColor (times texture) under a dielectric coat of index 1.5, smooth or GGX,
                 ///< mixed with the metal lobe by `metallic` (common/trace/plastic_bsdf.h)
};

/// glTF perceptual roughness at or below which a Mirror, Dielectric or Plastic coat is the exact smooth specular
/// surface (deterministic splits in the eye pass, exact reflection and refraction of photons).
/// Above it the surface is a GGX microfacet surface (common/trace/microfacet.h).
inline constexpr float kSmoothRoughness = 0.01f;

/// glTF KHR_texture_transform of a texture lookup: uv' = T(offset) · R(rotation) · S(scale) · uv,
/// with the extension's rotation convention (counter-clockwise in uv space, radians).
struct TextureTransform {
    Vec2 offset{0.0f};
    float rotation = 0.0f;
    Vec2 scale{1.0f};
    bool isIdentity() const { return offset == Vec2(0.0f) && rotation == 0.0f && scale == Vec2(1.0f); }
    /// The transformed coordinates (the extension's matrix applied to (uv, 1)). Pure, O(1).
    Vec2 apply(Vec2 uv) const;
    bool operator==(const TextureTransform&) const = default;
};

/// docs/ARCHITECTURE.md §9 mapping from glTF metallic-roughness. Emission makes any material an
/// area light.
struct Material {
    std::string name;
    MaterialType type = MaterialType::Diffuse;
    Vec3 baseColor{0.8f};       ///< albedo (Diffuse, and the Lambertian share of a partly
                                ///< transmissive Dielectric) or reflectance (Mirror)
    int32_t baseColorTexture = -1;  ///< index into Scene::textures, -1 for none
    TextureTransform baseColorTransform;  ///< applied to the uv before the baseColorTexture lookup
    float ior = 1.5f;           ///< Dielectric: index of refraction inside the surface
    Vec3 absorption{0.0f};      ///< Dielectric: Beer–Lambert coefficient σ_a per metre inside
    /// Dielectric: share t ∈ (0, 1] of the smooth dielectric lobe; the rest (1 − t) is Lambertian
    /// with albedo baseColor × texture (glTF KHR_materials_transmission factor). 1 = clear glass.
    float transmission = 1.0f;
    /// Mirror, Dielectric and Plastic (its coat): glTF perceptual roughness in [0, 1] (GGX
    /// α = roughness²); at most kSmoothRoughness is a smooth surface. Ignored by Diffuse.
    float roughness = 0.0f;
    /// Plastic: glTF metallicFactor in [0, 1], the share of the metal lobe (F0 = baseColor) mixed
    /// with the coated base. Ignored by the other types.
    float metallic = 0.0f;
    /// Plastic: KHR_materials_specular specularFactor in [0, 1], the strength of the coat's
    /// reflection (0: the base alone, a Lambertian). Ignored by the other types.
    float specular = 1.0f;
    Vec3 emission{0.0f};        ///< emitted radiance W/(m²·sr) from the front face; > 0 → area light
    int32_t emissiveTexture = -1;  ///< index into Scene::textures multiplying emission, -1 for none
    /// Diffuse only, ignored for other types (glTF KHR_materials_unlit): seen as baseColor × texture, receives no light,
    /// stores no photons and absorbs every photon that hits it; not a light source by itself.
    bool unlit = false;
    bool isEmissive() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
    bool isSpecular() const { return type != MaterialType::Diffuse; }
    /// A rough Mirror, Dielectric or Plastic coat: scattered by the GGX BSDF instead of exactly.
    bool isGlossy() const { return type != MaterialType::Diffuse && roughness > kSmoothRoughness; }
    /// A Dielectric with a Lambertian share (transmission < 1).
    bool isPartlyDiffuse() const { return type == MaterialType::Dielectric && transmission < 1.0f; }
};

/// The lower-case name of `type` as edit scripts and the viewer spell it: "diffuse", "mirror",
/// "dielectric" or "plastic". Pure, O(1).
const char* materialTypeName(MaterialType type);

/// Albedo (Diffuse) at texture coordinates `uv`: baseColor times the transformed base-colour
/// texture lookup when the material has one. `textures` is Scene::textures. Pure, O(1).
Vec3 baseColorAt(const Material& material, const std::vector<Texture>& textures, Vec2 uv);
/// Emitted radiance at `uv`: emission times the emissive texture when there is one. Pure, O(1).
Vec3 emissionAt(const Material& material, const std::vector<Texture>& textures, Vec2 uv);

/// Triangle mesh in object space. `normals` and `uvs` are per vertex and may be empty.
struct Mesh {
    std::string name;
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;
    std::vector<Vec2> uvs;
    std::vector<uint32_t> indices;  ///< 3 per triangle
    uint32_t material = 0;          ///< index into Scene::materials
    size_t triangleCount() const { return indices.size() / 3; }
};

/// One placement of a mesh in the world; several instances may share a mesh.
struct Instance {
    std::string name;
    uint32_t mesh = 0;
    Mat4 transform{1.0f};  ///< object → world
};

enum class LightType : uint8_t { Point, Spot, Directional };

/// Punctual light (area lights are emissive triangles, see Material::emission).
/// docs/ARCHITECTURE.md §9: point/spot intensity is radiant intensity W/sr; directional is
/// irradiance W/m².
struct Light {
    std::string name;
    LightType type = LightType::Point;
    Vec3 position{0.0f};           ///< world, metres (point, spot)
    Vec3 direction{0.0f, -1.0f, 0.0f};  ///< unit, the direction light travels (spot, directional)
    Vec3 intensity{1.0f};          ///< W/sr (point, spot) or W/m² (directional), colour included
    float innerConeAngle = 0.0f;   ///< spot: full intensity inside (radians from the axis)
    float outerConeAngle = 0.785398f;  ///< spot: zero outside; smooth falloff between (glTF)
};

/// Pinhole camera, glTF convention: looks down −Z of its frame with +Y up.
/// Pixel (i, j), column i from the left, row j from the top, is sampled at its centre.
struct Camera {
    Vec3 position{0.0f};
    Vec3 forward{0.0f, 0.0f, -1.0f};  ///< unit
    Vec3 up{0.0f, 1.0f, 0.0f};        ///< unit, orthogonal to forward
    float yfov = 0.8f;                ///< vertical field of view, radians
    /// Camera at `eye` looking at `target`, `upHint` roughly up.
    static Camera lookAt(Vec3 eye, Vec3 target, Vec3 upHint, float yfovRadians);
    /// Unit world-space direction through the centre of pixel (i, j) of a width × height image.
    Vec3 rayDirection(int i, int j, int width, int height) const;

    /// What rayDirection computes once per image (the tangent, the right vector), so that a
    /// loop over pixels pays only the per-pixel part; direction() returns the same floats.
    struct PixelRays {
        Vec3 forward, right, up;
        float halfW, halfH, width, height;
        Vec3 direction(int i, int j) const;
    };
    PixelRays pixelRays(int width, int height) const;
};

/// A whole scene. Owned by value; loaders and builders fill it, everything else reads it.
struct Scene {
    std::string name;
    std::vector<Mesh> meshes;
    std::vector<Instance> instances;
    std::vector<Material> materials;
    std::vector<Texture> textures;
    std::vector<Light> lights;
    Environment environment;  ///< the world light; empty() when there is none (the default)
    std::optional<Camera> camera;
    std::vector<std::string> warnings;  ///< unsupported features met while loading
    /// The file says it has no world light (rtpm's own .glb export of a scene without one, glTF
    /// scene extras `"rtpm_world": "none"`): loadScene adds no default sky to it.
    bool worldless = false;

    /// World bounds of every instance (empty scene → empty bounds). Cost O(vertices).
    Bounds bounds() const;
    size_t triangleCount() const;
    /// Throws SceneError naming the element if an index is out of range or a value breaks the
    /// rules below (validateLight, validateMaterial, validateInstanceTransform, validateCamera).
    /// Cost O(vertices).
    void validate(const std::string& fileName) const;
};

/// Throws SceneError{fileName, element, …} unless `mesh` is usable geometry: index count a
/// multiple of 3, every index in range, finite positions. The one geometry rule: EmbreeScene
/// applies it before building, Scene::validate with the attribute checks (normals, uvs, material).
void validateMesh(const Mesh& mesh, const std::string& fileName, const std::string& element);

// ---- The one rule set for scene values ------------------------------------------------------
// Whatever a value comes from (a scene file, an edit script, --animate, the viewer, the wire), it
// is checked by these functions: Scene::validate calls them for the whole scene, the server for
// each edit before it is sent, each client for each edit it receives. So an edit the server
// accepts is one every client accepts, and Embree only ever sees finite values of sane size.

/// Largest |coordinate| in metres of anything in world space: vertices after their instance
/// transform, punctual lights, the camera. Float rays still resolve ~60 m there, squared
/// distances stay far from overflow, and Bounds' 1e30 sentinels stay outside.
constexpr float kMaxWorldCoordinate = 1e9f;
/// Range of the length of each column of an instance transform's linear part (its scale).
constexpr float kMinTransformScale = 1e-6f;
constexpr float kMaxTransformScale = 1e6f;
/// Largest per-channel light intensity (W/sr, or W/m² for directional lights) and material
/// emission (W/(m²·sr)): beyond the Sun's radiant intensity, far below float overflow once
/// multiplied by areas, 4π and photon counts.
constexpr float kMaxRadiantValue = 1e26f;
/// Largest absorption coefficient of a dielectric, per metre.
constexpr float kMaxAbsorption = 1e9f;

/// Object-space bounds of a mesh's positions (empty for a mesh without any). Cost O(vertices).
Bounds meshBounds(const Mesh& mesh);

/// Each throws SceneError{fileName, element, what is wrong} unless the value keeps the rules:
/// Light: finite; position within kMaxWorldCoordinate; intensity in [0, kMaxRadiantValue];
/// spot/directional direction a unit vector; spot cones 0 ≤ inner < outer ≤ π/2.
void validateLight(const Light& light, const std::string& fileName, const std::string& element);
/// Material: finite; colour, emission ≤ kMaxRadiantValue and absorption ≤ kMaxAbsorption
/// non-negative; a dielectric's ior in [1, 4]; roughness, metallic and specular in [0, 1]; texture
/// index < `textureCount`.
void validateMaterial(const Material& material, size_t textureCount, const std::string& fileName,
                      const std::string& element);
/// Instance transform: finite; affine (last row 0 0 0 1); every column of the linear part of
/// length in [kMinTransformScale, kMaxTransformScale] and the part invertible (no all-zero or
/// flattening matrix); the corners of `meshBoxObject` (the mesh's object-space bounds) within
/// kMaxWorldCoordinate once transformed.
void validateInstanceTransform(const Mat4& transform, const Bounds& meshBoxObject,
                               const std::string& fileName, const std::string& element);
/// Camera: finite; position within kMaxWorldCoordinate; forward and up non-zero and not
/// parallel; yfov in (1e-4, 3.1) radians.
void validateCamera(const Camera& camera, const std::string& fileName,
                    const std::string& element = "camera");

/// A spot light's cone in the form its falloff and solid angle use: s = 1 / max(0.001, cosI − cosO),
/// c₁ = min(1, cosO + 1/s), ramp = ∫_{cosO}^{c₁} falloff dc, flat = 1 − c₁.
struct SpotShape {
    double cosOuter, scale, c1, ramp, flat;  // ramp = ∫_{cosO}^{c1} a dc, flat = 1 − c1
};
/// The shape of `light`'s cone (spot lights; other types give a meaningless shape). Pure, O(1).
SpotShape spotShape(const Light& light);


/// glTF KHR_lights_punctual spot attenuation (the spec's reference implementation):
/// clamp((cosθ − cosO)·s, 0, 1)² with s = 1 / max(0.001, cosI − cosO). Pure, O(1).
float spotFalloff(const Light& light, float cosTheta);
/// ∫ spotFalloff dω over the sphere (sr), exact closed form:
/// 2π·[(1 − c₁) + s²(c₁ − cosO)³/3] with c₁ = min(1, cosO + 1/s).
float spotSolidAngle(const Light& light);

}  // namespace rtpm
