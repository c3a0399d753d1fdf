// Smooth vertex normals for meshes that carry none, shared by the glTF and OBJ loaders.
#pragma once

#include <cstdint>
#include <vector>

#include "common/scene/scene.h"

namespace rtpm {

/// Area-weighted smooth vertex normals: every triangle adds its unnormalised geometric normal
/// (so its area) to its three vertices; vertices touched by no non-degenerate triangle get +Z.
/// Used by every loader and builder. Cost O(vertices + indices). Precondition: indices valid.
std::vector<Vec3> smoothVertexNormals(const std::vector<Vec3>& positions,
                                      const std::vector<uint32_t>& indices);

}  // namespace rtpm
