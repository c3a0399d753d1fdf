// rtpm-server's command line (server_flags.h).
#include "server/server_flags.h"

#include <cstdlib>

#include "common/cmd/command_line.h"
#include "proto/net/listen_address.h"
#include "server/animation.h"

namespace rtpm::server {

namespace {

// The master's addresses and the browser viewer.
void addAddressFlags(CLI::App& app, MasterOptions& o) {
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
}

// Tokens, TLS and the admission budgets.
void addSecurityFlags(CLI::App& app, MasterOptions& o, ServerFlags& flags) {
    // Security and admission.
    app.add_option("--token", o.token, "shared secret clients must present (default: $RTPM_TOKEN)")
        ->group("security");
    app.add_flag("--insecure-no-token", o.insecureNoToken, "accept clients without a token (trusted networks only)")
        ->group("security");
    flags.handshakeMs = int(o.handshakeTimeout.count());
    flags.readMs = int(o.readTimeout.count());
    app.add_option("--handshake-timeout-ms", flags.handshakeMs, "a new connection must authenticate within this, >= 1")
        ->capture_default_str()
        ->group("security");
    app.add_option("--read-timeout-ms", flags.readMs,
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
}

// The frame loop and its live edits.
void addFrameLoopFlags(CLI::App& app, MasterOptions& o, ServerFlags& flags) {
    // Cluster: the frame loop.
    app.add_option("--min-clients", o.minClients, "start frames once this many clients joined, >= 1")->capture_default_str()
        ->group("cluster");
    app.add_option("--deadline-ms", flags.deadline,
                   "a frame still missing data this long after it became the oldest is shown with the sets' "
                   "previous values; auto = 4 x the median measured frame time within [1000, 10000] ms (the "
                   "ceiling for a frame that starts an epoch, moves sets or is the last of the run)")
        ->capture_default_str()
        ->group("cluster");
    app.add_option("--evict-after", o.evictAfter,
                   "evict a client late or skipped this many frames in a row, >= 1 (it is told why and may rejoin)")
        ->capture_default_str()
        ->group("cluster");
    app.add_option("--encoding", flags.encoding,
                   "pixels on the wire (default rgb9e5-zstd: HDR in ~4 B/px; use float32 for a bit-exact copy of rtpm-render): float32 (exact, 24 B/px), rgb9e5 (8 B/px, <= 2^-9 relative error), "
                   "rgb9e5-zstd (rgb9e5 with a compressed caustic plane), rgb8 (6 B/px, clamped to [0,1])")
        ->capture_default_str()
        ->group("cluster");
    app.add_flag("--walkthrough", o.walkthrough, "no photon shooting after the first frame of each epoch")
        ->group("photons");
    app.add_flag("--static-sets", o.staticSets,
                 "keep the round-robin share of sets (no moves from slower to faster clients by measured cost)")
        ->group("cluster");
    app.add_option("--animate", flags.animate, "live edit preset: orbit (camera), light, ior or object (scene edits)")
        ->group("scene");
    app.add_option("--edit-script", flags.editScript, "file of 'frame <n> camera|light|material|transform|settings ...' lines (server/script/script_edit.h)")
        ->group("scene");
}

void addOutputFlags(CLI::App& app, MasterOptions& o, ServerFlags& flags) {
    // Output.
    flags.frames = app.add_option("--frames", o.frames,
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
}

}  // namespace

void addServerFlags(CLI::App& app, MasterOptions& o, ServerFlags& flags) {
    // Rendering settings: the same names, meanings and defaults as rtpm-render. --help lists the
    // groups scene, image, photons, estimator (these), cluster, viewer, security, output.
    addRenderFlags(app, o.settings, o.sceneName, flags.noDefaultLight);
    addSceneInputFlags(app, flags.sceneInput);
    addSceneChoiceFlags(app, flags.overrides);
    addConvergenceFlags(app, flags.convergence);
    addAddressFlags(app, o);
    addSecurityFlags(app, o, flags);
    addFrameLoopFlags(app, o, flags);
    addOutputFlags(app, o, flags);
}

void applyServerFlags(const ServerFlags& flags, MasterOptions& o) {
    o.frameBudgetMs = flags.convergence.frameBudgetMs;
    o.targetError = flags.convergence.targetError;
    if (!o.http.empty() && flags.frames->count() == 0) o.frames = 0;
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
    if (flags.deadline != "auto") {
        if (flags.deadline.empty() || flags.deadline.size() > 9 || flags.deadline.find_first_not_of("0123456789") != std::string::npos ||
            std::stol(flags.deadline) < 1)
            throw UsageError("--deadline-ms must be auto or a whole number of milliseconds >= 1, got '" +
                                        flags.deadline + "'");
        o.deadline.fixed = std::chrono::milliseconds(std::stol(flags.deadline));
    }
    if (flags.handshakeMs < 1) throw UsageError("--handshake-timeout-ms must be >= 1");
    if (flags.readMs < 0) throw UsageError("--read-timeout-ms must be >= 0");
    if (o.maxPeers < 1 || o.admission.maxPending < 1 || o.admission.maxPendingPerSource < 1)
        throw UsageError("--max-clients, --max-pending and --max-pending-per-source must be >= 1");
    o.handshakeTimeout = std::chrono::milliseconds(flags.handshakeMs);
    o.readTimeout = std::chrono::milliseconds(flags.readMs);
    if (o.token.empty())
        if (const char* env = std::getenv("RTPM_TOKEN")) o.token = env;
    if (o.token.empty() && !o.insecureNoToken)
        throw UsageError("no token: set RTPM_TOKEN for the server and every client, e.g. "
                         "export RTPM_TOKEN=$(openssl rand -hex 16) (--token works too but shows the token to other "
                         "users of the machine), or --insecure-no-token on a trusted network");
    auto anim = parseAnimation(flags.animate);
    if (!anim) throw UsageError("--animate must be orbit, light, ior or object, got '" + flags.animate + "'");
    o.animation = *anim;
    if (flags.encoding == "float32") o.encoding = proto::PixelEncoding::Float32;
    else if (flags.encoding == "rgb9e5") o.encoding = proto::PixelEncoding::Rgb9e5;
    else if (flags.encoding == "rgb9e5-zstd") o.encoding = proto::PixelEncoding::Rgb9e5Zstd;
    else if (flags.encoding == "rgb8") o.encoding = proto::PixelEncoding::Rgb8;
    else throw UsageError("--encoding must be float32, rgb9e5, rgb9e5-zstd or rgb8, got '" + flags.encoding + "'");
    try {
        validateSettings(o.settings);
    } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
    }
}

}  // namespace rtpm::server
