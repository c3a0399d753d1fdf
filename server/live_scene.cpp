// The master's live scene: edits checked against the rules every client applies, then recorded.
#include "server/live_scene.h"

#include <stdexcept>

#include <glm/gtc/matrix_transform.hpp>

#include "proto/bridge/bridge.h"

namespace rtpm::server {

namespace {

std::string lineEl(int line) { return line > 0 ? "line " + std::to_string(line) : "edit"; }

[[noreturn]] void fail(const std::string& file, int line, const std::string& msg) {
    throw SceneError(file, lineEl(line), msg);
}

bool inUnit(Vec3 v) { return v.x >= 0 && v.y >= 0 && v.z >= 0 && v.x <= 1 && v.y <= 1 && v.z <= 1; }
bool nonNegative(Vec3 v) { return v.x >= 0 && v.y >= 0 && v.z >= 0; }

uint64_t editKey(const proto::SceneEdit& e) {
    if (auto* l = std::get_if<proto::LightEdit>(&e)) return (1ull << 32) | l->index;
    if (auto* m = std::get_if<proto::MaterialEdit>(&e)) return (2ull << 32) | m->index;
    if (auto* t = std::get_if<proto::TransformEdit>(&e)) return (3ull << 32) | t->instance;
    return 0;
}

}  // namespace

LiveScene::LiveScene(Scene loaded) : loaded_(std::move(loaded)), scene_(loaded_) {
    if (!scene_.camera) throw std::invalid_argument("scene has no camera");
    camera_ = *scene_.camera;
    meshBoxes_.reserve(loaded_.meshes.size());
    for (const Mesh& m : loaded_.meshes) meshBoxes_.push_back(meshBounds(m));
}

void LiveScene::record(const proto::SceneEdit& e) {
    ++version_;
    uint64_t key = editKey(e);
    for (proto::SceneEdit& old : compacted_)
        if (editKey(old) == key) {
            old = e;
            return;
        }
    compacted_.push_back(e);
}

void LiveScene::apply(const ScriptEdit& e, const std::string& file, std::vector<proto::SceneEdit>& out) {
    using K = ScriptEdit::Kind;
    switch (e.kind) {
        case K::Settings: fail(file, e.line, "settings edits are applied by the master, not the scene");
        case K::Camera: {
            Camera c = camera_;
            if (e.camera.eye) c.position = *e.camera.eye;
            if (e.camera.target) {
                if (glm::length(*e.camera.target - c.position) < 1e-6f) fail(file, e.line, "camera target equals its eye");
                c = Camera::lookAt(c.position, *e.camera.target, Vec3(0, 1, 0), c.yfov);
            }
            if (e.camera.yfov) c.yfov = *e.camera.yfov;
            validateCamera(c, file, lineEl(e.line));
            camera_ = c;
            return;
        }
        case K::Light: {
            if (e.index >= scene_.lights.size())
                fail(file, e.line, "light " + std::to_string(e.index) + " does not exist (scene has " +
                                       std::to_string(scene_.lights.size()) + " punctual lights)");
            Light l = scene_.lights[e.index];
            if (e.light.position) l.position = *e.light.position;
            if (e.light.direction) {
                if (glm::length(*e.light.direction) == 0.0f) fail(file, e.line, "light direction is zero");
                l.direction = glm::normalize(*e.light.direction);
            }
            if (e.light.intensity) {
                if (!nonNegative(*e.light.intensity)) fail(file, e.line, "light intensity must be >= 0");
                l.intensity = *e.light.intensity;
            }
            validateLight(l, file, lineEl(e.line));  // the rule every client applies
            scene_.lights[e.index] = l;
            out.emplace_back(bridge::lightToWire(scene_, e.index));
            return;
        }
        case K::Material: {
            if (e.index >= scene_.materials.size())
                fail(file, e.line, "material " + std::to_string(e.index) + " does not exist (scene has " +
                                       std::to_string(scene_.materials.size()) + ")");
            Material m = scene_.materials[e.index];
            if (e.material.type) m.type = *e.material.type;
            if (e.material.color) {
                if (!inUnit(*e.material.color)) fail(file, e.line, "material color must be in [0, 1]");
                m.baseColor = *e.material.color;
            }
            if (e.material.ior) {
                if (!(*e.material.ior > 0.0f)) fail(file, e.line, "ior must be > 0");
                m.ior = *e.material.ior;
            }
            if (e.material.absorption) {
                if (!nonNegative(*e.material.absorption)) fail(file, e.line, "absorption must be >= 0");
                m.absorption = *e.material.absorption;
            }
            if (e.material.emission) {
                if (!nonNegative(*e.material.emission)) fail(file, e.line, "emission must be >= 0");
                m.emission = *e.material.emission;
            }
            validateMaterial(m, scene_.textures.size(), file, lineEl(e.line));
            scene_.materials[e.index] = m;
            out.emplace_back(bridge::materialToWire(scene_, e.index));
            return;
        }
        case K::Transform: {
            if (e.index >= scene_.instances.size())
                fail(file, e.line, "instance " + std::to_string(e.index) + " does not exist (scene has " +
                                       std::to_string(scene_.instances.size()) + ")");
            Mat4 m;
            if (e.transform.matrix) {
                m = *e.transform.matrix;
            } else {
                Mat4 t(1.0f);
                if (e.transform.translate) t = glm::translate(t, *e.transform.translate);
                if (e.transform.rotate) t = glm::rotate(t, glm::radians(e.transform.rotate->w), glm::normalize(Vec3(*e.transform.rotate)));
                if (e.transform.scale) t = glm::scale(t, Vec3(*e.transform.scale));
                m = t * loaded_.instances[e.index].transform;
            }
            validateInstanceTransform(m, meshBoxes_[scene_.instances[e.index].mesh], file, lineEl(e.line));
            scene_.instances[e.index].transform = m;
            out.emplace_back(bridge::transformToWire(scene_, e.index));
            return;
        }
    }
}

}  // namespace rtpm::server
