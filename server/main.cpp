// rtpm-server entry point: parses flags (rtpm-render's rendering flags plus the cluster's) and runs the master.
#include <CLI/CLI.hpp>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "common/core/console.h"
#include "common/cmd/command_line.h"
#include "common/render/render_flags.h"
#include "common/core/output_file.h"
#include "common/core/strings.h"
#include "common/scene/scene_loader.h"
#include "proto/net/listen_address.h"
#include "server/animation.h"
#include "server/script/script_edit.h"
#include "common/image/image_io.h"
#include "server/master.h"

namespace {

using namespace rtpm;


int run(int argc, char** argv) {
    server::MasterOptions o;
    RenderSettings& rs = o.settings;
    bool noDefaultLight = false;
    std::string animate, editScript, encoding = "rgb9e5-zstd";
    std::string deadline = "auto";
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
    // Rendering settings: the same names, meanings and defaults as rtpm-render. --help lists the
    // groups scene, image, photons, estimator (these), cluster, viewer, security, output.
    addRenderFlags(app, rs, o.sceneName, noDefaultLight);
    SceneInputPolicy sceneInput;
    addSceneInputFlags(app, sceneInput);
    SceneOverrides overrides;
    addSceneChoiceFlags(app, overrides);
    ConvergenceFlags convergence;
    addConvergenceFlags(app, convergence);
    // Cluster.
    app.add_option("--listen", o.listen, "address to listen on")->capture_default_str()
        ->group("cluster");
    app.add_option("--port", o.port, "TCP port, [0, 65535] (0 = any free port; see --port-file)")->capture_default_str()
        ->group("cluster");
    app.add_option("--port-file", o.portFile, "write the bound port here (atomically) once listening")
        ->group("cluster");
    // Browser viewer.
    app.add_option("--http", o.http,
                   "serve the browser viewer on HOST:PORT (port 0 = any free port; the URL is printed as "
                   "'viewer: http://HOST:PORT/'); e.g. 127.0.0.1:0")
        ->group("viewer");
    app.add_option("--viewer-token", o.viewerToken,
                   "token the viewer's controls need (default: the cluster token; required with --insecure-no-token)")
        ->group("viewer");
    app.add_flag("--viewer-public", o.viewerPublic, "viewers without a token may watch (controls still need it)")
        ->group("viewer");
    app.add_option("--viewer-origin", o.viewerOrigins,
                   "an origin (http://HOST[:PORT]) whose pages may open the viewer besides the address it is served "
                   "on, e.g. the name or published port a browser uses; repeatable")
        ->group("viewer");
    app.add_option("--max-viewers", o.maxViewers, "viewers connected at once, >= 1")->capture_default_str()
        ->group("viewer");
    app.add_option("--viewer-fps", o.viewerFps,
                   "frames per second sent to a viewer at most, [0, 1000] (0 = every frame the master composes)")
        ->capture_default_str()
        ->group("viewer");
    // Security and admission.
    app.add_option("--token", o.token, "shared secret clients must present (default: $RTPM_TOKEN)")
        ->group("security");
    app.add_flag("--insecure-no-token", o.insecureNoToken, "accept clients without a token (trusted networks only)")
        ->group("security");
    int handshakeMs = int(o.handshakeTimeout.count()), readMs = int(o.readTimeout.count());
    app.add_option("--handshake-timeout-ms", handshakeMs, "a new connection must authenticate within this, >= 1")
        ->capture_default_str()
        ->group("security");
    app.add_option("--read-timeout-ms", readMs,
                   "drop a client that stops sending in the middle of a message for this long at most, >= 0; once "
                   "frames are measured, for the frame deadline (at least 1 s) (0 = never)")
        ->capture_default_str()
        ->group("security");
    app.add_option("--tls-cert", o.tlsCert, "PEM certificate chain: clients connect over TLS (with --tls-key)")
        ->group("security");
    app.add_option("--tls-key", o.tlsKey, "PEM private key of --tls-cert")
        ->group("security");
    app.add_option("--max-clients", o.maxPeers, "authenticated clients at once, >= 1; more are refused (capacity)")
        ->capture_default_str()
        ->group("security");
    app.add_option("--max-pending", o.admission.maxPending, "connections in their handshake at once, all addresses, >= 1")
        ->capture_default_str()
        ->group("security");
    app.add_option("--max-pending-per-source", o.admission.maxPendingPerSource,
                   "connections in their handshake at once from one address (IPv6: one /64), >= 1")
        ->capture_default_str()
        ->group("security");
    // Cluster: the frame loop.
    app.add_option("--min-clients", o.minClients, "start frames once this many clients joined, >= 1")->capture_default_str()
        ->group("cluster");
    app.add_option("--deadline-ms", deadline,
                   "a frame still missing data this long after it became the oldest is shown with the sets' "
                   "previous values; auto = 4 x the median measured frame time within [1000, 10000] ms (the "
                   "ceiling for a frame that starts an epoch, moves sets or is the last of the run)")
        ->capture_default_str()
        ->group("cluster");
    app.add_option("--evict-after", o.evictAfter,
                   "evict a client late or skipped this many frames in a row, >= 1 (it is told why and may rejoin)")
        ->capture_default_str()
        ->group("cluster");
    app.add_option("--encoding", encoding,
                   "pixels on the wire (default rgb9e5-zstd: HDR in ~4 B/px; use float32 for a bit-exact copy of rtpm-render): float32 (exact, 24 B/px), rgb9e5 (8 B/px, <= 2^-9 relative error), "
                   "rgb9e5-zstd (rgb9e5 with a compressed caustic plane), rgb8 (6 B/px, clamped to [0,1])")
        ->capture_default_str()
        ->group("cluster");
    app.add_flag("--walkthrough", o.walkthrough, "no photon shooting after the first frame of each epoch")
        ->group("photons");
    app.add_flag("--static-sets", o.staticSets,
                 "keep the round-robin share of sets (no moves from slower to faster clients by measured cost)")
        ->group("cluster");
    app.add_option("--animate", animate, "live edit preset: orbit (camera), light, ior or object (scene edits)")
        ->group("scene");
    app.add_option("--edit-script", editScript, "file of 'frame <n> camera|light|material|transform|settings ...' lines (server/script/script_edit.h)")
        ->group("scene");
    // Output.
    auto* framesOpt = app.add_option("--frames", o.frames,
                                     "frames to render; the last one is written to --out; 0 = until SIGINT/SIGTERM "
                                     "(the default with --http)")
                          ->capture_default_str()
                          ->group("output");
    app.add_option("--out", o.out,
                   "final image NAME.exr or NAME.png: both NAME.exr (every layer, linear) and NAME.png "
                   "(tone-mapped) are written (default out/<scene>.exr)")
        ->group("output");
    app.add_option("--save-every", o.saveEvery, "also write every n-th frame as <out>_<frame>.exr/.png, >= 0 (0 = off)")
        ->capture_default_str()
        ->group("output");
    app.add_option("--csv", o.csv,
                   "append per-frame figures: frame, fps, photons per set, mode, bytes, slowest client and ms")
        ->group("output");
    app.add_flag("--quiet", o.quiet, "no per-frame line")
        ->group("output");
    if (auto code = parseCommandLine(app, argc, argv)) return *code;
    o.frameBudgetMs = convergence.frameBudgetMs;
    o.targetError = convergence.targetError;
    if (!o.http.empty() && framesOpt->count() == 0) o.frames = 0;
    if (!o.http.empty()) {
        try {
            net::parseListenAddress("--http", o.http);
        } catch (const std::invalid_argument& e) {
            throw UsageError(e.what());
        }
    }
    if (o.maxViewers < 1) throw UsageError("--max-viewers must be >= 1");
    if (!(o.viewerFps >= 0.0 && o.viewerFps <= 1000.0))
        throw UsageError("--viewer-fps must be in [0, 1000] (0 = no cap)");
    if (deadline != "auto") {
        if (deadline.empty() || deadline.size() > 9 || deadline.find_first_not_of("0123456789") != std::string::npos ||
            std::stol(deadline) < 1)
            throw UsageError("--deadline-ms must be auto or a whole number of milliseconds >= 1, got '" +
                                        deadline + "'");
        o.deadline.fixed = std::chrono::milliseconds(std::stol(deadline));
    }
    if (handshakeMs < 1) throw UsageError("--handshake-timeout-ms must be >= 1");
    if (readMs < 0) throw UsageError("--read-timeout-ms must be >= 0");
    if (o.maxPeers < 1 || o.admission.maxPending < 1 || o.admission.maxPendingPerSource < 1)
        throw UsageError("--max-clients, --max-pending and --max-pending-per-source must be >= 1");
    o.handshakeTimeout = std::chrono::milliseconds(handshakeMs);
    o.readTimeout = std::chrono::milliseconds(readMs);
    if (o.token.empty())
        if (const char* env = std::getenv("RTPM_TOKEN")) o.token = env;
    if (o.token.empty() && !o.insecureNoToken)
        throw UsageError("no token: set RTPM_TOKEN for the server and every client, e.g. "
                         "export RTPM_TOKEN=$(openssl rand -hex 16) (--token works too but shows the token to other "
                         "users of the machine), or --insecure-no-token on a trusted network");
    auto anim = server::parseAnimation(animate);
    if (!anim) throw UsageError("--animate must be orbit, light, ior or object, got '" + animate + "'");
    o.animation = *anim;
    if (encoding == "float32") o.encoding = proto::PixelEncoding::Float32;
    else if (encoding == "rgb9e5") o.encoding = proto::PixelEncoding::Rgb9e5;
    else if (encoding == "rgb9e5-zstd") o.encoding = proto::PixelEncoding::Rgb9e5Zstd;
    else if (encoding == "rgb8") o.encoding = proto::PixelEncoding::Rgb8;
    else throw UsageError("--encoding must be float32, rgb9e5, rgb9e5-zstd or rgb8, got '" + encoding + "'");
    try {
        validateSettings(rs);
    } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
    }

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
    overrides.defaultLight = !noDefaultLight;
    Scene scene = loadScene(o.sceneName, overrides, sceneInput);
    for (const std::string& w : scene.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (!editScript.empty()) {
        o.script = server::loadEditScript(editScript);
        o.scriptFile = editScript;
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
