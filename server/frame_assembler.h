// Bookkeeping of frames in flight: which sets and stats arrived, deadlines, late and bad data.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <vector>

#include "server/assignment.h"

namespace rtpm::server {

using Clock = std::chrono::steady_clock;
using TimePoint = Clock::time_point;

/// What to do with a FrameData or Stats a client sent.
enum class Verdict {
    Accept,       ///< belongs to a frame in flight: keep it
    Late,         ///< legitimate, but its frame was already shown (deadline): drop it silently
    NotSent,      ///< that frame was never sent to this client, or it already finished it: protocol error
    NotAssigned,  ///< the set is not one this client was asked to render in that frame: protocol error
    Duplicate,    ///< this set of this frame already arrived from this client: protocol error
    StatsEarly,   ///< Stats before every FrameData of that frame: protocol error
};

/// Human-readable name of a verdict, for log lines.
const char* verdictName(Verdict v);

/// True for the verdicts that must close the peer.
inline bool isProtocolError(Verdict v) { return v != Verdict::Accept && v != Verdict::Late; }

/// A frame ready to be shown, handed out in frame order.
struct RetiredFrame {
    uint64_t frame = 0;
    std::vector<uint32_t> arrived;  ///< sets whose FrameData arrived in time, ascending
    std::vector<uint32_t> missing;  ///< sets to show with their previous values, ascending
    std::vector<ClientId> late;     ///< clients that were sent the frame and had not finished it
    bool deadlineHit = false;       ///< retired by its deadline rather than complete
    /// Time from becoming the oldest frame in flight to retirement: what its deadline measures
    /// (for a complete frame, the frame time the adaptive deadline learns from).
    std::chrono::nanoseconds waited{0};
};

/// Tracks the frames in flight of the master (pure: no sockets, no clock of its own — every call
/// takes `now`). A frame is complete when every set sent to a client has arrived and every such
/// client has sent its Stats; frames retire strictly in order: a complete frame waits for older
/// ones. Only the oldest frame in flight has a deadline, armed when it becomes the oldest, so a
/// pipelined frame is never charged for the time its client spent on the previous one.
/// Also validates each client's messages against what it was sent. Not thread-safe.
class FrameAssembler {
public:
    /// `setCount` = M²; `deadline` = how long the oldest frame may wait for data.
    FrameAssembler(uint32_t setCount, std::chrono::milliseconds deadline);

    /// Starts `frame` (strictly greater than every earlier one). `owner[s]` is the client asked
    /// to render set s in this frame, kNoClient for a set nobody renders (it is shown with its
    /// previous values). `deadline`: this frame's own wait once it is the oldest (default: the
    /// constructor's). Precondition (checked): owner.size() == setCount.
    void beginFrame(uint64_t frame, const std::vector<ClientId>& owner, TimePoint now,
                    std::optional<std::chrono::milliseconds> deadline = std::nullopt);

    /// `frame` (begun) was also sent to `client` with no set: its Stats is expected and accepted
    /// (outstanding() counts it), but the frame never waits for it.
    void probe(ClientId client, uint64_t frame);

    /// Records FrameData{frame, set} from `client`; see Verdict.
    Verdict onFrameData(ClientId client, uint64_t frame, uint32_t set);
    /// Records Stats{frame} from `client`, which ends that frame for the client.
    Verdict onStats(ClientId client, uint64_t frame);

    /// The client left: its unfinished sets of every frame in flight become missing, and nothing
    /// more is expected from it (so those frames may now be complete).
    void dropClient(ClientId client);

    /// Retires, in order, every frame at the front that is complete, or whose deadline is ≤ `now`
    /// (its unfinished sets become missing). Cost O(sets) per frame retired.
    std::vector<RetiredFrame> takeReady(TimePoint now);

    /// Changes M² (a settings change of M). Precondition (checked): no frame in flight. Frames
    /// already retired stay known, so their late data is still recognised as Late.
    void resize(uint32_t setCount);

    /// Deadline of the oldest frame in flight, if any.
    std::optional<TimePoint> nextDeadline() const;
    /// Frames begun and not yet retired.
    size_t inFlight() const { return frames_.size(); }
    /// Frames sent to `client` that it has not finished (no Stats yet), shown or not.
    size_t outstanding(ClientId client) const;
    /// Consecutive deadline retirements in which `client` was late (reset when it finishes a frame
    /// in time).
    uint32_t consecutiveMisses(ClientId client) const;

private:
    struct Frame {
        uint64_t frame = 0;
        std::vector<ClientId> owner;
        std::vector<uint8_t> arrived;  // per set: 1 once its FrameData is in
        size_t pendingSets = 0;        // sets sent and not arrived (nor dropped)
        std::vector<ClientId> pendingStats;
        std::vector<uint32_t> dropped;  // sets given up (client left)
        TimePoint begun{};
        std::chrono::milliseconds budget{0};  // how long it may wait once it is the oldest
        TimePoint oldestSince{};              // when it became the oldest (valid with deadline)
        std::optional<TimePoint> deadline;
    };
    struct ClientFrame {
        std::vector<uint32_t> pendingSets;  // ascending
        std::vector<uint32_t> doneSets;
    };
    Frame* findFrame(uint64_t frame);

    uint32_t setCount_;
    std::chrono::milliseconds deadline_;
    std::deque<Frame> frames_;
    std::map<ClientId, std::map<uint64_t, ClientFrame>> clients_;
    std::map<ClientId, uint32_t> misses_;
};

}  // namespace rtpm::server
