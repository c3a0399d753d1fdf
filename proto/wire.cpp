// Wire primitives: little-endian Writer/Reader, header encoding and validation, per-type limits.
#include "proto/wire.h"

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

namespace rtpm::proto {

const char* errorCodeName(ErrorCode code) {
    switch (code) {
        case ErrorCode::Truncated: return "truncated";
        case ErrorCode::BadMagic: return "bad-magic";
        case ErrorCode::BadVersion: return "bad-version";
        case ErrorCode::UnknownType: return "unknown-type";
        case ErrorCode::BadFlags: return "bad-flags";
        case ErrorCode::PayloadTooLarge: return "payload-too-large";
        case ErrorCode::LengthTooLarge: return "length-too-large";
        case ErrorCode::BadEnum: return "bad-enum";
        case ErrorCode::NonFinite: return "non-finite";
        case ErrorCode::BadValue: return "bad-value";
        case ErrorCode::TrailingBytes: return "trailing-bytes";
        case ErrorCode::Corrupt: return "corrupt";
        case ErrorCode::NotAllowed: return "not-allowed";
    }
    return "unknown-error";
}

void abortResultAccess(const char* what) {
    std::fprintf(stderr, "rtpm::proto::Result: bad access (%s)\n", what);
    std::abort();
}

// ---- Writer -------------------------------------------------------------------------------

void Writer::u16(uint16_t v) {
    buf_.push_back(static_cast<uint8_t>(v));
    buf_.push_back(static_cast<uint8_t>(v >> 8));
}

void Writer::u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) buf_.push_back(static_cast<uint8_t>(v >> (8 * i)));
}

void Writer::u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) buf_.push_back(static_cast<uint8_t>(v >> (8 * i)));
}

void Writer::f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
void Writer::f64(double v) { u64(std::bit_cast<uint64_t>(v)); }

void Writer::str(std::string_view s) {
    bytes(std::span(reinterpret_cast<const uint8_t*>(s.data()), s.size()));
}

void Writer::bytes(std::span<const uint8_t> b) {
    if (b.size() > std::numeric_limits<uint32_t>::max()) {
        std::fprintf(stderr, "rtpm::proto::Writer: %zu bytes do not fit a u32 length\n", b.size());
        std::abort();
    }
    u32(static_cast<uint32_t>(b.size()));
    raw(b);
}

void Writer::patchU32(size_t offset, uint32_t v) {
    if (offset + 4 > buf_.size()) {
        std::fprintf(stderr, "rtpm::proto::Writer: patch at %zu past the end (%zu)\n", offset,
                     buf_.size());
        std::abort();
    }
    for (int i = 0; i < 4; ++i) buf_[offset + i] = static_cast<uint8_t>(v >> (8 * i));
}

// ---- Reader -------------------------------------------------------------------------------

bool Reader::fail(ErrorCode code, std::string message) {
    if (!failed_) {
        failed_ = true;
        error_ = Error{code, std::move(message)};
    }
    return false;
}

bool Reader::need(size_t n, const char* what) {
    if (failed_) return false;
    if (n > remaining()) {
        return fail(ErrorCode::Truncated, std::string(what) + ": needs " + std::to_string(n) +
                                              " bytes, " + std::to_string(remaining()) +
                                              " left at offset " + std::to_string(pos_));
    }
    return true;
}

bool Reader::u8(uint8_t& v) {
    v = 0;
    if (!need(1, "u8")) return false;
    v = bytes_[pos_++];
    return true;
}

bool Reader::u16(uint16_t& v) {
    v = 0;
    if (!need(2, "u16")) return false;
    v = static_cast<uint16_t>(bytes_[pos_] | (bytes_[pos_ + 1] << 8));
    pos_ += 2;
    return true;
}

bool Reader::u32(uint32_t& v) {
    v = 0;
    if (!need(4, "u32")) return false;
    for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(bytes_[pos_ + i]) << (8 * i);
    pos_ += 4;
    return true;
}

bool Reader::u64(uint64_t& v) {
    v = 0;
    if (!need(8, "u64")) return false;
    for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(bytes_[pos_ + i]) << (8 * i);
    pos_ += 8;
    return true;
}

bool Reader::i32(int32_t& v) {
    uint32_t u = 0;
    bool r = u32(u);
    v = static_cast<int32_t>(u);
    return r;
}

bool Reader::f32(float& v) {
    uint32_t u = 0;
    bool r = u32(u);
    v = r ? std::bit_cast<float>(u) : 0.0f;
    return r;
}

bool Reader::f64(double& v) {
    uint64_t u = 0;
    bool r = u64(u);
    v = r ? std::bit_cast<double>(u) : 0.0;
    return r;
}

bool Reader::f32Finite(float& v, const char* field) {
    if (!f32(v)) return false;
    if (!std::isfinite(v)) {
        v = 0.0f;
        return fail(ErrorCode::NonFinite, std::string(field) + " is not finite");
    }
    return true;
}

bool Reader::f64Finite(double& v, const char* field) {
    if (!f64(v)) return false;
    if (!std::isfinite(v)) {
        v = 0.0;
        return fail(ErrorCode::NonFinite, std::string(field) + " is not finite");
    }
    return true;
}

bool Reader::view(std::span<const uint8_t>& out, size_t n, const char* field) {
    out = {};
    if (!need(n, field)) return false;
    out = bytes_.subspan(pos_, n);
    pos_ += n;
    return true;
}

bool Reader::count(uint32_t& n, size_t maxCount, size_t minElementBytes, const char* field) {
    n = 0;
    uint32_t v = 0;
    if (!u32(v)) return false;
    if (v > maxCount) {
        return fail(ErrorCode::LengthTooLarge, std::string(field) + ": count " +
                                                   std::to_string(v) + " above limit " +
                                                   std::to_string(maxCount));
    }
    // 64-bit product: v < 2^32 and minElementBytes is small, so it cannot overflow.
    if (static_cast<uint64_t>(v) * minElementBytes > remaining()) {
        return fail(ErrorCode::LengthTooLarge,
                    std::string(field) + ": count " + std::to_string(v) + " needs at least " +
                        std::to_string(static_cast<uint64_t>(v) * minElementBytes) +
                        " bytes, " + std::to_string(remaining()) + " left");
    }
    n = v;
    return true;
}

bool Reader::str(std::string& s, size_t maxBytes, const char* field) {
    s.clear();
    std::span<const uint8_t> v;
    uint32_t n = 0;
    if (!count(n, maxBytes, 1, field)) return false;
    if (!view(v, n, field)) return false;
    s.assign(reinterpret_cast<const char*>(v.data()), v.size());
    return true;
}

bool Reader::bytes(std::vector<uint8_t>& b, size_t maxBytes, const char* field) {
    b.clear();
    std::span<const uint8_t> v;
    uint32_t n = 0;
    if (!count(n, maxBytes, 1, field)) return false;
    if (!view(v, n, field)) return false;
    b.assign(v.begin(), v.end());
    return true;
}

Status Reader::finish(const char* what) {
    if (!failed_ && remaining() != 0) {
        fail(ErrorCode::TrailingBytes, std::string(what) + ": " + std::to_string(remaining()) +
                                           " bytes after the end of the message");
    }
    if (failed_) return error_;
    return okStatus();
}

// ---- Header -------------------------------------------------------------------------------

uint32_t payloadLimit(MessageType type) {
    constexpr uint32_t kKiB = 1024;
    constexpr uint32_t kMiB = 1024 * 1024;
    switch (type) {
        case MessageType::Hello: return 4 * kKiB;
        case MessageType::Welcome: return 64 * kKiB;
        case MessageType::Reject: return 4 * kKiB;
        case MessageType::Scene: return 256 * kMiB;
        case MessageType::Settings: return 1 * kKiB;
        case MessageType::FrameBegin: return 8 * kMiB;  // the shared photons (kMaxSharedPhotons × 20 B + 12 B per set)
        case MessageType::FrameData: return 256 * kMiB;
        case MessageType::Edit: return 1 * kKiB;
        case MessageType::Stats: return 1 * kKiB;
        case MessageType::Bye: return 4 * kKiB;
        case MessageType::Challenge: return 64;
        case MessageType::Auth: return 64;
        case MessageType::Heartbeat: return 0;
    }
    return 0;
}

void encodeHeader(const Header& h, Writer& w) {
    w.u32(h.magic);
    w.u16(h.version);
    w.u16(static_cast<uint16_t>(h.type));
    w.u32(h.flags);
    w.u32(h.payloadBytes);
}

Result<Header> decodeHeader(std::span<const uint8_t> bytes) {
    if (bytes.size() < kHeaderBytes) {
        return Error{ErrorCode::Truncated, "header: needs 16 bytes, got " +
                                               std::to_string(bytes.size())};
    }
    Reader r(bytes.first(kHeaderBytes));
    Header h;
    uint16_t type = 0;
    r.u32(h.magic);
    r.u16(h.version);
    r.u16(type);
    r.u32(h.flags);
    r.u32(h.payloadBytes);
    if (h.magic != kMagic) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "header: magic 0x%08X, expected 0x%08X ('RTPM')", h.magic,
                      kMagic);
        return Error{ErrorCode::BadMagic, buf};
    }
    if (h.version != kProtocolVersion) {
        return Error{ErrorCode::BadVersion, "header: protocol version " +
                                                std::to_string(h.version) + ", this peer speaks " +
                                                std::to_string(kProtocolVersion)};
    }
    if (type == 0 || type > kMaxMessageType) {
        return Error{ErrorCode::UnknownType, "header: unknown message type " + std::to_string(type)};
    }
    h.type = static_cast<MessageType>(type);
    if (h.flags != 0) {
        return Error{ErrorCode::BadFlags,
                     "header: flags " + std::to_string(h.flags) + " set, none are defined"};
    }
    if (h.payloadBytes > payloadLimit(h.type)) {
        return Error{ErrorCode::PayloadTooLarge,
                     "header: type " + std::to_string(type) + " payload of " +
                         std::to_string(h.payloadBytes) + " bytes above the limit of " +
                         std::to_string(payloadLimit(h.type))};
    }
    return h;
}

}  // namespace rtpm::proto
