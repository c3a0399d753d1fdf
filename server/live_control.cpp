// The one edit path and the settings in force; what each frame begins with.
#include "server/live_control.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <variant>

#include "common/core/knobs.h"
#include "common/scene/gltf_export.h"
#include "proto/bridge/bridge.h"
#include "server/animation.h"
#include "server/image_output.h"
#include "server/peers.h"

namespace rtpm::server {

namespace {

net::Connection::Buffer encodeSettings(const RenderSettings& s, proto::PixelEncoding encoding) {
    return std::make_shared<const std::vector<uint8_t>>(proto::encode(proto::Settings{encoding, s}));
}

}  // namespace

LiveControl::LiveControl(const MasterOptions& options, Scene scene, Peers& peers, ImageOutput& output)
    : opt_(options),
      peers_(peers),
      output_(output),
      live_(std::move(scene)),
      settings_(options.settings),
      settingsMessage_(encodeSettings(options.settings, options.encoding)) {
    checkAnimation(opt_.animation, live_.scene());
    {
        LiveScene dry(live_.loaded());
        RenderSettings drySettings = opt_.settings;
        std::vector<proto::SceneEdit> sink;
        for (const ScriptEdit& e : opt_.script) {
            if (e.kind == ScriptEdit::Kind::Settings) applySettingsEdit(e, opt_.scriptFile, drySettings);
            else dry.apply(e, opt_.scriptFile, sink);
        }
    }
    if (!opt_.builtin || !live_.loaded().environment.empty()) {
        if (!opt_.builtin) glb_ = encodeGlb(live_.loaded());
        auto probe = proto::tryEncode(sceneMessage());
        if (!probe.ok()) throw std::invalid_argument("scene too large to send: " + probe.error().message);
    }
}

proto::Scene LiveControl::sceneMessage() const {
    proto::Scene m;
    m.sceneVersion = live_.version();
    if (opt_.builtin) {
        m.source = proto::Scene::Source::Builtin;
        m.builtinName = opt_.sceneName;
    } else {
        m.source = proto::Scene::Source::Gltf;
        m.gltf = glb_;
    }
    m.edits = live_.compactedEdits();
    bridge::environmentToWire(live_.loaded().environment, m);
    return m;
}

void LiveControl::apply(const ScriptEdit& e, const std::string& source, uint64_t nextFrame) {
    if (e.kind == ScriptEdit::Kind::Settings) {
        applySettings(e, source);
    } else {
        live_.apply(e, source, pendingEdits_);
        if (e.kind == ScriptEdit::Kind::Camera) cameraMoved_ = true;
    }
    ScriptEdit recorded = e;
    recorded.frame = nextFrame;
    session_.push_back(recorded);
}

// What a change resets is the changed knobs' rows' (common/core/knobs.h): a resize waits for the
// frames in flight; any other change is sent to the clients now, and an epoch starts with the
// next frame unless only the master's output stage changed.
void LiveControl::applySettings(const ScriptEdit& e, const std::string& source) {
    RenderSettings s = settingsShown();
    applySettingsEdit(e, source, s);
    const std::optional<KnobReset> reset = knobChangeReset(settings_, s);
    if (reset == KnobReset::Resize || pendingResize_) {
        pendingResize_ = s;
        return;
    }
    if (s.filterSize() != settings_.filterSize()) output_.reconfigure(s.interleave, s.filterSize());
    settings_ = s;
    settingsMessage_ = encodeSettings(settings_, opt_.encoding);
    peers_.sendToAll(settingsMessage_);
    settingsChanged_ = settingsChanged_ || (reset && *reset >= KnobReset::Epoch);
}

const RenderSettings& LiveControl::applyResize() {
    settings_ = *pendingResize_;
    pendingResize_.reset();
    settingsMessage_ = encodeSettings(settings_, opt_.encoding);
    settingsChanged_ = true;
    return settings_;
}

std::optional<FrameStart> LiveControl::startFrame(uint64_t f) {
    std::vector<proto::SceneEdit> edits;
    animate(opt_.animation, f, live_, edits);
    while (scriptPos_ < opt_.script.size() && opt_.script[scriptPos_].frame <= f) {
        try {
            apply(opt_.script[scriptPos_++], opt_.scriptFile, f);  // validated by the dry run
        } catch (const SceneError& e) {
            std::fprintf(stderr, "rtpm-server: edit script: %s\n", e.what());
        }
    }
    if (pendingResize_) return std::nullopt;  // an M change waits for the frames in flight
    edits.insert(edits.end(), pendingEdits_.begin(), pendingEdits_.end());
    pendingEdits_.clear();
    FrameStart start;
    if (settingsChanged_) start.messages.push_back(settingsMessage_);
    // Every client gets the edits before the FrameBegin of the new epoch (flow §6).
    for (const proto::SceneEdit& e : edits) {
        live_.record(e);
        start.messages.push_back(
            std::make_shared<const std::vector<uint8_t>>(proto::encode(proto::Edit{live_.version(), e})));
    }
    start.camera = bridge::toWire(live_.camera());
    const bool still = previousCamera_ && *previousCamera_ == start.camera;
    previousCamera_ = start.camera;
    start.sceneVersion = live_.version();
    start.sceneChanged = !edits.empty() || settingsChanged_;
    start.sceneEdited = !edits.empty();
    start.relit = !edits.empty() && !settingsChanged_ &&
                  std::all_of(edits.begin(), edits.end(),
                              [](const proto::SceneEdit& e) { return std::holds_alternative<proto::LightEdit>(e); });
    start.cameraMoved = cameraMoved_;
    start.still = still && !cameraMoved_;
    settingsChanged_ = false;
    cameraMoved_ = false;
    return start;
}

std::string LiveControl::sessionScript() const {
    std::string text = "# rtpm edit script recorded by the viewer: replay with\n# rtpm-server --scene " +
                       opt_.sceneName + " --edit-script FILE";
    if (opt_.animation != Animation::None) text += "  (this session also ran an --animate preset)";
    text += "\n";
    for (const ScriptEdit& e : session_) text += formatScriptEdit(e) + "\n";
    return text;
}

std::string LiveControl::lastEditLine() const { return session_.empty() ? "" : formatScriptEdit(session_.back()); }

}  // namespace rtpm::server
