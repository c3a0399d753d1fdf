// The settings of a render, one table row each: the live knobs (kKnobs: a running cluster may
// change them through a flag at start, an edit-script line or a viewer control) and the settings
// fixed for a run (kFixedSettings: a flag at start). Every consumer reads the rows: the
// command-line flags and their --help group, validateSettings, the image metadata, the wire's
// Settings message (proto/settings_rows.h: the rows with a wire type, in table order, each
// validated against its row's limits), and for live knobs the edit-script grammar, the viewer's
// controls and form, and what a change resets. A new setting is a row here, its RenderSettings
// field, and the code that uses it, also when it reaches the clients: for a knob of the output
// stage, writeImageFiles (common/render/image_metadata.h), which both programs write their images
// through; for one the clients obey, the code of the stage that reads it (the eye pass reads
// EyeSettings, the photon stage PhotonSettings).
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

enum class Knob : uint8_t { Interleave, Filter, Photons, K, RMax, Tree, Estimator, Confidence, Exposure, GlossySamples, FilterEdges };
inline constexpr size_t kKnobCount = 11;

/// How a row travels in the Settings message, little-endian (proto/PROTOCOL.md §5.5): an
/// unsigned integer of 1, 4 or 8 bytes, or an IEEE-754 binary32. A row's limits fit its type
/// (static_assert in proto/settings_rows.h).
enum class WireType : uint8_t {
    None = 0,  ///< not on the wire: the master's alone
    U8 = 1,    ///< a switch or a choice's index
    U32 = 2,
    U64 = 3,
    F32 = 4,
};

/// How a row's flag takes its value.
enum class FlagForm : uint8_t {
    Value,     ///< `--flag VALUE`
    Switch,    ///< `--flag` alone sets the value 1 (default 0)
    ClearSwitch,  ///< `--flag` alone sets the value 0 (default 1), e.g. --no-spt
};

/// One setting: what its flag, --help text, validation and the image metadata read. Values travel
/// as double (every integer setting fits exactly; a choice's value is the index of its name in
/// `choices`, which is its enum's value; a switch is 0 or 1).
struct SettingRow {
    std::string_view name;       ///< what --help and error messages call it
    std::string_view flag;       ///< long flag of rtpm-render and rtpm-server
    std::string_view shortFlag;  ///< short flag, or empty
    std::string_view group;      ///< --help group
    std::string_view unit;       ///< of the value, for --help
    double min, max;             ///< inclusive limits (choice knobs: first and last index)
    double defaultValue;         ///< RenderSettings{}'s value (static_assert in knobs.cpp)
    bool integer;                ///< whole numbers only
    std::array<std::string_view, 3> choices;  ///< a choice's value names in enum order; else empty
    WireType wire;               ///< its type in the Settings message (proto/PROTOCOL.md §5.5);
                                 ///< None: the master's alone (a live knob that resets only Output)
    std::string_view help;       ///< --help text (the range is appended)
    double (*get)(const RenderSettings&);
    void (*set)(RenderSettings&, double);
    FlagForm form = FlagForm::Value;

    constexpr bool isChoice() const { return !choices[0].empty(); }
};

/// One live knob: a setting a running cluster may change, with what only a live knob has.
struct KnobRow : SettingRow {
    Knob id;
    std::string_view scriptKey;  ///< keyword after `settings` in an edit script line
    std::string_view viewerKey;  ///< key of the viewer's {"type":"settings"} control
    KnobReset resets;            ///< what a change of it resets
};

// clang-format off
inline constexpr std::array<KnobRow, kKnobCount> kKnobs{{
    {{"interleave M", "--interleave", "-M", "image", "sets per side", 1, 16, 3, true, {}, WireType::U32,
      "M: the image is split into M×M interleaving sets, one photon map each",
      [](const RenderSettings& s) { return double(s.interleave); },
      [](RenderSettings& s, double v) { s.interleave = int(v); }},
     Knob::Interleave, "M", "M", KnobReset::Resize},
    {{"filter F", "--filter", "-F", "image", "pixels", 0, 64, 0, true, {}, WireType::U32,
      "F: caustic box filter size (0 = M)",
      [](const RenderSettings& s) { return double(s.filter); },
      [](RenderSettings& s, double v) { s.filter = int(v); }},
     Knob::Filter, "F", "F", KnobReset::Output},
    {{"photons P", "--photons", "-P", "photons", "paths", 1, 50'000'000, 20000, true, {}, WireType::U32,
      "P: photon paths traced per set per frame",
      [](const RenderSettings& s) { return double(s.photons.photonsPerBatch); },
      [](RenderSettings& s, double v) { s.photons.photonsPerBatch = uint32_t(v); }},
     Knob::Photons, "P", "P", KnobReset::Epoch},
    {{"k", "--k", "", "estimator", "photons", 1, 4096, 64, true, {}, WireType::U32,
      "photons per density estimate",
      [](const RenderSettings& s) { return double(s.photons.k); },
      [](RenderSettings& s, double v) { s.photons.k = uint32_t(v); }},
     Knob::K, "k", "k", KnobReset::Epoch},
    {{"gather radius r_max", "--rmax", "", "estimator", "metres", 0, 1e6, 0, false, {}, WireType::F32,
      "maximum gather radius (0 = 2% of the scene diagonal)",
      [](const RenderSettings& s) { return double(s.photons.rMax); },
      [](RenderSettings& s, double v) { s.photons.rMax = float(v); }},
     Knob::RMax, "rmax", "rmax", KnobReset::Epoch},
    {{"photon index", "--tree", "", "photons", "", 0, 2, 0, true, {"middle", "median", "grid"}, WireType::U8,
      "photon map index: middle (incremental middle-split kd-tree), median (balanced kd-tree rebuilt "
      "each frame) or grid (uniform grid rebuilt each frame)",
      [](const RenderSettings& s) { return double(s.photons.tree); },
      [](RenderSettings& s, double v) { s.photons.tree = PhotonTree(uint8_t(v)); }},
     Knob::Tree, "tree", "tree", KnobReset::Epoch},
    {{"estimator", "--estimator", "", "estimator", "", 0, 1, 0, true, {"progressive", "knn"}, WireType::U8,
      "caustic estimator: progressive (while the view is still, every photon of every pass counted, each "
      "pixel's gather disc chosen from them; converges) or knn (the paper's k nearest photons and box filter)",
      [](const RenderSettings& s) { return double(s.photons.estimator); },
      [](RenderSettings& s, double v) { s.photons.estimator = CausticEstimatorKind(uint8_t(v)); }},
     Knob::Estimator, "estimator", "estimator", KnobReset::Epoch},
    {{"confidence width", "--confidence", "", "estimator", "standard deviations", 0.001, kMaxProgressiveGamma, 1.5,
      false, {}, WireType::F32,
      "progressive: confidence width Γ by which each pixel chooses its gather disc; larger is smoother, "
      "smaller sharper",
      [](const RenderSettings& s) { return double(s.photons.progressiveGamma); },
      [](RenderSettings& s, double v) { s.photons.progressiveGamma = float(v); }},
     Knob::Confidence, "confidence", "confidence", KnobReset::Epoch},
    {{"exposure", "--exposure", "", "image", "stops", -20, 20, 0, false, {}, WireType::None,
      "exposure of the PNG and of the viewer's frames, in stops above the automatic one (which maps "
      "the 99th-percentile luminance to white); the EXR stays linear",
      [](const RenderSettings& s) { return double(s.exposure); },
      [](RenderSettings& s, double v) { s.exposure = float(v); }},
     Knob::Exposure, "exposure", "exposure", KnobReset::Output},
    {{"glossy samples", "--glossy-samples", "", "image", "rays", 1, 64, 4, true, {}, WireType::U32,
      "BSDF samples an eye path takes at each glossy (rough metal or glass) surface it meets: more "
      "is smoother, fewer is faster",
      [](const RenderSettings& s) { return double(s.eye.glossySamples); },
      [](RenderSettings& s, double v) { s.eye.glossySamples = int(v); }},
     Knob::GlossySamples, "glossy", "glossy", KnobReset::Epoch},
    {{"filter edges", "--filter-edges", "", "image", "ratio", 0, 64, 2, false, {}, WireType::None,
      "progressive: a pixel's filter window leaves out the neighbours whose caustic is more than this "
      "factor brighter or darker than its own beyond their noise (a fold line or a caustic's rim; "
      "faded from 5 % of the window's mean on), so edges stay sharp; 0 = every neighbour, the paper's box filter (knn "
      "always uses it); below 1 acts as 1",
      [](const RenderSettings& s) { return double(s.filterEdges); },
      [](RenderSettings& s, double v) { s.filterEdges = float(v); }},
     Knob::FilterEdges, "edges", "edges", KnobReset::Output},
}};

/// The settings fixed for a run (a flag at start; the edit script and the viewer cannot change
/// them): rows of the live knobs' shape without the edit-script key, viewer control and reset.
/// The flags, --help groups, validateSettings and describeSettings read them as they read kKnobs;
/// the wire's ceilings are at least their limits (static_assert in proto/bridge).
inline constexpr size_t kFixedSettingCount = 10;
inline constexpr std::array<SettingRow, kFixedSettingCount> kFixedSettings{{
    {"width", "--width", "", "image", "pixels", 1, 16384, 640, true, {}, WireType::U32,
     "image width",
     [](const RenderSettings& s) { return double(s.width); },
     [](RenderSettings& s, double v) { s.width = int(v); }},
    {"height", "--height", "", "image", "pixels", 1, 16384, 480, true, {}, WireType::U32,
     "image height",
     [](const RenderSettings& s) { return double(s.height); },
     [](RenderSettings& s, double v) { s.height = int(v); }},
    {"eye depth", "--depth", "", "image", "bounces", 0, 64, 16, true, {}, WireType::U32,
     "specular depth limit of eye paths",
     [](const RenderSettings& s) { return double(s.eye.maxDepth); },
     [](RenderSettings& s, double v) { s.eye.maxDepth = int(v); }},
    {"area light samples", "--area-samples", "", "image", "rays", 1, 256, 4, true, {}, WireType::U32,
     "shadow samples per emissive triangle for a near, large light; a small or far one takes fewer, by "
     "its solid angle (down to 1 per pixel)",
     [](const RenderSettings& s) { return double(s.eye.areaLightSamples); },
     [](RenderSettings& s, double v) { s.eye.areaLightSamples = int(v); }},
    {"diffuse bounces", "--diffuse-bounces", "", "photons", "bounces", 0, 8, 1, true, {}, WireType::U32,
     "diffuse bounces a photon may take (0 = only L S+ D caustics)",
     [](const RenderSettings& s) { return double(s.photons.diffuseBounces); },
     [](RenderSettings& s, double v) { s.photons.diffuseBounces = uint32_t(v); }},
    {"photon cap", "--cap", "", "photons", "photons", 0, double(uint64_t(1) << 30), 2'000'000, true, {},
     WireType::U32,
     "stored photons per set at which accumulation stops (0 = none)",
     [](const RenderSettings& s) { return double(s.photons.capPhotons); },
     [](RenderSettings& s, double v) { s.photons.capPhotons = uint64_t(v); }},
    {"photon depth", "--photon-depth", "", "photons", "segments", 1, 64, 16, true, {}, WireType::U32,
     "ray segments per photon path",
     [](const RenderSettings& s) { return double(s.photons.maxDepth); },
     [](RenderSettings& s, double v) { s.photons.maxDepth = uint32_t(v); }},
    {"seed", "--seed", "", "photons", "", 0, double(uint64_t(1) << 53), double(PhotonSettings{}.seed), true, {},
     WireType::U64,
     "seed of the Halton rotations",
     [](const RenderSettings& s) { return double(s.photons.seed); },
     [](RenderSettings& s, double v) { s.photons.seed = uint64_t(v); }},
    {"plain shooting", "--no-spt", "", "photons", "", 0, 1, 1, true, {}, WireType::U8,
     "plain QMC photon shooting instead of Selective Photon Tracing",
     [](const RenderSettings& s) { return s.photons.selective ? 1.0 : 0.0; },
     [](RenderSettings& s, double v) { s.photons.selective = v != 0.0; }, FlagForm::ClearSwitch},
    {"gather visibility", "--gather-visibility", "", "estimator", "", 0, 1, 0, true, {}, WireType::U8,
     "count only photons visible from the shaded point (a shadow ray per gathered photon): no caustic "
     "leaks through thin walls, k more rays per pixel",
     [](const RenderSettings& s) { return s.photons.gatherVisibility ? 1.0 : 0.0; },
     [](RenderSettings& s, double v) { s.photons.gatherVisibility = v != 0.0; }, FlagForm::Switch},
}};
// clang-format on

constexpr const KnobRow& knobRow(Knob k) { return kKnobs[size_t(k)]; }

/// The knob values an edit sets (nullopt: unchanged), indexed by Knob.
using KnobValues = std::array<std::optional<double>, kKnobCount>;

/// The error naming the knob when `value` is outside its row's limits (or not whole for an
/// integer knob, or not finite); nullopt when it fits.
std::optional<std::string> knobValueError(const SettingRow& row, double value);

/// A value as an edit script and the viewer write it: a number, or a choice knob's name;
/// nullopt when `text` is neither (the limits are not checked: knobValueError does).
std::optional<double> parseKnobValue(const SettingRow& row, std::string_view text);
/// Inverse of parseKnobValue: the shortest number that reads back to `value` (to the same float
/// when `value` is one, as the float-valued knobs store it), or the choice's name.
std::string formatKnobValue(const SettingRow& row, double value);

/// "[1, 16]" or "middle|median|grid", for --help and error messages.
std::string knobRange(const SettingRow& row);

/// The strongest reset among the knobs whose value differs between `before` and `after`;
/// nullopt when no knob changed.
std::optional<KnobReset> knobChangeReset(const RenderSettings& before, const RenderSettings& after);

}  // namespace rtpm
