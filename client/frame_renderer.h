// The client's render state machine: turns the server's Settings, Scene, Edit and FrameBegin
// messages into FrameData and Stats replies, with no sockets (tests drive it directly).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/render/render_job.h"
#include "common/core/render_settings.h"
#include "common/scene/scene.h"
#include "proto/messages.h"

namespace rtpm::client {

/// Something the server sent that this client cannot use (bad scene bytes, an edit naming a
/// missing light, settings the renderer refuses, a FrameBegin that contradicts earlier messages).
/// The worker answers it with Bye{ProtocolError, what()} and exits non-zero.
struct ProtocolViolation : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// The settings a Settings message carries, checked again by validateSettings (the decoder
/// checked each row and the rule between them; a message built in memory was not decoded), a
/// refusal as ProtocolViolation.
RenderSettings toRenderSettings(const proto::Settings& settings);

/// bridge::fromWire for the camera (bit for bit, so the cluster traces the rays rtpm-render
/// traces), with its refusal of a degenerate camera as ProtocolViolation.
Camera toCamera(const proto::CameraState& camera);

/// Applies one wire edit to `scene` (bridge::fromWire, then applyEdit; camera edits change
/// nothing: FrameBegin carries the camera). On failure throws ProtocolViolation naming the edit
/// and leaves `scene` unchanged. Returns the equivalent RenderJob edit (nullopt for camera).
std::optional<SceneEdit> applyWireEdit(Scene& scene, const proto::SceneEdit& edit);

/// What to send back for one frame: one FrameData per set in FrameBegin.sets order, then Stats.
struct RenderedFrame {
    std::vector<proto::FrameData> data;
    proto::Stats stats;
};

/// Holds the scene, the settings and the photon maps of the sets this client renders.
/// One scene and one BVH (a RenderScene), shared read-only by every group's RenderJob while a
/// frame renders; an edit is applied to it once, between frames. Sets are kept in groups, one
/// RenderJob (photon maps and progressions) per group: when the server moves
/// sets at a frame boundary, a group whose sets are all still owned keeps accumulating, a group
/// that lost any set is dropped (its remaining sets restart from batch 0 in a new group, like
/// sets that moved here). So a set's photons depend only on the batches its current owner shot,
/// and frame f of an undisturbed set is bit-identical to rtpm-render's frame f.
/// Messages must be given in the order they arrived. Not thread-safe (one render thread).
class FrameRenderer {
public:
    /// `threads` is reported in Stats (the caller limits TBB). `slowdown` (tests of the master's
    /// load balance only): each frame takes that many times its work, the rest asleep and
    /// reported as eye-pass time, as on a slower machine.
    explicit FrameRenderer(uint32_t threads, double slowdown = 1.0);
    ~FrameRenderer();

    /// Takes effect at the next frame. A change of anything but f and the pixel encoding drops
    /// every photon map (new RenderJobs). Throws ProtocolViolation for unusable settings.
    void setSettings(const proto::Settings& settings);
    /// Loads the scene (built-in name, or glTF/GLB bytes), applies its edits and builds its BVH;
    /// replaces any previous scene and drops every photon map. Throws ProtocolViolation naming
    /// what is wrong. Cost: the scene load and the BVH build, O(file size + triangles log triangles).
    void setScene(const proto::Scene& scene);
    /// Queues an edit; edits apply at the next FrameBegin (docs/ARCHITECTURE.md §2: all clients
    /// switch at the same frame). Throws ProtocolViolation if its sceneVersion does not increase.
    void queueEdit(const proto::Edit& edit);
    /// Renders `frame`: applies queued edits (once, to the shared scene), resets photons when the epoch changed, adopts the
    /// frame's sets, shoots (unless Walkthrough) and traces, encodes the pixels with the settings'
    /// encoding. `received` is when the FrameBegin arrived (for Stats.frameMs).
    /// Throws ProtocolViolation when the frame contradicts what was received (no scene or
    /// settings yet, scene version mismatch, a set id ≥ M², a degenerate camera).
    /// Cost: one RenderJob::renderFrame per group (all cores) plus O(pixels) encoding.
    RenderedFrame render(const proto::FrameBegin& frame,
                         std::chrono::steady_clock::time_point received);

    /// Sets rendered by the last frame (for logs and tests).
    std::vector<uint32_t> currentSets() const;
    /// Number of RenderJob groups alive (tests check that kept sets keep their maps).
    size_t groupCount() const { return groups_.size(); }
    /// Batches shot by `set` since its map was created or reset; 0 for a set not held.
    uint32_t batches(uint32_t set) const;

private:
    struct Group;
    void adoptSets(const std::vector<uint32_t>& sets);

    uint32_t threads_;
    double slowdown_;
    std::optional<proto::Settings> wire_;
    RenderSettings settings_;
    std::shared_ptr<RenderScene> scene_;  ///< the scene with every applied edit, shared by the groups
    uint32_t sceneVersion_ = 0;
    uint32_t queuedVersion_ = 0;  ///< sceneVersion after the queued edits
    std::vector<proto::Edit> queued_;
    std::optional<uint32_t> epoch_;
    std::vector<std::unique_ptr<Group>> groups_;
    std::vector<SetPixels> scratch_;
};

}  // namespace rtpm::client
