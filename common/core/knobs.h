// The live knobs — the settings a running cluster may change (a flag at start, an edit-script
// line, a viewer control) — one table row each. Every consumer reads its row: the command-line
// flags and their --help group, validateSettings, the wire limits (static_assert in proto/bridge),
// the edit-script grammar, the viewer's controls and form, and what a change resets.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "common/core/render_settings.h"

namespace rtpm {

/// What a change of a knob costs a running cluster (ordered: a later one includes the earlier).
enum class KnobReset : uint8_t {
    Output,  ///< only the master's output stage changes (the box filter): no new epoch
    Epoch,   ///< clients get new Settings and the next frame starts an epoch (photon maps restart)
    Resize,  ///< every structure sized by M² is rebuilt once no frame is in flight, then an epoch
};

enum class Knob : uint8_t { Interleave, Filter, Photons, K, RMax, Tree, Estimator, Confidence };
inline constexpr size_t kKnobCount = 8;

/// One live knob. Values travel as double (every integer knob fits exactly; a choice knob's
/// value is the index of its name in `choices`, which is its enum's value).
struct KnobRow {
    Knob id;
    std::string_view name;       ///< what --help and error messages call it
    std::string_view flag;       ///< long flag of rtpm-render and rtpm-server
    std::string_view shortFlag;  ///< short flag, or empty
    std::string_view group;      ///< --help group
    std::string_view unit;       ///< of the value, for --help
    double min, max;             ///< inclusive limits (choice knobs: first and last index)
    double defaultValue;         ///< RenderSettings{}'s value (static_assert in knobs.cpp)
    bool integer;                ///< whole numbers only
    std::array<std::string_view, 3> choices;  ///< a choice knob's value names in enum order; else empty
    std::string_view wireField;  ///< the Settings field that carries it (PROTOCOL.md §4)
    std::string_view scriptKey;  ///< keyword after `settings` in an edit script line
    std::string_view viewerKey;  ///< key of the viewer's {"type":"settings"} control
    KnobReset resets;            ///< what a change of it resets
    std::string_view help;       ///< --help text (the range is appended)
    double (*get)(const RenderSettings&);
    void (*set)(RenderSettings&, double);

    constexpr bool isChoice() const { return !choices[0].empty(); }
};

// clang-format off
inline constexpr std::array<KnobRow, kKnobCount> kKnobs{{
    {Knob::Interleave, "interleave M", "--interleave", "-M", "image", "sets per side",
     1, 16, 3, true, {}, "Settings.m", "M", "M", KnobReset::Resize,
     "M: the image is split into M×M interleaving sets, one photon map each",
     [](const RenderSettings& s) { return double(s.interleave); },
     [](RenderSettings& s, double v) { s.interleave = int(v); }},
    {Knob::Filter, "filter F", "--filter", "-F", "image", "pixels",
     0, 64, 0, true, {}, "Settings.f", "F", "F", KnobReset::Output,
     "F: caustic box filter size (0 = M)",
     [](const RenderSettings& s) { return double(s.filter); },
     [](RenderSettings& s, double v) { s.filter = int(v); }},
    {Knob::Photons, "photons P", "--photons", "-P", "photons", "paths",
     1, 50'000'000, 20000, true, {}, "Settings.photonsPerBatch", "P", "P", KnobReset::Epoch,
     "P: photon paths traced per set per frame",
     [](const RenderSettings& s) { return double(s.photons.photonsPerBatch); },
     [](RenderSettings& s, double v) { s.photons.photonsPerBatch = uint32_t(v); }},
    {Knob::K, "k", "--k", "", "estimator", "photons",
     1, 4096, 64, true, {}, "Settings.k", "k", "k", KnobReset::Epoch,
     "photons per density estimate",
     [](const RenderSettings& s) { return double(s.photons.k); },
     [](RenderSettings& s, double v) { s.photons.k = uint32_t(v); }},
    {Knob::RMax, "gather radius r_max", "--rmax", "", "estimator", "metres",
     0, 1e6, 0, false, {}, "Settings.rMax", "rmax", "rmax", KnobReset::Epoch,
     "maximum gather radius (0 = 2% of the scene diagonal)",
     [](const RenderSettings& s) { return double(s.photons.rMax); },
     [](RenderSettings& s, double v) { s.photons.rMax = float(v); }},
    {Knob::Tree, "photon index", "--tree", "", "photons", "",
     0, 2, 0, true, {"middle", "median", "grid"}, "Settings.tree", "tree", "tree", KnobReset::Epoch,
     "photon map index: middle (incremental middle-split kd-tree), median (balanced kd-tree rebuilt "
     "each frame) or grid (uniform grid rebuilt each frame)",
     [](const RenderSettings& s) { return double(s.photons.tree); },
     [](RenderSettings& s, double v) { s.photons.tree = PhotonTree(uint8_t(v)); }},
    {Knob::Estimator, "estimator", "--estimator", "", "estimator", "",
     0, 1, 0, true, {"progressive", "knn"}, "Settings.estimator", "estimator", "estimator", KnobReset::Epoch,
     "caustic estimator: progressive (while the view is still, every photon of every pass counted, each "
     "pixel's gather disc chosen from them; converges) or knn (the paper's k nearest photons and box filter)",
     [](const RenderSettings& s) { return double(s.photons.estimator); },
     [](RenderSettings& s, double v) { s.photons.estimator = CausticEstimatorKind(uint8_t(v)); }},
    {Knob::Confidence, "confidence width", "--confidence", "", "estimator", "standard deviations",
     0.001, kMaxProgressiveGamma, 1.5, false, {}, "Settings.progressiveGamma", "confidence", "confidence",
     KnobReset::Epoch,
     "progressive: confidence width Γ by which each pixel chooses its gather disc; larger is smoother, "
     "smaller sharper",
     [](const RenderSettings& s) { return double(s.photons.progressiveGamma); },
     [](RenderSettings& s, double v) { s.photons.progressiveGamma = float(v); }},
}};
// clang-format on

constexpr const KnobRow& knobRow(Knob k) { return kKnobs[size_t(k)]; }

/// The knob values an edit sets (nullopt: unchanged), indexed by Knob.
using KnobValues = std::array<std::optional<double>, kKnobCount>;

/// The error naming the knob when `value` is outside its row's limits (or not whole for an
/// integer knob, or not finite); nullopt when it fits.
std::optional<std::string> knobValueError(const KnobRow& row, double value);

/// A value as an edit script and the viewer write it: a number, or a choice knob's name;
/// nullopt when `text` is neither (the limits are not checked: knobValueError does).
std::optional<double> parseKnobValue(const KnobRow& row, std::string_view text);
/// Inverse of parseKnobValue: the shortest number that reads back to `value` (to the same float
/// when `value` is one, as the float-valued knobs store it), or the choice's name.
std::string formatKnobValue(const KnobRow& row, double value);

/// "[1, 16]" or "middle|median|grid", for --help and error messages.
std::string knobRange(const KnobRow& row);

/// The strongest reset among the knobs whose value differs between `before` and `after`;
/// nullopt when no knob changed.
std::optional<KnobReset> knobChangeReset(const RenderSettings& before, const RenderSettings& after);

}  // namespace rtpm
