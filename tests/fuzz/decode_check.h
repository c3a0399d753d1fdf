// Shared by the libFuzzer target, the replay test and the message tests: sample messages of every
// type and the properties every decoder must keep on arbitrary bytes.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "proto/messages.h"
#include "proto/pixel_codec.h"

namespace rtpm::proto::testing {

/// One valid message of every type, several for types with alternatives (edits, sources).
inline std::vector<Message> sampleMessages() {
    std::vector<Message> out;
    out.push_back(Hello{kProtocolVersion, 8, "node-07"});
    Challenge challenge;
    for (size_t i = 0; i < challenge.nonce.size(); ++i) challenge.nonce[i] = uint8_t(7 * i + 1);
    out.push_back(challenge);
    Auth auth;
    for (size_t i = 0; i < auth.mac.size(); ++i) auth.mac[i] = uint8_t(255 - 3 * i);
    out.push_back(auth);
    out.push_back(Reject{RejectReason::Capacity, "retry later"});
    out.push_back(Welcome{3, {0, 5, 10, 15}});
    out.push_back(Welcome{4, {}});
    out.push_back(Reject{RejectReason::BadToken, "token does not match"});
    CameraState cam{{0.5f, 1.0f, 4.0f}, {0.0f, -0.2f, -1.0f}, {0.0f, 1.0f, 0.0f}, 0.7f};
    TransformEdit tr;
    tr.instance = 2;
    for (int i = 0; i < 16; ++i) tr.matrix[i] = (i % 5 == 0) ? 1.0f : 0.01f * i;
    out.push_back(Scene{7, Scene::Source::Builtin, "ring", {},
                        {CameraEdit{cam},
                         LightEdit{0, {0, 3, 0}, {0, -1, 0}, {10, 9, 8}},
                         MaterialEdit{1, MaterialKind::Dielectric, {1, 1, 1}, 1.33f, {0.1f, 2, 3}, {0, 0, 0}},
                         tr}});
    out.push_back(Scene{8, Scene::Source::Gltf, "", {'g', 'l', 'T', 'F', 2, 0, 0, 0}, {}});
    Scene uniformSky{9, Scene::Source::Builtin, "glass", {}, {}};
    uniformSky.environment = Scene::Environment::Uniform;
    uniformSky.environmentColour = {0.25f, 0.5f, 1.0f};
    out.push_back(uniformSky);
    Scene mapSky{10, Scene::Source::Gltf, "", {'g', 'l', 'T', 'F', 2, 0, 0, 0}, {}};
    mapSky.environment = Scene::Environment::Map;
    mapSky.environmentWidth = 4;
    mapSky.environmentHeight = 2;
    for (int i = 0; i < 24; ++i) mapSky.environmentTexels.push_back(0.125f * float(i));
    out.push_back(mapSky);
    Settings s;
    s.render.width = 320;
    s.render.height = 240;
    s.render.interleave = 3;
    s.render.filter = 3;
    s.render.photons.selective = false;
    s.render.photons.tree = PhotonTree::UniformGrid;
    s.encoding = PixelEncoding::Rgb8;
    s.render.photons.estimator = CausticEstimatorKind::Knn;
    s.render.photons.seed = 123456789;
    s.render.photons.rMax = 0.25f;
    out.push_back(s);
    out.push_back(FrameBegin{42, 2, 7, cam, FrameMode::Walkthrough, {1, 2, 3}});
    out.push_back(FrameBegin{43, 2, 7, cam, FrameMode::Converging, {4}});
    std::vector<PixelPair> px(10);
    for (int i = 0; i < 10; ++i) px[i] = {{0.1f * i, 0.2f, 0.3f}, {i % 3 == 0 ? 1.0f : 0.0f, 0, 0}};
    for (PixelEncoding e : {PixelEncoding::Float32, PixelEncoding::Rgb8, PixelEncoding::Rgb9e5}) {
        EncodedPixels enc = encodePixels(px, e);
        out.push_back(FrameData{42, 5, enc.encoding, 10, enc.bytes, 7});
    }
    std::vector<PixelPair> sparse(400, PixelPair{{0.5f, 0.5f, 0.5f}, {0, 0, 0}});
    sparse[17].caustic[0] = 3.0f;
    EncodedPixels z = encodePixels(sparse, PixelEncoding::Rgb9e5Zstd);
    out.push_back(FrameData{43, 6, z.encoding, 400, z.bytes});
    FrameData unchanged{44, 6, z.encoding, 400};
    unchanged.unchanged = true;
    unchanged.sameAs = 43;
    out.push_back(unchanged);
    out.push_back(Edit{9, LightEdit{1, {1, 2, 3}, {0, 0, -1}, {5, 5, 5}}});
    out.push_back(Edit{10, tr});
    out.push_back(Stats{42, 1.5f, 20.25f, 0.5f, 25.0f, 1000, 50000, 1u << 20, 8});
    out.push_back(Bye{ByeReason::Shutdown, "server stopping"});
    out.push_back(Heartbeat{});
    return out;
}

/// Runs every decoder on `data` and checks what must hold for any input: no crash (the caller's
/// sanitizer watches), an accepted message re-encodes to exactly the bytes it came from
/// (canonical encoding), decoded pixels are finite, and the stream splitter agrees with
/// decodeMessage. Returns an empty string, or what was violated.
inline std::string checkDecoders(std::span<const uint8_t> data) {
    // 1. As one whole message.
    Result<Message> whole = decodeMessage(data);
    if (whole.ok()) {
        std::vector<uint8_t> again = encode(*whole);
        if (again.size() != data.size() || !std::equal(again.begin(), again.end(), data.begin()))
            return "accepted message does not re-encode to the same bytes";
        if (auto* fd = std::get_if<FrameData>(&*whole); fd && !fd->unchanged) {
            std::vector<PixelPair> px(fd->pixelCount);
            if (decodePixels(fd->encoding, fd->pixels, px).ok())
                for (const PixelPair& p : px)
                    for (int c = 0; c < 3; ++c)
                        if (!std::isfinite(p.direct[c]) || !std::isfinite(p.caustic[c]) ||
                            p.direct[c] < 0 || p.caustic[c] < 0)
                            return "decoded pixel not finite and non-negative";
        }
    }
    // 2. As the payload of every type (the header is the first thing fuzzers break).
    if (!data.empty()) {
        const auto type = static_cast<MessageType>(1 + data[0] % kMaxMessageType);
        Result<Message> p = decodePayload(type, data.subspan(1));
        if (p.ok() && typeOf(*p) != type) return "decodePayload returned another type";
    }
    // 3. As pixels in every encoding, for a pixel count taken from the first byte.
    if (!data.empty()) {
        std::vector<PixelPair> px(data[0] % 64);
        for (uint8_t e = 0; e <= kMaxPixelEncoding; ++e) {
            if (decodePixels(static_cast<PixelEncoding>(e), data.subspan(1), px).ok())
                for (const PixelPair& q : px)
                    for (int c = 0; c < 3; ++c)
                        if (!std::isfinite(q.direct[c]) || !std::isfinite(q.caustic[c]))
                            return "decodePixels produced a non-finite value";
        }
    }
    // 4. As a stream in uneven chunks: the first result must match decodeMessage's verdict when
    //    the data is exactly one message.
    FrameSplitter splitter;
    size_t pos = 0, chunk = 1;
    int messages = 0;
    bool failed = false;
    while (pos < data.size() && !failed) {
        size_t n = std::min(chunk, data.size() - pos);
        splitter.feed(data.subspan(pos, n));
        pos += n;
        chunk = chunk * 3 % 17 + 1;
        for (;;) {
            auto r = splitter.next();
            if (!r.ok()) {
                failed = true;
                break;
            }
            if (!r->has_value()) break;
            ++messages;
        }
    }
    if (whole.ok() && (failed || messages != 1)) return "splitter rejected a valid message";
    if (!whole.ok() && messages == 1 && !failed && splitter.buffered() == 0)
        return "splitter accepted what decodeMessage rejected";
    return {};
}

}  // namespace rtpm::proto::testing
