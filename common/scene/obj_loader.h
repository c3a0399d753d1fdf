// Wavefront OBJ + MTL import into the rtpm Scene model (tinyobjloader), with line-accurate errors.
//
// MTL → rtpm material mapping (OBJ has no physically based convention, so this is ours):
//   * emission: Ke (radiance W/(m²·sr)) on any material makes it an area light.
//   * Mirror when illum is 3 or 5, or when Ks ≈ 1 (max ≥ 0.99) and Kd ≈ 0 (max ≤ 0.01), or when
//     the PBR extension says Pm ≥ 0.99 and Pr ≤ 0.01; reflectance = Ks (Kd for the PBR case).
//   * Dielectric when illum is 4, 6, 7 or 9, or when d < 1 (dissolve) and Ni > 1; ior = Ni when
//     Ni > 1, otherwise 1.5 with a warning. Tf (transmission filter), when not black, is read as
//     the transmittance through 1 m of the medium: absorption σ = −ln(Tf) per metre (Tf clamped
//     to ≥ 1e-4); a black or absent Tf means no absorption.
//   * Otherwise Diffuse with albedo Kd (clamped to [0, 1]) times map_Kd (decoded through
//     stb_image, sRGB → linear). Other maps (bump, map_Ks, …) are ignored with a warning.
// OBJ carries no camera and no punctual light: the caller (loadScene) supplies defaults.
// Faces are triangulated (fan); missing normals are computed per OBJ vertex (area-weighted).
#pragma once

#include <string>

#include "common/scene/scene.h"
#include "common/scene/scene_files.h"

namespace rtpm {

/// Loads `path` (.obj) and the MTL libraries it names (relative to its directory).
/// `mtllib` and `map_Kd` files are read through SceneFiles: regular files inside the OBJ's
/// folder or `policy.allowedDirs` only (symlinks resolved first; outside is an error), and
/// the file, the MTL libraries, the parsed arrays and the textures count against
/// `policy.maxSceneBytes` before they are allocated.
/// One rtpm Mesh per (object/group, material) pair, each with one identity Instance.
/// Throws SceneError{file, element, message}; element is "line N" where the fault has a line
/// (bad number, face index out of range, NaN/Inf vertex), or the MTL material's name.
/// A missing MTL file or texture is a warning (Scene::warnings), not an error.
/// Thread-safe. Cost: O(file size).
Scene loadObj(const std::string& path, const SceneInputPolicy& policy = {});

/// Same as loadObj for OBJ text in memory named `fileName`; `baseDir` plays the OBJ folder's
/// role for `mtllib`/`map_Kd` (empty: every file reference is an error). Used by the fuzz target.
Scene loadObjFromMemory(const std::string& text, const std::string& fileName,
                        const std::string& baseDir, const SceneInputPolicy& policy = {});

}  // namespace rtpm
