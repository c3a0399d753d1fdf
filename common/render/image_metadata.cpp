// The EXR header attributes that say what made an image (image_metadata.h).
#include "common/render/image_metadata.h"

#include "common/core/version.h"

namespace rtpm {

ExrAttributes imageMetadata(const ImageProvenance& p) {
    return {
        {"rtpm:program", p.program},
        {"rtpm:scene", p.scene},
        {"rtpm:resolution", std::to_string(p.settings.width) + "x" + std::to_string(p.settings.height)},
        {"rtpm:settings", describeSettings(p.settings)},
        {"rtpm:estimator", causticEstimatorName(p.settings.photons.estimator)},
        {"rtpm:frames", std::to_string(p.frames)},
        {"rtpm:photons", std::to_string(p.photonsStored)},
        {"rtpm:version", rtpmVersion()},
        {"rtpm:commit", rtpmCommit()},
    };
}

}  // namespace rtpm
