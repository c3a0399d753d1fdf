// The master: accepts and authenticates clients, drives the frame loop, assembles and outputs.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/core/render_settings.h"
#include "common/scene/scene.h"
#include "proto/messages.h"
#include "server/deadline.h"
#include "server/admission.h"
#include "server/animation.h"
#include "server/script/script_edit.h"

namespace rtpm::server {

/// Exit code of a run that rendered its frames but could not write an image (--out, --save-every).
constexpr int kExitImageNotWritten = 5;
/// Exit code of a run that showed frames but none complete (every one missed sets at its deadline
/// or had sets nobody rendered): the image written is not the scene's. kExitImageNotWritten wins.
constexpr int kExitNoCompleteFrame = 6;

/// Everything rtpm-server's flags decide.
struct MasterOptions {
    std::string listen = "127.0.0.1";  ///< address to bind
    uint16_t port = proto::kDefaultPort;  ///< 0 = ephemeral (see portFile)
    std::string portFile;              ///< written atomically with the bound port once listening
    std::string token;                 ///< shared secret; empty only with insecureNoToken
    bool insecureNoToken = false;

    std::string sceneName = "RING";    ///< built-in name or file path (for logs and output names)
    bool builtin = true;               ///< clients load sceneName themselves; else they get a .glb
    RenderSettings settings;
    int frames = 10;                   ///< 0 = render until stopped (service mode)
    proto::PixelEncoding encoding = proto::PixelEncoding::Float32;
    bool walkthrough = false;          ///< no shooting after the first frame of each epoch
    bool staticSets = false;           ///< never move sets by measured cost (server/balance.h)

    int minClients = 1;                ///< frames start once this many clients joined
    DeadlinePolicy deadline;           ///< how long the oldest frame waits for data (adaptive by default)
    int evictAfter = 3;                ///< consecutive late or skipped frames before a client is evicted
    /// Pre-authentication: a connection must finish Hello → Challenge → Auth within this.
    std::chrono::milliseconds handshakeTimeout{3000};
    int maxPeers = 256;                ///< authenticated clients; more are refused with Reject{Capacity}
    AdmissionLimits admission;         ///< pending-handshake budgets, failed-authentication limits
    /// An authenticated peer that stops mid-message for this long is dropped (0 = never), or for
    /// the measured frame deadline if shorter (at least 1 s: Peers::boundReadStall); a message
    /// must also arrive at kMinReadBytesPerSecond on average (proto/net/connection.h).
    std::chrono::milliseconds readTimeout{10000};
    /// TLS on the cluster link: PEM certificate chain and private key (both or neither).
    std::string tlsCert, tlsKey;
    size_t maxQueuedBytes = 256u << 20;  ///< per-peer unsent bytes before it is dropped

    std::string out;                   ///< final EXR (PNG beside it); empty = no output
    int saveEvery = 0;                 ///< also write frames n, 2n, … as <out stem>_<frame>.exr/.png
    std::string csv;                   ///< per-frame figures (appended; header when new)
    Animation animation = Animation::None;
    std::vector<ScriptEdit> script;
    std::string scriptFile;
    bool quiet = false;                ///< no per-frame line on stdout
    /// Progressive still views: the frame time their passes grow to (ms; 0 = one batch per pass)
    /// and the estimated caustic error that ends the run (0 = off).
    double frameBudgetMs = kDefaultFrameBudgetMs;
    double targetError = 0.0;

    // Browser viewer (docs/ARCHITECTURE.md §10).
    std::string http;                  ///< HOST:PORT of the viewer's HTTP port; empty = no viewer
    std::string viewerToken;           ///< controls need this (default: the cluster token)
    bool viewerPublic = false;         ///< viewers without a token may watch (no controls)
    int maxViewers = 8;
    /// Origins besides the served address whose pages may open the viewer's WebSocket.
    std::vector<std::string> viewerOrigins;
    double viewerFps = 30.0;           ///< frames sent to each viewer per second at most (0 = every frame)
};

/// Totals of a run, for the summary line and tests.
struct MasterSummary {
    uint64_t framesShown = 0;
    uint64_t framesIncomplete = 0;  ///< shown at their deadline or with sets nobody rendered
    double seconds = 0.0;           ///< first FrameBegin → last frame shown
    uint64_t bytesReceived = 0;     ///< FrameData wire bytes
    uint64_t clientsJoined = 0;
    uint64_t clientsEvicted = 0;    ///< late or skipped evictAfter frames in a row (told Bye{Timeout})
    uint64_t peersRefused = 0;      ///< refused at connect or in the handshake: capacity, rate limit, version
    uint64_t failedAuth = 0;        ///< refused for a wrong token (or none where one is needed)
    uint64_t protocolErrors = 0;    ///< closed for bytes that break the protocol, in or after the handshake
};

/// The master (docs/ARCHITECTURE.md §1, threads §8). One io_context thread does all networking;
/// decoding, scattering, filtering, composing and image output run on a separate assembly thread
/// (and TBB), so a slow frame never stalls the sockets. Peers that send bad bytes are closed with a
/// log line naming them; the master keeps serving the others.
class Master {
public:
    /// `scene` is the scene as loaded (clients of a file scene receive it as .glb).
    /// Throws std::invalid_argument for bad options, std::runtime_error if it cannot listen.
    Master(MasterOptions options, Scene scene);
    ~Master();
    Master(const Master&) = delete;
    Master& operator=(const Master&) = delete;

    /// Bound port (valid after construction).
    uint16_t port() const;
    /// The viewer's bound HTTP port, 0 without a viewer.
    uint16_t viewerPort() const;
    /// Runs until every frame is shown (then Bye{Normal} to all) or stop() / SIGINT / SIGTERM:
    /// those finish the frames in flight, write the last image to `out` and say Bye{Shutdown};
    /// a second signal stops at once. Returns the process exit code: 0 when all frames were
    /// shown or a service (frames = 0) was stopped, 130 when a finite run was interrupted,
    /// kExitNoCompleteFrame when frames were shown but none complete, kExitImageNotWritten.
    int run();
    /// Thread-safe request to stop (clients get Bye{Shutdown}).
    void stop();
    const MasterSummary& summary() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rtpm::server
