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
    for (const SettingRow& row : kFixedSettings)
        if (auto error = knobValueError(row, row.get(s))) require(false, *error);
    for (const KnobRow& row : kKnobs)
        if (auto error = knobValueError(row, row.get(s))) require(false, *error);
    require(s.interleave <= s.width && s.interleave <= s.height,
            "interleave M = " + std::to_string(s.interleave) + " exceeds the image size");
}

static_assert(kFixedSettings[0].flag == "--width" && kFixedSettings[1].flag == "--height",
              "describeSettings names the image size first");

std::string describeSettings(const RenderSettings& s) {
    RenderSettings resolved = s;
    resolved.filter = s.filterSize();  // F as the filter runs it (0 means M)
    std::string d;
    auto describe = [&](const SettingRow& row) {
        const double v = row.get(resolved);
        if (row.form != FlagForm::Value) {
            if (v != row.defaultValue) d += (d.empty() ? "" : " ") + std::string(row.flag);
            return;
        }
        d += (d.empty() ? "" : " ") + std::string(row.shortFlag.empty() ? row.flag : row.shortFlag) + " " +
             formatKnobValue(row, v);
    };
    describe(kFixedSettings[0]);  // --width
    describe(kFixedSettings[1]);  // --height
    for (const KnobRow& row : kKnobs) describe(row);
    for (size_t i = 2; i < kFixedSettingCount; ++i) describe(kFixedSettings[i]);
    return d;
}

}  // namespace rtpm
