// Encoded images (PNG, JPEG, …) to linear RGB textures, shared by the glTF and OBJ loaders.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/scene/scene.h"
#include "common/scene/scene_files.h"

namespace rtpm {

/// Decodes an encoded image (PNG, JPEG, BMP, TGA, … any format stb_image reads, recognised by its
/// signature) holding sRGB colour to a linear RGB Texture (grey replicated, alpha dropped).
/// `formatHint` (a file name or extension) names the expected format in error messages.
/// Throws SceneError{file, element, …} for undecodable or absurdly large (> 2^26 texels) images.
/// When `files` is given, the decoded texture (width·height·3 floats) is charged to its budget
/// before any pixel is decoded; the decode needs as much again while it runs. `srgb` false keeps
/// the stored values (data such as glTF's metallic-roughness texture), scaled to [0, 1].
Texture decodeSrgbTexture(const std::vector<uint8_t>& encoded, const std::string& formatHint,
                          const std::string& file, const std::string& element,
                          SceneFiles* files = nullptr, bool srgb = true);

}  // namespace rtpm
