// Writes a Scene as a binary glTF 2.0 (.glb) file that rtpm's own loader reads back unchanged.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/scene/scene.h"

namespace rtpm {

/// Encodes `scene` as GLB bytes. One glTF mesh (one primitive) per rtpm Mesh, one node per
/// Instance (matrix), one node per light (KHR_lights_punctual; intensity = max channel, colour
/// = intensity / max, so colour × intensity is exact) and one for the camera. Materials follow
/// docs/ARCHITECTURE.md §9 in reverse: Mirror → metallic 1 / its roughness; Dielectric → its roughness,
/// KHR_materials_transmission (its factor) + KHR_materials_ior + KHR_materials_volume
/// (attenuationColor = exp(−σ·d) with d = 1 m); emission → emissiveFactor ×
/// KHR_materials_emissive_strength (× emissiveTexture); unlit → KHR_materials_unlit (required);
/// base-colour texture transforms → KHR_texture_transform (uv set 0); textures embedded as
/// 8-bit sRGB PNG (so a texture survives the trip only up to 8-bit quantisation). The scene's
/// extras say "rtpm_world": "none" when it has no world light; with `withWorld` a world light is
/// written there too (a uniform radiance, or the map's float32 texels in a buffer view: bit for
/// bit), without it left out (the cluster's wire carries it apart). Throws SceneError if the
/// scene fails Scene::validate. Cost O(scene size).
std::vector<uint8_t> encodeGlb(const Scene& scene, bool withWorld = false);

/// Writes encodeGlb(scene, true) to `path`. Throws OutputError (common/core/output_file.h) when it
/// cannot write, SceneError as encodeGlb.
void exportGlb(const Scene& scene, const std::string& path);

}  // namespace rtpm
