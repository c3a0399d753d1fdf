// directlyLitShare: a coarse grid of primary rays and one shadow ray per light at each hit.
#include "common/trace/light_probe.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "common/scene/environment_loader.h"
#include "common/scene/scene_loader.h"
#include "common/trace/embree_scene.h"

namespace rtpm {

namespace {

// A light this close to the surface's plane (3°) lights it too faintly to show.
const float kGrazingCosine = std::sin(3.0f * kPi / 180.0f);

// True when `light` reaches `hit` (unit normal `n` facing the viewer) at more than a grazing
// angle, inside its cone and unshadowed.
bool reaches(const EmbreeScene& es, const Light& light, const SurfaceHit& hit, Vec3 n, Vec3 ng) {
    if (!(maxComponent(light.intensity) > 0.0f)) return false;
    Vec3 wi;
    Ray shadow;
    if (light.type == LightType::Directional) {
        wi = -glm::normalize(light.direction);
        shadow = Ray{es.offsetOrigin(hit.position, ng, wi), wi, 0.0f, std::numeric_limits<float>::infinity()};
    } else {
        const Vec3 d = light.position - hit.position;
        const float dist = glm::length(d);
        if (!(dist > 0.0f)) return false;
        wi = d / dist;
        if (light.type == LightType::Spot && !(spotFalloff(light, glm::dot(glm::normalize(light.direction), -wi)) > 0.0f))
            return false;
        const Vec3 origin = es.offsetOrigin(hit.position, ng, wi);
        shadow = Ray{origin, light.position - origin, 0.0f, 1.0f};
    }
    if (!(glm::dot(n, wi) > kGrazingCosine) || !(glm::dot(ng, wi) > 0.0f)) return false;
    return !es.occluded(shadow);
}

}  // namespace

float directlyLitShare(const Scene& scene, int columns, int rows) {
    if (!scene.camera || columns <= 0 || rows <= 0) return 1.0f;
    const EmbreeScene es(scene);
    const Camera::PixelRays rays = scene.camera->pixelRays(columns, rows);
    int lit = 0;
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < columns; ++i) {
            const Vec3 dir = rays.direction(i, j);
            SurfaceHit hit;
            if (!es.intersect(Ray{scene.camera->position, dir}, hit)) continue;
            if (hit.material < scene.materials.size() && scene.materials[hit.material].isEmissive()) {
                ++lit;  // a lamp shows itself
                continue;
            }
            const Vec3 ng = glm::dot(hit.geometricNormal, dir) < 0.0f ? hit.geometricNormal : -hit.geometricNormal;
            const Vec3 n = glm::dot(hit.shadingNormal, ng) > 0.0f ? hit.shadingNormal : -hit.shadingNormal;
            for (const Light& light : scene.lights)
                if (reaches(es, light, hit, n, ng)) {
                    ++lit;
                    break;
                }
        }
    return float(lit) / float(columns * rows);
}

bool addSkyWhereLightsMissTheView(Scene& scene, const std::string& nameOrPath, const SceneOverrides& overrides) {
    if (!overrides.defaultLight || overrides.environment || !scene.environment.empty() || scene.worldless ||
        isBuiltinScene(nameOrPath))
        return false;
    const float share = directlyLitShare(scene);
    if (share >= kUnlitViewShare) return false;
    scene.environment = defaultSky();
    char percent[32];
    std::snprintf(percent, sizeof percent, "%.1f %%", 100.0 * share);
    scene.warnings.push_back(nameOrPath + ": its lights reach only " + percent +
                             " of what the camera sees; added the dim grey sky as its world, as Blender's "
                             "default world; --no-default-light leaves it out");
    return true;
}

Scene loadSceneToRender(const std::string& nameOrPath, const SceneOverrides& overrides,
                        const SceneInputPolicy& input) {
    Scene scene = loadScene(nameOrPath, overrides, input);
    addSkyWhereLightsMissTheView(scene, nameOrPath, overrides);
    return scene;
}

}  // namespace rtpm
