// Challenge–response authentication of a client (PROTOCOL.md §7): nonces, the Auth MAC over the
// session parameters (HMAC-SHA256 from OpenSSL's libcrypto), and the token-strength rule.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>

#include "proto/messages.h"

namespace rtpm::proto {

using Nonce = std::array<uint8_t, kNonceBytes>;
using Mac = std::array<uint8_t, kMacBytes>;

/// A fresh nonce from OpenSSL's CSPRNG (RAND_bytes). Aborts if the generator fails: a server
/// that cannot make unpredictable nonces must not authenticate anyone.
Nonce makeNonce();

/// HMAC-SHA256 keyed with `token` over a domain label, `nonce` and every field of `hello`
/// (protocol version, cores, client name, settings layout), each in its wire encoding: the MAC proves that the
/// sender holds the token *and* binds it to this connection's nonce and to what the Hello said,
/// so it can be neither replayed on another connection nor moved to another Hello. The token
/// itself never leaves the process. Cost: one HMAC over < 400 bytes.
Mac authMac(std::string_view token, const Nonce& nonce, const Hello& hello);

/// Constant-time equality (CRYPTO_memcmp): the time does not depend on where the MACs differ.
bool macEquals(const Mac& a, const Mac& b);

/// Minimum strength of a token (the cluster's and the viewer's): at least kMinTokenChars
/// characters, at least kMinTokenBits bits by a character-frequency (Shannon) estimate, so short,
/// repetitive or dictionary-short tokens are refused, and at least kMinTokenStepBits by the same
/// estimate over the steps between neighbouring characters, so runs (abcdefghijklmnop,
/// 0123456789abcdef, ponm…, aceg…) and repeated runs are refused although every character
/// differs. `openssl rand -hex 16` (32 hex digits) gives ≈ 118 and ≥ 96 bits by these estimates
/// (128 bits of real entropy); 16 distinct random characters give 64 and ≈ 45–59.
inline constexpr size_t kMinTokenChars = 16;
inline constexpr double kMinTokenBits = 64.0;
inline constexpr double kMinTokenStepBits = 32.0;

/// Estimated entropy of `token` in bits: length × the Shannon entropy of its character
/// frequencies. An upper bound for random tokens, an overestimate for words; a filter, not proof.
double tokenEntropyBits(std::string_view token);

/// The same estimate over the token's steps: the differences between the positions of
/// neighbouring characters in 0–9a–z (case folded; other bytes by their code). 0 for any run.
double tokenStepEntropyBits(std::string_view token);

/// Why `token` is too weak (a sentence for the user), or nullopt when it is acceptable.
std::optional<std::string> tokenWeakness(std::string_view token);

}  // namespace rtpm::proto
