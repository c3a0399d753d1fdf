// The rendering flags rtpm-render and rtpm-server share: same names, meanings and defaults.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdlib>
#include <string>

#include "common/core/knobs.h"
#include "common/core/render_settings.h"
#include "common/scene/scene_files.h"
#include "common/scene/scene_loader.h"

namespace rtpm {

/// Adds the flag of setting `row` (common/core/knobs.h: its name, short form, help group, range and
/// default come from the row), bound to `settings`. A value outside the row's limits is refused by
/// the parser (CLI::ValidationError naming the flag); a switch takes no value.
inline void addSettingFlag(CLI::App& app, const SettingRow& row, RenderSettings& settings) {
    std::string names(row.flag);
    if (!row.shortFlag.empty()) names += "," + std::string(row.shortFlag);
    if (row.form != FlagForm::Value) {
        const double value = row.form == FlagForm::Switch ? 1.0 : 0.0;
        app.add_flag_callback(names, [&settings, &row, value] { row.set(settings, value); }, std::string(row.help))
            ->group(std::string(row.group));
        return;
    }
    std::string help = std::string(row.help) + ", " + knobRange(row);
    if (!row.unit.empty()) help += " " + std::string(row.unit);
    help += ", default " + formatKnobValue(row, row.defaultValue);
    // Refusals in the parser's own words, as for every other flag ("--photons: Value 0 not in
    // range 1 to 50000000").
    auto set = [&settings, &row](const std::string& text) {
        const std::optional<double> v = parseKnobValue(row, text);
        if (!v)
            throw CLI::ValidationError(std::string(row.flag), "'" + text + "' is not " +
                                                                  (row.isChoice() ? "one of " : "a number in ") +
                                                                  knobRange(row));
        if (knobValueError(row, *v))
            throw CLI::ValidationError(std::string(row.flag),
                                       row.integer && std::floor(*v) != *v
                                           ? "Value " + text + " is not a whole number"
                                           : "Value " + text + " not in range " + formatKnobValue(row, row.min) +
                                                 " to " + formatKnobValue(row, row.max));
        row.set(settings, *v);
    };
    app.add_option_function<std::string>(names, set, help)
        ->type_name(row.isChoice() ? "NAME" : row.integer ? "INT" : "FLOAT")
        ->group(std::string(row.group));
}

/// Adds every flag that decides what a frame looks like to `app`, bound to `settings`: --scene and
/// --no-default-light, then one flag per row of common/core/knobs.h (the fixed settings, then the
/// live knobs), in the --help groups scene, image, photons and estimator. `sceneName` receives
/// --scene, `noDefaultLight` --no-default-light (the caller passes SceneOverrides::defaultLight =
/// !noDefaultLight to loadScene).
inline void addRenderFlags(CLI::App& app, RenderSettings& settings, std::string& sceneName, bool& noDefaultLight) {
    app.add_option("--scene", sceneName,
                   "built-in scene (RING GLASS EGG HEADLIGHT CORNELL) or .gltf/.glb/.obj file")
        ->capture_default_str()
        ->group("scene");
    app.add_flag("--no-default-light", noDefaultLight,
                 "refuse a scene with no light and no emissive material instead of adding the "
                 "default lights (a caustic spot light behind it, a key light on the camera's side; see README)")
        ->group("scene");
    for (const SettingRow& row : kFixedSettings) addSettingFlag(app, row, settings);
    for (const KnobRow& row : kKnobs) addSettingFlag(app, row, settings);
}

/// How a still view converges: the frame-time budget its passes grow to (PassBudget) and the
/// estimated caustic error at which a still render ends (0: none).
struct ConvergenceFlags {
    double frameBudgetMs = kDefaultFrameBudgetMs;
    double targetError = 0.0;
};

/// Adds --frame-budget-ms and --target-error, bound to `flags`.
inline void addConvergenceFlags(CLI::App& app, ConvergenceFlags& flags) {
    app.add_option("--frame-budget-ms", flags.frameBudgetMs,
                   "a still view's frame time: its passes grow (more photon batches per turn) while a "
                   "frame takes less than half this, and the sets take turns while a frame takes more (a "
                   "set off its turn shows its last pixels and bins the photons shared meanwhile at its "
                   "next turn), so the view keeps about 1000/budget updates a second (and the master "
                   "keeps a faster motion's frame time after it); an orbit over a growing map takes turns "
                   "beyond 200 ms (or four budgets if more); 0 = one batch per pass, no turns (the frames "
                   "then do not depend on the machine's speed)")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 60000.0))
        ->group("estimator");
    app.add_option("--target-error", flags.targetError,
                   "progressive: end a still render once the estimated relative error of the caustic "
                   "(printed per frame) is at most this, e.g. 0.02; 0 = off")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1.0))
        ->group("estimator");
}

/// Adds the flags that choose among what a scene file offers (--variant) and the world light
/// (--env FILE, --env-color R,G,B, --env-strength S), bound to `overrides`. --env and --env-color
/// exclude each other, --env-strength needs one of them (parse errors naming the flag).
inline void addSceneChoiceFlags(CLI::App& app, SceneOverrides& overrides) {
    app.add_option("--variant", overrides.variant,
                   "glTF material variant (KHR_materials_variants) to render, by name; default: the "
                   "file's default materials. An unknown name is refused with the file's variant names")
        ->group("scene");
    auto environment = [&overrides]() -> EnvironmentOverride& {
        if (!overrides.environment) overrides.environment.emplace();
        return *overrides.environment;
    };
    auto* file = app.add_option_function<std::string>(
                        "--env", [environment](const std::string& f) { environment().file = f; },
                        "world light: an equirectangular (2:1) OpenEXR or Radiance HDR map of linear "
                        "radiance, lighting the scene from every direction, seen in mirrors and through "
                        "glass and throwing caustics (README: world light)")
                     ->type_name("FILE")
                     ->group("scene");
    auto* colour = app.add_option_function<std::string>(
                          "--env-color",
                          [environment](const std::string& text) {
                              // "R,G,B" or one value for grey.
                              Vec3 c(0.0f);
                              int n = 0;
                              size_t start = 0;
                              bool ok = !text.empty();
                              while (ok && start <= text.size() && n < 4) {
                                  const size_t end = std::min(text.find(',', start), text.size());
                                  const std::string part = text.substr(start, end - start);
                                  char* stop = nullptr;
                                  const float v = std::strtof(part.c_str(), &stop);
                                  ok = !part.empty() && stop == part.c_str() + part.size() && std::isfinite(v) &&
                                       v >= 0.0f && v <= kMaxRadiantValue;
                                  if (ok && n < 3) c[n] = v;
                                  ++n;
                                  start = end + 1;
                              }
                              if (!ok || (n != 1 && n != 3))
                                  throw CLI::ValidationError("--env-color", "'" + text +
                                                                                "' is not R,G,B (three "
                                                                                "non-negative radiances) or one grey value");
                              environment().colour = n == 1 ? Vec3(c.x) : c;
                          },
                          "world light of uniform radiance R,G,B (W/(m²·sr), or one grey value): a "
                          "white sky of 1 lights a white diffuse surface to radiance 1")
                       ->type_name("R,G,B")
                       ->group("scene");
    file->excludes(colour);
    auto* strength = app.add_option_function<float>(
                            "--env-strength", [environment](float s) { environment().strength = s; },
                            "multiplies the world light of --env or --env-color, default 1")
                         ->check(CLI::Range(0.0f, kMaxRadiantValue))
                         ->type_name("FLOAT")
                         ->group("scene");
    app.parse_complete_callback([file, colour, strength] {
        if (strength->count() > 0 && file->count() == 0 && colour->count() == 0)
            throw CLI::RequiresError("--env-strength scales the world light of --env or --env-color; give one",
                                     CLI::ExitCodes::RequiresError);
    });
}

/// Adds the flags that say which files a scene may read and how much it may decode
/// (--allow-scene-dir, repeatable; --max-scene-bytes), bound to `input`.
inline void addSceneInputFlags(CLI::App& app, SceneInputPolicy& input) {
    app.add_option("--allow-scene-dir", input.allowedDirs,
                   "folder a scene file may read buffers, textures and MTL files from besides its "
                   "own (repeatable; symlinks are resolved before the check)")
        ->allow_extra_args(false)
        ->take_all()
        ->group("scene");
    app.add_option("--max-scene-bytes", input.maxSceneBytes,
                   "bytes a scene may read from files plus decode into arrays (meshes, textures) "
                   "before loading stops with an error")
        ->capture_default_str()
        ->check(CLI::Range(uint64_t(1), uint64_t(1) << 40))
        ->group("scene");
}

}  // namespace rtpm
