// The live control: the one path every edit takes (an edit-script line, an --animate preset, a
// viewer control), the settings in force, and what the next frame must tell the clients.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/core/render_settings.h"
#include "proto/messages.h"
#include "proto/net/connection.h"
#include "server/live_scene.h"
#include "server/master.h"
#include "server/script/script_edit.h"

namespace rtpm::server {

class ImageOutput;
class Peers;

/// What a frame begins with: the messages every client gets before its FrameBegin (new Settings,
/// then one Edit per scene edit), the camera, and what the frame policy must know.
struct FrameStart {
    std::vector<net::Connection::Buffer> messages;
    proto::CameraState camera;
    uint32_t sceneVersion = 1;
    bool sceneChanged = false;  ///< a scene edit or a settings change: a new epoch
    bool sceneEdited = false;   ///< a scene edit (light, material, transform): the epoch starts with an Edit frame
    bool relit = false;         ///< every edit is a light edit (no settings change): Relight if the camera is still
    bool cameraMoved = false;   ///< a camera edit: a walkthrough frame
    bool still = false;         ///< the camera is where the previous FrameBegin had it, and no edit moved it
};

/// Owns the live scene and settings. What a settings change resets is the changed knobs' row
/// (common/core/knobs.h, KnobReset): Output and Epoch changes reach the clients at once (Epoch
/// also starts an epoch with the next frame); a Resize (M) waits until no frame is in flight
/// (resizePending, applyResize). Scene and camera edits go out with the next frame.
/// Lives on the I/O thread; not thread-safe.
class LiveControl {
public:
    /// Checks the --animate preset against the scene and dry-runs the edit script on a copy, so
    /// a bad line fails at start, not at frame n; a file scene is encoded as .glb for clients.
    /// Throws std::invalid_argument or SceneError. `options` (validated), `peers` and `output`
    /// outlive the control.
    LiveControl(const MasterOptions& options, Scene scene, Peers& peers, ImageOutput& output);

    /// The one edit path: a script line or a viewer control. Throws SceneError (nothing changes)
    /// when the edit does not fit the scene or the settings. Takes effect with the next frame;
    /// recorded as of `nextFrame` for the session script.
    void apply(const ScriptEdit& edit, const std::string& source, uint64_t nextFrame);

    /// Applies the --animate preset and the script lines of frame `frame`, then hands over what
    /// the frame begins with; nullopt while a change of M waits (nothing is taken then).
    std::optional<FrameStart> startFrame(uint64_t frame);

    bool resizePending() const { return pendingResize_.has_value(); }
    /// Puts the waiting change of M in force; the next frame sends the new Settings.
    const RenderSettings& applyResize();

    /// The settings in force.
    const RenderSettings& settings() const { return settings_; }
    /// The settings the viewer shows: a waiting change of M included.
    const RenderSettings& settingsShown() const { return pendingResize_ ? *pendingResize_ : settings_; }
    const net::Connection::Buffer& settingsMessage() const { return settingsMessage_; }
    /// The Scene message for a client joining now (file scenes as .glb, edits compacted).
    proto::Scene sceneMessage() const;
    const LiveScene& live() const { return live_; }

    bool paused() const { return paused_; }
    void setPaused(bool paused) { paused_ = paused; }

    /// Every edit applied so far, as an edit script (the viewer's "download script").
    std::string sessionScript() const;
    /// The last edit applied, as a script line.
    std::string lastEditLine() const;

private:
    void applySettings(const ScriptEdit& edit, const std::string& source);

    const MasterOptions& opt_;
    Peers& peers_;
    ImageOutput& output_;
    LiveScene live_;
    std::vector<uint8_t> glb_;  // file scenes: what clients load
    RenderSettings settings_;
    net::Connection::Buffer settingsMessage_;
    std::optional<RenderSettings> pendingResize_;  // an M change, applied once no frame is in flight
    bool settingsChanged_ = false;                 // the next frame sends Settings and starts an epoch
    std::vector<proto::SceneEdit> pendingEdits_;   // applied to live_, sent with the next frame
    bool cameraMoved_ = false;                     // the next frame is a walkthrough frame
    bool paused_ = false;
    std::vector<ScriptEdit> session_;              // every edit applied, for "download script"
    size_t scriptPos_ = 0;                         // next line of the edit script
    std::optional<proto::CameraState> previousCamera_;  // of the last FrameBegin
};

}  // namespace rtpm::server
