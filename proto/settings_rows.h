// The Settings message's rows (PROTOCOL.md §5.5): the settings of common/core/knobs.h that have a
// wire type, in the order the message carries them — kFixedSettings, then kKnobs, each in table
// order — with each type's size, the payload's size and the layout fingerprint a Hello carries
// (PROTOCOL.md §5.1), so that two builds whose tables differ refuse each other at the handshake.
#pragma once

#include <array>
#include <bit>
#include <cfloat>
#include <cstddef>
#include <cstdint>

#include "common/core/knobs.h"

namespace rtpm::proto {

/// Bytes of a value of `type` on the wire (0 for None).
constexpr size_t wireBytes(WireType type) {
    switch (type) {
        case WireType::None: return 0;
        case WireType::U8: return 1;
        case WireType::U32: return 4;
        case WireType::U64: return 8;
        case WireType::F32: return 4;
    }
    return 0;
}

/// The largest whole value an integer row of `type` may have: one below the type's largest (an
/// encoder sends a value its type cannot hold as the type's largest, which every row then refuses),
/// and for U64 2^53, the largest below which a double (a row's value) holds every integer.
constexpr double wireRowCeiling(WireType type) {
    switch (type) {
        case WireType::U8: return 254.0;
        case WireType::U32: return 4294967294.0;
        case WireType::U64: return 9007199254740992.0;
        case WireType::F32: return double(FLT_MAX);
        case WireType::None: break;
    }
    return 0.0;
}

inline constexpr size_t kSettingsRowCount = [] {
    size_t n = 0;
    for (const SettingRow& r : kFixedSettings) n += r.wire != WireType::None;
    for (const KnobRow& r : kKnobs) n += r.wire != WireType::None;
    return n;
}();

/// The rows of the Settings message, in wire order.
inline constexpr std::array<const SettingRow*, kSettingsRowCount> kSettingsRows = [] {
    std::array<const SettingRow*, kSettingsRowCount> rows{};
    size_t n = 0;
    for (const SettingRow& r : kFixedSettings)
        if (r.wire != WireType::None) rows[n++] = &r;
    for (const KnobRow& r : kKnobs)
        if (r.wire != WireType::None) rows[n++] = &r;
    return rows;
}();

/// Settings payload: the pixel encoding (u8), then every row's value.
inline constexpr size_t kSettingsPayloadBytes = [] {
    size_t n = 1;
    for (const SettingRow* r : kSettingsRows) n += wireBytes(r->wire);
    return n;
}();

/// A row's limits fit its wire type: an integer row's within [0, wireRowCeiling], a float row's
/// finite binary32 values.
constexpr bool rowFitsItsWireType(const SettingRow& r) {
    if (r.wire == WireType::F32) return r.min >= -double(FLT_MAX) && r.max <= double(FLT_MAX);
    return r.integer && r.min >= 0.0 && r.max <= wireRowCeiling(r.wire);
}
static_assert([] {
    for (const SettingRow* r : kSettingsRows)
        if (!rowFitsItsWireType(*r)) return false;
    return true;
}(), "a setting row's limits do not fit its wire type (common/core/knobs.h)");

/// FNV-1a (64 bits) over each row in wire order: its flag's bytes, a zero byte, its type's id
/// (U8 1, U32 2, U64 3, F32 4) and its min and max as little-endian binary64 (PROTOCOL.md §5.1).
/// Equal on two peers exactly when their Settings messages have the same fields, types and limits.
inline constexpr uint64_t kSettingsLayout = [] {
    uint64_t h = 0xcbf29ce484222325ull;
    auto byte = [&h](uint8_t b) {
        h ^= b;
        h *= 0x100000001b3ull;
    };
    auto f64 = [&byte](double v) {
        const uint64_t bits = std::bit_cast<uint64_t>(v);
        for (int i = 0; i < 8; ++i) byte(uint8_t(bits >> (8 * i)));
    };
    for (const SettingRow* r : kSettingsRows) {
        for (char c : r->flag) byte(uint8_t(c));
        byte(0);
        byte(uint8_t(r->wire));
        f64(r->min);
        f64(r->max);
    }
    return h;
}();

}  // namespace rtpm::proto
