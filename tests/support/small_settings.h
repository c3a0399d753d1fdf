// Render settings for small test images: the defaults but for the size, the interleave, the
// paths per batch and the estimator a test asks for.
#pragma once

#include <cstdint>

#include "common/core/render_settings.h"

namespace rtpm::testsupport {

/// The default settings at `width`×`height` with `pathsPerBatch` paths per set and batch, M =
/// `interleave` and `estimator`.
inline RenderSettings smallSettings(int width, int height, uint32_t pathsPerBatch, int interleave,
                                    CausticEstimatorKind estimator = CausticEstimatorKind::Progressive) {
    RenderSettings rs;
    rs.width = width;
    rs.height = height;
    rs.interleave = interleave;
    rs.photons.photonsPerBatch = pathsPerBatch;
    rs.photons.estimator = estimator;
    return rs;
}

}  // namespace rtpm::testsupport
