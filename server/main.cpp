// rtpm-server entry point: parses flags (rtpm-render's rendering flags plus the cluster's) and runs the master.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>

#include "common/core/console.h"
#include "common/cmd/command_line.h"
#include "common/core/output_file.h"
#include "common/core/strings.h"
#include "common/scene/scene_loader.h"
#include "common/trace/light_probe.h"
#include "server/script/script_edit.h"
#include "common/image/image_io.h"
#include "server/master.h"
#include "server/server_flags.h"

namespace {

using namespace rtpm;

int run(int argc, char** argv) {
    server::MasterOptions o;
    server::ServerFlags flags;
    CLI::App app{"rtpm-server: the cluster master. Waits for rtpm-client processes, deals them the M×M "
                 "interleaving sets, runs the frame loop, assembles their pixels, box-filters the caustics and "
                 "writes the image rtpm-render writes for the same settings.",
                 "rtpm-server"};
    addStandardFlags(app, proto::kProtocolVersion,
                     {{0, "normal end: all frames shown, or a service (--frames 0) stopped by SIGINT/SIGTERM"},
                      {1, "start-up failure: scene, edit script, an output that cannot be written, an address "
                          "that cannot be listened on"},
                      {server::kExitImageNotWritten, "frames rendered but an image could not be written"},
                      {server::kExitNoCompleteFrame, "frames shown but none complete (clients missing)"},
                      {130, "a finite run interrupted by SIGINT or SIGTERM (the last image is written)"}},
                     {{"export RTPM_TOKEN=$(openssl rand -hex 16); rtpm-server --scene RING --http 127.0.0.1:8080",
                       "a service with the browser viewer at http://127.0.0.1:8080/ until Ctrl-C; clients "
                       "started with the same RTPM_TOKEN join it on port 7411"},
                      {"rtpm-server --listen 0.0.0.0 --scene GLASS --frames 64 --min-clients 4 --out out/glass.exr",
                       "64 frames once 4 clients (with RTPM_TOKEN as above) joined from any interface, written to "
                       "out/glass.exr and .png"}});
    server::addServerFlags(app, o, flags);
    if (auto code = parseCommandLine(app, argc, argv)) return *code;
    server::applyServerFlags(flags, o);

    o.builtin = isBuiltinScene(o.sceneName);
    if (o.builtin) o.sceneName = toUpper(o.sceneName);
    // Every output is checked (and its folder created) before any work: frames rendered into an
    // --out that cannot be written would be lost.
    const ImageOutputPaths outPaths =
        imageOutputPaths(o.out.empty() ? "out/" + toLower(std::filesystem::path(o.sceneName).stem().string()) + ".exr"
                                       : o.out);
    prepareOutputFile("--out", outPaths.exr);
    prepareOutputFile("--out", outPaths.png);
    o.out = outPaths.exr;
    if (!o.csv.empty()) prepareOutputFile("--csv", o.csv, OutputWrite::Append);
    if (!o.portFile.empty()) prepareOutputFile("--port-file", o.portFile);
    flags.overrides.defaultLight = !flags.noDefaultLight;
    Scene scene = loadSceneToRender(o.sceneName, flags.overrides, flags.sceneInput);
    for (const std::string& w : scene.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (!flags.editScript.empty()) {
        o.script = server::loadEditScript(flags.editScript);
        o.scriptFile = flags.editScript;
    }

    server::Master master(std::move(o), std::move(scene));
    return master.run();
}

}  // namespace

int main(int argc, char** argv) {
    rtpm::lineBufferConsole();
    try {
        return run(argc, argv);
    } catch (const rtpm::UsageError& e) {
        return rtpm::reportUsageError("rtpm-server", e);
    } catch (const rtpm::OutputError& e) {
        std::fprintf(stderr, "rtpm-server: output error: %s\n", e.what());
    } catch (const rtpm::SceneError& e) {
        std::fprintf(stderr, "rtpm-server: scene error: %s\n", e.what());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtpm-server: %s\n", e.what());
    }
    return 1;
}
