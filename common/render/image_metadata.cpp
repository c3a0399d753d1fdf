// The EXR header attributes that say what made an image (image_metadata.h).
#include "common/render/image_metadata.h"

#include <filesystem>
#include <future>

#include "common/core/version.h"
#include "common/image/frame_image.h"

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

std::string writeImageFiles(const std::string& exrPath, const FrameImage& image, const ImageProvenance& p) {
    const std::string png = std::filesystem::path(exrPath).replace_extension(".png").string();
    // The PNG is compressed while the EXR is: a run's last step waits for the slower of the two,
    // not for their sum (or after it, where no thread can be started: deferred). Should the EXR
    // fail, the PNG's thread still ends before its error leaves.
    auto pngWritten = std::async(std::launch::async | std::launch::deferred, [&] {
        writePng(png, image.width(), image.height(), image.final(), ToneMap{.stopsAboveAuto = p.settings.exposure});
    });
    writeExr(exrPath, image, false, imageMetadata(p));
    pngWritten.get();
    return png;
}

}  // namespace rtpm
