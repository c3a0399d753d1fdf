// The frame loop: begin, collect, retire, evict, resize, end.
#include "server/frame_loop.h"

#include <algorithm>
#include <cstdio>

#include "common/image/image_io.h"
#include "server/image_output.h"
#include "server/live_control.h"
#include "server/peers.h"

namespace rtpm::server {

namespace {

/// Converging frames reuse every pixel's record; the other modes trace every pixel again.
FrameCost frameCost(proto::FrameMode mode) {
    return mode == proto::FrameMode::Converging ? FrameCost::Converging : FrameCost::Retraced;
}

}  // namespace

FrameLoop::FrameLoop(asio::io_context& io, const MasterOptions& options, Peers& peers, LiveControl& control,
                     ImageOutput& output, FrameLoopListener& listener)
    : opt_(options),
      peers_(peers),
      control_(control),
      output_(output),
      listener_(listener),
      policy_(setCount(), options.walkthrough, kPipeline, static_cast<uint32_t>(std::max(1, options.evictAfter)),
              options.settings.photons.estimator == CausticEstimatorKind::Progressive,
              BalanceOptions{.enabled = !options.staticSets}),
      clock_(io, options.deadline),
      assembler_(setCount(), clock_.forFrame(true)),
      convergence_(options.frameBudgetMs, options.targetError) {}

Interleave FrameLoop::pattern() const {
    const RenderSettings& s = control_.settings();
    return Interleave{s.width, s.height, s.interleave};
}

std::vector<uint32_t> FrameLoop::clientJoined(ClientId id) {
    policy_.clientJoined(id);
    return policy_.tentativeSets(id, peers_.registry().joinOrder());
}

void FrameLoop::clientLeft(ClientId id) {
    probes_.erase(id);
    assembler_.dropClient(id);
    policy_.clientLeft(id);
    ledger_.clientLeft(id);
}

void FrameLoop::onMessage(ClientInfo& client, proto::Message&& m, size_t wireBytes) {
    if (auto* fd = std::get_if<proto::FrameData>(&m)) onFrameData(client, std::move(*fd), wireBytes);
    else if (auto* st = std::get_if<proto::Stats>(&m)) onStats(client, *st);
}

void FrameLoop::onFrameData(ClientInfo& client, proto::FrameData&& fd, size_t wireBytes) {
    net::Connection& c = *client.connection;
    // The negotiated encoding (issue 13: the master asked for rgb9e5-zstd and took float32).
    if (!proto::encodingAnswers(opt_.encoding, fd.encoding)) {
        peers_.protocolError(c, "frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) +
                                    ": pixel encoding " + std::to_string(static_cast<int>(fd.encoding)) +
                                    ", the master asked for " + std::to_string(static_cast<int>(opt_.encoding)));
        return;
    }
    Verdict v = assembler_.onFrameData(client.id, fd.frame, fd.set);
    if (isProtocolError(v)) {
        peers_.protocolError(c, "FrameData frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) +
                                    ": " + verdictName(v));
        return;
    }
    ledger_.counts().bytesReceived += wireBytes;
    // Late data may belong to a frame rendered before a change of M: only data of a frame in
    // flight is checked against the current pattern.
    if (v == Verdict::Late) return;
    const int setPixels = pattern().pixelCount(static_cast<int>(fd.set));
    if (fd.pixelCount != static_cast<uint32_t>(setPixels)) {
        peers_.protocolError(c, "frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) + ": " +
                                    std::to_string(fd.pixelCount) + " pixels, the set has " +
                                    std::to_string(setPixels));
        return;
    }
    relay_.record(fd.frame, fd.set, fd.shotBatches, std::move(fd.shot));
    ledger_.addData(std::move(fd), wireBytes);
}

void FrameLoop::onStats(ClientInfo& client, const proto::Stats& st) {
    Verdict v = assembler_.onStats(client.id, st.frame);
    if (isProtocolError(v)) {
        peers_.protocolError(*client.connection, "Stats frame " + std::to_string(st.frame) + ": " + verdictName(v));
        return;
    }
    if (policy_.answered(client.id)) {  // the frame sent to a joiner with no set: it takes sets now
        probes_.erase(client.id);
        pump();
        return;
    }
    if (v == Verdict::Accept) {
        const FrameLedger::StatsOf of = ledger_.addStats(client.id, client.name, st);
        policy_.stats(client.id, of.mode, st.photonsShot, of.passPeriod);
        // While the sets take turns a frame's work depends on whose turn it was (a set off its
        // turn shows its last pixels): such frames say nothing of a set's cost.
        if (of.passPeriod <= 1)
            policy_.balance().measured(client.id, of.sets, double(st.photonMs) + double(st.renderMs) + double(st.encodeMs));
    }
    pump();
}

void FrameLoop::pump() {
    if (state_ == State::Ending) return;
    TimePoint now = Clock::now();
    for (RetiredFrame& r : assembler_.takeReady(now)) retire(r, now);
    evictSlowClients();
    ClientRegistry& registry = peers_.registry();
    if (!ledger_.started() && registry.size() >= static_cast<size_t>(opt_.minClients)) {
        ledger_.start(now);
        std::fprintf(stderr, "rtpm-server: %zu client(s) connected, starting frames\n", registry.size());
    }
    const bool idle = assembler_.inFlight() == 0 && outputsQueued_ == 0;
    if (control_.resizePending() && idle) resize();
    peers_.raisePayloadCap(control_.settings());  // before any FrameBegin under new settings
    const bool unlimited = opt_.frames == 0;
    while (ledger_.started() && (unlimited || nextFrame_ < static_cast<uint64_t>(opt_.frames)) &&
           !control_.paused() && state_ == State::Running && !control_.resizePending() &&
           assembler_.inFlight() < kPipeline && outputsQueued_ < kPipeline && !registry.empty())
        beginFrame(now);
    armDeadline();
    if (assembler_.inFlight() != 0 || outputsQueued_ != 0) return;
    if (!unlimited && nextFrame_ == static_cast<uint64_t>(opt_.frames))
        end(ledger_.counts().imageWriteFailed ? kExitImageNotWritten : 0, proto::ByeReason::Normal,
            "all frames rendered");
    else if (state_ == State::Stopping)
        finishStopped();
}

void FrameLoop::requestStop() {
    if (state_ != State::Running) return;
    state_ = State::Stopping;
    pump();
}

void FrameLoop::abort() { end(130, proto::ByeReason::Shutdown, "server interrupted"); }

void FrameLoop::end(int exitCode, proto::ByeReason reason, const std::string& text) {
    if (state_ == State::Ending) return;
    state_ = State::Ending;
    clock_.cancel();
    listener_.ending();
    listener_.finished(exitCode, reason, text);
}

// Stopped with nothing in flight: the last image is written only if a frame was shown
// (otherwise there is none), then the run ends.
void FrameLoop::finishStopped() {
    const bool unlimited = opt_.frames == 0;
    if (opt_.out.empty() || ledger_.counts().framesShown == 0) {
        end(unlimited || convergence_.reached() ? 0 : 130, proto::ByeReason::Shutdown, "server stopped");
        return;
    }
    state_ = State::Ending;
    listener_.ending();
    output_.write(opt_.out, [this, unlimited](std::string error) {
        const bool failed = !error.empty();
        if (failed) std::fprintf(stderr, "rtpm-server: cannot write %s: %s\n", opt_.out.c_str(), error.c_str());
        asio::post(clock_.executor(), [this, unlimited, failed] {
            FrameCounts& counts = ledger_.counts();
            counts.imageWriteFailed |= failed;
            clock_.cancel();
            listener_.finished(counts.imageWriteFailed ? kExitImageNotWritten : unlimited || convergence_.reached() ? 0 : 130,
                               proto::ByeReason::Shutdown, "server stopped");
        });
    });
}

// A change of M: every structure sized by M² is rebuilt while no frame is in flight; the
// clients get the new Settings with the next frame, which starts an epoch.
void FrameLoop::resize() {
    const RenderSettings& s = control_.applyResize();
    policy_.resize(setCount());
    assembler_.resize(setCount());
    output_.reconfigure(s.interleave, s.filterSize());
    std::fprintf(stderr, "rtpm-server: M is now %d (%u sets)\n", s.interleave, setCount());
}

void FrameLoop::armDeadline() {
    clock_.arm(assembler_.nextDeadline(), [this] { pump(); });
}

void FrameLoop::evictSlowClients() {
    ClientRegistry& registry = peers_.registry();
    const auto evict =
        policy_.evictions(registry.joinOrder(), [this](ClientId id) { return assembler_.consecutiveMisses(id); });
    for (ClientId id : evict) {
        const std::string why = "evicted: late or skipped " + std::to_string(opt_.evictAfter) +
                                " frames in a row (frame deadline " + std::to_string(clock_.last().count()) +
                                " ms); its sets go to others, it may rejoin";
        std::fprintf(stderr, "rtpm-server: client %u (%s) %s (before frame %llu)\n", id,
                     registry.find(id)->name.c_str(), why.c_str(), (unsigned long long)nextFrame_);
        ++ledger_.counts().clientsEvicted;
        peers_.evict(id, why);
    }
    // A joiner that does not answer a frame without sets within the deadline's ceiling (what a
    // frame would have waited for it) holds a client slot for nothing.
    const auto ceiling = clock_.forFrame(true);
    const TimePoint now = Clock::now();
    std::vector<ClientId> silent;
    for (const auto& [id, sent] : probes_)
        if (now - sent >= ceiling) silent.push_back(id);
    for (ClientId id : silent) {
        probes_.erase(id);
        if (!registry.find(id)) continue;
        const std::string why = "evicted: did not answer its first frame within " + std::to_string(ceiling.count()) +
                                " ms; it may rejoin";
        std::fprintf(stderr, "rtpm-server: client %u (%s) %s\n", id, registry.find(id)->name.c_str(), why.c_str());
        ++ledger_.counts().clientsEvicted;
        peers_.evict(id, why);
    }
}

void FrameLoop::beginFrame(TimePoint now) {
    const uint64_t f = nextFrame_;
    std::optional<FrameStart> start = control_.startFrame(f);
    if (!start) return;  // an M change waits for the frames in flight (pump resumes)
    ++nextFrame_;
    for (const net::Connection::Buffer& m : start->messages) peers_.sendToAll(m);
    ClientRegistry& registry = peers_.registry();
    policy_.setProgressive(control_.settings().photons.estimator == CausticEstimatorKind::Progressive);
    FramePlan plan = policy_.plan(f, start->sceneChanged, registry.joinOrder(),
                                  [this](ClientId id) { return assembler_.outstanding(id); }, start->cameraMoved,
                                  start->still, start->sceneEdited, start->relit);
    if (plan.balanced) {
        std::string share;
        for (ClientId id : registry.joinOrder()) {
            const auto cost = policy_.balance().msPerSet(id);
            char part[96];
            std::snprintf(part, sizeof part, "%s%u: %zu (%.1f ms/set)", share.empty() ? "" : ", ", id,
                          policy_.assignment().countOf(id), cost ? *cost : 0.0);
            share += part;
        }
        std::fprintf(stderr, "rtpm-server: frame %llu: sets by measured cost, client: sets (cost) %s\n",
                     (unsigned long long)f, share.c_str());
    }
    // A still view's passes grow to the frame-time budget; any other frame shoots one batch.
    const uint32_t passBatches = convergence_.batchesFor(plan.mode);
    const uint32_t passPeriod = convergence_.periodFor(plan.mode, start->still);
    // Every set's shot of two frames ago, for this frame's passes (photon_relay.h).
    relay_.began(f, plan.epoch, start->sceneVersion, setCount());
    const std::vector<proto::SetShot> shared = relay_.forwardFor(f, plan.mode == proto::FrameMode::Converging);
    for (auto& [id, sets] : plan.sets)
        registry.find(id)->connection->send(proto::FrameBegin{f, plan.epoch, start->sceneVersion, start->camera,
                                                              plan.mode, std::move(sets), passBatches, passPeriod,
                                                              shared});
    // A joiner's first frame, without sets: nothing of it is rendered, so nothing is shared.
    for (ClientId id : plan.probes)
        registry.find(id)->connection->send(proto::FrameBegin{f, plan.epoch, start->sceneVersion, start->camera,
                                                              plan.mode, {}, passBatches, passPeriod});
    ledger_.began(f, plan.mode, start->still, plan.epoch, plan.owners, passBatches, passPeriod);
    // A frame whose cost the last ones do not predict waits the ceiling, and so does the last
    // frame of a finite run (it is the image written: nothing rendered may be cut short).
    const bool last = opt_.frames > 0 && f + 1 == static_cast<uint64_t>(opt_.frames);
    const bool epochStart = plan.mode == proto::FrameMode::Interaction || plan.mode == proto::FrameMode::Edit ||
                            plan.mode == proto::FrameMode::Relight;
    const auto deadline = clock_.begin(epochStart || plan.reassigned || last, frameCost(plan.mode));
    // A message that stops halfway is no client building maps: it gets the measured deadline
    // even when this frame waits the ceiling.
    peers_.boundReadStall(clock_.forFrame(false, frameCost(plan.mode)));
    assembler_.beginFrame(f, plan.owners, now, deadline);
    for (ClientId id : plan.probes) {
        assembler_.probe(id, f);
        probes_.try_emplace(id, now);
    }
}

void FrameLoop::retire(RetiredFrame& r, TimePoint now) {
    auto [job, shown] = ledger_.retire(r, now, setCount());
    job.last = r.frame + 1 == static_cast<uint64_t>(opt_.frames);
    job.shown = ledger_.counts().framesShown;
    job.elapsedSeconds = ledger_.counts().seconds;
    job.settings = control_.settings();
    if (!opt_.out.empty() && opt_.saveEvery > 0 && r.frame > 0 && r.frame % uint64_t(opt_.saveEvery) == 0)
        job.saveAs = numberedPath(opt_.out, r.frame, ".exr");
    if (!r.deadlineHit && !r.arrived.empty()) clock_.completed(r.waited, frameCost(shown.mode));
    // The budget bounds a client's work on a frame (shooting, eye pass, encoding), not the time
    // from FrameBegin to its last FrameData: with frames in flight that also holds the wait behind
    // the frame before, about twice the work, and the passes never grew.
    const double workMs = double(job.slowestPhotonMs) + double(job.slowestEyeMs) + double(job.slowestEncodeMs);
    convergence_.recordWork(shown.mode, job.cameraStill, workMs, job.passPeriod, double(job.slowestPhotonMs));
    if (r.deadlineHit) {
        std::string late;
        for (ClientId c : r.late) late += " " + std::to_string(c);
        std::fprintf(stderr, "rtpm-server: frame %llu shown at its deadline (%lld ms) with %zu/%u sets (late:%s)\n",
                     (unsigned long long)r.frame,
                     (long long)std::chrono::duration_cast<std::chrono::milliseconds>(r.waited).count(),
                     r.arrived.size(), setCount(), late.c_str());
    }
    ++outputsQueued_;
    output_.post(std::move(job), [this, shown = std::move(shown)](OutputResult result) {
        asio::post(clock_.executor(), [this, shown, result = std::move(result)]() mutable {
            --outputsQueued_;
            ledger_.counts().imageWriteFailed |= result.writeFailed;
            // The error figure comes from the composed image (ImageOutput, shown_change.h).
            shown.errorEstimate = result.errorEstimate;
            if (state_ == State::Running && convergence_.reachesTarget(shown.mode, shown.errorEstimate)) {
                // No new frame begins; the frames in flight finish and the last one shown is
                // written (finishStopped), as after a signal, but the run counts as complete.
                state_ = State::Stopping;
                std::fprintf(stderr, "rtpm-server: frame %llu reached the target error (estimated %.4f <= %g)\n",
                             (unsigned long long)shown.frame, shown.errorEstimate, opt_.targetError);
            }
            if (result.unmatchedUnchanged > 0)
                std::fprintf(stderr, "rtpm-server: frame %llu: %llu sets keep older pixels (unchanged since a frame whose data came late)\n",
                             (unsigned long long)shown.frame, (unsigned long long)result.unmatchedUnchanged);
            listener_.frameShown(shown, result.masterMs);
            for (const auto& [id, why] : result.badPayloads)
                if (ClientInfo* c = peers_.registry().find(id)) peers_.protocolError(*c->connection, why);
            pump();
        });
    });
}

ViewerStatus FrameLoop::status(const ViewerFrame& frame, double masterMs) {
    ViewerStatus st;
    st.frame = frame;
    st.masterMs = masterMs;
    st.paused = control_.paused();
    st.settings = control_.settings();
    st.camera = control_.live().camera();
    ClientRegistry& registry = peers_.registry();
    const bool assigned = policy_.assignment().owner.size() == setCount();
    for (ClientId id : registry.joinOrder()) {
        const ClientInfo* c = registry.find(id);
        const proto::Stats* last = ledger_.lastStats(id);
        st.clients.push_back({id, c->name, c->cores, assigned ? policy_.assignment().setsOf(id) : std::vector<uint32_t>{},
                              last ? last->frameMs : 0.0f, last ? last->photonsStored : 0});
    }
    return st;
}

}  // namespace rtpm::server
