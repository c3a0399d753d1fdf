// HMAC-SHA256 challenge–response and token strength, on OpenSSL's libcrypto (no hand-written crypto).
#include "proto/auth.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace rtpm::proto {

namespace {
/// Domain separation: a MAC made for this purpose is never valid for another one.
constexpr std::string_view kAuthLabel = "rtpm client auth v3";
}  // namespace

Nonce makeNonce() {
    Nonce n{};
    if (RAND_bytes(n.data(), static_cast<int>(n.size())) != 1) {
        std::fprintf(stderr, "rtpm: the random generator (RAND_bytes) failed; cannot authenticate\n");
        std::abort();
    }
    return n;
}

Mac authMac(std::string_view token, const Nonce& nonce, const Hello& hello) {
    // The authenticated bytes: label, nonce, then the Hello's fields in their wire encoding.
    Writer w;
    w.str(kAuthLabel);
    w.raw(nonce);
    w.u16(hello.protocolVersion);
    w.u32(hello.cores);
    w.str(hello.clientName);
    w.u64(hello.settingsLayout);
    Mac mac{};
    unsigned int len = 0;
    static const unsigned char kEmpty = 0;  // HMAC needs a non-null key pointer even when empty
    const unsigned char* key = token.empty() ? &kEmpty : reinterpret_cast<const unsigned char*>(token.data());
    if (!HMAC(EVP_sha256(), key, static_cast<int>(token.size()), w.data().data(), w.data().size(), mac.data(), &len) ||
        len != mac.size()) {
        std::fprintf(stderr, "rtpm: HMAC-SHA256 failed\n");
        std::abort();
    }
    return mac;
}

bool macEquals(const Mac& a, const Mac& b) { return CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0; }

double tokenEntropyBits(std::string_view token) {
    if (token.empty()) return 0.0;
    size_t counts[256] = {};
    for (unsigned char c : token) ++counts[c];
    const double n = double(token.size());
    double perChar = 0.0;
    for (size_t c : counts)
        if (c) perChar -= (double(c) / n) * std::log2(double(c) / n);
    return perChar * n;
}

double tokenStepEntropyBits(std::string_view token) {
    if (token.size() < 2) return 0.0;
    // 0-9 then a-z (case folded) are one alphabet, so 0123456789abcdef is one run of step 1.
    auto position = [](unsigned char c) -> int {
        if (c >= '0' && c <= '9') return c - '0';
        if (c >= 'a' && c <= 'z') return 10 + (c - 'a');
        if (c >= 'A' && c <= 'Z') return 10 + (c - 'A');
        return 100 + c;
    };
    size_t counts[1024] = {};  // steps lie in [-355, 355]
    for (size_t i = 1; i < token.size(); ++i)
        ++counts[size_t(position(uint8_t(token[i])) - position(uint8_t(token[i - 1])) + 512)];
    const double n = double(token.size() - 1);
    double perStep = 0.0;
    for (size_t c : counts)
        if (c) perStep -= (double(c) / n) * std::log2(double(c) / n);
    return perStep * n;
}

std::optional<std::string> tokenWeakness(std::string_view token) {
    const std::string advice = "; generate one with `openssl rand -hex 16`";
    if (token.size() < kMinTokenChars)
        return "the token has " + std::to_string(token.size()) + " characters, at least " +
               std::to_string(kMinTokenChars) + " are required" + advice;
    if (token.size() > kMaxTokenBytes)
        return "the token is longer than " + std::to_string(kMaxTokenBytes) + " bytes";
    const double bits = tokenEntropyBits(token);
    if (bits < kMinTokenBits) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "the token is too predictable (about %.0f bits by its character frequencies, "
                      "at least %.0f are required)", bits, kMinTokenBits);
        return buf + advice;
    }
    const double stepBits = tokenStepEntropyBits(token);
    if (stepBits < kMinTokenStepBits) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "the token is too predictable: a run or a repeated sequence (about %.0f bits "
                      "by the steps between its characters, at least %.0f are required)", stepBits, kMinTokenStepBits);
        return buf + advice;
    }
    return std::nullopt;
}

}  // namespace rtpm::proto
