// Wire primitives: typed decode errors, Result<T>, the bounds-checked Writer/Reader and the 16-byte header.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "common/core/version.h"

namespace rtpm::proto {

/// 'R','T','P','M' on the wire (little-endian u32 0x4D505452).
inline constexpr uint32_t kMagic = 0x4D505452u;
/// Bumped on any change of a message layout (in common/core/version.h, where every program's
/// --version reads it); peers must match exactly (PROTOCOL.md §2).
inline constexpr uint16_t kProtocolVersion = kWireProtocolVersion;
/// The master's TCP port when none is given (rtpm-server --port, rtpm-client --server HOST).
inline constexpr uint16_t kDefaultPort = 7411;
/// Size of the fixed header that precedes every payload.
inline constexpr size_t kHeaderBytes = 16;

/// Message ids. Explicit and append-only: a retired id is never reused (PROTOCOL.md §3).
enum class MessageType : uint16_t {
    Hello = 1,       ///< client → server, first message
    Welcome = 2,     ///< server → client, handshake accepted
    Reject = 3,      ///< server → client, handshake refused; the server then closes
    Scene = 4,       ///< server → client, scene to load
    Settings = 5,    ///< server → client, render settings
    FrameBegin = 6,  ///< server → client, start of a frame
    FrameData = 7,   ///< client → server, pixels of one interleaving set
    Edit = 8,        ///< server → client, one scene edit
    Stats = 9,       ///< client → server, timings and counters
    Bye = 10,        ///< either way, orderly close
    Challenge = 11,  ///< server → client, answer to Hello: the nonce to authenticate with (version 3)
    Auth = 12,       ///< client → server, HMAC of the nonce and the Hello (version 3)
    Heartbeat = 13,  ///< server → client, "still here" while no other message is due (version 3)
};
/// Highest id this build knows; ids 1..kMaxMessageType are all assigned.
inline constexpr uint16_t kMaxMessageType = 13;

/// What went wrong while decoding bytes from a peer. Every code is fatal for the connection.
enum class ErrorCode : uint8_t {
    Truncated,        ///< fewer bytes than the field or payload needs
    BadMagic,         ///< header does not start with 'RTPM'
    BadVersion,       ///< header version differs from kProtocolVersion
    UnknownType,      ///< header type is not a known MessageType
    BadFlags,         ///< header flags not zero (no flag is defined in version 3)
    PayloadTooLarge,  ///< header payloadBytes above the per-type limit
    LengthTooLarge,   ///< a string, byte array or count above its field limit or the bytes left
    BadEnum,          ///< an enumerated field out of range
    NonFinite,        ///< a float that must be finite is NaN or ±Inf
    BadValue,         ///< a value out of its documented range or inconsistent with another field
    TrailingBytes,    ///< payload longer than the message it holds
    Corrupt,          ///< compressed data that does not decompress to the announced size
    NotAllowed,       ///< a type or size the peer may not send in its state (e.g. before authenticating)
};

/// Short stable name of a code, e.g. "bad-magic" (for logs and tests).
const char* errorCodeName(ErrorCode code);

/// A decode failure: the code for programs, a message naming the field for people.
struct Error {
    ErrorCode code = ErrorCode::BadValue;
    std::string message;
};

/// A value or an Error; what every decoder returns (decoders never throw or assert on input).
/// Accessing value() of an error (or error() of a value) is a bug and aborts.
template <class T>
class [[nodiscard]] Result {
public:
    Result(T value) : v_(std::in_place_index<0>, std::move(value)) {}  // NOLINT: implicit by design
    Result(Error error) : v_(std::in_place_index<1>, std::move(error)) {}  // NOLINT

    bool ok() const { return v_.index() == 0; }
    explicit operator bool() const { return ok(); }

    T& value() & { return *checkedValue(); }
    const T& value() const& { return *const_cast<Result*>(this)->checkedValue(); }
    T&& value() && { return std::move(*checkedValue()); }
    T& operator*() & { return value(); }
    const T& operator*() const& { return value(); }
    T* operator->() { return checkedValue(); }
    const T* operator->() const { return const_cast<Result*>(this)->checkedValue(); }

    const Error& error() const {
        if (v_.index() != 1) abortBadAccess("error() of a value");
        return *std::get_if<1>(&v_);
    }

private:
    T* checkedValue() {
        if (v_.index() != 0) abortBadAccess(std::get_if<1>(&v_)->message.c_str());
        return std::get_if<0>(&v_);
    }
    [[noreturn]] static void abortBadAccess(const char* what);

    std::variant<T, Error> v_;
};

/// Result without a value.
using Status = Result<std::monostate>;
inline Status okStatus() { return Status(std::monostate{}); }

[[noreturn]] void abortResultAccess(const char* what);
template <class T>
void Result<T>::abortBadAccess(const char* what) {
    abortResultAccess(what);
}

/// Appends little-endian fields to a growing byte buffer. Floats go as their IEEE-754 bit
/// pattern; strings and byte arrays as a u32 byte count followed by the bytes. Never memcpys a
/// struct. Not thread-safe. Cost: amortised O(1) per byte.
class Writer {
public:
    Writer() = default;
    /// Appends to the end of an existing buffer (e.g. after a reserved header).
    explicit Writer(std::vector<uint8_t> initial) : buf_(std::move(initial)) {}

    void u8(uint8_t v) { buf_.push_back(v); }
    void u16(uint16_t v);
    void u32(uint32_t v);
    void u64(uint64_t v);
    void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
    void f32(float v);
    void f64(double v);
    /// u32 byte count, then the bytes. Precondition: size < 2^32 (aborts otherwise: a bug).
    void str(std::string_view s);
    /// u32 byte count, then the bytes. Same precondition as str().
    void bytes(std::span<const uint8_t> b);
    /// The bytes as they are, no length prefix.
    void raw(std::span<const uint8_t> b) { buf_.insert(buf_.end(), b.begin(), b.end()); }
    /// Overwrites 4 bytes at `offset` (already written) with `v`: for back-patched lengths.
    void patchU32(size_t offset, uint32_t v);

    size_t size() const { return buf_.size(); }
    const std::vector<uint8_t>& data() const { return buf_; }
    std::vector<uint8_t> take() { return std::move(buf_); }

private:
    std::vector<uint8_t> buf_;
};

/// Reads little-endian fields from a byte span without ever reading past its end.
/// The first failure is sticky: it is recorded (error()) and every later read fails too and
/// leaves its output zero/empty, so a decoder may read a whole message and test ok() once.
/// Lengths are checked against the field limit and the bytes left before any allocation.
/// Not thread-safe; does not own the bytes.
class Reader {
public:
    explicit Reader(std::span<const uint8_t> bytes) : bytes_(bytes) {}

    bool u8(uint8_t& v);
    bool u16(uint16_t& v);
    bool u32(uint32_t& v);
    bool u64(uint64_t& v);
    bool i32(int32_t& v);
    bool f32(float& v);
    bool f64(double& v);
    /// A float that must be finite; `field` names it in the error.
    bool f32Finite(float& v, const char* field);
    /// A double that must be finite; `field` names it in the error.
    bool f64Finite(double& v, const char* field);
    /// u32 length then bytes; length ≤ maxBytes and ≤ bytes left, checked before allocating.
    bool str(std::string& s, size_t maxBytes, const char* field);
    bool bytes(std::vector<uint8_t>& b, size_t maxBytes, const char* field);
    /// A view of the next n bytes (no copy); fails if fewer remain.
    bool view(std::span<const uint8_t>& out, size_t n, const char* field);
    /// An element count followed by elements of at least `minElementBytes` each: fails unless
    /// count ≤ maxCount and count · minElementBytes ≤ bytes left (so a hostile count cannot
    /// make the caller allocate).
    bool count(uint32_t& n, size_t maxCount, size_t minElementBytes, const char* field);

    /// Records an error (if none yet) and returns false; for decoders' semantic checks.
    bool fail(ErrorCode code, std::string message);
    /// Fails with TrailingBytes unless every byte was consumed; returns the final status.
    Status finish(const char* what);

    bool ok() const { return !failed_; }
    const Error& error() const { return error_; }
    size_t remaining() const { return bytes_.size() - pos_; }
    size_t position() const { return pos_; }

private:
    bool need(size_t n, const char* what);

    std::span<const uint8_t> bytes_;
    size_t pos_ = 0;
    bool failed_ = false;
    Error error_;
};

/// Largest payload accepted for each type, in bytes (PROTOCOL.md §4). Checked from the header
/// alone, before the payload is received or any buffer is allocated. 0 for unknown types.
uint32_t payloadLimit(MessageType type);

/// The fixed 16-byte header: magic u32, version u16, type u16, flags u32, payloadBytes u32.
struct Header {
    uint32_t magic = kMagic;
    uint16_t version = kProtocolVersion;
    MessageType type = MessageType::Hello;
    uint32_t flags = 0;
    uint32_t payloadBytes = 0;
};

/// Writes `h` as 16 little-endian bytes.
void encodeHeader(const Header& h, Writer& w);

/// Decodes and validates a header from the first 16 bytes of `bytes` (more are ignored).
/// Errors, in this order: Truncated (< 16 bytes), BadMagic, BadVersion, UnknownType, BadFlags,
/// PayloadTooLarge. Pure; O(1).
Result<Header> decodeHeader(std::span<const uint8_t> bytes);

}  // namespace rtpm::proto
