// printableText: escape and bound strings that came from a peer or a file before they are logged.
#include "common/core/printable_text.h"

#include <cstdint>
#include <algorithm>
#include <cstdio>

namespace rtpm {

namespace {

// Length of the valid UTF-8 sequence starting at s[i] (1–4), or 0 if it is not valid
// (overlong forms, surrogates and code points above U+10FFFF are invalid). `cp` gets its value.
size_t utf8Sequence(std::string_view s, size_t i, uint32_t& cp) {
    const auto b = [&](size_t k) { return uint8_t(s[i + k]); };
    const uint8_t c = b(0);
    size_t n;
    uint32_t min;
    if (c < 0x80) {
        cp = c;
        return 1;
    } else if ((c & 0xE0) == 0xC0) {
        n = 2, cp = c & 0x1F, min = 0x80;
    } else if ((c & 0xF0) == 0xE0) {
        n = 3, cp = c & 0x0F, min = 0x800;
    } else if ((c & 0xF8) == 0xF0) {
        n = 4, cp = c & 0x07, min = 0x10000;
    } else {
        return 0;
    }
    if (i + n > s.size()) return 0;
    for (size_t k = 1; k < n; ++k) {
        if ((b(k) & 0xC0) != 0x80) return 0;
        cp = (cp << 6) | (b(k) & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
    return n;
}

bool isBidiOrSeparator(uint32_t cp) {
    return cp == 0x2028 || cp == 0x2029 || (cp >= 0x202A && cp <= 0x202E) ||
           (cp >= 0x2066 && cp <= 0x2069);
}

}  // namespace

std::string printableText(std::string_view text, size_t maxBytes) {
    std::string out;
    out.reserve(std::min(text.size(), maxBytes) + 16);
    size_t i = 0;
    char buf[16];
    while (i < text.size()) {
        uint32_t cp = 0;
        size_t n = utf8Sequence(text, i, cp);
        std::string piece;
        if (n == 0) {
            std::snprintf(buf, sizeof buf, "\\x%02X", unsigned(uint8_t(text[i])));
            piece = buf;
            n = 1;
        } else if (cp == '\n') {
            piece = "\\n";
        } else if (cp == '\r') {
            piece = "\\r";
        } else if (cp == '\t') {
            piece = "\\t";
        } else if (cp == '\\') {
            piece = "\\\\";
        } else if (cp < 0x20 || cp == 0x7F || (cp >= 0x80 && cp < 0xA0)) {
            std::snprintf(buf, sizeof buf, "\\x%02X", unsigned(cp));
            piece = buf;
        } else if (isBidiOrSeparator(cp)) {
            std::snprintf(buf, sizeof buf, "\\u{%04X}", unsigned(cp));
            piece = buf;
        } else {
            piece.assign(text.substr(i, n));
        }
        if (out.size() + piece.size() > maxBytes) break;
        out += piece;
        i += n;
    }
    if (i < text.size()) out += "\xE2\x80\xA6(+" + std::to_string(text.size() - i) + " bytes)";
    return out;
}

}  // namespace rtpm
