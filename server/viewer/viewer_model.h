// What the master tells viewers, as plain structs and the JSON built from them: scene, status,
// client events and replies (the inbound half of the viewer protocol is viewer_command.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/core/render_settings.h"
#include "common/scene/scene.h"
#include "proto/messages.h"

namespace rtpm::server {

/// A client joined (`why` unused) or left (`cores` unused).
struct ViewerClientEvent {
    bool joined = true;
    uint32_t id = 0;
    std::string name;
    unsigned cores = 0;
    std::string why;
};

/// One frame as the frame loop saw it when it retired.
struct ViewerFrame {
    uint64_t frame = 0;
    uint32_t epoch = 0;
    proto::FrameMode mode{};
    double fps = 0, photonsPerSet = 0;
    proto::Stats slowest;      ///< of the slowest client
    std::string slowestName;   ///< "id:name", "-" when no Stats arrived
    size_t arrived = 0;        ///< sets that arrived
    std::vector<uint32_t> owners;  ///< client asked for each set
    uint32_t passes = 0;  ///< progressive estimator: fewest passes of a set that arrived (0 = knn or a restart)
    /// Progressive estimator: the caustic's estimated relative error (0 = none: knn, no caustic).
    double errorEstimate = 0.0;
    uint32_t passBatches = 1;  ///< batches each pass of this frame shot
};

/// A client row of the status.
struct ViewerClientRow {
    uint32_t id = 0;
    std::string name;
    unsigned cores = 0;
    std::vector<uint32_t> sets;  ///< empty while no assignment covers every set
    float lastMs = 0.0f;         ///< its last frame time (0 before its first Stats)
    uint64_t photons = 0;        ///< photons stored after its last frame
};

/// The status a viewer shows under the image, published after every frame written.
struct ViewerStatus {
    ViewerFrame frame;
    double masterMs = 0.0;  ///< the master's assembly and output time of the frame
    bool paused = false;
    RenderSettings settings;  ///< the settings in force
    std::vector<ViewerClientRow> clients;
    Camera camera;
};

/// {"type":"event","what":"joined"|"left",…}.
std::string clientEventJson(const ViewerClientEvent& event);

/// {"type":"scene",…}: lights, materials and emissive instances (at most 64 of each; an emitter's
/// centre is given as loaded and now), the image size, the live knobs' values ("settings", by
/// viewer key) and the settings form ("knobs": key, name, unit, limits or choices, what a change
/// resets; one field per row of common/core/knobs.h).
std::string sceneJson(const std::string& sceneName, const Scene& loaded, const Scene& current,
                      const RenderSettings& settings);

/// {"type":"status",…}.
std::string statusJson(const ViewerStatus& status);

/// Replies to a control: {"type":"ok","what":…}, {"type":"error","message":…}, {"type":"script","text":…}.
std::string replyOkJson(const std::string& what);
std::string replyErrorJson(const std::string& message);
std::string replyScriptJson(const std::string& text);

}  // namespace rtpm::server
