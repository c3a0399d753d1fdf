// What made an image, written into its EXR header so a file says which scene, settings, frame
// count, estimator and version produced it (rtpm-render and rtpm-server write the same keys).
#pragma once

#include <cstdint>
#include <string>

#include "common/core/render_settings.h"
#include "common/image/image_io.h"

namespace rtpm {

/// The run an image comes from.
struct ImageProvenance {
    std::string program;         ///< "rtpm-render", "rtpm-server"
    std::string scene;           ///< built-in name or the scene file's path, as given
    RenderSettings settings;     ///< at the frame written
    uint64_t frames = 0;         ///< frames rendered up to and including this one
    uint64_t photonsStored = 0;  ///< photons in the maps of every set at this frame
};

/// The EXR string attributes of `p`: rtpm:program, rtpm:scene, rtpm:resolution ("640x480"),
/// rtpm:settings (describeSettings), rtpm:estimator, rtpm:frames, rtpm:photons, rtpm:version,
/// rtpm:commit.
ExrAttributes imageMetadata(const ImageProvenance& p);

}  // namespace rtpm
