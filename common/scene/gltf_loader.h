// glTF 2.0 (.gltf / .glb) import into the rtpm Scene model, hardened against malformed files.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/scene/scene.h"
#include "common/scene/scene_files.h"

namespace rtpm {

/// Choices a glTF file leaves to the reader.
struct GltfOptions {
    /// KHR_materials_variants: the variant whose materials the primitives use; empty: each
    /// primitive's own `material` (the default variant). A name the file does not define is an
    /// error listing the names it does.
    std::string variant;
};

/// Loads a glTF 2.0 file (`.gltf` JSON with embedded or external buffers, or `.glb`).
/// Mapping (docs/ARCHITECTURE.md §9): every primitive of a glTF mesh becomes one rtpm Mesh; every
/// node that uses the mesh adds one Instance per primitive with the node's world transform (matrix
/// or TRS). Cameras: the first perspective camera met in a depth-first traversal of the default
/// scene (glTF cameras look down local −Z with +Y up). KHR_lights_punctual: point/spot intensity in
/// W/sr, directional in W/m², times colour; spot cone angles; direction = the node's local −Z.
/// Materials: KHR_materials_unlit → unlit Diffuse; KHR_materials_transmission t > 0 → Dielectric
/// with transmission t and roughnessFactor (t < 1: the rest Lambertian with the base colour and
/// texture; KHR_materials_ior, default 1.5; absorption σ = −ln(attenuationColor)/attenuationDistance
/// from KHR_materials_volume, read whatever the thicknessFactor, because rtpm traces the real
/// geometry); metallic ≥ 0.99 → Mirror with roughnessFactor (reflectance or Schlick F0
/// baseColorFactor; a roughness outside [0, 1] is an error);
/// otherwise Diffuse with baseColorFactor times the sRGB-decoded baseColorTexture, through its
/// KHR_texture_transform. emissiveFactor × KHR_materials_emissive_strength (× emissiveTexture) →
/// emission. A mesh's uv set is the TEXCOORD_n its material's base-colour (else emissive) texture
/// names. EXT_mesh_gpu_instancing: one Instance per (instance, primitive), node transform times
/// the instance's TRS. KHR_mesh_quantization: integer POSITION/NORMAL/TEXCOORD_n of the types the
/// extension allows, dequantized at load (other types are errors naming the attribute).
/// KHR_materials_variants: `options.variant`'s mapping, else each primitive's own material.
/// KHR_materials_pbrSpecularGlossiness: converted to metallic-roughness (see
/// fromSpecularGlossiness in gltf_materials.cpp), one warning per file. Primitives other than TRIANGLES are skipped with a warning; missing
/// normals are computed (area-weighted smooth). Unsupported required extensions are errors,
/// unsupported used ones warnings (Scene::warnings); README lists every feature.
/// Throws SceneError{file, element, message} for any malformed input (bad JSON or GLB framing,
/// missing buffers, out-of-range indices, accessor bounds, wrong component types, NaN/Inf
/// vertices). Never reads outside a buffer and never allocates more than the file justifies.
/// Files: buffer and image URIs are percent-decoded (by tinygltf, which also reads `+` as a
/// space) and read through SceneFiles: only regular files inside the scene's folder or
/// `policy.allowedDirs`, symlinks resolved first; a reference outside is an error, never read.
/// Budget: the file, every external file, every data: URI (decoded size) and every decoded
/// array (accessor values, mesh arrays, textures) count against `policy.maxSceneBytes` before
/// they are allocated; transient peaks are a small multiple of it (tinygltf holds a data: URI
/// as JSON text and decoded bytes at once).
/// Thread-safe. Cost: O(file size + triangles).
Scene loadGltf(const std::string& path, const SceneInputPolicy& policy = {},
               const GltfOptions& options = {});

/// Same as loadGltf for bytes already in memory. `fileName` names the source in errors;
/// `baseDir` plays the scene folder's role for external buffer and image URIs (empty: every
/// external URI is an error). Used by the fuzz target.
Scene loadGltfFromMemory(const std::vector<uint8_t>& bytes, const std::string& fileName,
                         const std::string& baseDir, const SceneInputPolicy& policy = {},
                         const GltfOptions& options = {});

}  // namespace rtpm
