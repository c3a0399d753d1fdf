// The frame loop: begins frames (FrameBegin to the clients the policy picks), collects their data
// and Stats against a deadline, retires them to the output stage, evicts clients that fall
// behind, and decides when the run ends. Policy, deadline and assembly are the pure parts
// (frame_policy.h, deadline.h, frame_assembler.h); this room drives them with the clock.
#pragma once

#include <asio.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/core/interleave.h"
#include "proto/messages.h"
#include "server/client_registry.h"
#include "server/convergence.h"
#include "server/deadline_clock.h"
#include "server/frame_assembler.h"
#include "server/frame_ledger.h"
#include "server/frame_policy.h"
#include "server/photon_relay.h"
#include "server/master.h"
#include "server/viewer/viewer_model.h"

namespace rtpm::server {

class ImageOutput;
class LiveControl;
class Peers;

/// What the frame loop tells the rest of the master. Called on the I/O thread.
class FrameLoopListener {
public:
    virtual ~FrameLoopListener() = default;
    /// Frame `frame` was written by the output stage, which took `masterMs`.
    virtual void frameShown(const ViewerFrame& frame, double masterMs) = 0;
    /// The run is ending: no new peers or messages are wanted.
    virtual void ending() = 0;
    /// The run is over: say Bye{reason, text} to every client; the process exits with `exitCode`.
    virtual void finished(int exitCode, proto::ByeReason reason, const std::string& text) = 0;
};

/// Runs on the master's io_context; not thread-safe.
class FrameLoop {
public:
    /// Frames in flight at once (and output jobs queued at once): a client renders frame f+1
    /// while f travels and is assembled, so neither side idles (docs/ARCHITECTURE.md §2.2).
    static constexpr size_t kPipeline = 2;

    /// Everything passed by reference outlives the loop.
    FrameLoop(asio::io_context& io, const MasterOptions& options, Peers& peers, LiveControl& control,
              ImageOutput& output, FrameLoopListener& listener);

    /// Retires what is ready, evicts, applies a waiting change of M, begins what may begin and
    /// ends the run when every frame is shown or a stop was asked for. Called after every event.
    void pump();
    /// Finish the frames in flight, write the last image, Bye{Shutdown} (a signal, stop()).
    void requestStop();
    /// Stop now (a second signal): Bye{Shutdown}, exit code 130.
    void abort();
    /// Neither stopping nor ending.
    bool running() const { return state_ == State::Running; }

    /// A client joined: the sets it would hold if a frame began now (Welcome; FrameBegin is binding).
    std::vector<uint32_t> clientJoined(ClientId id);
    void clientLeft(ClientId id);
    /// FrameData or Stats of a registered client.
    void onMessage(ClientInfo& client, proto::Message&& m, size_t wireBytes);

    /// The status a viewer shows for `frame`, with the clients and settings as they are now.
    ViewerStatus status(const ViewerFrame& frame, double masterMs);

    uint64_t nextFrame() const { return nextFrame_; }
    bool deadlineAdaptive() const { return clock_.adaptive(); }
    const FrameCounts& counts() const { return ledger_.counts(); }

private:
    enum class State { Running, Stopping, Ending };

    void beginFrame(TimePoint now);
    void retire(RetiredFrame& r, TimePoint now);
    void resize();
    void evictSlowClients();
    void armDeadline();
    void onFrameData(ClientInfo& client, proto::FrameData&& fd, size_t wireBytes);
    void onStats(ClientInfo& client, const proto::Stats& st);
    void finishStopped();
    void end(int exitCode, proto::ByeReason reason, const std::string& text);
    /// The interleaving of the settings in force (LiveControl: M changes only in resize()).
    Interleave pattern() const;
    uint32_t setCount() const { return static_cast<uint32_t>(pattern().setCount()); }

    const MasterOptions& opt_;
    Peers& peers_;
    LiveControl& control_;
    ImageOutput& output_;
    FrameLoopListener& listener_;
    FramePolicy policy_;
    DeadlineClock clock_;
    FrameAssembler assembler_;
    FrameLedger ledger_;
    Convergence convergence_;
    PhotonRelay relay_;
    std::map<ClientId, TimePoint> probes_;  // joiners sent a frame without sets, since when
    uint64_t nextFrame_ = 0;
    size_t outputsQueued_ = 0;
    State state_ = State::Running;
};

}  // namespace rtpm::server
