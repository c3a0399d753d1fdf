// The --animate presets (orbit, light, ior, object), each a pure function of the loaded scene and the frame.
#include "server/animation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/gtc/matrix_transform.hpp>

namespace rtpm::server {

namespace {

// Rotation by `degrees` about the vertical axis through `pivot`.
Mat4 spinY(Vec3 pivot, float degrees) {
    Mat4 m = glm::translate(Mat4(1.0f), pivot);
    m = glm::rotate(m, glm::radians(degrees), Vec3(0, 1, 0));
    return glm::translate(m, -pivot);
}

Bounds instanceBounds(const Scene& s, uint32_t instance) {
    Bounds b;
    const Instance& in = s.instances[instance];
    for (const Vec3& p : s.meshes[in.mesh].positions) b.extend(Vec3(in.transform * glm::vec4(p, 1.0f)));
    return b;
}

std::optional<uint32_t> firstInstanceWith(const Scene& s, bool (*pred)(const Material&)) {
    for (uint32_t i = 0; i < s.instances.size(); ++i)
        if (pred(s.materials[s.meshes[s.instances[i].mesh].material])) return i;
    return std::nullopt;
}

bool isEmissive(const Material& m) { return m.isEmissive(); }
bool isSpecular(const Material& m) { return m.isSpecular(); }

std::optional<uint32_t> firstDielectric(const Scene& s) {
    for (uint32_t i = 0; i < s.materials.size(); ++i)
        if (s.materials[i].type == MaterialType::Dielectric) return i;
    return std::nullopt;
}

}  // namespace

std::optional<Animation> parseAnimation(std::string_view name) {
    if (name.empty() || name == "none") return Animation::None;
    if (name == "orbit") return Animation::Orbit;
    if (name == "light") return Animation::Light;
    if (name == "ior") return Animation::Ior;
    if (name == "object") return Animation::Object;
    return std::nullopt;
}

void checkAnimation(Animation a, const Scene& s) {
    switch (a) {
        case Animation::None: return;
        case Animation::Orbit: break;
        case Animation::Light:
            if (s.lights.empty() && !firstInstanceWith(s, isEmissive))
                throw std::invalid_argument("--animate light: the scene has no punctual light and no emissive object");
            break;
        case Animation::Ior:
            if (!firstDielectric(s))
                throw std::invalid_argument("--animate ior: the scene has no dielectric material");
            break;
        case Animation::Object:
            if (!firstInstanceWith(s, isSpecular))
                throw std::invalid_argument("--animate object: the scene has no mirror or dielectric object");
            break;
    }
    // Every preset repeats within kAnimationPeriod frames: run them all once on a copy, so a
    // state a client would refuse (an object spun beyond the world's bounds, …) fails now.
    LiveScene dry(s);
    std::vector<proto::SceneEdit> sink;
    for (uint64_t f = 1; f <= kAnimationPeriod; ++f) {
        animate(a, f, dry, sink);
        sink.clear();
    }
}

void animate(Animation a, uint64_t frame, LiveScene& live, std::vector<proto::SceneEdit>& out) {
    if (frame == 0 || a == Animation::None) return;
    const Scene& loaded = live.loaded();
    const Bounds bounds = loaded.bounds();
    const float f = static_cast<float>(frame % 7200);  // all presets repeat within 7200 frames
    switch (a) {
        case Animation::None: return;
        case Animation::Orbit: {
            Mat4 r = spinY(bounds.centre(), 3.0f * f);
            Camera c = *loaded.camera;
            c.position = Vec3(r * glm::vec4(c.position, 1.0f));
            c.forward = glm::normalize(Vec3(r * glm::vec4(c.forward, 0.0f)));
            c.up = glm::normalize(Vec3(r * glm::vec4(c.up, 0.0f)));
            validateCamera(c, "--animate orbit", "camera");
            live.setCamera(c);
            return;
        }
        case Animation::Light: {
            const float radius = 0.1f * bounds.diagonal();
            const float theta = glm::radians(6.0f * f);
            // Circle through the loaded position: offset (cos θ − 1, 0, sin θ)·radius.
            const Vec3 offset = radius * Vec3(std::cos(theta) - 1.0f, 0.0f, std::sin(theta));
            ScriptEdit e;
            e.line = 0;
            if (!loaded.lights.empty()) {
                e.kind = ScriptEdit::Kind::Light;
                e.index = 0;
                e.light.position = loaded.lights[0].position + offset;
            } else {
                e.kind = ScriptEdit::Kind::Transform;
                e.index = *firstInstanceWith(loaded, isEmissive);
                e.transform.translate = offset;
            }
            live.apply(e, "--animate light", out);
            return;
        }
        case Animation::Ior: {
            uint32_t m = *firstDielectric(loaded);
            ScriptEdit e;
            e.kind = ScriptEdit::Kind::Material;
            e.index = m;
            e.material.ior = std::max(1.01f, loaded.materials[m].ior + 0.2f * std::sin(2.0f * kPi * f / 60.0f));
            live.apply(e, "--animate ior", out);
            return;
        }
        case Animation::Object: {
            uint32_t i = *firstInstanceWith(loaded, isSpecular);
            ScriptEdit e;
            e.kind = ScriptEdit::Kind::Transform;
            e.index = i;
            e.transform.matrix = spinY(instanceBounds(loaded, i).centre(), 3.0f * f) * loaded.instances[i].transform;
            live.apply(e, "--animate object", out);
            return;
        }
    }
}

}  // namespace rtpm::server
