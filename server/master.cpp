// The master's frame loop on one io_context, with assembly and output on a separate thread.
#include "server/master.h"

#include <asio.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <csignal>
#include <deque>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <thread>

#include "common/image/frame_image.h"
#include "common/scene/gltf_export.h"
#include "common/image/image_io.h"
#include "common/core/interleave.h"
#include "server/assignment.h"
#include "server/frame_assembler.h"
#include "server/session.h"

namespace rtpm::server {

namespace {

/// Frames in flight at once (and assembly jobs queued at once): the client renders frame f+1
/// while f travels and is assembled, so neither side idles (DESIGN §2.1 pipelining).
constexpr size_t kPipeline = 2;
/// Frames over which the per-frame fps figure is averaged.
constexpr size_t kFpsWindow = 8;

static_assert(sizeof(proto::PixelPair) == sizeof(PixelRadiance), "decoded pixels copy 1:1");

bool tokenMatches(const std::string& expected, const std::string& given) {
    // Constant time in the secret's content: every byte is compared whatever differs first.
    size_t n = std::max(expected.size(), given.size());
    size_t diff = expected.size() ^ given.size();
    for (size_t i = 0; i < n; ++i) {
        unsigned char a = i < expected.size() ? static_cast<unsigned char>(expected[i]) : 0;
        unsigned char b = i < given.size() ? static_cast<unsigned char>(given[i]) : 0;
        diff |= static_cast<size_t>(a ^ b);
    }
    return diff == 0;
}


std::string framePath(const std::string& out, uint64_t frame, const char* ext) {
    std::filesystem::path p(out);
    char buf[32];
    std::snprintf(buf, sizeof buf, "_%05llu", static_cast<unsigned long long>(frame));
    return (p.parent_path() / (p.stem().string() + buf + ext)).string();
}

}  // namespace

struct Master::Impl : SessionHandler {
    struct Client {
        ClientId id = 0;
        std::shared_ptr<Session> session;
        std::string name;
        bool capped = false;  // last Stats of a non-interaction frame shot no photon
        uint32_t skips = 0;   // consecutive frames skipped (two frames still outstanding)
    };
    struct FrameInfo {
        proto::FrameMode mode = proto::FrameMode::Accumulate;
        uint64_t bytes = 0;
        uint64_t photonsStored = 0;
        uint64_t setsReported = 0;  // sets of the clients whose Stats arrived
        float slowestMs = -1.0f;
        std::string slowest = "-";
        std::vector<ClientId> owners;  // who was asked for each set
        std::vector<proto::FrameData> data;
    };
    struct RetireJob {
        uint64_t frame = 0;
        proto::FrameMode mode{};
        double fps = 0.0;
        uint64_t bytes = 0;
        double photonsPerSet = 0.0;
        std::string slowest;
        float slowestMs = 0.0f;
        size_t arrived = 0;
        bool deadlineHit = false;
        std::vector<ClientId> owners;  // owner per set at this frame, to name bad payloads
        std::vector<proto::FrameData> data;
        bool save = false;
        bool last = false;
    };

    MasterOptions opt;
    Interleave pattern;
    uint32_t setCount;
    LiveScene live;
    std::vector<uint8_t> glb;  // file scenes: what clients load
    Session::Buffer settingsMsg;

    asio::io_context io;
    asio::ip::tcp::acceptor acceptor{io};
    asio::steady_timer deadlineTimer{io};
    asio::steady_timer finishTimer{io};
    asio::signal_set signals{io};

    std::set<std::shared_ptr<Session>> sessions;
    std::map<Session*, ClientId> bySession;
    std::map<ClientId, Client> clients;
    std::vector<ClientId> joinOrder;
    ClientId nextClientId = 1;

    FrameAssembler assembler;
    Assignment assignment;
    bool clientsChanged = false;
    std::map<uint64_t, FrameInfo> frameInfo;
    uint64_t nextFrame = 0;
    uint32_t epoch = 0;
    uint32_t sceneVersion = 1;
    uint64_t epochStart = 0;
    bool allCapped = false;
    size_t scriptPos = 0;
    size_t retiresQueued = 0;
    bool started = false;
    bool finishing = false;
    int exitCode = 0;
    TimePoint startTime{}, lastShown{};
    std::deque<TimePoint> shownTimes;  // retirement times of the last kFpsWindow + 1 frames
    MasterSummary summary;

    // Assembly thread and its state (touched only there).
    asio::io_context workerIo;
    asio::executor_work_guard<asio::io_context::executor_type> workerGuard{workerIo.get_executor()};
    std::thread worker;
    FrameImage image;
    std::vector<std::vector<proto::PixelPair>> decodeBufs;
    std::vector<std::vector<PixelRadiance>> radianceBufs;
    FILE* csv = nullptr;

    Impl(MasterOptions o, Scene scene)
        : opt(std::move(o)),
          pattern{opt.settings.width, opt.settings.height, opt.settings.interleave},
          setCount(static_cast<uint32_t>(opt.settings.interleave * opt.settings.interleave)),
          live(std::move(scene)),
          assembler(setCount, opt.deadline),
          image(opt.settings.width, opt.settings.height),
          decodeBufs(setCount),
          radianceBufs(setCount) {
        validateSettings(opt.settings);
        if (opt.frames < 1) throw std::invalid_argument("--frames must be >= 1");
        if (opt.minClients < 1) throw std::invalid_argument("--min-clients must be >= 1");
        if (opt.token.empty() && !opt.insecureNoToken)
            throw std::invalid_argument("no token: pass --token or set RTPM_TOKEN (or --insecure-no-token)");
        if (opt.token.size() > proto::kMaxTokenBytes)
            throw std::invalid_argument("token longer than " + std::to_string(proto::kMaxTokenBytes) + " bytes");
        checkAnimation(opt.animation, live.scene());
        // Dry-run the script on a copy so a bad line fails at start, not at frame n.
        {
            LiveScene dry(live.loaded());
            std::vector<proto::SceneEdit> sink;
            for (const ScriptEdit& e : opt.script) dry.apply(e, opt.scriptFile, sink);
        }
        proto::Settings s;
        const RenderSettings& rs = opt.settings;
        s.width = static_cast<uint32_t>(rs.width);
        s.height = static_cast<uint32_t>(rs.height);
        s.m = static_cast<uint32_t>(rs.interleave);
        s.f = static_cast<uint32_t>(rs.filterSize());
        s.photonsPerSetPerFrame = rs.photons.photonsPerBatch;
        s.k = rs.photons.k;
        s.rMax = rs.photons.rMax;
        s.maxDepth = static_cast<uint32_t>(rs.eye.maxDepth);
        s.diffuseBounces = rs.photons.diffuseBounces;
        if (rs.photons.capPhotons > (1u << 30)) throw std::invalid_argument("--cap must be at most 2^30 in a cluster");
        s.capPhotonsPerSet = static_cast<uint32_t>(rs.photons.capPhotons);
        s.spt = rs.photons.selective;
        s.tree = rs.photons.tree == PhotonTree::MedianBalanced ? proto::TreeVariant::BalancedKdTree
                 : rs.photons.tree == PhotonTree::UniformGrid  ? proto::TreeVariant::UniformGrid
                                                               : proto::TreeVariant::MiddleSplitKdTree;
        s.encoding = opt.encoding;
        s.seed = rs.photons.seed;
        s.photonMaxDepth = rs.photons.maxDepth;
        s.areaLightSamples = static_cast<uint32_t>(rs.eye.areaLightSamples);
        s.gatherVisibility = rs.photons.gatherVisibility;
        settingsMsg = std::make_shared<const std::vector<uint8_t>>(proto::encode(s));
        if (!opt.builtin) {
            glb = encodeGlb(live.loaded());
            auto probe = proto::tryEncode(sceneMessage());
            if (!probe.ok()) throw std::invalid_argument("scene too large to send: " + probe.error().message);
        }

        asio::ip::tcp::endpoint ep(asio::ip::make_address(opt.listen), opt.port);
        acceptor.open(ep.protocol());
        acceptor.set_option(asio::socket_base::reuse_address(true));
        acceptor.bind(ep);
        acceptor.listen();

        if (!opt.csv.empty()) {
            bool fresh = !std::filesystem::exists(opt.csv);
            csv = std::fopen(opt.csv.c_str(), "a");
            if (!csv) throw std::runtime_error("cannot open " + opt.csv);
            if (fresh)
                std::fprintf(csv, "frame,fps,photons_per_set,mode,bytes,slowest_client,slowest_ms,sets_arrived,"
                                  "sets_total,deadline_hit,master_ms\n");
        }
        worker = std::thread([this] { workerIo.run(); });
    }

    ~Impl() override {
        workerGuard.reset();
        if (worker.joinable()) worker.join();
        if (csv) std::fclose(csv);
    }

    proto::Scene sceneMessage() const {
        proto::Scene m;
        m.sceneVersion = sceneVersion;
        if (opt.builtin) {
            m.source = proto::Scene::Source::Builtin;
            m.builtinName = opt.sceneName;
        } else {
            m.source = proto::Scene::Source::Gltf;
            m.gltf = glb;
        }
        m.edits = live.compactedEdits();
        return m;
    }

    uint16_t port() const { return acceptor.local_endpoint().port(); }

    // ---- startup -------------------------------------------------------------------------

    int run() {
        if (!opt.portFile.empty()) {
            std::string tmp = opt.portFile + ".tmp";
            FILE* f = std::fopen(tmp.c_str(), "w");
            if (!f) throw std::runtime_error("cannot write " + tmp);
            std::fprintf(f, "%u\n", static_cast<unsigned>(port()));
            std::fclose(f);
            std::filesystem::rename(tmp, opt.portFile);
        }
        std::printf("rtpm-server listening on %s:%u\n", opt.listen.c_str(), static_cast<unsigned>(port()));
        std::printf("scene %s, %dx%d, M=%d (%u sets), F=%d, P=%u, k=%u, %s, %d frames, waiting for %d client(s)\n",
                    opt.sceneName.c_str(), opt.settings.width, opt.settings.height, opt.settings.interleave,
                    setCount, opt.settings.filterSize(), opt.settings.photons.photonsPerBatch,
                    opt.settings.photons.k, opt.settings.photons.selective ? "SPT" : "plain shooting", opt.frames,
                    opt.minClients);
        std::fflush(stdout);
        signals.add(SIGINT);
        signals.add(SIGTERM);
        signals.async_wait([this](const asio::error_code& ec, int sig) {
            if (ec) return;
            std::fprintf(stderr, "rtpm-server: signal %d, shutting down\n", sig);
            shutdown(130, proto::ByeReason::Shutdown, "server interrupted");
        });
        accept();
        io.run();
        workerGuard.reset();
        if (worker.joinable()) worker.join();
        if (!opt.quiet || exitCode == 0) printSummary();
        return exitCode;
    }

    void printSummary() {
        double fps = summary.seconds > 0 ? double(summary.framesShown) / summary.seconds : 0.0;
        std::printf("summary: %llu frames shown (%llu incomplete) in %.2f s = %.2f fps, %.1f MB received, "
                    "%llu clients joined, %llu peers refused or dropped for protocol errors\n",
                    (unsigned long long)summary.framesShown, (unsigned long long)summary.framesIncomplete,
                    summary.seconds, fps, double(summary.bytesReceived) / 1e6,
                    (unsigned long long)summary.clientsJoined, (unsigned long long)summary.peersRejected);
        std::fflush(stdout);
    }

    void accept() {
        acceptor.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket sock) {
            if (ec) {
                if (ec != asio::error::operation_aborted && !finishing) {
                    std::fprintf(stderr, "rtpm-server: accept failed: %s\n", ec.message().c_str());
                    accept();
                }
                return;
            }
            if (finishing) return;
            if (sessions.size() >= static_cast<size_t>(opt.maxPeers)) {
                std::fprintf(stderr, "rtpm-server: refusing a connection: %zu peers already connected\n",
                             sessions.size());
                asio::error_code ignored;
                sock.close(ignored);
            } else {
                auto s = std::make_shared<Session>(std::move(sock), *this, opt.maxQueuedBytes);
                sessions.insert(s);
                s->start(opt.handshakeTimeout);
            }
            accept();
        });
    }

    // ---- peers ---------------------------------------------------------------------------

    std::string who(Session& s) const {
        auto it = bySession.find(&s);
        if (it == bySession.end()) return "peer " + s.peer() + " (not authenticated)";
        const Client& c = clients.at(it->second);
        return "client " + std::to_string(c.id) + " (" + c.name + ", " + s.peer() + ")";
    }

    void reject(Session& s, proto::RejectReason reason, const std::string& text) {
        std::fprintf(stderr, "rtpm-server: rejecting %s: %s\n", who(s).c_str(), text.c_str());
        ++summary.peersRejected;
        s.send(proto::Reject{reason, text.substr(0, proto::kMaxTextBytes)});
        s.closeAfterFlush();
    }

    // A peer that broke the protocol after its handshake: log, Bye{ProtocolError}, drop.
    void protocolError(Session& s, const std::string& why) {
        std::fprintf(stderr, "rtpm-server: closing %s: protocol error: %s\n", who(s).c_str(), why.c_str());
        ++summary.peersRejected;
        s.send(proto::Bye{proto::ByeReason::ProtocolError, why.substr(0, proto::kMaxTextBytes)});
        s.closeAfterFlush();
        dropClientOf(s, "protocol error");
    }

    void dropClientOf(Session& s, const std::string& why) {
        auto it = bySession.find(&s);
        if (it == bySession.end()) return;
        ClientId id = it->second;
        bySession.erase(it);
        assembler.dropClient(id);
        std::fprintf(stderr, "rtpm-server: client %u (%s) left: %s\n", id, clients[id].name.c_str(), why.c_str());
        clients.erase(id);
        joinOrder.erase(std::find(joinOrder.begin(), joinOrder.end(), id));
        clientsChanged = true;
        post([this] { pump(); });
    }

    template <class F>
    void post(F&& f) {
        asio::post(io, std::forward<F>(f));
    }

    void onBadBytes(Session& s, const proto::Error& e) override {
        std::string why = std::string(proto::errorCodeName(e.code)) + ": " + e.message;
        if (!bySession.count(&s)) {
            reject(s, e.code == proto::ErrorCode::BadVersion ? proto::RejectReason::VersionMismatch
                                                              : proto::RejectReason::ProtocolError,
                   why);
            return;
        }
        protocolError(s, why);
    }

    void onClosed(Session& s, const std::string& why) override {
        dropClientOf(s, why);
        for (auto it = sessions.begin(); it != sessions.end(); ++it)
            if (it->get() == &s) {
                sessions.erase(it);
                break;
            }
        if (finishing && sessions.empty()) io.stop();
    }

    void onMessage(Session& s, proto::Message&& m, size_t wireBytes) override {
        if (finishing) return;
        auto it = bySession.find(&s);
        if (it == bySession.end()) {
            handshake(s, m);
            return;
        }
        Client& c = clients.at(it->second);
        if (auto* fd = std::get_if<proto::FrameData>(&m)) {
            onFrameData(s, c, std::move(*fd), wireBytes);
        } else if (auto* st = std::get_if<proto::Stats>(&m)) {
            onStats(s, c, *st);
        } else if (auto* bye = std::get_if<proto::Bye>(&m)) {
            std::string why = "said Bye (" + std::to_string(static_cast<int>(bye->reason)) + ") " + bye->text;
            s.closeAfterFlush();
            dropClientOf(s, why);
        } else {
            protocolError(s, std::string("unexpected ") + proto::messageTypeName(proto::typeOf(m)) + " from a client");
        }
    }

    void handshake(Session& s, const proto::Message& m) {
        const auto* hello = std::get_if<proto::Hello>(&m);
        if (!hello) {
            reject(s, proto::RejectReason::ProtocolError,
                   std::string("first message must be Hello, got ") + proto::messageTypeName(proto::typeOf(m)));
            return;
        }
        if (hello->protocolVersion != proto::kProtocolVersion) {
            reject(s, proto::RejectReason::VersionMismatch,
                   "protocol version " + std::to_string(hello->protocolVersion) + ", server speaks " +
                       std::to_string(proto::kProtocolVersion));
            return;
        }
        if (!opt.insecureNoToken && !tokenMatches(opt.token, hello->authToken)) {
            reject(s, proto::RejectReason::BadToken, "wrong token");
            return;
        }
        s.markAuthenticated();
        Client c;
        c.id = nextClientId++;
        c.session = nullptr;
        for (const auto& p : sessions)
            if (p.get() == &s) c.session = p;
        c.name = hello->clientName.empty() ? "unnamed" : hello->clientName;
        bySession[&s] = c.id;
        joinOrder.push_back(c.id);
        clients[c.id] = c;
        clientsChanged = true;
        ++summary.clientsJoined;
        // Tentative sets: what the client would hold if a frame began now. FrameBegin is binding.
        Assignment tentative = started ? rebalance(assignment, setCount, joinOrder) : dealSets(setCount, joinOrder);
        std::fprintf(stderr, "rtpm-server: client %u (%s, %s, %u cores) joined\n", c.id, c.name.c_str(),
                     s.peer().c_str(), hello->cores);
        s.send(proto::Welcome{c.id, tentative.setsOf(c.id)});
        s.send(settingsMsg);
        s.send(sceneMessage());
        pump();
    }

    void onFrameData(Session& s, Client& c, proto::FrameData&& fd, size_t wireBytes) {
        if (fd.set < setCount && fd.pixelCount != static_cast<uint32_t>(pattern.pixelCount(static_cast<int>(fd.set)))) {
            protocolError(s, "frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) + ": " +
                                 std::to_string(fd.pixelCount) + " pixels, the set has " +
                                 std::to_string(pattern.pixelCount(static_cast<int>(fd.set))));
            return;
        }
        Verdict v = assembler.onFrameData(c.id, fd.frame, fd.set);
        if (isProtocolError(v)) {
            protocolError(s, "FrameData frame " + std::to_string(fd.frame) + " set " + std::to_string(fd.set) +
                                 ": " + verdictName(v));
            return;
        }
        summary.bytesReceived += wireBytes;
        if (v == Verdict::Late) return;
        FrameInfo& info = frameInfo[fd.frame];
        info.bytes += wireBytes;
        info.data.push_back(std::move(fd));
    }

    void onStats(Session& s, Client& c, const proto::Stats& st) {
        Verdict v = assembler.onStats(c.id, st.frame);
        if (isProtocolError(v)) {
            protocolError(s, "Stats frame " + std::to_string(st.frame) + ": " + verdictName(v));
            return;
        }
        if (v == Verdict::Accept) {
            FrameInfo& info = frameInfo[st.frame];
            info.photonsStored += st.photonsStored;
            info.setsReported += static_cast<uint64_t>(std::count(info.owners.begin(), info.owners.end(), c.id));
            if (st.frameMs > info.slowestMs) {
                info.slowestMs = st.frameMs;
                info.slowest = std::to_string(c.id) + ":" + c.name;
            }
            if (info.mode != proto::FrameMode::Interaction) c.capped = st.photonsShot == 0;
            c.skips = 0;
        }
        pump();
    }

    // ---- frame loop ----------------------------------------------------------------------

    void pump() {
        if (finishing) return;
        TimePoint now = Clock::now();
        for (RetiredFrame& r : assembler.takeReady(now)) retire(r, now);
        evictSlowClients();
        if (!started && joinOrder.size() >= static_cast<size_t>(opt.minClients)) {
            started = true;
            startTime = lastShown = now;
            std::fprintf(stderr, "rtpm-server: %zu client(s) connected, starting frames\n", joinOrder.size());
        }
        while (started && nextFrame < static_cast<uint64_t>(opt.frames) && assembler.inFlight() < kPipeline &&
               retiresQueued < kPipeline && !joinOrder.empty())
            beginFrame(now);
        armDeadline();
        if (nextFrame == static_cast<uint64_t>(opt.frames) && assembler.inFlight() == 0 && retiresQueued == 0)
            shutdown(0, proto::ByeReason::Normal, "all frames rendered");
    }

    void armDeadline() {
        auto d = assembler.nextDeadline();
        if (!d) {
            deadlineTimer.cancel();
            return;
        }
        deadlineTimer.expires_at(*d);
        deadlineTimer.async_wait([this](const asio::error_code& ec) {
            if (!ec) pump();
        });
    }

    void evictSlowClients() {
        std::vector<ClientId> evict;
        for (auto& [id, c] : clients)
            if (assembler.consecutiveMisses(id) >= static_cast<uint32_t>(opt.evictAfter) ||
                c.skips >= static_cast<uint32_t>(opt.evictAfter))
                evict.push_back(id);
        for (ClientId id : evict) {
            auto session = clients[id].session;
            std::fprintf(stderr, "rtpm-server: client %u (%s) missed %d frames in a row; its sets go to others\n",
                         id, clients[id].name.c_str(), opt.evictAfter);
            session->send(proto::Bye{proto::ByeReason::Timeout, "too slow: missed the frame deadline repeatedly"});
            session->closeAfterFlush();
            dropClientOf(*session, "evicted (too slow)");
        }
    }

    void beginFrame(TimePoint now) {
        const uint64_t f = nextFrame++;
        std::vector<proto::SceneEdit> edits;
        animate(opt.animation, f, live, edits);
        while (scriptPos < opt.script.size() && opt.script[scriptPos].frame <= f)
            live.apply(opt.script[scriptPos++], opt.scriptFile, edits);  // validated by the dry run
        bool newEpoch = f == 0;
        if (!edits.empty()) {
            ++epoch;
            newEpoch = true;
            // Every client gets the edits before the FrameBegin of the new epoch (flow §6).
            for (const proto::SceneEdit& e : edits) {
                ++sceneVersion;
                live.record(e);
                auto bytes = std::make_shared<const std::vector<uint8_t>>(proto::encode(proto::Edit{sceneVersion, e}));
                for (auto& [id, c] : clients) c.session->send(bytes);
            }
        }
        if (newEpoch) epochStart = f;
        if (newEpoch || assignment.owner.size() != setCount) {
            // Every map restarts at an epoch anyway, so the plain round-robin deal costs nothing.
            assignment = dealSets(setCount, joinOrder);
            for (auto& [id, c] : clients) c.capped = false;
        } else if (clientsChanged) {
            Assignment next = rebalance(assignment, setCount, joinOrder);
            if (!movedSets(assignment, next).empty())
                for (auto& [id, c] : clients) c.capped = false;
            assignment = std::move(next);
        }
        clientsChanged = false;
        allCapped = !clients.empty();
        for (auto& [id, c] : clients)
            if (assignment.countOf(id) > 0 && !c.capped) allCapped = false;

        proto::FrameMode mode = f == epochStart              ? proto::FrameMode::Interaction
                                : opt.walkthrough || allCapped ? proto::FrameMode::Walkthrough
                                                               : proto::FrameMode::Accumulate;
        std::vector<ClientId> owners = assignment.owner;
        for (ClientId& o : owners)
            if (o != kNoClient && assembler.outstanding(o) >= kPipeline) o = kNoClient;
        const proto::CameraState cam = toCameraState(live.camera());
        for (auto& [id, c] : clients) {
            std::vector<uint32_t> sets = assignment.setsOf(id);
            if (sets.empty()) continue;
            if (assembler.outstanding(id) >= kPipeline) {
                ++c.skips;
                continue;
            }
            c.session->send(proto::FrameBegin{f, epoch, sceneVersion, cam, mode, std::move(sets)});
        }
        frameInfo[f].mode = mode;
        frameInfo[f].owners = owners;
        assembler.beginFrame(f, owners, now);
    }

    void retire(RetiredFrame& r, TimePoint now) {
        FrameInfo info = std::move(frameInfo[r.frame]);
        frameInfo.erase(r.frame);
        RetireJob job;
        job.frame = r.frame;
        job.mode = info.mode;
        // Frames often retire in pairs (pipelining): a rate over the last few frames says more
        // than the gap to the previous one.
        shownTimes.push_back(now);
        if (shownTimes.size() > kFpsWindow + 1) shownTimes.pop_front();
        double span = std::chrono::duration<double>(now - (shownTimes.size() > 1 ? shownTimes.front() : startTime)).count();
        double frames = shownTimes.size() > 1 ? double(shownTimes.size() - 1) : 1.0;
        job.fps = span > 0 ? frames / span : 0.0;
        lastShown = now;
        job.bytes = info.bytes;
        job.photonsPerSet = info.setsReported ? double(info.photonsStored) / double(info.setsReported) : 0.0;
        job.slowest = info.slowest;
        job.slowestMs = std::max(0.0f, info.slowestMs);
        job.arrived = r.arrived.size();
        job.deadlineHit = r.deadlineHit;
        job.owners = std::move(info.owners);
        job.data = std::move(info.data);
        job.last = r.frame + 1 == static_cast<uint64_t>(opt.frames);
        job.save = !opt.out.empty() && opt.saveEvery > 0 && r.frame > 0 && r.frame % uint64_t(opt.saveEvery) == 0;
        ++summary.framesShown;
        if (!r.missing.empty()) ++summary.framesIncomplete;
        summary.seconds = std::chrono::duration<double>(now - startTime).count();
        if (r.deadlineHit) {
            std::string late;
            for (ClientId c : r.late) late += " " + std::to_string(c);
            std::fprintf(stderr, "rtpm-server: frame %llu shown at its deadline with %zu/%u sets (late:%s)\n",
                         (unsigned long long)r.frame, r.arrived.size(), setCount, late.c_str());
        }
        ++retiresQueued;
        asio::post(workerIo, [this, job = std::move(job)]() mutable { assemble(job); });
    }

    // ---- assembly thread -----------------------------------------------------------------

    void assemble(RetireJob& job) {
        auto t0 = Clock::now();
        std::vector<std::string> errors(job.data.size());
        // Decoding is the master's heaviest step: sets decode in parallel (each set appears once
        // per frame, so each buffer has one writer); scatter stays serial (FrameImage contract).
        tbb::parallel_for(size_t(0), job.data.size(), [&](size_t i) {
            const proto::FrameData& d = job.data[i];
            auto& buf = decodeBufs[d.set];
            buf.resize(d.pixelCount);
            proto::Status st = proto::decodePixels(d.encoding, d.pixels, buf);
            if (!st.ok()) {
                errors[i] = st.error().message;
                return;
            }
            auto& rad = radianceBufs[d.set];
            rad.resize(d.pixelCount);
            for (size_t p = 0; p < buf.size(); ++p) {
                rad[p].direct = Vec3(buf[p].direct[0], buf[p].direct[1], buf[p].direct[2]);
                rad[p].caustic = Vec3(buf[p].caustic[0], buf[p].caustic[1], buf[p].caustic[2]);
            }
        });
        std::vector<std::pair<ClientId, std::string>> bad;
        for (size_t i = 0; i < job.data.size(); ++i) {
            const proto::FrameData& d = job.data[i];
            if (!errors[i].empty()) {
                bad.emplace_back(job.owners[d.set], "frame " + std::to_string(d.frame) + " set " +
                                                        std::to_string(d.set) + ": bad pixel payload: " + errors[i]);
                continue;
            }
            image.scatter(pattern, static_cast<int>(d.set), radianceBufs[d.set]);
        }
        image.filterAndCompose(opt.settings.filterSize());
        double masterMs = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        try {
            if (job.save) writeImages(framePath(opt.out, job.frame, ".exr"));
            if (job.last && !opt.out.empty()) writeImages(opt.out);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "rtpm-server: cannot write images: %s\n", e.what());
        }
        if (!opt.quiet) {
            std::printf("frame %5llu  %7.2f fps  %-11s  photons/set %10.0f  sets %3zu/%-3u  %8.2f MB  "
                        "slowest %s %.1f ms  master %.2f ms%s\n",
                        (unsigned long long)job.frame, job.fps, proto::frameModeName(job.mode), job.photonsPerSet, job.arrived,
                        setCount, double(job.bytes) / 1e6, job.slowest.c_str(), job.slowestMs, masterMs,
                        job.deadlineHit ? "  (deadline)" : "");
            std::fflush(stdout);
        }
        if (csv) {
            std::fprintf(csv, "%llu,%.3f,%.1f,%s,%llu,%s,%.3f,%zu,%u,%d,%.3f\n", (unsigned long long)job.frame,
                         job.fps, job.photonsPerSet, proto::frameModeName(job.mode), (unsigned long long)job.bytes,
                         job.slowest.c_str(), job.slowestMs, job.arrived, setCount, job.deadlineHit ? 1 : 0,
                         masterMs);
            std::fflush(csv);
        }
        asio::post(io, [this, bad = std::move(bad)] {
            --retiresQueued;
            for (const auto& [id, why] : bad) {
                auto it = clients.find(id);
                if (it != clients.end()) protocolError(*it->second.session, why);
            }
            pump();
        });
    }

    void writeImages(const std::string& exrPath) {
        std::filesystem::path dir = std::filesystem::path(exrPath).parent_path();
        if (!dir.empty()) std::filesystem::create_directories(dir);
        writeExr(exrPath, image);
        std::string png = std::filesystem::path(exrPath).replace_extension(".png").string();
        writePng(png, image.width(), image.height(), image.final());
        std::fprintf(stderr, "rtpm-server: wrote %s and %s\n", exrPath.c_str(), png.c_str());
    }

    // ---- end -----------------------------------------------------------------------------

    void shutdown(int code, proto::ByeReason reason, const std::string& text) {
        if (finishing) return;
        finishing = true;
        exitCode = code;
        asio::error_code ec;
        acceptor.close(ec);
        deadlineTimer.cancel();
        signals.cancel();
        for (const auto& s : sessions) {
            if (bySession.count(s.get())) s->send(proto::Bye{reason, text});
            s->closeAfterFlush();
        }
        if (sessions.empty()) {
            io.stop();
            return;
        }
        finishTimer.expires_after(std::chrono::seconds(3));
        finishTimer.async_wait([this](const asio::error_code& e) {
            if (!e) io.stop();
        });
    }
};

Master::Master(MasterOptions options, Scene scene) : impl_(std::make_unique<Impl>(std::move(options), std::move(scene))) {}
Master::~Master() = default;
uint16_t Master::port() const { return impl_->port(); }
int Master::run() { return impl_->run(); }
void Master::stop() {
    asio::post(impl_->io, [this] { impl_->shutdown(130, proto::ByeReason::Shutdown, "server stopped"); });
}
const MasterSummary& Master::summary() const { return impl_->summary; }

}  // namespace rtpm::server
