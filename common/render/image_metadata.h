// What made an image, written into its EXR header so a file says which scene, settings, frame
// count, estimator and version produced it (rtpm-render and rtpm-server write the same keys), and
// the one output path both programs write an image through.
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

/// Writes an image output: the EXR at `exrPath` (every layer of `image`, imageMetadata(p) in its
/// header) and the PNG beside it (the same path ending in .png), tone-mapped as `p.settings` say.
/// The one place the settings of the output stage (today the exposure knob) reach the files of
/// rtpm-render and rtpm-server: such a knob is its row (common/core/knobs.h), its RenderSettings
/// field and its use here. Returns the PNG's path; throws as writeExr and writePng do.
std::string writeImageFiles(const std::string& exrPath, const FrameImage& image, const ImageProvenance& p);

}  // namespace rtpm
