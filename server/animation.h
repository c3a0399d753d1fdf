// The --animate presets: the state at frame n as a function of the loaded scene.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "common/scene/scene.h"
#include "proto/messages.h"
#include "server/live_scene.h"

namespace rtpm::server {

/// --animate presets. Each gives the state at frame `frame` as a function of the loaded scene
/// (no drift over long runs):
///  * Orbit: the camera turns 3° per frame about the vertical axis through the scene's centre;
///    no scene edit (photons keep accumulating: camera moves never reset).
///  * Light: the first punctual light circles 6° per frame on a horizontal circle of radius 10 %
///    of the scene diagonal through its loaded position; without a punctual light the instance
///    carrying the first emissive material moves on that circle instead.
///  * Ior: the first dielectric material's index of refraction oscillates ±0.2 around its loaded
///    value with a period of 60 frames.
///  * Object: the first instance with a specular (mirror or dielectric) material spins 3° per
///    frame about the vertical axis through its centre.
/// Scene-changing presets edit every frame ≥ 1, so every frame is a new epoch (interaction mode).
enum class Animation { None, Orbit, Light, Ior, Object };

/// Parses "orbit", "light", "ior", "object" (or "" / "none"); std::nullopt otherwise.
std::optional<Animation> parseAnimation(std::string_view name);

/// Frames after which every preset repeats (Light and Ior: 60, Orbit and Object: 120).
constexpr uint64_t kAnimationPeriod = 120;

/// Throws std::invalid_argument naming what is missing when `scene` cannot be animated so, and
/// SceneError when a frame of the preset would break the scene rules (every state of the
/// preset, frames 1…kAnimationPeriod, is tried on a copy). Cost: kAnimationPeriod edits.
void checkAnimation(Animation a, const Scene& scene);

/// Applies preset `a` for `frame` to `live` (camera or scene) and appends scene edits to `out`.
/// Frame 0 is the scene as loaded: nothing happens. Precondition: checkAnimation passed.
void animate(Animation a, uint64_t frame, LiveScene& live, std::vector<proto::SceneEdit>& out);

}  // namespace rtpm::server
