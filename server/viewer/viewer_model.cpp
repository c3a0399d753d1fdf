// The outbound viewer JSON, built from the plain structs of viewer_model.h.
#include "server/viewer/viewer_model.h"

#include <nlohmann/json.hpp>

#include "common/core/knobs.h"

namespace rtpm::server {

namespace {

nlohmann::json vec(Vec3 v) { return nlohmann::json::array({v.x, v.y, v.z}); }

Vec3 instanceCentre(const Scene& s, size_t i) {
    Bounds b;
    const Instance& in = s.instances[i];
    for (const Vec3& p : s.meshes[in.mesh].positions) b.extend(Vec3(in.transform * glm::vec4(p, 1.0f)));
    return b.centre();
}

// A knob's value as the viewer's settings control takes it: a whole number, a number or a name.
nlohmann::json knobJson(const KnobRow& row, double v) {
    if (row.isChoice()) return formatKnobValue(row, v);
    if (row.integer) return int64_t(v);
    return v;
}

nlohmann::json knobValuesJson(const RenderSettings& rs) {
    nlohmann::json values = nlohmann::json::object();
    for (const KnobRow& row : kKnobs) values[std::string(row.viewerKey)] = knobJson(row, row.get(rs));
    return values;
}

// The settings form, one field per live knob row, in table order.
nlohmann::json knobFormJson() {
    nlohmann::json form = nlohmann::json::array();
    for (const KnobRow& row : kKnobs) {
        nlohmann::json field{{"key", row.viewerKey}, {"name", row.name}, {"unit", row.unit},
                             {"resets", row.resets == KnobReset::Resize ? "resize"
                                        : row.resets == KnobReset::Epoch ? "epoch" : "output"}};
        if (row.isChoice()) {
            nlohmann::json choices = nlohmann::json::array();
            for (std::string_view c : row.choices)
                if (!c.empty()) choices.push_back(c);
            field["choices"] = choices;
        } else {
            field["min"] = knobJson(row, row.min);
            field["max"] = knobJson(row, row.max);
            field["step"] = row.integer ? nlohmann::json(1) : nlohmann::json("any");
        }
        form.push_back(field);
    }
    return form;
}

}  // namespace

std::string clientEventJson(const ViewerClientEvent& e) {
    if (e.joined)
        return nlohmann::json{{"type", "event"}, {"what", "joined"}, {"id", e.id}, {"name", e.name}, {"cores", e.cores}}
            .dump();
    return nlohmann::json{{"type", "event"}, {"what", "left"}, {"id", e.id}, {"name", e.name}, {"why", e.why}}.dump();
}

std::string sceneJson(const std::string& sceneName, const Scene& loaded, const Scene& s, const RenderSettings& rs) {
    nlohmann::json lights = nlohmann::json::array(), materials = nlohmann::json::array();
    for (size_t i = 0; i < s.lights.size() && i < 64; ++i)
        lights.push_back({{"index", i}, {"position", vec(s.lights[i].position)}, {"intensity", vec(s.lights[i].intensity)}});
    for (size_t i = 0; i < s.materials.size() && i < 64; ++i) {
        const Material& m = s.materials[i];
        materials.push_back({{"index", i}, {"type", materialTypeName(m.type)}, {"color", vec(m.baseColor)},
                             {"ior", m.ior}, {"absorption", vec(m.absorption)}});
    }
    // Emissive instances are the lights of scenes without punctual ones (RING): the viewer moves
    // them with transform edits (translation from the loaded pose) and sets their emission.
    nlohmann::json emitters = nlohmann::json::array();
    for (size_t i = 0; i < s.instances.size() && emitters.size() < 64; ++i) {
        const uint32_t mat = s.meshes[s.instances[i].mesh].material;
        if (!s.materials[mat].isEmissive()) continue;
        emitters.push_back({{"index", i}, {"name", s.instances[i].name}, {"material", mat},
                            {"loadedCentre", vec(instanceCentre(loaded, i))}, {"centre", vec(instanceCentre(s, i))},
                            {"emission", vec(s.materials[mat].emission)}});
    }
    const Bounds b = s.bounds();
    return nlohmann::json{
        {"type", "scene"}, {"name", sceneName}, {"width", rs.width}, {"height", rs.height},
        {"centre", vec(b.centre())}, {"diagonal", b.diagonal()}, {"lights", lights}, {"emitters", emitters},
        {"materials", materials},
        {"settings", knobValuesJson(rs)}, {"knobs", knobFormJson()}}
        .dump();
}

std::string statusJson(const ViewerStatus& st) {
    const ViewerFrame& f = st.frame;
    nlohmann::json clients = nlohmann::json::array();
    for (const ViewerClientRow& c : st.clients)
        clients.push_back({{"id", c.id}, {"name", c.name}, {"cores", c.cores}, {"sets", c.sets},
                           {"lastMs", c.lastMs}, {"photons", c.photons}});
    const Camera& cam = st.camera;
    return nlohmann::json{
        {"type", "status"}, {"frame", f.frame}, {"epoch", f.epoch}, {"mode", proto::frameModeName(f.mode)},
        {"fps", f.fps}, {"photonsPerSet", f.photonsPerSet}, {"cap", st.settings.photons.capPhotons},
        {"M", st.settings.interleave}, {"setsArrived", f.arrived}, {"paused", st.paused},
        {"estimator", causticEstimatorName(st.settings.photons.estimator)}, {"passes", f.passes},
        {"errorEstimate", f.errorEstimate}, {"passBatches", f.passBatches},
        {"split", {{"photonMs", f.slowest.photonMs}, {"renderMs", f.slowest.renderMs},
                   {"encodeMs", f.slowest.encodeMs}, {"clientMs", f.slowest.frameMs}, {"masterMs", st.masterMs}}},
        {"slowest", f.slowestName}, {"owners", f.owners}, {"clients", clients},
        {"camera", {{"eye", vec(cam.position)}, {"forward", vec(cam.forward)}, {"up", vec(cam.up)}, {"yfov", cam.yfov}}}}
        .dump();
}

std::string replyOkJson(const std::string& what) { return nlohmann::json{{"type", "ok"}, {"what", what}}.dump(); }
std::string replyErrorJson(const std::string& message) {
    return nlohmann::json{{"type", "error"}, {"message", message}}.dump();
}
std::string replyScriptJson(const std::string& text) { return nlohmann::json{{"type", "script"}, {"text", text}}.dump(); }

}  // namespace rtpm::server
