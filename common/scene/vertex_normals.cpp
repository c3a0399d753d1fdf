// Area-weighted smooth vertex normals.
#include "common/scene/vertex_normals.h"

#include <cmath>

namespace rtpm {

std::vector<Vec3> smoothVertexNormals(const std::vector<Vec3>& positions,
                                      const std::vector<uint32_t>& indices) {
    std::vector<Vec3> n(positions.size(), Vec3(0.0f));
    for (size_t t = 0; t + 2 < indices.size(); t += 3) {
        Vec3 a = positions[indices[t]], b = positions[indices[t + 1]], c = positions[indices[t + 2]];
        Vec3 g = glm::cross(b - a, c - a);
        n[indices[t]] += g;
        n[indices[t + 1]] += g;
        n[indices[t + 2]] += g;
    }
    for (Vec3& v : n) {
        float len = glm::length(v);
        v = len > 0.0f && std::isfinite(len) ? v / len : Vec3(0.0f, 0.0f, 1.0f);
    }
    return n;
}

}  // namespace rtpm
