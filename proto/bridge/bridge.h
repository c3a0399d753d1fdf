// The one place where wire types (proto/) and rendering types (common/) are converted, both ways.
#pragma once

#include <optional>
#include <span>

#include "common/core/frame_mode.h"
#include "common/core/pixel_radiance.h"
#include "common/photon/set_photons.h"
#include "common/scene/scene.h"
#include "common/scene/scene_edit.h"
#include "proto/messages.h"
#include "proto/pixel_codec.h"

namespace rtpm::bridge {

proto::Vec3f toWire(Vec3 v);
Vec3 fromWire(proto::Vec3f v);

/// Bit-exact camera conversion (FrameBegin and camera edits carry it).
proto::CameraState toWire(const Camera& camera);
/// Inverse of toWire(Camera). Throws std::invalid_argument for a camera validateCamera refuses
/// (common/scene/scene.h: non-finite, eye beyond kMaxWorldCoordinate, zero or parallel axes,
/// yfov outside (1e-4, 3.1)), the rule the server applied before sending it.
Camera fromWire(const proto::CameraState& camera);

/// The frame mode as FrameBegin carries it, and back (the same four values, the wire's ids).
proto::FrameMode toWire(FrameMode mode);
FrameMode fromWire(proto::FrameMode mode);

/// The wire edit that sets light / material / instance `index` of `scene` to its current value.
/// Precondition: the index exists.
proto::LightEdit lightToWire(const Scene& scene, uint32_t index);
proto::MaterialEdit materialToWire(const Scene& scene, uint32_t index);
proto::TransformEdit transformToWire(const Scene& scene, uint32_t instance);

/// The scene edit a wire edit asks for on `scene` (fields the wire does not carry — a light's
/// type and cone, a material's name and texture — are kept from `scene`); nullopt for a camera
/// edit. Throws std::invalid_argument when the index does not exist in `scene`. The result is
/// applied with applyEdit(), which validates it.
std::optional<SceneEdit> fromWire(const Scene& scene, const proto::SceneEdit& edit);

/// Shared photons (FrameBegin.shared, FrameData.shot), field for field.
proto::PhotonRecord toWire(const Photon& photon);
Photon fromWire(const proto::PhotonRecord& photon);
std::vector<proto::PhotonRecord> toWire(const std::vector<Photon>& photons);
std::vector<Photon> fromWire(const std::vector<proto::PhotonRecord>& photons);
/// The FrameBegin.shared entries as SetPhotons, and back (sets with no photon are left out).
std::vector<SetPhotons> fromWire(const std::vector<proto::SetShot>& shots);
std::vector<proto::SetShot> toWire(const std::vector<SetPhotons>& shots);
/// Sets the world-light fields of Scene message `message` (environment … environmentTexels) to
/// `environment`'s floats as they are (none, uniform radiance, or the map's texels).
void environmentToWire(const Environment& environment, proto::Scene& message);
/// The world light a Scene message carries (Environment{} for none); bit-exact inverse of
/// environmentToWire. Throws SceneError (file "scene from server") for a map
/// validateEnvironmentMap refuses (the decoder has checked sizes and finiteness already).
Environment environmentFromWire(const proto::Scene& message);

/// Codec views over the renderer's and the master's pixel buffers (no copy).
proto::ConstPixelView pixelView(std::span<const PixelRadiance> pixels);
proto::PixelView pixelView(std::span<PixelRadiance> pixels);

}  // namespace rtpm::bridge
