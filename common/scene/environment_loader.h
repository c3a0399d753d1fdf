// The world light a user asks for (--env, --env-color, --env-strength) turned into an Environment,
// and the default sky of a scene without lights.
#pragma once

#include <string>

#include "common/scene/environment.h"

namespace rtpm {

/// A world light given on the command line: an equirectangular map file, or a uniform colour.
struct EnvironmentOverride {
    /// OpenEXR (.exr) or Radiance (.hdr) file of linear radiance, equirectangular (width = 2·height,
    /// Environment's mapping). Empty: the uniform `colour`.
    std::string file;
    Vec3 colour{0.0f};     ///< uniform radiance W/(m²·sr) per channel, when `file` is empty
    float strength = 1.0f; ///< multiplies the map or the colour, in [0, kMaxRadiantValue]
};

/// Reads and checks the world light of `request`: the file is read as a regular file (from any folder:
/// the user named it) and, with the decoded texels, counts against `budgetBytes` (what
/// --max-scene-bytes leaves after the scene) before anything is allocated. Throws
/// SceneError{file, "environment", …}: missing or unreadable file, not EXR or HDR, not
/// equirectangular, too large, a NaN, infinite or negative texel (named by column and row), a
/// non-finite or negative colour or strength. Cost O(texels).
Environment loadEnvironment(const EnvironmentOverride& request, uint64_t budgetBytes);

/// The sky a scene without any light gets besides the default spot lights (loadScene): grey,
/// radiance 0.12 W/(m²·sr) at the zenith, 0.06 at the horizon and 0.03 at the nadir, linear in the
/// sine of the elevation — a dim studio sky: faces in every light's shadow stay readable (a white
/// face turned up reflects ≈ 0.09 of radiance, a tenth of what the caustic spot gives), and a
/// mirror or a metal shows its shape against the gradient instead of a black world. A 512 × 256
/// map (3.7 MB with its sampling tables, 1.6 MB sent to each client). Pure.
Environment defaultSky();

}  // namespace rtpm
