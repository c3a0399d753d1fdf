// Validation of rendering settings at the process boundary (flags, the Settings message).
#include "common/core/render_settings.h"

#include "common/core/knobs.h"

#include <cmath>
#include <stdexcept>

namespace rtpm {

namespace {

void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("invalid setting: " + what);
}

}  // namespace

std::optional<PhotonTree> parsePhotonTree(std::string_view name) {
    if (name == "middle") return PhotonTree::MiddleSplit;
    if (name == "median") return PhotonTree::MedianBalanced;
    if (name == "grid") return PhotonTree::UniformGrid;
    return std::nullopt;
}

const char* photonTreeName(PhotonTree tree) {
    switch (tree) {
        case PhotonTree::MiddleSplit: return "middle";
        case PhotonTree::MedianBalanced: return "median";
        case PhotonTree::UniformGrid: return "grid";
    }
    return "?";
}

std::optional<CausticEstimatorKind> parseCausticEstimator(std::string_view name) {
    if (name == "progressive") return CausticEstimatorKind::Progressive;
    if (name == "knn") return CausticEstimatorKind::Knn;
    return std::nullopt;
}

const char* causticEstimatorName(CausticEstimatorKind kind) {
    switch (kind) {
        case CausticEstimatorKind::Progressive: return "progressive";
        case CausticEstimatorKind::Knn: return "knn";
    }
    return "?";
}

void validateSettings(const RenderSettings& s) {
    require(s.width >= 1 && s.width <= 16384, "width must be in [1, 16384], got " + std::to_string(s.width));
    require(s.height >= 1 && s.height <= 16384, "height must be in [1, 16384], got " + std::to_string(s.height));
    // The live knobs (M, F, k, P, r_max, index, estimator, confidence): the limits of their rows.
    for (const KnobRow& row : kKnobs)
        if (auto error = knobValueError(row, row.get(s))) require(false, *error);
    require(s.interleave <= s.width && s.interleave <= s.height,
            "interleave M = " + std::to_string(s.interleave) + " exceeds the image size");
    require(s.eye.maxDepth >= 0 && s.eye.maxDepth <= 64, "eye depth must be in [0, 64]");
    require(s.eye.areaLightSamples >= 1 && s.eye.areaLightSamples <= 256, "area light samples must be in [1, 256]");
    const PhotonSettings& p = s.photons;
    require(p.diffuseBounces <= 8, "diffuse bounces must be at most 8");
    require(p.maxDepth >= 1 && p.maxDepth <= 64, "photon path depth must be in [1, 64]");
}

std::string describeSettings(const RenderSettings& s) {
    const PhotonSettings& p = s.photons;
    RenderSettings resolved = s;
    resolved.filter = s.filterSize();  // F as the filter runs it (0 means M)
    std::string d = "--width " + std::to_string(s.width) + " --height " + std::to_string(s.height);
    for (const KnobRow& row : kKnobs)
        d += " " + std::string(row.shortFlag.empty() ? row.flag : row.shortFlag) + " " +
             formatKnobValue(row, row.get(resolved));
    d += " --cap " + std::to_string(p.capPhotons) + " --diffuse-bounces " + std::to_string(p.diffuseBounces) +
         " --depth " + std::to_string(s.eye.maxDepth) + " --photon-depth " + std::to_string(p.maxDepth) +
         " --area-samples " + std::to_string(s.eye.areaLightSamples) + " --seed " + std::to_string(p.seed);
    if (!p.selective) d += " --no-spt";
    if (p.gatherVisibility) d += " --gather-visibility";
    return d;
}

}  // namespace rtpm
