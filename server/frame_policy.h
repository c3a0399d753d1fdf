// The frame loop's decisions: epochs, frame modes, set (re)assignment, skips and eviction.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "proto/messages.h"
#include "server/assignment.h"
#include "server/balance.h"

namespace rtpm::server {

/// What to send for one frame.
struct FramePlan {
    uint64_t frame = 0;
    uint32_t epoch = 0;
    proto::FrameMode mode = proto::FrameMode::Interaction;
    /// Per set: the client asked to render it, kNoClient when nobody is (shown with its previous
    /// values). A client that already has kPipeline frames outstanding is not asked.
    std::vector<ClientId> owners;
    /// The clients to send FrameBegin to, with their sets (ascending).
    std::map<ClientId, std::vector<uint32_t>> sets;
    /// Sets were dealt afresh or changed owner with this frame (their new owners build maps).
    bool reassigned = false;
    /// The share changed by measured cost (Balance) with this frame, an epoch's first.
    bool balanced = false;
    /// Clients that joined after frames began and have not yet answered a frame: each is sent
    /// this frame with no set (it answers with Stats alone); no frame waits for them.
    std::vector<ClientId> probes;
};

/// The master's frame-loop policy, pure: no sockets, no clock, no threads (docs/ARCHITECTURE.md
/// §2–§3).
///  * Epochs: frame 0 and every frame that carries scene edits start a new epoch (edits increment
///    the epoch number); all clients
///    reset their photon maps at it, and the plain round-robin deal is used (maps restart anyway).
///  * Modes: decideFrameMode (common/core/frame_mode.h, which rtpm-render's frames also take):
///    the first frame of an epoch is Interaction; a frame for which the camera was moved (a viewer
///    camera edit) is Walkthrough; with the progressive estimator a later frame whose camera
///    equals the previous frame's is Converging (unless walkthrough was asked for); otherwise
///    Walkthrough when asked for, or when every client with sets reported that it shot nothing
///    (capped); otherwise Accumulate. Clients render by the mode they are sent.
///  * Reassignment: clients joining or leaving within an epoch move as few sets as possible
///    (rebalance()); moved sets restart accumulation on their new owner, in every mode (a
///    Walkthrough frame shoots the first batch of a map that has none: FrameRenderer), and the
///    plan says `reassigned` so the master gives that frame the full deadline.
///  * Joining: a client that joins after frames began holds no set until it has answered a frame
///    sent to it with no set (its Stats, once its scene is loaded), so a joiner that never
///    answers costs the frames nothing; the frame that then moves sets to it waits the ceiling
///    for a client known to be alive. While no client holds sets every client takes sets at once.
///  * Balance (unless `balance.enabled` is false: --static-sets): at an epoch's first frame,
///    where every map restarts, the share of the epoch before carries over and sets move from
///    slower to faster clients once each has reported a few frames at its share and the move
///    cuts the predicted frame time by balance.minGain (server/balance.h). So a set moves only
///    where it holds nothing yet, and the image stays bit for bit what one process renders.
///  * Pipelining: a client with `pipeline` frames outstanding is skipped (its sets shown with
///    previous values); a client skipped or late `evictAfter` times in a row is evicted.
/// Not thread-safe.
class FramePolicy {
public:
    FramePolicy(uint32_t setCount, bool walkthrough, size_t pipeline, uint32_t evictAfter,
                bool progressive = false, BalanceOptions balance = {});

    /// Plans frame `frame` (strictly increasing). `edited`: scene edits (or settings that change
    /// photons) are sent with it. `cameraMoved`: the camera changed for it — photons are kept and
    /// the frame is a Walkthrough (no shooting while the view moves) unless it starts an epoch.
    /// `cameraStill`: the frame's camera equals the previous frame's (progressive: Converging).
    /// `sceneEdited`: among the edits a scene edit (light, material, transform), not only
    /// settings: the epoch starts with an Edit frame (frame_mode.h). `relit`: every edit is a
    /// light edit: with `cameraStill` the epoch starts with a Relight frame instead.
    /// `outstanding(id)`: frames sent to client id that it has not finished.
    FramePlan plan(uint64_t frame, bool edited, const std::vector<ClientId>& joinOrder,
                   const std::function<size_t(ClientId)>& outstanding, bool cameraMoved = false,
                   bool cameraStill = false, bool sceneEdited = false, bool relit = false);

    /// The caustic estimator changed (a settings edit, which also starts an epoch): with the
    /// progressive one, still frames are Converging.
    void setProgressive(bool progressive) { progressive_ = progressive; }

    /// Changes M² (a settings change of M); the next plan deals the sets afresh. Call with no
    /// frame in flight and with `edited` set on the next plan (the maps restart).
    void resize(uint32_t setCount) {
        setCount_ = setCount;
        assignment_ = Assignment{};
    }

    /// A client joined: the next plan rebalances (within an epoch). Once frames began, it takes
    /// sets only after answered().
    void clientJoined(ClientId id);
    void clientLeft(ClientId id);
    /// A Stats of `id` arrived (in time or late). Returns true when it answered the frame sent to
    /// it with no set: it takes sets from the next plan on.
    bool answered(ClientId id);
    /// A client's Stats for a frame of mode `mode` arrived in time: it finished a frame, and in an
    /// Accumulate frame of every set (`passPeriod` 1) `photonsShot == 0` means its sets are capped.
    void stats(ClientId id, proto::FrameMode mode, uint64_t photonsShot, uint32_t passPeriod = 1);
    /// Sets `id` would hold if a frame began now (for Welcome; FrameBegin is binding).
    std::vector<uint32_t> tentativeSets(ClientId id, const std::vector<ClientId>& joinOrder) const;

    /// Clients to evict: skipped `evictAfter` frames in a row, or `misses(id)` (consecutive
    /// deadline misses) ≥ evictAfter.
    std::vector<ClientId> evictions(const std::vector<ClientId>& clients,
                                    const std::function<uint32_t(ClientId)>& misses) const;

    uint32_t epoch() const { return epoch_; }
    /// The balance's measurements (FrameLoop feeds it each client's Stats).
    Balance& balance() { return balance_; }
    const Assignment& assignment() const { return assignment_; }

private:
    struct ClientState {
        bool capped = false;  // last Stats of a non-interaction frame shot no photon
        uint32_t skips = 0;   // consecutive frames skipped (pipeline full)
        bool ready = true;    // takes sets (a joiner after frames began: once it answered)
    };
    uint32_t setCount_;
    bool walkthrough_;
    size_t pipeline_;
    uint32_t evictAfter_;
    bool progressive_ = false;
    Assignment assignment_;
    Balance balance_;
    bool clientsChanged_ = false;
    bool started_ = false;
    uint32_t epoch_ = 0;
    uint64_t epochStart_ = 0;
    std::map<ClientId, ClientState> state_;
};

}  // namespace rtpm::server
