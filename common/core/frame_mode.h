// The kind of a frame — the one decision of "still" (converging) against "moving", for the master and rtpm-render.
#pragma once

#include <cstdint>

namespace rtpm {

/// What a frame does with the photon maps and the progressive estimator (docs/ARCHITECTURE.md
/// §2.1). The master decides it per frame and sends it in FrameBegin; every client renders by it
/// (RenderJob::renderFrame), and rtpm-render decides its own frames with the same function.
enum class FrameMode : uint8_t {
    Interaction = 0,  ///< first frame of an epoch: the maps start from nothing
    Accumulate = 1,   ///< one more photon batch per set, a full eye pass
    Walkthrough = 2,  ///< no shooting (the view moves, or every map is capped), a full eye pass
    Converging = 3,   ///< progressive estimator, still view: a pass at the kept eye records
    /// First frame of an epoch that a scene edit (light, material, transform) began — a settings
    /// change alone starts an Interaction frame: it is made once, not dragged: as Interaction,
    /// except that with the progressive estimator no progression starts — the caustics are the
    /// map's k-NN estimate, and the next still frame restarts — and that the eye paths sample the
    /// dielectric splits as a moving camera's do. A light or material being dragged makes every
    /// frame an epoch start: each then costs a knn frame of sampled glass, not a restart's
    /// gathers over the full split trees.
    Edit = 4,
    /// First frame of an epoch that punctual-light edits alone began, the camera where the
    /// previous frame had it: what eye rays meet is the previous frame's, so the eye paths'
    /// deterministic split trees are kept (RenderJob) and only re-lit — the light's direct
    /// light and the map's k-NN caustic at their end points. As Edit otherwise (no progression
    /// starts). A light dragged over glass then costs shadow rays and gathers, not split trees,
    /// and shows the full trees' image instead of sampled glass.
    Relight = 5,
};

/// What the frame-mode decision looks at.
struct FrameFacts {
    bool epochStart = false;   ///< first frame of an epoch (frame 0, or edits/settings come with it)
    bool edited = false;       ///< the epoch starts because of a scene edit (not settings alone)
    bool relit = false;        ///< every edit that starts the epoch moves or changes a punctual light
    bool cameraMoved = false;  ///< the camera was moved for this frame (the maps are kept)
    bool cameraStill = false;  ///< this frame's camera equals the previous frame's, bit for bit
    bool progressive = false;  ///< the progressive estimator is in use
    bool walkthrough = false;  ///< walkthrough was asked for (no shooting after the first frame)
    bool allCapped = false;    ///< every set reached its photon cap (the last batch shot nothing)
};

/// The frame's mode. The first frame of an epoch is Interaction, or Edit when an edit began the
/// epoch (Relight when only punctual-light edits did and the camera is still); a moved camera is
/// Walkthrough;
/// with the progressive estimator a still camera is Converging (unless walkthrough was asked
/// for); otherwise Walkthrough when asked for or when every map is capped, else Accumulate.
/// Pure; the single place this is decided.
constexpr FrameMode decideFrameMode(const FrameFacts& f) {
    if (f.epochStart)
        return !f.edited ? FrameMode::Interaction
                         : f.relit && f.cameraStill && !f.cameraMoved ? FrameMode::Relight : FrameMode::Edit;
    if (f.cameraMoved) return FrameMode::Walkthrough;
    if (f.progressive && f.cameraStill && !f.walkthrough) return FrameMode::Converging;
    if (f.walkthrough || f.allCapped) return FrameMode::Walkthrough;
    return FrameMode::Accumulate;
}

}  // namespace rtpm
