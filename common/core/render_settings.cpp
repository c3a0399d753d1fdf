// Validation of rendering settings at the process boundary (flags, the Settings message).
#include "common/core/render_settings.h"

#include <cmath>
#include <cstdio>
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
    require(s.interleave >= 1 && s.interleave <= 16,
            "interleave M must be in [1, 16], got " + std::to_string(s.interleave));
    require(s.interleave <= s.width && s.interleave <= s.height,
            "interleave M = " + std::to_string(s.interleave) + " exceeds the image size");
    require(s.filter >= 0 && s.filter <= 64, "filter F must be in [0, 64] (0 = M), got " + std::to_string(s.filter));
    require(s.eye.maxDepth >= 0 && s.eye.maxDepth <= 64, "eye depth must be in [0, 64]");
    require(s.eye.areaLightSamples >= 1 && s.eye.areaLightSamples <= 256, "area light samples must be in [1, 256]");
    const PhotonSettings& p = s.photons;
    require(p.photonsPerBatch <= 50'000'000, "photons per set per frame must be at most 5e7");
    require(p.k >= 1 && p.k <= 4096, "k must be in [1, 4096], got " + std::to_string(p.k));
    require(std::isfinite(p.rMax) && p.rMax >= 0.0f, "r_max must be finite and >= 0 (0 = automatic)");
    require(p.diffuseBounces <= 8, "diffuse bounces must be at most 8");
    require(p.maxDepth >= 1 && p.maxDepth <= 64, "photon path depth must be in [1, 64]");
    require(p.estimator == CausticEstimatorKind::Progressive || p.estimator == CausticEstimatorKind::Knn,
            "estimator must be progressive or knn");
    require(p.progressiveGamma > 0.0f && p.progressiveGamma <= kMaxProgressiveGamma,
            "progressive confidence width must be in (0, 16], got " + std::to_string(p.progressiveGamma));
}

std::string describeSettings(const RenderSettings& s) {
    const PhotonSettings& p = s.photons;
    char rMax[32], confidence[32];
    std::snprintf(rMax, sizeof rMax, "%g", double(p.rMax));
    std::snprintf(confidence, sizeof confidence, "%g", double(p.progressiveGamma));
    std::string d = "--width " + std::to_string(s.width) + " --height " + std::to_string(s.height) + " -M " +
                    std::to_string(s.interleave) + " -F " + std::to_string(s.filterSize()) + " -P " +
                    std::to_string(p.photonsPerBatch) + " --k " + std::to_string(p.k) + " --rmax " + rMax +
                    " --cap " + std::to_string(p.capPhotons) + " --diffuse-bounces " +
                    std::to_string(p.diffuseBounces) + " --depth " + std::to_string(s.eye.maxDepth) +
                    " --photon-depth " + std::to_string(p.maxDepth) + " --area-samples " +
                    std::to_string(s.eye.areaLightSamples) + " --seed " + std::to_string(p.seed) + " --tree " +
                    photonTreeName(p.tree) + " --estimator " + causticEstimatorName(p.estimator) +
                    " --confidence " + confidence;
    if (!p.selective) d += " --no-spt";
    if (p.gatherVisibility) d += " --gather-visibility";
    return d;
}

}  // namespace rtpm
