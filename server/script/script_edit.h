// The edit-script grammar: one ScriptEdit per line, parsed and formatted without a scene.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/core/knobs.h"
#include "common/core/render_settings.h"
#include "common/scene/scene.h"

namespace rtpm::server {

/// One line of an edit script. Grammar (one edit per line; `#` starts a comment; blank lines are
/// ignored; numbers are decimal floats; every keyword below is optional, at least one is needed,
/// and what a line does not mention keeps its current value):
///
///     frame <n> camera [eye x y z] [target x y z] [yfov radians]
///     frame <n> light <i> [position x y z] [direction x y z] [intensity r g b]
///     frame <n> material <i> [type diffuse|mirror|dielectric] [color r g b] [ior v]
///                            [absorption r g b] [emission r g b]
///     frame <n> transform <i> [translate x y z] [rotate ax ay az degrees] [scale s]
///                             [matrix m0 … m15]
///     frame <n> settings [<key> <value>]…   (one pair per live knob: common/core/knobs.h,
///                                            e.g. M 4 F 0 k 32 P 20000 rmax 0.05 tree grid
///                                            estimator knn)
///
/// `transform` builds T·R·S from its keywords and applies it to the instance's transform as
/// loaded (not to the current one), so a script can state absolute poses; `matrix` (16 floats,
/// column-major object → world) replaces the loaded transform and excludes the other three.
/// `camera eye` alone translates the camera (orientation kept); with `target` the camera looks at
/// that point (up stays near +Y). `settings` changes live knobs (their keys, values and limits
/// are the rows of common/core/knobs.h; what a change resets is the row's too). Edits take
/// effect at the start of frame n.
struct ScriptEdit {
    enum class Kind { Camera, Light, Material, Transform, Settings };
    /// The keywords of each kind (only the kind's own group is set).
    struct CameraKeys {
        std::optional<Vec3> eye, target;
        std::optional<float> yfov;
    };
    struct LightKeys {
        std::optional<Vec3> position, direction, intensity;
    };
    struct MaterialKeys {
        std::optional<MaterialType> type;
        std::optional<Vec3> color, absorption, emission;
        std::optional<float> ior;
    };
    struct TransformKeys {
        std::optional<Vec3> translate;
        std::optional<glm::vec4> rotate;  ///< axis xyz, angle in degrees
        std::optional<float> scale;
        std::optional<Mat4> matrix;
    };

    uint64_t frame = 0;
    int line = 0;  ///< 1-based line in the file, for error messages
    Kind kind = Kind::Camera;
    uint32_t index = 0;  ///< light, material or instance index

    CameraKeys camera;
    LightKeys light;
    MaterialKeys material;
    TransformKeys transform;
    KnobValues settings;  ///< settings: the live knobs this edit sets

    std::optional<double> knob(Knob k) const { return settings[size_t(k)]; }
};

/// Largest edit script file read, and most edits one script may hold (each ScriptEdit is a few
/// hundred bytes): a script beyond either is refused before it can take the master's memory.
constexpr uint64_t kMaxScriptBytes = uint64_t(16) << 20;
constexpr size_t kMaxScriptEdits = 250000;

/// One script line (without a trailing newline) that parseEditScript reads back as `edit`
/// (floats printed with 9 significant digits, so the round trip is exact). Pure.
std::string formatScriptEdit(const ScriptEdit& edit);

/// Applies the settings keywords of a Kind::Settings edit to `settings` and validates the result
/// (validateSettings); throws SceneError{fileName, "line N", …} and leaves `settings` unchanged
/// when the result is refused. Pure.
void applySettingsEdit(const ScriptEdit& edit, const std::string& fileName, RenderSettings& settings);

/// Parses a whole script. Throws SceneError{fileName, "line N", what is wrong} on the first bad
/// line (unknown keyword, missing or non-finite number, trailing words, negative frame…, more
/// than kMaxScriptEdits edits).
/// Edits come back sorted by frame (stable: lines of one frame keep their order). Pure.
std::vector<ScriptEdit> parseEditScript(std::string_view text, const std::string& fileName);

/// Reads and parses a script file; SceneError{path, "file", …} if it cannot be read, is not a
/// regular file or is larger than kMaxScriptBytes (checked before reading).
std::vector<ScriptEdit> loadEditScript(const std::string& path);

}  // namespace rtpm::server
