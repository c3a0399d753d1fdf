// Validation of viewer controls: JSON (nlohmann) → ViewerCommand, refusing anything doubtful.
#include "server/viewer/viewer_command.h"

#include <algorithm>

#include "common/core/knobs.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <initializer_list>
#include <optional>

#include "common/core/math.h"

namespace rtpm::server {

namespace {

using nlohmann::json;

struct Refused {
    std::string why;
};

void onlyKeys(const json& j, std::initializer_list<const char*> allowed) {
    for (auto it = j.begin(); it != j.end(); ++it) {
        bool ok = it.key() == "type";
        for (const char* a : allowed) ok = ok || it.key() == a;
        if (!ok) throw Refused{"unknown field \"" + it.key() + "\""};
    }
}

double number(const json& j, const char* key, double lo, double hi) {
    const json& v = j.at(key);
    if (!v.is_number()) throw Refused{std::string("\"") + key + "\" must be a number"};
    const double x = v.get<double>();
    if (!std::isfinite(x)) throw Refused{std::string("\"") + key + "\" must be finite"};
    if (x < lo || x > hi)
        throw Refused{std::string("\"") + key + "\" must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                      "], got " + std::to_string(x)};
    return x;
}

int64_t integer(const json& j, const char* key, int64_t lo, int64_t hi) {
    const json& v = j.at(key);
    if (!v.is_number_integer()) throw Refused{std::string("\"") + key + "\" must be an integer"};
    const int64_t x = v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(INT64_MAX) ? INT64_MAX : v.get<int64_t>();
    if (x < lo || x > hi)
        throw Refused{std::string("\"") + key + "\" must be an integer in [" + std::to_string(lo) + ", " +
                      std::to_string(hi) + "], got " + std::to_string(x)};
    return x;
}

Vec3 vec3(const json& j, const char* key, double lo, double hi) {
    const json& v = j.at(key);
    if (!v.is_array() || v.size() != 3) throw Refused{std::string("\"") + key + "\" must be an array of 3 numbers"};
    Vec3 out;
    for (int i = 0; i < 3; ++i) {
        json one = json::object({{key, v[size_t(i)]}});
        out[i] = float(number(one, key, lo, hi));
    }
    return out;
}

template <class T, class F>
void optionalField(const json& j, const char* key, std::optional<T>& slot, F read) {
    if (j.contains(key)) slot = read(j, key);
}

std::string string(const json& j, const char* key, size_t maxBytes) {
    const json& v = j.at(key);
    if (!v.is_string()) throw Refused{std::string("\"") + key + "\" must be a string"};
    std::string s = v.get<std::string>();
    if (s.size() > maxBytes) throw Refused{std::string("\"") + key + "\" is too long"};
    return s;
}

constexpr double kMaxCoord = 1e6;

ViewerCommand parseObject(const json& j) {
    if (!j.is_object()) throw Refused{"a control must be a JSON object"};
    if (!j.contains("type") || !j["type"].is_string()) throw Refused{"a control needs a \"type\" string"};
    const std::string type = j["type"].get<std::string>();
    auto v3 = [](double lo, double hi) { return [lo, hi](const json& o, const char* k) { return vec3(o, k, lo, hi); }; };
    if (type == "hello") {
        onlyKeys(j, {"token"});
        return ViewerHello{j.contains("token") ? string(j, "token", 256) : ""};
    }
    if (type == "display") {
        onlyKeys(j, {"layer", "exposure"});
        ViewerDisplay d;
        const std::string layer = string(j, "layer", 32);
        if (layer == "final") d.layer = ViewerLayer::Final;
        else if (layer == "direct") d.layer = ViewerLayer::Direct;
        else if (layer == "caustic") d.layer = ViewerLayer::Caustic;
        else if (layer == "caustic_unfiltered") d.layer = ViewerLayer::CausticUnfiltered;
        else throw Refused{"\"layer\" must be final, direct, caustic or caustic_unfiltered, got \"" + layer + "\""};
        d.exposureStops = float(number(j, "exposure", -20, 20));
        return d;
    }
    if (type == "ack") {
        onlyKeys(j, {"frame"});
        return ViewerAck{uint64_t(integer(j, "frame", 0, int64_t(1) << 53))};
    }
    if (type == "pause") {
        onlyKeys(j, {"paused"});
        if (!j.contains("paused") || !j["paused"].is_boolean()) throw Refused{"\"paused\" must be true or false"};
        return ViewerPause{j["paused"].get<bool>()};
    }
    if (type == "snapshot") {
        onlyKeys(j, {});
        return ViewerSnapshot{};
    }
    if (type == "script") {
        onlyKeys(j, {});
        return ViewerScriptRequest{};
    }
    ScriptEdit e;
    e.line = 0;
    using K = ScriptEdit::Kind;
    auto index = [&] { e.index = uint32_t(integer(j, "index", 0, 1 << 20)); };
    if (type == "camera") {
        onlyKeys(j, {"eye", "target", "yfov"});
        e.kind = K::Camera;
        optionalField(j, "eye", e.camera.eye, v3(-kMaxCoord, kMaxCoord));
        optionalField(j, "target", e.camera.target, v3(-kMaxCoord, kMaxCoord));
        if (j.contains("yfov")) {
            e.camera.yfov = float(number(j, "yfov", 1e-3, kPi - 1e-3));
        }
        if (!e.camera.eye && !e.camera.target && !e.camera.yfov) throw Refused{"a camera control needs eye, target or yfov"};
    } else if (type == "light") {
        onlyKeys(j, {"index", "position", "intensity"});
        e.kind = K::Light;
        index();
        optionalField(j, "position", e.light.position, v3(-kMaxCoord, kMaxCoord));
        optionalField(j, "intensity", e.light.intensity, v3(0, 1e9));
        if (!e.light.position && !e.light.intensity) throw Refused{"a light control needs position or intensity"};
    } else if (type == "material") {
        onlyKeys(j, {"index", "color", "ior", "absorption", "emission"});
        e.kind = K::Material;
        index();
        optionalField(j, "color", e.material.color, v3(0, 1));
        if (j.contains("ior")) e.material.ior = float(number(j, "ior", 1.0, 4.0));
        optionalField(j, "absorption", e.material.absorption, v3(0, 1e6));
        optionalField(j, "emission", e.material.emission, v3(0, 1e9));
        if (!e.material.color && !e.material.ior && !e.material.absorption && !e.material.emission)
            throw Refused{"a material control needs color, ior, absorption or emission"};
    } else if (type == "transform") {
        onlyKeys(j, {"index", "translate"});
        e.kind = K::Transform;
        index();
        if (!j.contains("translate")) throw Refused{"a transform control needs translate"};
        e.transform.translate = vec3(j, "translate", -kMaxCoord, kMaxCoord);
    } else if (type == "settings") {
        // One key per live knob (common/core/knobs.h): its viewer key, its limits, its choices.
        e.kind = K::Settings;
        for (auto it = j.begin(); it != j.end(); ++it) {
            if (it.key() == "type") continue;
            const KnobRow* row = nullptr;
            for (const KnobRow& r : kKnobs)
                if (it.key() == r.viewerKey) row = &r;
            if (!row) throw Refused{"unknown field \"" + it.key() + "\""};
            const std::string key(row->viewerKey);
            std::optional<double> v;
            if (row->isChoice()) {
                const std::string t = string(j, key.c_str(), 16);
                v = parseKnobValue(*row, t);
                if (!v) throw Refused{"\"" + key + "\" must be " + knobRange(*row) + ", got \"" + t + "\""};
            } else {
                v = row->integer ? double(integer(j, key.c_str(), int64_t(row->min), int64_t(row->max)))
                                 : number(j, key.c_str(), row->min, row->max);
            }
            e.settings[size_t(row->id)] = v;
        }
        if (std::none_of(e.settings.begin(), e.settings.end(), [](const auto& v) { return v.has_value(); }))
            throw Refused{"a settings control needs one of its keys"};
    } else {
        throw Refused{"unknown control type \"" + type.substr(0, 32) + "\""};
    }
    return ViewerEdit{e};
}

}  // namespace

const char* viewerLayerName(ViewerLayer layer) {
    switch (layer) {
        case ViewerLayer::Final: return "final";
        case ViewerLayer::Direct: return "direct";
        case ViewerLayer::Caustic: return "caustic";
        case ViewerLayer::CausticUnfiltered: return "caustic_unfiltered";
    }
    return "?";
}

ViewerParse parseViewerCommand(std::string_view text) {
    if (text.size() > kMaxViewerMessageBytes)
        return {std::string("control message of ") + std::to_string(text.size()) + " bytes (limit " +
                std::to_string(kMaxViewerMessageBytes) + ")"};
    json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded()) return {std::string("control message is not valid JSON")};
    try {
        return {parseObject(j)};
    } catch (const Refused& r) {
        return {r.why};
    } catch (const json::exception& e) {
        return {std::string("bad control message: ") + e.what()};
    }
}

}  // namespace rtpm::server
