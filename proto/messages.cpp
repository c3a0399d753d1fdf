// Message encoding, field-by-field validated decoding and the stream splitter (PROTOCOL.md §5).
#include "proto/messages.h"
#include "proto/photon_records.h"

#include <algorithm>
#include <bitset>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace rtpm::proto {
namespace {

// Limits that only the decoder uses.
constexpr uint32_t kMaxCores = 1u << 16;

// ---- encoding -----------------------------------------------------------------------------

void putVec3(Writer& w, const Vec3f& v) {
    w.f32(v.x);
    w.f32(v.y);
    w.f32(v.z);
}

void putCamera(Writer& w, const CameraState& c) {
    putVec3(w, c.position);
    putVec3(w, c.forward);
    putVec3(w, c.up);
    w.f32(c.yfov);
}

void putSets(Writer& w, const std::vector<uint32_t>& sets) {
    w.u32(static_cast<uint32_t>(sets.size()));
    for (uint32_t s : sets) w.u32(s);
}

void putEdit(Writer& w, const SceneEdit& e) {
    if (auto* c = std::get_if<CameraEdit>(&e)) {
        w.u8(static_cast<uint8_t>(EditKind::Camera));
        putCamera(w, c->camera);
    } else if (auto* l = std::get_if<LightEdit>(&e)) {
        w.u8(static_cast<uint8_t>(EditKind::Light));
        w.u32(l->index);
        putVec3(w, l->position);
        putVec3(w, l->direction);
        putVec3(w, l->intensity);
    } else if (auto* m = std::get_if<MaterialEdit>(&e)) {
        w.u8(static_cast<uint8_t>(EditKind::Material));
        w.u32(m->index);
        w.u8(static_cast<uint8_t>(m->kind));
        putVec3(w, m->baseColor);
        w.f32(m->ior);
        putVec3(w, m->absorption);
        putVec3(w, m->emission);
    } else if (auto* t = std::get_if<TransformEdit>(&e)) {
        w.u8(static_cast<uint8_t>(EditKind::Transform));
        w.u32(t->instance);
        for (float v : t->matrix) w.f32(v);
    }
}

void putPayload(Writer& w, const Hello& m) {
    w.u16(m.protocolVersion);
    w.u32(m.cores);
    w.str(m.clientName);
    w.u64(m.settingsLayout);
}
void putPayload(Writer& w, const Challenge& m) { w.raw(m.nonce); }
void putPayload(Writer& w, const Auth& m) { w.raw(m.mac); }
void putPayload(Writer& w, const Welcome& m) {
    w.u32(m.clientId);
    putSets(w, m.sets);
}
void putPayload(Writer& w, const Reject& m) {
    w.u16(static_cast<uint16_t>(m.reason));
    w.str(m.text);
}
void putPayload(Writer& w, const Scene& m) {
    w.u32(m.sceneVersion);
    w.u8(static_cast<uint8_t>(m.source));
    w.str(m.builtinName);
    w.bytes(m.gltf);
    w.u32(static_cast<uint32_t>(m.edits.size()));
    for (const SceneEdit& e : m.edits) putEdit(w, e);
    w.u8(static_cast<uint8_t>(m.environment));
    putVec3(w, m.environmentColour);
    w.u32(m.environmentWidth);
    w.u32(m.environmentHeight);
    for (float v : m.environmentTexels) w.f32(v);
}
void putPayload(Writer& w, const Settings& m) {
    w.u8(static_cast<uint8_t>(m.encoding));
    // Each row's value in its type; one its type cannot hold (negative, too large, not a number:
    // only an in-memory message nobody validated has one) goes as the type's largest, which
    // every row refuses (proto/settings_rows.h wireRowCeiling).
    for (const SettingRow* row : kSettingsRows) {
        const double v = row->get(m.render);
        switch (row->wire) {
            case WireType::U8: w.u8(v >= 0.0 && v <= 255.0 ? static_cast<uint8_t>(v) : UINT8_MAX); break;
            case WireType::U32: w.u32(v >= 0.0 && v <= 4294967295.0 ? static_cast<uint32_t>(v) : UINT32_MAX); break;
            case WireType::U64: w.u64(v >= 0.0 && v < 18446744073709551616.0 ? static_cast<uint64_t>(v) : UINT64_MAX); break;
            case WireType::F32: w.f32(static_cast<float>(v)); break;
            case WireType::None: break;
        }
    }
}
void putPayload(Writer& w, const FrameBegin& m) {
    w.u64(m.frame);
    w.u32(m.epoch);
    w.u32(m.sceneVersion);
    putCamera(w, m.camera);
    w.u8(static_cast<uint8_t>(m.mode));
    putSets(w, m.sets);
    w.u32(m.passBatches);
    w.u32(m.passPeriod);
    w.u32(static_cast<uint32_t>(m.shared.size()));
    for (const SetShot& shot : m.shared) {
        w.u32(shot.set);
        w.u32(shot.batches);
        putPhotons(w, shot.photons);
    }
}
void putPayload(Writer& w, const FrameData& m) {
    w.u64(m.frame);
    w.u32(m.set);
    w.u8(static_cast<uint8_t>(m.encoding));
    w.u32(m.pixelCount);
    w.u8(m.unchanged ? 1 : 0);
    w.u64(m.sameAs);
    w.bytes(m.pixels);
    w.u32(m.passes);
    w.bytes(m.ownWeights);
    w.f64(m.errorSigma);
    w.f64(m.errorRadiance);
    w.u32(m.errorPixels);
    w.f64(m.errorBatches);
    w.u32(m.shotBatches);
    putPhotons(w, m.shot);
    w.bytes(m.noise);
}
void putPayload(Writer& w, const Edit& m) {
    w.u32(m.sceneVersion);
    putEdit(w, m.edit);
}
void putPayload(Writer& w, const Stats& m) {
    w.u64(m.frame);
    w.f32(m.photonMs);
    w.f32(m.renderMs);
    w.f32(m.encodeMs);
    w.f32(m.frameMs);
    w.u64(m.photonsShot);
    w.u64(m.photonsStored);
    w.u64(m.memoryBytes);
    w.u32(m.threads);
}
void putPayload(Writer& w, const Bye& m) {
    w.u16(static_cast<uint16_t>(m.reason));
    w.str(m.text);
}
void putPayload(Writer&, const Heartbeat&) {}

// ---- decoding -----------------------------------------------------------------------------

bool getVec3(Reader& r, Vec3f& v, const char* field) {
    return r.f32Finite(v.x, field) && r.f32Finite(v.y, field) && r.f32Finite(v.z, field);
}

bool nonNegative(Reader& r, const Vec3f& v, const char* field) {
    if (!r.ok()) return false;
    if (v.x < 0.0f || v.y < 0.0f || v.z < 0.0f)
        return r.fail(ErrorCode::BadValue, std::string(field) + " is negative");
    return true;
}

bool nonZero(Reader& r, const Vec3f& v, const char* field) {
    if (!r.ok()) return false;
    if (v.x == 0.0f && v.y == 0.0f && v.z == 0.0f)
        return r.fail(ErrorCode::BadValue, std::string(field) + " is the zero vector");
    return true;
}

bool getCamera(Reader& r, CameraState& c) {
    getVec3(r, c.position, "camera.position");
    getVec3(r, c.forward, "camera.forward");
    getVec3(r, c.up, "camera.up");
    r.f32Finite(c.yfov, "camera.yfov");
    nonZero(r, c.forward, "camera.forward");
    nonZero(r, c.up, "camera.up");
    // yfov must leave a finite tan(yfov/2): strictly inside (0, π).
    if (r.ok() && !(c.yfov > 0.0f && c.yfov < 3.14159f))
        r.fail(ErrorCode::BadValue, "camera.yfov " + std::to_string(c.yfov) + " not in (0, pi)");
    return r.ok();
}

bool getSets(Reader& r, std::vector<uint32_t>& sets, const char* field) {
    sets.clear();
    uint32_t n = 0;
    if (!r.count(n, kMaxSets, 4, field)) return false;
    sets.resize(n);
    std::bitset<kMaxSets> seen;
    for (uint32_t& s : sets) {
        if (!r.u32(s)) return false;
        if (s >= kMaxSets)
            return r.fail(ErrorCode::BadValue, std::string(field) + ": set " + std::to_string(s) +
                                                   " not below " + std::to_string(kMaxSets));
        if (seen.test(s))
            return r.fail(ErrorCode::BadValue,
                          std::string(field) + ": set " + std::to_string(s) + " listed twice");
        seen.set(s);
    }
    return true;
}

template <class E>
bool getEnum8(Reader& r, E& out, uint8_t maxValue, const char* field) {
    uint8_t v = 0;
    if (!r.u8(v)) return false;
    if (v > maxValue)
        return r.fail(ErrorCode::BadEnum, std::string(field) + ": value " + std::to_string(v) +
                                              " above " + std::to_string(maxValue));
    out = static_cast<E>(v);
    return true;
}

bool inRange(Reader& r, uint64_t v, uint64_t lo, uint64_t hi, const char* field) {
    if (!r.ok()) return false;
    if (v < lo || v > hi)
        return r.fail(ErrorCode::BadValue, std::string(field) + " = " + std::to_string(v) +
                                               " not in [" + std::to_string(lo) + ", " +
                                               std::to_string(hi) + "]");
    return true;
}

bool getEdit(Reader& r, SceneEdit& out) {
    EditKind kind{};
    if (!getEnum8(r, kind, 3, "edit.kind")) return false;
    switch (kind) {
        case EditKind::Camera: {
            CameraEdit e;
            getCamera(r, e.camera);
            out = e;
            break;
        }
        case EditKind::Light: {
            LightEdit e;
            r.u32(e.index);
            getVec3(r, e.position, "light.position");
            getVec3(r, e.direction, "light.direction");
            getVec3(r, e.intensity, "light.intensity");
            nonZero(r, e.direction, "light.direction");
            nonNegative(r, e.intensity, "light.intensity");
            out = e;
            break;
        }
        case EditKind::Material: {
            MaterialEdit e;
            r.u32(e.index);
            getEnum8(r, e.kind, kMaxMaterialKind, "material.kind");
            getVec3(r, e.baseColor, "material.baseColor");
            r.f32Finite(e.ior, "material.ior");
            getVec3(r, e.absorption, "material.absorption");
            getVec3(r, e.emission, "material.emission");
            nonNegative(r, e.baseColor, "material.baseColor");
            if (r.ok() && (e.baseColor.x > 1.0f || e.baseColor.y > 1.0f || e.baseColor.z > 1.0f))
                r.fail(ErrorCode::BadValue, "material.baseColor above 1 (not energy conserving)");
            if (r.ok() && !(e.ior > 0.0f)) r.fail(ErrorCode::BadValue, "material.ior not > 0");
            nonNegative(r, e.absorption, "material.absorption");
            nonNegative(r, e.emission, "material.emission");
            out = e;
            break;
        }
        case EditKind::Transform: {
            TransformEdit e;
            r.u32(e.instance);
            for (float& v : e.matrix) r.f32Finite(v, "transform.matrix");
            out = e;
            break;
        }
    }
    return r.ok();
}

void get(Reader& r, Hello& m) {
    r.u16(m.protocolVersion);
    r.u32(m.cores);
    r.str(m.clientName, kMaxNameBytes, "hello.clientName");
    r.u64(m.settingsLayout);
    inRange(r, m.cores, 1, kMaxCores, "hello.cores");
}
template <size_t N>
void getFixed(Reader& r, std::array<uint8_t, N>& out, const char* field) {
    std::span<const uint8_t> v;
    if (r.view(v, N, field)) std::copy(v.begin(), v.end(), out.begin());
}
void get(Reader& r, Challenge& m) { getFixed(r, m.nonce, "challenge.nonce"); }
void get(Reader& r, Auth& m) { getFixed(r, m.mac, "auth.mac"); }
void get(Reader& r, Welcome& m) {
    r.u32(m.clientId);
    getSets(r, m.sets, "welcome.sets");
}
void get(Reader& r, Reject& m) {
    uint16_t reason = 0;
    r.u16(reason);
    if (r.ok() && (reason == 0 || reason > kMaxRejectReason))
        r.fail(ErrorCode::BadEnum, "reject.reason " + std::to_string(reason));
    m.reason = static_cast<RejectReason>(reason);
    r.str(m.text, kMaxTextBytes, "reject.text");
}
void get(Reader& r, Scene& m) {
    r.u32(m.sceneVersion);
    getEnum8(r, m.source, 1, "scene.source");
    r.str(m.builtinName, kMaxNameBytes, "scene.builtinName");
    r.bytes(m.gltf, payloadLimit(MessageType::Scene), "scene.gltf");
    if (r.ok() && m.source == Scene::Source::Builtin && (m.builtinName.empty() || !m.gltf.empty()))
        r.fail(ErrorCode::BadValue, "scene: a built-in scene needs a name and no glTF bytes");
    if (r.ok() && m.source == Scene::Source::Gltf && (!m.builtinName.empty() || m.gltf.empty()))
        r.fail(ErrorCode::BadValue, "scene: a glTF scene needs bytes and no built-in name");
    uint32_t n = 0;
    // The smallest edit (a transform is larger) is a camera edit: 1 + 40 bytes.
    if (r.count(n, kMaxEditsPerScene, 41, "scene.edits")) {
        m.edits.resize(n);
        for (SceneEdit& e : m.edits)
            if (!getEdit(r, e)) break;
    }
    getEnum8(r, m.environment, 2, "scene.environment");
    r.f32Finite(m.environmentColour.x, "scene.environmentColour");
    r.f32Finite(m.environmentColour.y, "scene.environmentColour");
    r.f32Finite(m.environmentColour.z, "scene.environmentColour");
    r.u32(m.environmentWidth);
    r.u32(m.environmentHeight);
    if (!r.ok()) return;
    const Vec3f& c = m.environmentColour;
    if (c.x < 0.0f || c.y < 0.0f || c.z < 0.0f || (m.environment != Scene::Environment::Uniform && !(c == Vec3f{})))
        r.fail(ErrorCode::BadValue, "scene.environmentColour: negative, or set without a uniform environment");
    const uint64_t w = m.environmentWidth, h = m.environmentHeight;
    const bool map = m.environment == Scene::Environment::Map;
    if (r.ok() && (map ? (h == 0 || w != 2 * h || w * h > kMaxEnvironmentTexels) : (w != 0 || h != 0)))
        r.fail(ErrorCode::BadValue, "scene.environment: map size " + std::to_string(w) + "x" + std::to_string(h) +
                                        " is not 2:1 within 4096x2048, or given without a map");
    const uint64_t floats = w * h * 3;
    if (r.ok() && floats * 4 > r.remaining())
        r.fail(ErrorCode::LengthTooLarge, "scene.environmentTexels: " + std::to_string(floats) +
                                              " floats announced, " + std::to_string(r.remaining()) + " bytes left");
    if (!r.ok()) return;
    m.environmentTexels.resize(size_t(floats));
    for (float& v : m.environmentTexels) {
        if (!r.f32Finite(v, "scene.environmentTexels")) return;
        if (v < 0.0f) {
            r.fail(ErrorCode::BadValue, "scene.environmentTexels: negative radiance");
            return;
        }
    }
}
// Each row's value in its type, within the row's limits (refused by the row's name); then the
// rule between rows (M within the image) validateSettings applies.
void get(Reader& r, Settings& m) {
    getEnum8(r, m.encoding, kMaxPixelEncoding, "settings.encoding");
    for (const SettingRow* row : kSettingsRows) {
        double v = 0.0;
        switch (row->wire) {
            case WireType::U8: { uint8_t x = 0; r.u8(x); v = x; break; }
            case WireType::U32: { uint32_t x = 0; r.u32(x); v = x; break; }
            case WireType::U64: {
                uint64_t x = 0;
                // Above 2^53 a double would round it, perhaps onto a value within the limits.
                if (r.u64(x) && x > uint64_t(wireRowCeiling(WireType::U64))) {
                    r.fail(ErrorCode::BadValue, "settings: " + std::string(row->name) + " must be in " +
                                                    knobRange(*row) + ", got " + std::to_string(x));
                }
                v = double(x);
                break;
            }
            case WireType::F32: { float x = 0.0f; r.f32(x); v = x; break; }
            case WireType::None: break;
        }
        if (!r.ok()) return;
        if (!std::isfinite(v)) {
            r.fail(ErrorCode::NonFinite, "settings: " + std::string(row->name) + " is not finite");
            return;
        }
        if (auto error = knobValueError(*row, v)) {
            r.fail(row->isChoice() ? ErrorCode::BadEnum : ErrorCode::BadValue, "settings: " + *error);
            return;
        }
        row->set(m.render, v);
    }
    try {
        validateSettings(m.render);
    } catch (const std::invalid_argument& e) {
        r.fail(ErrorCode::BadValue, std::string("settings: ") + e.what());
    }
}
void get(Reader& r, FrameBegin& m) {
    r.u64(m.frame);
    r.u32(m.epoch);
    r.u32(m.sceneVersion);
    getCamera(r, m.camera);
    getEnum8(r, m.mode, kMaxFrameMode, "frameBegin.mode");
    getSets(r, m.sets, "frameBegin.sets");
    r.u32(m.passBatches);
    inRange(r, m.passBatches, 1, kMaxPassBatches, "frameBegin.passBatches");
    r.u32(m.passPeriod);
    inRange(r, m.passPeriod, 1, kMaxPassPeriod, "frameBegin.passPeriod");
    uint32_t n = 0;
    if (!r.count(n, kMaxSets, 12, "frameBegin.shared")) return;
    m.shared.resize(n);
    size_t total = 0;
    for (size_t i = 0; i < n && r.ok(); ++i) {
        SetShot& shot = m.shared[i];
        r.u32(shot.set);
        r.u32(shot.batches);
        inRange(r, shot.set, 0, kMaxSets - 1, "frameBegin.shared.set");
        inRange(r, shot.batches, 1, kMaxPassBatches, "frameBegin.shared.batches");
        if (r.ok() && i > 0 && shot.set <= m.shared[i - 1].set)
            r.fail(ErrorCode::BadValue, "frameBegin.shared: sets not ascending and distinct");
        if (!getPhotons(r, shot.photons, kMaxSharedPhotons - total, "frameBegin.shared.photons")) return;
        if (shot.photons.empty()) r.fail(ErrorCode::BadValue, "frameBegin.shared: a set with no photon");
        total += shot.photons.size();
    }
}
// A FrameData's per-pixel byte plane (own weights, noise): empty, or one byte per pixel, and
// empty when the set's pixels are unchanged.
bool getPixelBytes(Reader& r, const FrameData& m, std::vector<uint8_t>& out, const char* field) {
    uint32_t n = 0;
    if (!r.count(n, m.pixelCount, 1, field)) return false;
    if (n != 0 && (n != m.pixelCount || m.unchanged))
        return r.fail(ErrorCode::BadValue, std::string(field) + ": " + std::to_string(n) + " bytes for " +
                                               std::to_string(m.pixelCount) + " pixels");
    std::span<const uint8_t> v;
    if (r.view(v, n, field)) out.assign(v.begin(), v.end());
    return r.ok();
}
void get(Reader& r, FrameData& m) {
    r.u64(m.frame);
    r.u32(m.set);
    getEnum8(r, m.encoding, kMaxPixelEncoding, "frameData.encoding");
    r.u32(m.pixelCount);
    inRange(r, m.set, 0, kMaxSets - 1, "frameData.set");
    uint8_t unchanged = 0;
    r.u8(unchanged);
    inRange(r, unchanged, 0, 1, "frameData.unchanged");
    m.unchanged = unchanged != 0;
    r.u64(m.sameAs);
    const std::string sameAs = "frameData.sameAs: " + std::to_string(m.sameAs);
    if (r.ok() && m.unchanged && !(m.sameAs < m.frame)) r.fail(ErrorCode::BadValue, sameAs + " is not an earlier frame");
    if (r.ok() && !m.unchanged && m.sameAs != 0) r.fail(ErrorCode::BadValue, sameAs + " without unchanged pixels");
    // Check the announced length against the pixel count before copying anything.
    uint32_t len = 0;
    if (!r.count(len, payloadLimit(MessageType::FrameData), 1, "frameData.pixels")) return;
    Status sized = m.unchanged ? checkUnchangedPixels(m.pixelCount, len, payloadLimit(MessageType::FrameData))
                               : checkPixelPayloadSize(m.encoding, m.pixelCount, len);
    if (!sized) {
        r.fail(sized.error().code, "frameData: " + sized.error().message);
        return;
    }
    std::span<const uint8_t> v;
    if (r.view(v, len, "frameData.pixels")) m.pixels.assign(v.begin(), v.end());
    r.u32(m.passes);
    if (!getPixelBytes(r, m, m.ownWeights, "frameData.ownWeights")) return;
    r.f64Finite(m.errorSigma, "frameData.errorSigma");
    r.f64Finite(m.errorRadiance, "frameData.errorRadiance");
    r.u32(m.errorPixels);
    r.f64Finite(m.errorBatches, "frameData.errorBatches");
    if (r.ok() && std::min({m.errorSigma, m.errorRadiance, m.errorBatches}) < 0.0) r.fail(ErrorCode::BadValue, "frameData.error figures must be >= 0");
    inRange(r, m.errorPixels, 0, m.pixelCount, "frameData.errorPixels");
    r.u32(m.shotBatches);
    inRange(r, m.shotBatches, 0, kMaxPassBatches, "frameData.shotBatches");
    if (!getPhotons(r, m.shot, kMaxSharedPhotons, "frameData.shot")) return;
    if (r.ok() && m.shot.empty() != (m.shotBatches == 0))
        r.fail(ErrorCode::BadValue, "frameData.shot: photons and batches must both be present or absent");
    getPixelBytes(r, m, m.noise, "frameData.noise");
}
void get(Reader& r, Edit& m) {
    r.u32(m.sceneVersion);
    getEdit(r, m.edit);
}
void get(Reader& r, Stats& m) {
    r.u64(m.frame);
    r.f32Finite(m.photonMs, "stats.photonMs");
    r.f32Finite(m.renderMs, "stats.renderMs");
    r.f32Finite(m.encodeMs, "stats.encodeMs");
    r.f32Finite(m.frameMs, "stats.frameMs");
    r.u64(m.photonsShot);
    r.u64(m.photonsStored);
    r.u64(m.memoryBytes);
    r.u32(m.threads);
    if (r.ok() && (m.photonMs < 0 || m.renderMs < 0 || m.encodeMs < 0 || m.frameMs < 0))
        r.fail(ErrorCode::BadValue, "stats: negative time");
}
void get(Reader& r, Bye& m) {
    uint16_t reason = 0;
    r.u16(reason);
    if (r.ok() && reason > kMaxByeReason)
        r.fail(ErrorCode::BadEnum, "bye.reason " + std::to_string(reason));
    m.reason = static_cast<ByeReason>(reason);
    r.str(m.text, kMaxTextBytes, "bye.text");
}
void get(Reader&, Heartbeat&) {}

template <class M>
Result<Message> decodeAs(std::span<const uint8_t> payload, const char* name) {
    Reader r(payload);
    M m;
    get(r, m);
    Status s = r.finish(name);
    if (!s) return s.error();
    return Message(std::move(m));
}

}  // namespace

const char* messageTypeName(MessageType type) {
    switch (type) {
        case MessageType::Hello: return "Hello";
        case MessageType::Welcome: return "Welcome";
        case MessageType::Reject: return "Reject";
        case MessageType::Scene: return "Scene";
        case MessageType::Settings: return "Settings";
        case MessageType::FrameBegin: return "FrameBegin";
        case MessageType::FrameData: return "FrameData";
        case MessageType::Edit: return "Edit";
        case MessageType::Stats: return "Stats";
        case MessageType::Bye: return "Bye";
        case MessageType::Challenge: return "Challenge";
        case MessageType::Auth: return "Auth";
        case MessageType::Heartbeat: return "Heartbeat";
    }
    return "unknown";
}

const char* rejectReasonName(RejectReason reason) {
    switch (reason) {
        case RejectReason::VersionMismatch: return "protocol version mismatch";
        case RejectReason::BadToken: return "bad token";
        case RejectReason::ServerFull: return "server full";
        case RejectReason::ProtocolError: return "protocol error";
        case RejectReason::Capacity: return "server at capacity";
        case RejectReason::RateLimited: return "rate limited";
    }
    return "unknown";
}

const char* byeReasonName(ByeReason reason) {
    switch (reason) {
        case ByeReason::Normal: return "normal";
        case ByeReason::Shutdown: return "shutdown";
        case ByeReason::ProtocolError: return "protocol error";
        case ByeReason::Timeout: return "timeout (evicted, or the peer fell silent)";
    }
    return "unknown";
}

const char* frameModeName(FrameMode mode) {
    switch (mode) {
        case FrameMode::Interaction: return "interaction";
        case FrameMode::Accumulate: return "accumulate";
        case FrameMode::Walkthrough: return "walkthrough";
        case FrameMode::Converging: return "converging";
        case FrameMode::Edit: return "edit";
        case FrameMode::Relight: return "relight";
    }
    return "unknown";
}

MessageType typeOf(const Message& m) {
    // Variant alternatives are listed in MessageType order, ids 1..kMaxMessageType.
    static_assert(std::variant_size_v<Message> == kMaxMessageType);
    return static_cast<MessageType>(m.index() + 1);
}

Result<std::vector<uint8_t>> tryEncode(const Message& m) {
    Writer w;
    Header h;
    h.type = typeOf(m);
    encodeHeader(h, w);  // payloadBytes patched below
    std::visit([&w](const auto& msg) { putPayload(w, msg); }, m);
    size_t payload = w.size() - kHeaderBytes;
    if (payload > payloadLimit(h.type)) {
        return Error{ErrorCode::PayloadTooLarge,
                     "encode: type " + std::to_string(static_cast<int>(h.type)) + " payload of " +
                         std::to_string(payload) + " bytes above the limit of " +
                         std::to_string(payloadLimit(h.type))};
    }
    w.patchU32(12, static_cast<uint32_t>(payload));
    return w.take();
}

std::vector<uint8_t> encode(const Message& m) {
    Result<std::vector<uint8_t>> r = tryEncode(m);
    if (!r) {
        std::fprintf(stderr, "rtpm::proto::encode: %s\n", r.error().message.c_str());
        std::abort();
    }
    return std::move(r).value();
}

Result<Message> decodePayload(MessageType type, std::span<const uint8_t> payload) {
    if (payload.size() > payloadLimit(type)) {
        return Error{ErrorCode::PayloadTooLarge, "payload of " + std::to_string(payload.size()) +
                                                     " bytes above the limit for type " +
                                                     std::to_string(static_cast<int>(type))};
    }
    switch (type) {
        case MessageType::Hello: return decodeAs<Hello>(payload, "hello");
        case MessageType::Welcome: return decodeAs<Welcome>(payload, "welcome");
        case MessageType::Reject: return decodeAs<Reject>(payload, "reject");
        case MessageType::Scene: return decodeAs<Scene>(payload, "scene");
        case MessageType::Settings: return decodeAs<Settings>(payload, "settings");
        case MessageType::FrameBegin: return decodeAs<FrameBegin>(payload, "frameBegin");
        case MessageType::FrameData: return decodeAs<FrameData>(payload, "frameData");
        case MessageType::Edit: return decodeAs<Edit>(payload, "edit");
        case MessageType::Stats: return decodeAs<Stats>(payload, "stats");
        case MessageType::Bye: return decodeAs<Bye>(payload, "bye");
        case MessageType::Challenge: return decodeAs<Challenge>(payload, "challenge");
        case MessageType::Auth: return decodeAs<Auth>(payload, "auth");
        case MessageType::Heartbeat: return decodeAs<Heartbeat>(payload, "heartbeat");
    }
    return Error{ErrorCode::UnknownType,
                 "unknown message type " + std::to_string(static_cast<int>(type))};
}

Result<Message> decodeMessage(std::span<const uint8_t> bytes) {
    Result<Header> h = decodeHeader(bytes);
    if (!h) return h.error();
    size_t rest = bytes.size() - kHeaderBytes;
    if (rest < h->payloadBytes) {
        return Error{ErrorCode::Truncated, "message: header announces " +
                                               std::to_string(h->payloadBytes) +
                                               " payload bytes, " + std::to_string(rest) + " present"};
    }
    if (rest > h->payloadBytes) {
        return Error{ErrorCode::TrailingBytes,
                     "message: " + std::to_string(rest - h->payloadBytes) + " bytes after the payload"};
    }
    return decodePayload(h->type, bytes.subspan(kHeaderBytes));
}

// ---- FrameSplitter ------------------------------------------------------------------------

void FrameSplitter::feed(std::span<const uint8_t> bytes) {
    if (error_) return;  // a failed stream is dead; do not buffer more of it
    // Drop consumed bytes once they dominate the buffer, so memory stays bounded by one message.
    if (pos_ > 0 && pos_ >= buf_.size() / 2) {
        buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(pos_));
        pos_ = 0;
    }
    buf_.insert(buf_.end(), bytes.begin(), bytes.end());
}

Result<std::optional<Message>> FrameSplitter::next() {
    if (error_) return *error_;
    std::span<const uint8_t> avail(buf_.data() + pos_, buf_.size() - pos_);
    if (!header_) {
        if (avail.size() < kHeaderBytes) return std::optional<Message>();
        Result<Header> h = decodeHeader(avail);
        if (!h) {
            error_ = h.error();
            return *error_;
        }
        if ((onlyType_ && h->type != *onlyType_) || h->payloadBytes > maxPayload_) {
            error_ = Error{ErrorCode::NotAllowed,
                           std::string(messageTypeName(h->type)) + " of " + std::to_string(h->payloadBytes) +
                               " bytes where " + (onlyType_ ? std::string("only ") + messageTypeName(*onlyType_) : std::string("any message")) +
                               " of at most " + std::to_string(maxPayload_) + " bytes is allowed"};
            return *error_;
        }
        header_ = *h;
        pos_ += kHeaderBytes;
        avail = avail.subspan(kHeaderBytes);
    }
    if (avail.size() < header_->payloadBytes) return std::optional<Message>();
    Result<Message> m = decodePayload(header_->type, avail.first(header_->payloadBytes));
    pos_ += header_->payloadBytes;
    header_.reset();
    if (!m) {
        error_ = m.error();
        return *error_;
    }
    return std::optional<Message>(std::move(m).value());
}

}  // namespace rtpm::proto
