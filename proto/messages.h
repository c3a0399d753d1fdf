// The protocol's messages, their encoding and validated decoding, and a TCP stream splitter.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "common/core/render_settings.h"
#include "proto/pixel_codec.h"
#include "proto/settings_rows.h"
#include "proto/wire.h"

namespace rtpm::proto {

// Field limits (PROTOCOL.md §4). Decoders reject anything above them. The Settings message's
// limits are its rows' (common/core/knobs.h, proto/settings_rows.h).
inline constexpr size_t kMaxTokenBytes = 256;        ///< the shared secret (never on the wire; proto/auth.h)
inline constexpr size_t kNonceBytes = 32;            ///< Challenge.nonce
inline constexpr size_t kMacBytes = 32;              ///< Auth.mac (HMAC-SHA256)
inline constexpr uint64_t kMaxEnvironmentTexels = uint64_t(4096) * 2048;  ///< Scene's map (common/scene/environment.h)
inline constexpr size_t kMaxNameBytes = 256;         ///< Hello.clientName, Scene.builtinName
inline constexpr size_t kMaxTextBytes = 1024;        ///< Reject.text, Bye.text
/// Set ids are below this: M×M sets for the largest M the interleave row allows (16).
inline constexpr uint32_t kMaxSets =
    uint32_t(knobRow(Knob::Interleave).max) * uint32_t(knobRow(Knob::Interleave).max);
inline constexpr uint32_t kMaxEditsPerScene = 65536; ///< Scene.edits
inline constexpr uint32_t kMaxPassBatches = 1024;     ///< FrameBegin.passBatches
inline constexpr uint32_t kMaxPassPeriod = 64;        ///< FrameBegin.passPeriod
inline constexpr uint32_t kMaxSharedPhotons = 1u << 18;  ///< FrameBegin.shared, FrameData.shot (all photons)

/// Three floats; the protocol's own vector type (proto/ does not depend on GLM).
struct Vec3f {
    float x = 0.0f, y = 0.0f, z = 0.0f;
    bool operator==(const Vec3f&) const = default;
};

/// Pinhole camera, glTF convention (docs/ARCHITECTURE.md §9): world position, unit forward and up,
/// yfov rad.
struct CameraState {
    Vec3f position;
    Vec3f forward{0.0f, 0.0f, -1.0f};
    Vec3f up{0.0f, 1.0f, 0.0f};
    float yfov = 0.8f;
    bool operator==(const CameraState&) const = default;
};

/// Client → server, first message on a connection. Carries no secret (version 3): the server
/// answers with a Challenge and the client proves it holds the token with an Auth.
struct Hello {
    uint16_t protocolVersion = kProtocolVersion;
    uint32_t cores = 1;      ///< hardware threads the client will use, ≥ 1
    std::string clientName;  ///< for logs; ≤ kMaxNameBytes
    /// The fingerprint of the client's Settings rows (version 8): the server refuses a client
    /// whose rows differ from its own (VersionMismatch), as it refuses another version.
    uint64_t settingsLayout = kSettingsLayout;
    bool operator==(const Hello&) const = default;
};

/// Server → client, the answer to a Hello: a fresh random nonce (never reused), so a recorded
/// Auth is worth nothing on another connection.
struct Challenge {
    std::array<uint8_t, kNonceBytes> nonce{};
    bool operator==(const Challenge&) const = default;
};

/// Client → server, the answer to a Challenge: HMAC-SHA256 keyed with the token over the nonce
/// and the Hello's session parameters (proto/auth.h, PROTOCOL.md §7).
struct Auth {
    std::array<uint8_t, kMacBytes> mac{};
    bool operator==(const Auth&) const = default;
};

/// Server → client: accepted. `sets` are the interleaving sets this client renders (distinct,
/// each < kMaxSets; may be empty for a spare client). The order is the server's choice.
struct Welcome {
    uint32_t clientId = 0;
    std::vector<uint32_t> sets;
    bool operator==(const Welcome&) const = default;
};

/// Why a handshake was refused. Append-only ids.
enum class RejectReason : uint16_t {
    VersionMismatch = 1,  ///< Hello.protocolVersion or header version differs
    BadToken = 2,         ///< authentication failed (Auth does not prove the server's token): do not retry
    ServerFull = 3,       ///< no interleaving set left to assign (not sent by this server)
    ProtocolError = 4,    ///< first message was not a valid Hello, or the handshake broke the protocol
    Capacity = 5,         ///< the master is at a connection limit: retry later, with backoff (version 3)
    RateLimited = 6,      ///< too many failed authentications from this address: retry later (version 3)
};
inline constexpr uint16_t kMaxRejectReason = 6;

/// True for refusals a client should retry with backoff (the master is busy, not hostile to it).
inline bool rejectIsTransient(RejectReason r) {
    return r == RejectReason::Capacity || r == RejectReason::RateLimited;
}

/// Server → client: refused; the server closes the connection after sending it.
struct Reject {
    RejectReason reason = RejectReason::ProtocolError;
    std::string text;  ///< for people; ≤ kMaxTextBytes
    bool operator==(const Reject&) const = default;
};

/// The scene edits (docs/ARCHITECTURE.md §2). Indices refer to the loaded scene's arrays; the
/// receiver checks them against its scene (the decoder cannot).
struct CameraEdit {
    CameraState camera;
    bool operator==(const CameraEdit&) const = default;
};
struct LightEdit {
    uint32_t index = 0;  ///< into Scene::lights (punctual lights)
    Vec3f position;      ///< world, metres
    Vec3f direction;     ///< unit; direction the light travels (spot, directional)
    Vec3f intensity;     ///< W/sr (point, spot) or W/m² (directional), colour included, ≥ 0
    bool operator==(const LightEdit&) const = default;
};
/// Material model of an edit (mirrors rtpm::MaterialType). Append-only ids.
enum class MaterialKind : uint8_t { Diffuse = 0, Mirror = 1, Dielectric = 2, Plastic = 3 };
inline constexpr uint8_t kMaxMaterialKind = 3;
struct MaterialEdit {
    uint32_t index = 0;  ///< into Scene::materials
    MaterialKind kind = MaterialKind::Diffuse;
    Vec3f baseColor;     ///< albedo or reflectance, each in [0, 1]
    float ior = 1.5f;    ///< > 0
    Vec3f absorption;    ///< Beer–Lambert σ_a per metre, ≥ 0
    Vec3f emission;      ///< W/(m²·sr), ≥ 0
    bool operator==(const MaterialEdit&) const = default;
};
struct TransformEdit {
    uint32_t instance = 0;           ///< into Scene::instances
    std::array<float, 16> matrix{};  ///< object → world, column-major (as glm::mat4 / glTF)
    bool operator==(const TransformEdit&) const = default;
};
using SceneEdit = std::variant<CameraEdit, LightEdit, MaterialEdit, TransformEdit>;
/// Wire ids of the SceneEdit alternatives (u8). Append-only.
enum class EditKind : uint8_t { Camera = 0, Light = 1, Material = 2, Transform = 3 };

/// Server → client: the scene to load, then `edits` applied in order. Replaces any previous scene.
struct Scene {
    enum class Source : uint8_t { Builtin = 0, Gltf = 1 };
    uint32_t sceneVersion = 0;
    Source source = Source::Builtin;
    std::string builtinName;    ///< Source::Builtin: e.g. "ring"; ≤ kMaxNameBytes; else empty
    std::vector<uint8_t> gltf;  ///< Source::Gltf: a .glb, or a .gltf with embedded buffers
    std::vector<SceneEdit> edits;  ///< ≤ kMaxEditsPerScene
    /// The world light (version 5, PROTOCOL.md §5.4): none, a uniform radiance or an
    /// equirectangular map of radiance texels, sent as the master loaded it.
    enum class Environment : uint8_t { None = 0, Uniform = 1, Map = 2 };
    Environment environment = Environment::None;
    Vec3f environmentColour;     ///< Uniform: W/(m²·sr), finite ≥ 0; else 0
    uint32_t environmentWidth = 0, environmentHeight = 0;  ///< Map: width = 2·height, ≤ kMaxEnvironmentTexels texels
    std::vector<float> environmentTexels;  ///< Map: width·height RGB triples, row 0 the zenith, finite ≥ 0
    bool operator==(const Scene&) const = default;
};

/// Server → client: render settings. Takes effect at the next FrameBegin; a change resets photon
/// maps unless only knobs that reset the master's output changed (PROTOCOL.md §5.5). On the wire:
/// the encoding, then the rows of kSettingsRows (proto/settings_rows.h), each read from and
/// written to `render` through its row; a decoded `render` holds RenderSettings{}'s values for
/// everything else.
struct Settings {
    PixelEncoding encoding = PixelEncoding::Rgb9e5Zstd;  ///< what clients send FrameData in
    RenderSettings render;
    bool operator==(const Settings&) const = default;
};

/// Frame mode (docs/ARCHITECTURE.md §2.1). Append-only ids.
/// Converging (version 2): camera and scene unchanged since the previous frame with the
/// progressive estimator; clients run a progressive pass (shooting even when capped).
/// Edit (version 7): the first frame of an epoch a scene edit began; as Interaction, but clients with the
/// progressive estimator show the map's k-NN estimate and start no progression.
enum class FrameMode : uint8_t {
    Interaction = 0,
    Accumulate = 1,
    Walkthrough = 2,
    Converging = 3,
    Edit = 4,
    Relight = 5,  ///< version 9
};
inline constexpr uint8_t kMaxFrameMode = 5;

/// Server → client: render `frame`. A client resets its photon maps when `epoch` changes.
/// `sets` lists the sets to render this frame (a subset of, or equal to, the Welcome sets).
/// One stored photon as the wire carries it (20 bytes; common/photon/photon.h's Photon): position
/// in metres, power as an RGB9E5 word in the maps' power unit, incoming direction octahedral.
struct PhotonRecord {
    float x = 0.0f, y = 0.0f, z = 0.0f;
    uint32_t power = 0;
    uint32_t incoming = 0;
    bool operator==(const PhotonRecord&) const = default;
};

/// The photons one set shot in one frame, `batches` whole batches of them (version 5:
/// common/photon/shared_photons.h).
struct SetShot {
    uint32_t set = 0;      ///< < kMaxSets
    uint32_t batches = 0;  ///< in [1, kMaxPassBatches]
    std::vector<PhotonRecord> photons;
    bool operator==(const SetShot&) const = default;
};

struct FrameBegin {
    uint64_t frame = 0;
    uint32_t epoch = 0;
    uint32_t sceneVersion = 0;
    CameraState camera;
    FrameMode mode = FrameMode::Interaction;
    std::vector<uint32_t> sets;  ///< distinct, each < kMaxSets
    /// Batches each progressive pass of this frame shoots, in [1, kMaxPassBatches] (version 4:
    /// still views grow their passes to the master's frame-time budget).
    uint32_t passBatches = 1;
    /// Version 6: in a Converging frame the sets take turns shooting, a set's pass shooting only
    /// every passPeriod-th pass of its progression (common/render/pass_budget.h passShoots), in
    /// [1, kMaxPassPeriod]; 1 in every other frame.
    uint32_t passPeriod = 1;
    /// Version 5: every set's shot of frame `frame` − 2 (kSharedPhotonLag), for the progressive
    /// passes of this frame; empty when none may be binned (the camera moved, the scene changed).
    /// Ascending distinct sets, each with ≥ 1 photon; ≤ kMaxSharedPhotons photons in all.
    std::vector<SetShot> shared;
    bool operator==(const FrameBegin&) const = default;
};

/// Client → server: every pixel of one set for one frame, row-major within the set
/// (common/core/interleave.h). `pixels` is the pixel codec payload; its size is validated against
/// `pixelCount` and `encoding` by the decoder, its content by decodePixels().
struct FrameData {
    uint64_t frame = 0;
    uint32_t set = 0;  ///< < kMaxSets
    PixelEncoding encoding = PixelEncoding::Rgb9e5;
    uint32_t pixelCount = 0;
    std::vector<uint8_t> pixels;
    /// Progressive passes of the set's current progression (0 = a restart or the knn estimator);
    /// the master weighs the set's own caustic against the box filter by it (version 2).
    uint32_t passes = 0;
    // Appended in version 4: the progressive estimator's per-pixel own weights and error figures.
    /// Empty, or one byte per pixel: the weight in 255ths of the pixel's own caustic against the
    /// box filter (common/render/progressive.h).
    std::vector<uint8_t> ownWeights;
    double errorSigma = 0.0;     ///< Σ σ over the set's caustic region (finite, ≥ 0)
    double errorRadiance = 0.0;  ///< Σ radiance over the same pixels (finite, ≥ 0)
    uint32_t errorPixels = 0;    ///< pixels in it, ≤ pixelCount
    double errorBatches = 0.0;   ///< version 10: the set's own batches in its estimate (finite, ≥ 0)
    /// Version 5: the photons the set shot this frame (shotBatches whole batches; 0 and none for
    /// the knn estimator), which the master forwards to every client two frames later.
    uint32_t shotBatches = 0;
    std::vector<PhotonRecord> shot;  ///< ≤ kMaxSharedPhotons
    /// Version 10 (on the wire after pixelCount): the set's pixels and own weights are those its
    /// FrameData of frame `sameAs` (< frame) carried — a set off its turn — and `pixels` and
    /// `ownWeights` are empty.
    bool unchanged = false;
    uint64_t sameAs = 0;  ///< 0 unless `unchanged`
    /// Version 11 (last on the wire): empty (always with `unchanged`, and for knn), or one byte per
    /// pixel: the relative Poisson noise of its caustic in 64ths (ProgressiveSet::noise), which
    /// the master's filter allows for before it reads an edge.
    std::vector<uint8_t> noise;
    bool operator==(const FrameData&) const = default;
};

/// Server → client: one live edit; `sceneVersion` is the version after applying it.
struct Edit {
    uint32_t sceneVersion = 0;
    SceneEdit edit;
    bool operator==(const Edit&) const = default;
};

/// Client → server after each frame: where its time went. Times in milliseconds, finite, ≥ 0.
struct Stats {
    uint64_t frame = 0;
    float photonMs = 0.0f;   ///< shooting + kd-tree insertion
    float renderMs = 0.0f;   ///< eye pass of all owned sets
    float encodeMs = 0.0f;   ///< pixel encoding
    float frameMs = 0.0f;    ///< FrameBegin received → last FrameData sent
    uint64_t photonsShot = 0;     ///< this frame, all sets
    uint64_t photonsStored = 0;   ///< in all maps after this frame
    uint64_t memoryBytes = 0;     ///< photon maps + scene, approximate
    uint32_t threads = 0;
    bool operator==(const Stats&) const = default;
};

/// Why a peer leaves. Append-only ids.
///  * Normal: the run is complete (server) / —.
///  * Shutdown: the sender stops before the run is complete (operator, signal).
///  * ProtocolError: the receiver sent something unusable; `text` names it.
///  * Timeout: server → client: the client is evicted (it missed frame deadlines, or was frozen);
///    it may rejoin. Client → server: the server fell silent past the client's idle timeout.
enum class ByeReason : uint16_t { Normal = 0, Shutdown = 1, ProtocolError = 2, Timeout = 3 };
inline constexpr uint16_t kMaxByeReason = 3;

/// Either way: the sender closes after it. `text` ≤ kMaxTextBytes.
struct Bye {
    ByeReason reason = ByeReason::Normal;
    std::string text;
    bool operator==(const Bye&) const = default;
};

/// Server → client, no payload: sent every kHeartbeatInterval to each authenticated client with
/// nothing queued for it, so a client tells a silent (frozen, partitioned) server from an idle
/// one (paused, waiting for clients, a spare) by its idle timeout. Clients ignore it otherwise.
struct Heartbeat {
    bool operator==(const Heartbeat&) const = default;
};
/// How often the server sends Heartbeat.
inline constexpr auto kHeartbeatInterval = std::chrono::milliseconds(1000);

/// Any message. The alternative order matches nothing on the wire; use typeOf().
using Message = std::variant<Hello, Welcome, Reject, Scene, Settings, FrameBegin, FrameData, Edit,
                             Stats, Bye, Challenge, Auth, Heartbeat>;

/// The header type of a message.
MessageType typeOf(const Message& m);

/// Names for logs and errors ("Hello", "protocol error", …); "unknown" for out-of-range values.
const char* messageTypeName(MessageType type);
const char* rejectReasonName(RejectReason reason);
const char* byeReasonName(ByeReason reason);
const char* frameModeName(FrameMode mode);

/// Header + payload, ready to write to a socket. Precondition (a bug otherwise, aborts): the
/// payload fits payloadLimit(typeOf(m)); use tryEncode() for sizes that come from users (glTF).
/// Encodes what it is given: the receiver validates. Cost: O(size); one allocation.
std::vector<uint8_t> encode(const Message& m);
/// As encode(), but returns PayloadTooLarge instead of aborting.
Result<std::vector<uint8_t>> tryEncode(const Message& m);

/// Decodes and validates the payload of a message of type `type` (header already checked):
/// counts against the bytes left, enum ranges, finite floats, string and array limits, value
/// ranges, no trailing bytes. Never throws or asserts. Cost: O(payload).
Result<Message> decodePayload(MessageType type, std::span<const uint8_t> payload);

/// decodeHeader() then decodePayload() of exactly one whole message (header + payload).
Result<Message> decodeMessage(std::span<const uint8_t> bytes);

/// Splits a TCP byte stream into messages. Feed bytes as they arrive, in chunks of any size;
/// next() yields each complete message in order. The header is validated as soon as its 16 bytes
/// are in, so an oversize or garbage stream fails before its payload is buffered. After the
/// first error the splitter stays failed (close the peer). Not thread-safe.
/// Memory: at most one header + one payload (≤ its type's limit) beyond what was consumed.
class FrameSplitter {
public:
    /// Appends received bytes. Cost: O(bytes) amortised.
    void feed(std::span<const uint8_t> bytes);
    /// A message, std::nullopt when more bytes are needed, or the (sticky) fatal error.
    Result<std::optional<Message>> next();
    /// Bytes fed but not yet returned as messages.
    /// A header already decoded while its payload is awaited still counts.
    size_t buffered() const { return buf_.size() - pos_ + (header_ ? kHeaderBytes : 0); }
    bool failed() const { return error_.has_value(); }
    /// From the next header on, accepts only messages of `type` with at most `maxPayloadBytes`
    /// (below the type's own limit); anything else fails with NotAllowed before its payload is
    /// buffered. For peers that have not authenticated yet.
    void allowOnly(MessageType type, uint32_t maxPayloadBytes) {
        onlyType_ = type;
        maxPayload_ = maxPayloadBytes;
    }
    /// From the next header on, accepts every type but at most `maxPayloadBytes` (below each
    /// type's own limit), e.g. a bound derived from what the peer was asked to send.
    void capPayload(uint32_t maxPayloadBytes) {
        onlyType_.reset();
        maxPayload_ = maxPayloadBytes;
    }
    /// Lifts allowOnly() and capPayload(): every type up to its own limit.
    void allowAll() {
        onlyType_.reset();
        maxPayload_ = UINT32_MAX;
    }
    /// payloadBytes of the message being received (its header is in), 0 otherwise.
    uint32_t pendingPayloadBytes() const { return header_ ? header_->payloadBytes : 0; }

private:
    std::optional<MessageType> onlyType_;
    uint32_t maxPayload_ = UINT32_MAX;
    std::vector<uint8_t> buf_;
    size_t pos_ = 0;  ///< start of the first unconsumed byte in buf_
    std::optional<Header> header_;  ///< decoded header of the message being received
    std::optional<Error> error_;
};

}  // namespace rtpm::proto
